"""
Closed-form IK of PincherX-100-geometry arms: a waist about a vertical axis, then three parallel.

pitch joints (shoulder, elbow, wrist_angle) whose axes are perpendicular to the waist axis.

The geometry (link lengths, angular offsets, axis signs) is derived from the model's ``S_list``
and ``M``, so any arm of this family works (px100, mobile_px100, a DH-built px100, ...).
Inverse geometric model: the waist takes the target azimuth ``a`` or ``a + pi``; the planar
shoulder/elbow pair has two elbow signs; the wrist closes the pitch. From a full 4x4 pose
(mode 'full') the waist comes from the orientation instead.

Pitch convention: the 'sxyz' pitch of the end-effector with yaw forced to the target azimuth
(Interbotix ``set_ee_pose_components``), i.e. the angle of the tool x axis below the horizontal,
measured from the outward (base -> target) direction. Both waist branches realise the same tool
x axis at a given pitch (the back branch, reaching over the top, has its roll flipped by pi).
Units: m, rad.
"""
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
import functools
import math
import os
from typing import List, Optional, Sequence, Tuple

import numpy as np

from px100_control.errors import RobotModelError
from px100_control.kinematics.kernels import wrap, wrap_array

#: candidates() returns every closed-form solution: solve_ik needs no iterative fallback.
complete = True

_TWO_PI = 2.0 * math.pi
_REACH_EPS = 1e-12          # relative slack on |cos(elbow)| <= 1 (straight-arm rounding)
_POSITION_GRID = 48         # pitch samples per branch in 'position' mode (refined by solve.py)


@dataclass(frozen=True)
class Px100Geometry:
    """
    Planar parameters of a px100-family arm, derived from (S_list, M).

    The arm frame F has z along the waist axis and y along the shoulder axis (origin on the waist
    axis). Arm-plane coordinates are (u, v) = (x_F, -z_F), in which a positive rotation about
    +y_F is counter-clockwise. ``signs`` maps plane angles to joint angles (theta = sign * phi).
    """

    R_F: np.ndarray            # (3, 3) columns x_F, y_F, z_F in the base frame
    origin: np.ndarray         # (3,) a point on the waist axis [m]
    frame_is_base: bool        # R_F = I and origin = 0 (fast path)
    signs: Tuple[float, float, float, float]
    u2: float                  # shoulder axis in the plane [m]
    v2: float
    Lr: float                  # shoulder -> elbow [m] and its angle at q = 0 [rad]
    g1: float
    L3: float                  # elbow -> wrist [m], angle
    g2: float
    L4: float                  # wrist -> end effector [m], angle
    g3: float
    mu: float                  # elevation of the tool x axis at q = 0 [rad]
    R_M_F: np.ndarray          # (3, 3) tool orientation at q = 0 in F
    tool_is_identity: bool     # R_M_F = I (fast path)
    lower: Tuple[float, ...]
    upper: Tuple[float, ...]

    def to_arm_frame(self, p) -> Tuple[float, float, float]:
        """Return the base-frame point p [m] in arm-frame coordinates (x_F, y_F, z_F)."""
        if self.frame_is_base:
            return float(p[0]), float(p[1]), float(p[2])
        P = self.R_F.T @ (np.asarray(p, dtype=float) - self.origin)
        return float(P[0]), float(P[1]), float(P[2])


@functools.lru_cache(maxsize=64)
def geometry(model) -> Px100Geometry:
    """
    Return the planar geometry of a px100-family model (cached per model).

    :raises RobotModelError: if the model is not a waist + three parallel pitch joints arm
    """
    S = np.asarray(model.S_list, dtype=float)
    if S.shape != (6, 4) or any(t != 'revolute' for t in model.joint_types):
        raise RobotModelError(f"'{model.name}' is not a 4-revolute-joint arm; the px100 "
                              'solver does not apply')
    w, v = S[:3], S[3:]
    z, y = w[:, 0], w[:, 1]
    if abs(z @ y) > 1e-9:
        raise RobotModelError(f"'{model.name}': shoulder axis not perpendicular to the waist")
    for i in (2, 3):
        if np.linalg.norm(np.cross(w[:, i], y)) > 1e-9:
            raise RobotModelError(f"'{model.name}': joint {i + 1} axis not parallel to the "
                                  'shoulder axis')
    x = np.cross(y, z)
    R_F = np.column_stack([x, y, z])
    origin = np.cross(z, v[:, 0])

    def plane(pt):
        P = R_F.T @ (pt - origin)
        return P[0], -P[2], P[1]

    pts = [plane(np.cross(w[:, i], v[:, i])) for i in (1, 2, 3)]
    ue, ve, ye = plane(np.asarray(model.M, float)[:3, 3])
    if abs(ye) > 1e-9:
        raise RobotModelError(f"'{model.name}': the end effector is {ye:.4g} m off the arm "
                              'plane (lateral offset not supported)')
    (u2, v2, _), (u3, v3, _), (u4, v4, _) = pts
    R_M_F = R_F.T @ np.asarray(model.M, float)[:3, :3]
    xm = R_M_F[:, 0]
    signs = (1.0, 1.0, float(np.sign(w[:, 2] @ y)), float(np.sign(w[:, 3] @ y)))
    frame_is_base = bool(np.allclose(R_F, np.eye(3), atol=1e-15)
                         and np.allclose(origin, 0.0, atol=1e-15))
    return Px100Geometry(
        R_F=R_F, origin=origin, frame_is_base=frame_is_base, signs=signs,
        u2=float(u2), v2=float(v2),
        Lr=float(math.hypot(u3 - u2, v3 - v2)), g1=float(math.atan2(v3 - v2, u3 - u2)),
        L3=float(math.hypot(u4 - u3, v4 - v3)), g2=float(math.atan2(v4 - v3, u4 - u3)),
        L4=float(math.hypot(ue - u4, ve - v4)), g3=float(math.atan2(ve - v4, ue - u4)),
        mu=float(math.atan2(-xm[2], xm[0])), R_M_F=R_M_F,
        tool_is_identity=bool(np.allclose(R_M_F, np.eye(3), atol=1e-15)),
        lower=tuple(float(v) for v in model.lower), upper=tuple(float(v) for v in model.upper))


# ---------------------------------------------------------------------------------------------
# scalar core (math module only: this is the fast single-solve path)
# ---------------------------------------------------------------------------------------------

def _waist_values(g: Px100Geometry, t: float, out: list) -> None:
    """Append t wrapped to [-pi, pi) and its +-2 pi copies that fit the waist limits."""
    t = wrap(t)
    out.append(t)
    if t + _TWO_PI <= g.upper[0] + 1e-9:
        out.append(t + _TWO_PI)
    if t - _TWO_PI >= g.lower[0] - 1e-9:
        out.append(t - _TWO_PI)


def _planar(g: Px100Geometry, t1: float, phi: float, P0: float, P1: float, P2: float,
            out: list, u: Optional[float] = None) -> None:
    """
    Append the (<= 2) solutions with waist t1 and plane pitch sum phi; target P in F.

    u: (optional) the target's distance along the waist direction, when the caller knows it.
    """
    if u is None:
        u = P0 * math.cos(t1) + P1 * math.sin(t1)
    a3 = phi + g.g3
    wu = u - g.L4 * math.cos(a3) - g.u2
    wv = -P2 - g.L4 * math.sin(a3) - g.v2
    Lr, L3 = g.Lr, g.L3
    c = (wu * wu + wv * wv - Lr * Lr - L3 * L3) / (2.0 * Lr * L3)
    if c > 1.0:
        if c > 1.0 + _REACH_EPS:
            return
        c = 1.0
    elif c < -1.0:
        if c < -1.0 - _REACH_EPS:
            return
        c = -1.0
    s = math.sqrt(1.0 - c * c)
    base = math.atan2(wv, wu)
    k = math.atan2(L3 * s, Lr + L3 * c)
    el = math.atan2(s, c)
    _, _, s3, s4 = g.signs
    pi, two_pi = math.pi, _TWO_PI
    for sgn in ((1.0, -1.0) if s > 0.0 else (1.0,)):
        p2 = base - sgn * k - g.g1
        p3 = sgn * el - g.g2 + g.g1
        p4 = phi - p2 - p3
        # wrap inlined: solve_ik's 'full' path (kernels.wrap calls cost 3-6 % there)
        out.append((t1, (p2 + pi) % two_pi - pi, (s3 * p3 + pi) % two_pi - pi,
                    (s4 * p4 + pi) % two_pi - pi))


def _pitch_branches(g: Px100Geometry, P0: float, P1: float, pitch: float,
                    azimuth: Optional[float] = None):
    """Yield (waist, plane pitch sum) for the front and back branches of an (x, y, pitch)."""
    a = math.atan2(P1, P0) if azimuth is None else azimuth
    yield a, pitch - g.mu
    yield a + math.pi, math.pi - pitch - g.mu


def solve_xyz_pitch(g: Px100Geometry, x: float, y: float, z: float, pitch: float,
                    azimuth: Optional[float] = None, n_front: Optional[list] = None
                    ) -> List[tuple]:
    """
    Return every closed-form solution (4-tuples, no limit check) for a position and pitch.

    :param x, y, z: end-effector position in the base frame [m]
    :param pitch: tool pitch [rad], positive down (Interbotix convention; see module doc)
    :param azimuth: waist direction to use when the target is on the waist axis (default atan2)
    :param n_front: (optional) an empty list that receives the number of front-branch
        solutions, which come first (the back ones, waist + pi, have the tool roll flipped)
    """
    P0, P1, P2 = g.to_arm_frame((x, y, z))
    if azimuth is None and P0 * P0 + P1 * P1 < 1e-24:
        azimuth = 0.0
    out: list = []
    # with the waist at the target azimuth a (front) or a + pi (back) the target lies at +-r
    # along the waist direction: no cos/sin of the waist needed
    r = math.hypot(P0, P1) if azimuth is None else None
    for k, (t, phi) in enumerate(_pitch_branches(g, P0, P1, pitch, azimuth)):
        waists: list = []
        _waist_values(g, t, waists)
        u = None if r is None else (r if k == 0 else -r)
        for t1 in waists:
            _planar(g, t1, phi, P0, P1, P2, out, u)
        if n_front is not None and not n_front:
            n_front.append(len(out))
    return out


def _scalar_solver(g: Px100Geometry):
    """
    Return solve(x, y, z, pitch, tol) -> ([front], [back]): the in-limit solutions, unsorted.

    The scalar hot path with every geometric constant bound as a local: the same algebra as
    ``solve_xyz_pitch`` + ``_planar`` (both waist branches, both elbow signs, the +-2 pi copies
    of the waist that fit its limits), inlined (the two-link step as a shared function call
    measured 1-14 % slower here). Front = waist toward the target.
    """
    base_frame = g.frame_is_base
    (f00, f01, f02), (f10, f11, f12), (f20, f21, f22) = g.R_F.T.tolist()
    o0, o1, o2 = (float(v) for v in g.origin)
    mu, g1, g2, g3 = g.mu, g.g1, g.g2, g.g3
    L4, u2, v2, Lr, L3 = g.L4, g.u2, g.v2, g.Lr, g.L3
    k0, inv2 = Lr * Lr + L3 * L3, 1.0 / (2.0 * Lr * L3)
    s3, s4 = g.signs[2], g.signs[3]
    lo0, lo1, lo2, lo3 = g.lower
    hi0, hi1, hi2, hi3 = g.upper
    cd, sd = math.cos(g3 - mu), math.sin(g3 - mu)
    pi, two_pi, eps = math.pi, _TWO_PI, _REACH_EPS
    atan2, sqrt, cos, sin = math.atan2, math.sqrt, math.cos, math.sin
    g12 = g1 - g2

    def branch(t, phi, u, P2, ca3, sa3, tol, out):
        # the planar shoulder/elbow/wrist chain of one waist branch (see _planar)
        wu = u - L4 * ca3 - u2
        wv = -P2 - L4 * sa3 - v2
        c = (wu * wu + wv * wv - k0) * inv2
        if c > 1.0:
            if c > 1.0 + eps:
                return
            c = 1.0
        elif c < -1.0:
            if c < -1.0 - eps:
                return
            c = -1.0
        s = sqrt(1.0 - c * c)
        bse = atan2(wv, wu) - g1
        k = atan2(L3 * s, Lr + L3 * c)
        el = atan2(s, c)
        if not -pi <= t < pi:
            t = (t + pi) % two_pi - pi
        tl, th = lo0 - tol, hi0 + tol
        for p2, p3 in ((bse - k, el + g12), (bse + k, g12 - el)) if s > 0.0 else (
                (bse - k, el + g12),):
            q1 = p2 if -pi <= p2 < pi else (p2 + pi) % two_pi - pi
            if not lo1 - tol <= q1 <= hi1 + tol:
                continue
            q2 = s3 * p3
            if not -pi <= q2 < pi:
                q2 = (q2 + pi) % two_pi - pi
            if not lo2 - tol <= q2 <= hi2 + tol:
                continue
            q3 = s4 * (phi - p2 - p3)
            if not -pi <= q3 < pi:
                q3 = (q3 + pi) % two_pi - pi
            if not lo3 - tol <= q3 <= hi3 + tol:
                continue
            if tl <= t <= th:
                out.append((t, q1, q2, q3))
            if t + two_pi <= th:
                out.append((t + two_pi, q1, q2, q3))
            if t - two_pi >= tl:
                out.append((t - two_pi, q1, q2, q3))

    def solve(x, y, z, pitch, tol):
        if base_frame:
            P0, P1, P2 = x, y, z
        else:
            dx, dy, dz = x - o0, y - o1, z - o2
            P0 = f00 * dx + f01 * dy + f02 * dz
            P1 = f10 * dx + f11 * dy + f12 * dz
            P2 = f20 * dx + f21 * dy + f22 * dz
        r2 = P0 * P0 + P1 * P1
        a = atan2(P1, P0) if r2 >= 1e-24 else 0.0
        r = sqrt(r2)
        cp, sp = cos(pitch), sin(pitch)
        front: list = []
        back: list = []
        # front: a3 = pitch + (g3 - mu); back: a3 = pi - (pitch - (g3 - mu))
        branch(a, pitch - mu, r, P2, cp * cd - sp * sd, sp * cd + cp * sd, tol, front)
        branch(a + pi, pi - pitch - mu, -r, P2, -(cp * cd + sp * sd), sp * cd - cp * sd,
               tol, back)
        return front, back
    return solve


@functools.lru_cache(maxsize=64)
def _model_solver(model):
    """Return the cached ``_scalar_solver`` of a model."""
    return _scalar_solver(geometry(model))


def ik_xyz_pitch(model, x: float, y: float, z: float, pitch: float,
                 q_seed: Optional[Sequence[float]] = None, check_limits: bool = True,
                 tol: float = 1e-9) -> List[tuple]:
    """
    Return the in-limit solutions for (x, y, z [m], pitch [rad]), closest to q_seed first.

    The fast scalar path (plain floats, no numpy): the front branches (waist toward the target,
    tool roll 0 as Interbotix means it) before the back ones, each ordered by the cost
    function (Euclidean distance to q_seed, default model.home). Input must be finite.
    Without ``check_limits`` every closed-form solution is returned (``solve_xyz_pitch``).
    """
    if check_limits:
        front, back = _model_solver(model)(x, y, z, pitch, tol)
    else:
        n_front: list = []
        sols = solve_xyz_pitch(geometry(model), x, y, z, pitch, n_front=n_front)
        front, back = sols[:n_front[0]], sols[n_front[0]:]
    # the front branches have the target's tool roll: they come first
    if len(front) > 1 or len(back) > 1:
        s = model.home if q_seed is None else q_seed
        s0, s1, s2, s3 = float(s[0]), float(s[1]), float(s[2]), float(s[3])
        for part in (front, back):
            if len(part) > 1:
                part.sort(key=lambda q: (q[0] - s0) ** 2 + (q[1] - s1) ** 2
                          + (q[2] - s2) ** 2 + (q[3] - s3) ** 2)
    return front + back


# ---------------------------------------------------------------------------------------------
# plug-in contract (see kinematics/analytic/__init__.py)
# ---------------------------------------------------------------------------------------------

def _tool_plane_rotation(g: Px100Geometry, T: np.ndarray) -> np.ndarray:
    """Return G = R_F^T R_target R_M_F^T, equal to Rz(waist) Ry(pitch sum) when reachable."""
    if g.frame_is_base and g.tool_is_identity:
        return T[:3, :3]
    return g.R_F.T @ T[:3, :3] @ g.R_M_F.T


def target_pitch(g: Px100Geometry, T: np.ndarray) -> Tuple[float, float]:
    """
    Return (azimuth, pitch) [rad] of a (4, 4) target: waist direction and tool x elevation.

    The azimuth is atan2 of the target position about the waist axis; on the axis it comes from
    the tool x axis (or 0). The pitch is measured from the outward direction (module doc).
    """
    P0, P1, _ = g.to_arm_frame(T[:3, 3])
    X = T[:3, 0].tolist() if g.frame_is_base else (g.R_F.T @ T[:3, 0]).tolist()
    if P0 * P0 + P1 * P1 > 1e-24:
        a = math.atan2(P1, P0)
    elif X[0] * X[0] + X[1] * X[1] > 1e-24:
        a = math.atan2(X[1], X[0])
    else:
        a = 0.0
    pitch = math.atan2(-X[2], math.cos(a) * X[0] + math.sin(a) * X[1])
    return a, pitch


def candidates(model, T_target: np.ndarray, mode: str) -> np.ndarray:
    """
    Return every closed-form candidate (k, 4) for a (4, 4) target, before limit filtering.

    'full': waist from the tool orientation, two elbow signs; 'pitch': position and
    tool x axis (waist a and a + pi, two elbows); 'position': both waists and elbows over a grid
    of pitches (solve_ik refines them with the null-space task toward q_nominal).
    """
    g = geometry(model)
    T = np.asarray(T_target, dtype=float)
    if mode == 'full':
        return np.array(_full_rows(g, T.tolist(), T), dtype=float).reshape(-1, 4)
    P0, P1, P2 = g.to_arm_frame(T[:3, 3])
    out: list = []
    if mode == 'pitch':
        a, pitch = target_pitch(g, T)
        for t, phi in _pitch_branches(g, P0, P1, pitch, a):
            waists = []
            _waist_values(g, t, waists)
            for t1 in waists:
                _planar(g, t1, phi, P0, P1, P2, out)
    elif mode == 'position':
        a = math.atan2(P1, P0) if P0 * P0 + P1 * P1 > 1e-24 else 0.0
        for k in range(_POSITION_GRID):
            pitch = -math.pi + _TWO_PI * k / _POSITION_GRID
            for t, phi in _pitch_branches(g, P0, P1, pitch, a):
                _planar(g, wrap(t), phi, P0, P1, P2, out)
    else:
        raise ValueError(f'unknown IK mode {mode!r}')
    return np.array(out, dtype=float).reshape(-1, 4)


def _full_rows(g: Px100Geometry, L, T=None) -> list:
    """
    Return the 'full' candidates of a pose L (4 rows of 4 floats; T: the same as an array).

    The waist comes from the tool orientation (the heading of the tool's horizontal y axis),
    the pitch sum from the rotation about that axis, then two elbow signs.
    """
    if g.frame_is_base and g.tool_is_identity:
        P0, P1, P2 = L[0][3], L[1][3], L[2][3]
        G = L
    else:
        T = np.array(L, dtype=float) if T is None else T
        P0, P1, P2 = g.to_arm_frame(T[:3, 3])
        G = _tool_plane_rotation(g, T).tolist()
    if G[0][1] * G[0][1] + G[1][1] * G[1][1] > 1e-24:
        t = math.atan2(-G[0][1], G[1][1])
    else:
        t = math.atan2(P1, P0)
    phi = math.atan2(-G[2][0], G[2][2])
    waists: list = []
    _waist_values(g, t, waists)
    out: list = []
    for t1 in waists:
        _planar(g, t1, phi, P0, P1, P2, out)
    return out


def candidates_rows(model, T_rows, mode: str = 'full') -> list:
    """Return the candidates of ``candidates`` as lists; T_rows: 4 rows of 4 floats."""
    if mode == 'full':
        return _full_rows(geometry(model), T_rows)
    return candidates(model, np.array(T_rows, dtype=float), mode).tolist()


def _branch(g: Px100Geometry, P0: float, P1: float, P2: float, a: float, back: bool,
            sgn: float, pitch: float) -> Optional[tuple]:
    """Return the one solution of a branch (waist side, elbow sign) at a pitch, or None."""
    if back:
        t1, phi = wrap(a + math.pi), math.pi - pitch - g.mu
    else:
        t1, phi = wrap(a), pitch - g.mu
    out: list = []
    _planar(g, t1, phi, P0, P1, P2, out)
    if not out:
        return None
    if len(out) == 1:
        return out[0]
    return out[0] if sgn > 0 else out[1]


def _refine_pitch(f, x0: float, step: float, tol: float):
    """
    Minimise f(x) -> (cost, q) on [x0 - step, x0 + step]; return the best q.

    Safeguarded Newton on central differences (quadratic convergence), falling back to
    golden-section search when the curvature is not positive or a step leaves the bracket.
    """
    lo_x, hi_x = x0 - step, x0 + step
    x, (fx, qx) = x0, f(x0)
    h = 1e-5
    for _ in range(12):
        fp, fm = f(x + h)[0], f(x - h)[0]
        d1, d2 = (fp - fm) / (2 * h), (fp - 2 * fx + fm) / (h * h)
        if not (math.isfinite(d1) and math.isfinite(d2)) or d2 <= 0.0:
            break
        nx = x - d1 / d2
        if not lo_x <= nx <= hi_x:
            break
        fn, qn = f(nx)
        if fn > fx + 1e-12 * (1.0 + fx):
            break
        done = abs(nx - x) < max(tol, 1e-10)     # central differences: ~1e-11 noise
        x, fx, qx = nx, fn, qn
        if done:
            return qx
    # golden-section fallback (also lands on a joint-limit boundary)
    invphi = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = lo_x, hi_x
    x1, x2 = b - invphi * (b - a), a + invphi * (b - a)
    f1, f2 = f(x1)[0], f(x2)[0]
    while b - a > tol:
        if f1 <= f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - invphi * (b - a)
            f1 = f(x1)[0]
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + invphi * (b - a)
            f2 = f(x2)[0]
    cands = [f(a), f(b), (fx, qx)]
    best = min(cands, key=lambda t: t[0])
    return best[1]


def position_solutions(model, T_target: np.ndarray, q_nominal, check_limits: bool = True,
                       grid: int = 720, tol: float = 1e-12) -> np.ndarray:
    """
    Return (k, 4) position-only solutions, the free pitch chosen by the secondary task.

    For each branch (waist a / a + pi, elbow sign) the pitch minimises |q(pitch) - q_nominal|
    over the in-limit part of the branch (the fixed points of the null-space iteration
    q+ = q + alpha J# e + beta (I - J# J)(q_nom - q); a minimum on a joint limit is kept on
    the limit): grid search, then golden-section refinement to ``tol``.
    Without ``check_limits`` the limits are ignored.
    """
    g = geometry(model)
    T = np.asarray(T_target, dtype=float)
    P0, P1, P2 = g.to_arm_frame(T[:3, 3])
    a = math.atan2(P1, P0) if P0 * P0 + P1 * P1 > 1e-24 else 0.0
    qn = np.asarray(q_nominal, dtype=float)
    if check_limits:
        lo, hi = np.asarray(g.lower) - 1e-12, np.asarray(g.upper) + 1e-12
    else:
        lo, hi = np.full(4, -np.inf), np.full(4, np.inf)
    pitches = -math.pi + _TWO_PI * np.arange(grid) / grid
    ones = np.ones(grid)
    p = T[:3, 3]
    Q, geo = batch_candidates(model, p[0] * ones, p[1] * ones, p[2] * ones, pitches)
    inside = np.all((Q >= lo) & (Q <= hi), axis=2)
    cost = np.sum((Q - qn) ** 2, axis=2)                      # (grid, 4)
    # neighbour rules: where a branch ends geometrically (straight elbow) the self-motion
    # manifold continues on the other elbow branch, so that end is not a minimum (-inf);
    # a joint limit is a real boundary (+inf): a minimum there stays on the limit
    view = np.where(geo, np.where(inside, cost, np.inf), -np.inf)
    qn_t = tuple(float(x) for x in qn)
    lo_t, hi_t = tuple(lo), tuple(hi)

    def f(back, sgn, pitch):
        q = _branch(g, P0, P1, P2, a, back, sgn, pitch)
        if q is None or any(x < lo_t[i] or x > hi_t[i] for i, x in enumerate(q)):
            return math.inf, None
        return sum((x - y) ** 2 for x, y in zip(q, qn_t)), q

    out = []
    step = _TWO_PI / grid
    for j in range(4):
        back, sgn = j >= 2, (1.0 if j % 2 == 0 else -1.0)
        cj = view[:, j]
        left, right = np.roll(cj, 1), np.roll(cj, -1)
        for k in np.nonzero(geo[:, j] & inside[:, j] & (cj <= left) & (cj <= right))[0]:
            best = _refine_pitch(lambda x: f(back, sgn, x), float(pitches[k]), step, tol)
            if best is not None:
                out.append(best)
    return np.array(out, dtype=float).reshape(-1, 4)


def _reach_interval(g: Px100Geometry) -> Tuple[float, float]:
    return abs(g.Lr - g.L3), g.Lr + g.L3


def reach_margin(model, p, pitch: Optional[float] = None) -> float:
    """
    Return the signed reach margin [m] of a position (and optional pitch), joint limits ignored.

    Positive inside the workspace; negative: how far outside. With a pitch, the wrist centre must
    lie in the annulus |Lr - L3| <= d <= Lr + L3 around the shoulder (the workspace torus);
    without, the end effector must lie within [.., Lr + L3 + L4] of the shoulder. The best of the
    front and back waist branches counts.
    """
    g = geometry(model)
    P0, P1, P2 = g.to_arm_frame(p)
    r = math.hypot(P0, P1)
    lo, hi = _reach_interval(g)
    best = -math.inf
    for sign in (1.0, -1.0):
        u, v = sign * r, -P2
        if pitch is None:
            rho = math.hypot(u - g.u2, v - g.v2)
            margin = min(hi - abs(rho - g.L4), rho + g.L4 - lo)
        else:
            phi = (pitch - g.mu) if sign > 0 else (math.pi - pitch - g.mu)
            a3 = phi + g.g3
            d = math.hypot(u - g.L4 * math.cos(a3) - g.u2, v - g.L4 * math.sin(a3) - g.v2)
            margin = min(hi - d, d - lo)
        best = max(best, margin)
    return best


def unreachable_reason(model, T_target: np.ndarray, mode: str) -> str:
    """Explain in words why a target has no closed-form candidate ('' if it has some)."""
    g = geometry(model)
    T = np.asarray(T_target, dtype=float)
    if mode == 'full':
        G = _tool_plane_rotation(g, T)
        roll = math.asin(max(-1.0, min(1.0, G[2, 1])))
        if abs(roll) > 1e-9:
            return (f'orientation not reachable by a 4-DOF arm: the tool is rolled by '
                    f'{roll:.4g} rad (its y axis must stay horizontal)')
        t = math.atan2(-G[0, 1], G[1, 1])
        P0, P1, _ = g.to_arm_frame(T[:3, 3])
        off = -P0 * math.sin(t) + P1 * math.cos(t)
        if abs(off) > 1e-9:
            return (f'pose not reachable by a 4-DOF arm: the position is {abs(off):.4g} m off '
                    f'the vertical plane of the tool heading {t:.4g} rad')
        phi = math.atan2(-G[2, 0], G[2, 2])
        pitch = wrap(phi + g.mu) + 0.0
        margin = reach_margin(model, T[:3, 3], pitch)
        return _reach_words(margin, f' at pitch {pitch:.4g} rad')
    if mode == 'pitch':
        pitch = target_pitch(g, T)[1] + 0.0          # + 0.0: no '-0' in the words
        return _reach_words(reach_margin(model, T[:3, 3], pitch), f' at pitch {pitch:.4g} rad')
    return _reach_words(reach_margin(model, T[:3, 3]), '')


def _reach_words(margin: float, suffix: str) -> str:
    if margin >= 0.0:
        return ''
    return f'target is {-margin:.4g} m beyond reach{suffix}'


# ---------------------------------------------------------------------------------------------
# vectorised batch (numpy): every branch for N targets at once
# ---------------------------------------------------------------------------------------------

#: cost added to the roll-flipped branches in solve_batch (above any squared joint distance)
_FLIP_COST = 1e6


def _branches_np(g: Px100Geometry, x, y, z, pitch):
    """Yield (q1, q2, q3, q4, exists) arrays for the 4 branches of N targets (see below)."""
    if not g.frame_is_base:
        P = (np.stack([x, y, z], axis=-1) - g.origin) @ g.R_F
        x, y, z = P[:, 0], P[:, 1], P[:, 2]
    a = np.arctan2(y, x)
    r = np.sqrt(x * x + y * y)
    Lr, L3, L4 = g.Lr, g.L3, g.L4
    inv2 = 1.0 / (2.0 * Lr * L3)
    const = (Lr * Lr + L3 * L3) * inv2
    _, _, s3, s4 = g.signs
    vz = -z - g.v2
    # tool direction in the plane: front angle pitch + d, back angle pi - pitch + d
    d = g.g3 - g.mu
    cp, sp = np.cos(pitch), np.sin(pitch)
    if d == 0.0:
        c_front, s_front, c_back, s_back = cp, sp, -cp, sp
    else:
        cd, sd = math.cos(d), math.sin(d)
        c_front, s_front = cp * cd - sp * sd, sp * cd + cp * sd
        c_back, s_back = -(cp * cd + sp * sd), sp * cd - cp * sd
    a_back = np.where(a < 0.0, a + math.pi, a - math.pi)
    off3 = g.g1 - g.g2
    for u, ca3, sa3, t1, phi in ((r, c_front, s_front, a, pitch - g.mu),
                                 (-r, c_back, s_back, a_back, (math.pi - g.mu) - pitch)):
        wu = u - L4 * ca3 - g.u2
        wv = vz - L4 * sa3
        c = (wu * wu + wv * wv) * inv2 - const
        good = np.abs(c) <= 1.0 + _REACH_EPS
        np.clip(c, -1.0, 1.0, out=c)
        s = np.sqrt(1.0 - c * c)
        base = np.arctan2(wv, wu) - g.g1
        k = np.arctan2(L3 * s, Lr + L3 * c)
        el = np.arctan2(s, c)
        for sgn in (1.0, -1.0):
            p2 = base - k if sgn > 0 else base + k
            p3 = el + off3 if sgn > 0 else off3 - el
            p4 = phi - p2 - p3
            yield (t1, wrap_array(p2), wrap_array(p3 if s3 > 0 else -p3),
                   wrap_array(p4 if s4 > 0 else -p4), good)


def batch_candidates(model, x, y, z, pitch) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return (Q (N, 4, 4), ok (N, 4)): the 4 branch candidates of N (x, y, z, pitch) targets.

    Branch order: (front, elbow +), (front, elbow -), (back, elbow +), (back, elbow -). ``ok``
    says the branch exists geometrically (limits not checked). Waist values are wrapped to
    [-pi, pi). Inputs are (N,) float arrays in the base frame [m, rad].
    """
    g = geometry(model)
    x, y, z, pitch = (np.asarray(v, dtype=float) for v in (x, y, z, pitch))
    n = x.shape[0]
    Q = np.empty((n, 4, 4))
    ok = np.empty((n, 4), dtype=bool)
    for j, (q1, q2, q3, q4, good) in enumerate(_branches_np(g, x, y, z, pitch)):
        Q[:, j, 0], Q[:, j, 1], Q[:, j, 2], Q[:, j, 3] = q1, q2, q3, q4
        ok[:, j] = good
    return Q, ok


def solve_batch(model, targets, q_seed=None, check_limits: bool = True,
                return_all: bool = False, chunk: int = 1 << 15):
    """
    Return (Q (N, 4), ok (N,)): the best solution of each target, vectorised.

    :param targets: (N, 4, 4) poses ('pitch' semantics: position + tool pitch, yaw forced) or
        (N, 4) rows (x, y, z, pitch) in the base frame [m, rad]
    :param q_seed: (4,) the solutions closest to it win (default model.home)
    :param return_all: return (Q (N, 4, 4), ok (N, 4)) with every branch instead
    Targets on the waist axis (x = y = 0) take waist 0 (a pose's heading is not used here).
    """
    g = geometry(model)
    targets = np.asarray(targets, dtype=float)
    if targets.ndim == 3:
        rows, back_first = _pose_rows(model, targets, with_side=True)
    else:
        rows, back_first = targets, np.zeros(len(targets), dtype=bool)
    n = rows.shape[0]
    seed = [float(v) for v in (model.home if q_seed is None else q_seed)]
    lo = [v - 1e-9 for v in g.lower]
    hi = [v + 1e-9 for v in g.upper]
    if return_all:
        Q_all = np.empty((n, 4, 4))
        ok_all = np.empty((n, 4), dtype=bool)
        for s in range(0, n, chunk):
            e = min(n, s + chunk)
            Q, ok = batch_candidates(model, rows[s:e, 0], rows[s:e, 1], rows[s:e, 2],
                                     rows[s:e, 3])
            if check_limits:
                ok &= np.all((Q >= np.array(lo)) & (Q <= np.array(hi)), axis=2)
            Q_all[s:e], ok_all[s:e] = Q, ok
        return Q_all, ok_all
    Q_best = np.empty((n, 4))
    ok_best = np.empty(n, dtype=bool)
    cols = [np.ascontiguousarray(rows[:, i]) for i in range(4)]

    def work(s: int) -> None:
        e = min(n, s + chunk)
        best_cost = np.full(e - s, np.inf)
        best = [np.zeros(e - s) for _ in range(4)]
        flip_cost = np.where(back_first[s:e], _FLIP_COST, 0.0)
        for j, (q1, q2, q3, q4, good) in enumerate(_branches_np(
                g, cols[0][s:e], cols[1][s:e], cols[2][s:e], cols[3][s:e])):
            qs = (q1, q2, q3, q4)
            # the branches with the target's tool roll win over the roll-flipped ones
            cost = (q1 - seed[0]) ** 2 + (flip_cost if j < 2 else _FLIP_COST - flip_cost)
            for i in (1, 2, 3):
                cost += (qs[i] - seed[i]) ** 2
            valid = good.copy()
            if check_limits:
                for i in range(4):
                    valid &= qs[i] >= lo[i]
                    valid &= qs[i] <= hi[i]
            take = valid & (cost < best_cost)
            np.copyto(best_cost, cost, where=take)
            for i in range(4):
                np.copyto(best[i], qs[i], where=take)
        ok = np.isfinite(best_cost)
        for i in range(4):
            Q_best[s:e, i] = np.where(ok, best[i], np.nan)
        ok_best[s:e] = ok

    starts = range(0, n, chunk)
    workers = min(len(starts), os.cpu_count() or 1, 8)
    if workers > 1:
        # numpy ufuncs release the GIL: chunks run in parallel on the cores
        with ThreadPoolExecutor(workers) as pool:
            list(pool.map(work, starts))
    else:
        for s in starts:
            work(s)
    return Q_best, ok_best


def _pose_rows(model, T: np.ndarray, with_side: bool = False):
    """
    Return (N, 4) rows (x, y, z, pitch) of (N, 4, 4) poses (pitch as in target_pitch).

    with_side: also return (N,) bools, True where the pose's tool roll is that of the back
    (waist + pi) branches, i.e. its y axis points away from the front branches' y axis
    (-sin a, cos a, 0).
    """
    g = geometry(model)
    p = T[:, :3, 3]
    X = T[:, :3, 0]
    Y = T[:, :3, 1]
    if not g.frame_is_base:
        P = (p - g.origin) @ g.R_F
        X = X @ g.R_F
        Y = Y @ g.R_F
    else:
        P = p
    a = np.arctan2(P[:, 1], P[:, 0])
    on_axis = P[:, 0] ** 2 + P[:, 1] ** 2 <= 1e-24
    if np.any(on_axis):
        a = np.where(on_axis, np.arctan2(X[:, 1], X[:, 0]), a)
    pitch = np.arctan2(-X[:, 2], np.cos(a) * X[:, 0] + np.sin(a) * X[:, 1])
    rows = np.column_stack([p, pitch])
    if not with_side:
        return rows
    return rows, (np.cos(a) * Y[:, 1] - np.sin(a) * Y[:, 0]) < 0.0
