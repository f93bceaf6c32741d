"""
Analytic IK of the 7-DOF Elephant myArm 300 Pi, parameterised by the elbow swivel angle.

Structure (read from ``S_list``/``M`` and checked against the model's FK): axes at q = 0 are
z, y, z, x, z, x, z; joints 1-3 meet at the shoulder S = (0, 0, d1), joint 4 (the elbow) crosses
the z axis at (0, 0, d1 + d3), joints 5-7 meet at the wrist W = (0, 0, d1 + d3 + d5), and the
flange is d7 above W with M = I. Rotations compose as

    R = Rz(q1) Ry(q2) Rz(q3) Rx(q4) Rz(q5) Rx(q6) Rz(q7),
    W(q) = S + Rz(q1) Ry(q2) Rz(q3) (d3 z + Rx(q4) d5 z),   p = W + R d7 z.

For a target (R, p): W = p - d7 R z. |W - S| fixes |q4| (law of cosines). The elbow E lies on a
circle about the line S-W; the swivel angle psi places it on that circle, measured from the
plane through S-W and the world z axis (world x when S-W is vertical). For a given psi:

- shoulder: R_sh z = u = (E - S) / d3 gives q2 = +-acos(u_z), q1 = atan2(+-u_y, +-u_x);
- elbow: (Rz1 Ry2)^T (W - E) / d5 = Rz(q3) (0, -sin q4, cos q4) gives q4 = +-acos and q3;
- wrist: (Rz1 Ry2 Rz3 Rx4)^T R = Rz(q5) Rx(q6) Rz(q7) (ZXZ Euler), q6 = +-acos.

So 8 branches per swivel angle (``solve_swivel``). ``candidates`` chooses the swivel of each
branch by a 1-D search (a 10 deg grid, then two finer grids around the best): by default the
secondary criterion is the joint-limit-avoidance cost sum(((q - mid) / span)^2) (farthest from
the limits; in-limit solutions first); with ``q_seed`` it is the distance to the seed among the
in-limit solutions. It returns the chosen solution of every branch. It is not complete (a feasible
swivel interval narrower than the grid can be missed), so ``solve_ik`` falls back to its
iterative solvers. Modes: 'full' and 'pitch' (a 7-DOF arm reaches the whole pose);
'position': closed-form solutions for a few tool orientations, as starting points for
``solve_ik``'s null-space refinement. Units: m, rad.
"""
from dataclasses import dataclass
import functools
import math
from typing import Optional

import numpy as np

from px100_control.errors import RobotModelError
from px100_control.kinematics.kernels import wrap_array
from px100_control.kinematics.se3 import rot_x, rot_y, rot_z

#: the swivel search may miss narrow feasible intervals: solve_ik keeps its iterative fallback
complete = False

_GRID = 36            # swivel samples in the coarse search (10 deg)
_FINE = 15            # samples in each refinement stage
_TINY = 1e-12
_PATTERN = 'zyzxzxz'
_UNIT = {'x': np.array([1.0, 0.0, 0.0]), 'y': np.array([0.0, 1.0, 0.0]),
         'z': np.array([0.0, 0.0, 1.0])}


@dataclass(frozen=True)
class SrsGeometry:
    """Dimensions [m] and joint-angle signs of a myArm-like SRS arm."""

    d1: float
    d3: float
    d5: float
    d7: float
    signs: np.ndarray     # (7,) joint value = sign * geometric angle
    lower: np.ndarray
    upper: np.ndarray


def _fk_geometric(g: SrsGeometry, t: np.ndarray) -> np.ndarray:
    """Return the (4, 4) pose of geometric angles t (for the structure check)."""
    Rs = rot_z(t[0]) @ rot_y(t[1]) @ rot_z(t[2])
    R4 = Rs @ rot_x(t[3])
    R = R4 @ rot_z(t[4]) @ rot_x(t[5]) @ rot_z(t[6])
    z = np.array([0.0, 0.0, 1.0])
    W = np.array([0.0, 0.0, g.d1]) + Rs @ (g.d3 * z) + R4 @ (g.d5 * z)
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = W + g.d7 * R[:, 2]
    return T


@functools.lru_cache(maxsize=16)
def geometry(model) -> SrsGeometry:
    """
    Return the SRS geometry of a model (cached), derived from S_list and M.

    :raises RobotModelError: the model is not a myArm-like 7-DOF SRS arm
    """
    S = np.asarray(model.S_list, dtype=float)
    if S.shape != (6, 7) or any(t != 'revolute' for t in model.joint_types):
        raise RobotModelError(f"'{model.name}' is not a 7-revolute-joint arm; the "
                              'myarm300pi solver does not apply')
    signs, heights = [], []
    for i, a in enumerate(_PATTERN):
        w = S[:3, i]
        s = float(w @ _UNIT[a])
        pt = np.cross(w, S[3:, i])
        if abs(abs(s) - 1.0) > 1e-9 or math.hypot(pt[0], pt[1]) > 1e-9:
            raise RobotModelError(f"'{model.name}': joint {model.joint_names[i]} must be "
                                  f'+-{a} through the base z axis at q = 0')
        signs.append(math.copysign(1.0, s))
        heights.append(pt[2])
    M = np.asarray(model.M, dtype=float)
    if np.abs(M[:3, :3] - np.eye(3)).max() > 1e-9 or math.hypot(M[0, 3], M[1, 3]) > 1e-9:
        raise RobotModelError(f"'{model.name}': M must be the identity rotation on the z axis")
    d1, z4, z6 = heights[1], heights[3], heights[5]
    g = SrsGeometry(d1=float(d1), d3=float(z4 - d1), d5=float(z6 - z4), d7=float(M[2, 3] - z6),
                    signs=np.array(signs), lower=np.asarray(model.lower, float),
                    upper=np.asarray(model.upper, float))
    if g.d3 <= 0.0 or g.d5 <= 0.0:
        raise RobotModelError(f"'{model.name}': upper arm and forearm lengths must be > 0")
    rng = np.random.default_rng(3)
    for q in rng.uniform(model.lower, model.upper, size=(4, 7)):
        if np.abs(_fk_geometric(g, q * g.signs) - model.fk(q)).max() > 1e-9:
            raise RobotModelError(f"'{model.name}' does not match the SRS structure of the "
                                  'myArm 300 Pi')
    return g


def _frame(g: SrsGeometry, R: np.ndarray, p: np.ndarray):
    """Return (W, w_hat, L, n_hat, m_hat, cos_a, sin_a) of a target, or None if out of reach."""
    W = p - g.d7 * R[:, 2]
    sw = W - np.array([0.0, 0.0, g.d1])
    L = float(np.linalg.norm(sw))
    if L > g.d3 + g.d5 + 1e-12 or L < abs(g.d3 - g.d5) - 1e-12 or L < _TINY:
        return None
    w = sw / L
    ref = np.array([0.0, 0.0, 1.0]) if abs(w[2]) < 0.99 else np.array([1.0, 0.0, 0.0])
    n = ref - (ref @ w) * w
    n /= np.linalg.norm(n)
    m = np.cross(w, n)
    ca = min(1.0, max(-1.0, (g.d3 * g.d3 + L * L - g.d5 * g.d5) / (2.0 * g.d3 * L)))
    return W, w, L, n, m, ca, math.sqrt(1.0 - ca * ca)


_SIGNS = np.array([[1.0 if not (k >> 2) & 1 else -1.0, 1.0 if not (k >> 1) & 1 else -1.0,
                    1.0 if not k & 1 else -1.0] for k in range(8)])   # (8, 3): q2, q4, q6


def _solve(g: SrsGeometry, fr, R: np.ndarray, psi: np.ndarray, sg: np.ndarray) -> np.ndarray:
    """Return (K, 7) geometric angles for K (swivel, branch signs (q2, q4, q6)) pairs."""
    W, w, _, n, m, ca, sa = fr
    cps, sps = np.cos(psi), np.sin(psi)
    u = ca * w + sa * (cps[:, None] * n + sps[:, None] * m)          # (K, 3) upper arm
    f = (W - np.array([0.0, 0.0, g.d1]) - g.d3 * u) / g.d5           # (K, 3) forearm
    s2g, s4g, s6g = sg[:, 0], sg[:, 1], sg[:, 2]
    # cosines and sines come from the unit vectors directly (fewer transcendental calls)
    rxy = np.hypot(u[:, 0], u[:, 1])
    reg1 = rxy > _TINY
    inv1 = np.where(reg1, s2g / np.where(reg1, rxy, 1.0), 0.0)
    c1, s1 = np.where(reg1, u[:, 0] * inv1, 1.0), u[:, 1] * inv1
    c2, s2 = np.clip(u[:, 2], -1.0, 1.0), s2g * rxy
    t1, t2 = np.arctan2(s1, c1), np.arctan2(s2, c2)
    # g = (Rz1 Ry2)^T f = Rz(t3) (0, -sin t4, cos t4)
    gx = c1 * c2 * f[:, 0] + s1 * c2 * f[:, 1] - s2 * f[:, 2]
    gy = -s1 * f[:, 0] + c1 * f[:, 1]
    gz = c1 * s2 * f[:, 0] + s1 * s2 * f[:, 1] + c2 * f[:, 2]
    hxy = np.hypot(gx, gy)
    reg3 = hxy > _TINY
    inv3 = np.where(reg3, s4g / np.where(reg3, hxy, 1.0), 0.0)
    s3, c3 = gx * inv3, np.where(reg3, -gy * inv3, 1.0)
    c4, s4 = np.clip(gz, -1.0, 1.0), s4g * hxy
    t3, t4 = np.arctan2(s3, c3), np.arctan2(s4, c4)
    # C = Rz(t1) Ry(t2) Rz(t3) Rx(t4) (elementwise: batched 3x3 products are slow in numpy)
    a00, a01, a02, a10, a11, a12, a20, a22 = c1 * c2, -s1, c1 * s2, s1 * c2, c1, s1 * s2, -s2, c2
    b01, b02, b11, b12 = -s3 * c4, s3 * s4, c3 * c4, -c3 * s4
    C = [[a00 * c3 + a01 * s3, a00 * b01 + a01 * b11 + a02 * s4, a00 * b02 + a01 * b12 + a02 * c4],
         [a10 * c3 + a11 * s3, a10 * b01 + a11 * b11 + a12 * s4, a10 * b02 + a11 * b12 + a12 * c4],
         [a20 * c3, a20 * b01 + a22 * s4, a20 * b02 + a22 * c4]]

    def rw(i, k):
        """Entry (i, k) of C^T R = Rz(t5) Rx(t6) Rz(t7)."""
        return C[0][i] * R[0, k] + C[1][i] * R[1, k] + C[2][i] * R[2, k]
    w02, w12, w22, w20, w21, w10, w00 = rw(0, 2), rw(1, 2), rw(2, 2), rw(2, 0), rw(2, 1), \
        rw(1, 0), rw(0, 0)
    sb = np.hypot(w02, w12)
    regular = sb > 1e-10
    t6 = np.arctan2(s6g * sb, w22)
    t5 = np.where(regular, np.arctan2(s6g * w02, -s6g * w12), 0.0)
    z7 = np.arctan2(w10, w00)
    t7 = np.where(regular, np.arctan2(s6g * w20, s6g * w21), np.where(w22 > 0, z7, -z7))
    out = np.stack([t1, t2, t3, t4, t5, t6, t7], axis=1) * g.signs
    return wrap_array(out)


def solve_swivel(model, T_target: np.ndarray, psi) -> np.ndarray:
    """
    Return (G, 8, 7) joint values of all 8 branches at each of G swivel angles psi [rad].

    Branch k has q2, q4, q6 signs from bits 2, 1, 0 of k (0 = +). Rows are NaN when the
    wrist point is out of reach. Angles wrapped to [-pi, pi); limits not checked.
    """
    g = geometry(model)
    T = np.asarray(T_target, dtype=float)
    psi = np.atleast_1d(np.asarray(psi, dtype=float))
    G = psi.shape[0]
    fr = _frame(g, T[:3, :3], T[:3, 3])
    if fr is None:
        return np.full((G, 8, 7), np.nan)
    Q = _solve(g, fr, T[:3, :3], np.repeat(psi, 8), np.tile(_SIGNS, (G, 1)))
    return Q.reshape(G, 8, 7)


def swivel_angle(model, q) -> float:
    """Return the swivel angle [rad] of configuration q (as solve_swivel measures it)."""
    g = geometry(model)
    q = np.asarray(q, dtype=float) * g.signs
    T = _fk_geometric(g, q)
    fr = _frame(g, T[:3, :3], T[:3, 3])
    if fr is None:
        return float('nan')
    _, w, _, n, m, ca, _ = fr
    u = rot_z(q[0]) @ rot_y(q[1]) @ np.array([0.0, 0.0, 1.0])
    v = u - ca * w
    return math.atan2(float(v @ m), float(v @ n))


def _score(g: SrsGeometry, Q: np.ndarray, q_seed: Optional[np.ndarray]) -> np.ndarray:
    """
    Return the criterion (higher is better) of (..., 7) configurations; NaN rows -> -inf.

    In-limit solutions always rank above out-of-limit ones (those rank by their worst normalised
    violation). Among in-limit ones: without a seed, the classic joint-limit-avoidance cost
    -sum(((q - mid) / span)^2) (Liegeois), i.e. farthest from the limits; with a seed, -|q - seed|.
    """
    span = g.upper - g.lower
    margin = np.min(np.minimum(Q - g.lower, g.upper - Q) / span, axis=-1)
    if q_seed is None:
        mid = 0.5 * (g.upper + g.lower)
        inner = -np.sum(((Q - mid) / span) ** 2, axis=-1)
    else:
        inner = -np.sqrt(np.sum((Q - q_seed) ** 2, axis=-1))
    score = np.where(margin >= -1e-12, 100.0 + inner, margin - 100.0)
    return np.where(np.isnan(score), -np.inf, score)


def search_swivel(model, T_target: np.ndarray, q_seed=None):
    """
    Return (Q (8, 7), psi (8,), score (8,)): the best solution of each branch over the swivel.

    Coarse grid of ``_GRID`` angles, then two finer grids around each branch's best; the
    criterion is ``_score`` (in-limit first; then away from the limits, or close to q_seed).
    """
    g = geometry(model)
    seed = None if q_seed is None else np.asarray(q_seed, dtype=float)
    psi = np.linspace(-np.pi, np.pi, _GRID, endpoint=False)
    Q = solve_swivel(model, T_target, psi)                       # (G, 8, 7)
    sc = _score(g, Q, seed)                                      # (G, 8)
    best = np.argmax(sc, axis=0)
    br = np.arange(8)
    best_psi, best_q, best_sc = psi[best], Q[best, br], sc[best, br]
    half = 2.0 * np.pi / _GRID
    fr = _frame(g, np.asarray(T_target, float)[:3, :3], np.asarray(T_target, float)[:3, 3])
    if fr is None:
        return best_q, best_psi, best_sc
    signs = np.repeat(_SIGNS, _FINE, axis=0)                     # (8 * F, 3)
    for _ in range(2):
        offs = np.linspace(-half, half, _FINE)
        P = (best_psi[:, None] + offs[None, :])                  # (8, F)
        Qf = _solve(g, fr, np.asarray(T_target, float)[:3, :3], P.reshape(-1),
                    signs).reshape(8, _FINE, 7)
        scf = _score(g, Qf, seed)                                # (8, F)
        k = np.argmax(scf, axis=1)
        better = scf[br, k] > best_sc
        best_psi = np.where(better, P[br, k], best_psi)
        best_q = np.where(better[:, None], Qf[br, k], best_q)
        best_sc = np.where(better, scf[br, k], best_sc)
        half = 2.0 * half / (_FINE - 1)
    return best_q, best_psi, best_sc


def candidates(model, T_target: np.ndarray, mode: str, q_seed=None) -> np.ndarray:
    """
    Return one solution per branch (k <= 8, 7), its swivel chosen by the secondary criterion.

    'full'/'pitch': the whole pose; 'position': the same for 11 tool orientations (tool z along
    shoulder -> target and tilted 60 deg from it, and along +-x, +-y, +-z turned to the target
    azimuth), as starting points for refinement.
    """
    T = np.asarray(T_target, dtype=float)
    if mode in ('full', 'pitch'):
        Q, _, sc = search_swivel(model, T, q_seed)
        return Q[np.isfinite(sc)]
    if mode != 'position':
        raise ValueError(f'unknown IK mode {mode!r}')
    g = geometry(model)
    p = T[:3, 3]
    a = math.atan2(p[1], p[0]) if p[0] * p[0] + p[1] * p[1] > 1e-24 else 0.0
    # tool z along +-x, +-y, +-z (facing the target azimuth), then the radial family below
    orientations = [rot_z(a) @ R for R in (np.eye(3), rot_y(math.pi), rot_y(math.pi / 2),
                                           rot_y(-math.pi / 2), rot_x(math.pi / 2),
                                           rot_x(-math.pi / 2))]
    radial = p - np.array([0.0, 0.0, g.d1])
    if np.linalg.norm(radial) > 1e-9:
        # tool z along shoulder -> target: the wrist point then lies on that line (best reach)
        z = radial / np.linalg.norm(radial)
        x = np.cross([0.0, 1.0, 0.0], z) if abs(z[1]) < 0.9 else np.cross([1.0, 0.0, 0.0], z)
        x /= np.linalg.norm(x)
        Rr = np.column_stack([x, np.cross(z, x), z])
        orientations[:0] = [Rr, Rr @ rot_x(math.pi / 3), Rr @ rot_x(-math.pi / 3),
                            Rr @ rot_y(math.pi / 3), Rr @ rot_y(-math.pi / 3)]
    out = []
    for R in orientations:
        Tk = np.eye(4)
        Tk[:3, :3], Tk[:3, 3] = R, p
        Q, _, sc = search_swivel(model, Tk, q_seed)
        out.append(Q[np.isfinite(sc)])
    return np.concatenate(out, axis=0)


# ---------------------------------------------------------------------------------------------
# scalar fast path: the first in-limit swivel nearest the seed's (plain floats)
# ---------------------------------------------------------------------------------------------

_FAST_STEP = 2.0 * math.pi / _GRID      # swivel step of the scalar search [rad]


def _branch_angles(t, a: int, b: int, c: int):
    """
    Return the geometric angles of branch (q2, q4, q6 sign flips a, b, c) from branch 0's.

    Flipping q2 maps (t1, t2, t3) to (t1 + pi, -t2, t3 + pi) (ZYZ ambiguity, same elbow);
    flipping q4 maps (t3, t4, t5) to (t3 + pi, -t4, t5 - pi); flipping q6 maps (t5, t6, t7)
    to (t5 + pi, -t6, t7 + pi). Not wrapped.
    """
    pi = math.pi
    t1, t2, t3, t4, t5, t6, t7 = t
    return (t1 + a * pi, -t2 if a else t2, t3 + (a + b) * pi, -t4 if b else t4,
            t5 + (c - b) * pi, -t6 if c else t6, t7 + c * pi)


def _scalar_solver(g: SrsGeometry):
    """
    Return solve(R rows, p, q_seed) -> (q tuple or None, swivels tried).

    Swivel angles are tried outward from the seed's (steps of ``_FAST_STEP``, one full turn);
    at each, branch 0 is solved in closed form and the other 7 follow by sign flips; the joint
    groups (1, 2), (3, 4), (5, 6, 7) depend on the flips (a), (a, b), (b, c) only, so the
    in-limit branches are enumerated group by group and the one nearest the seed is returned.
    Degenerate swivels (shoulder, elbow or wrist singular) are skipped.
    """
    d1, d3, d5, d7 = g.d1, g.d3, g.d5, g.d7
    sg = [float(v) for v in g.signs]
    lo = [float(v) for v in g.lower]
    hi = [float(v) for v in g.upper]
    pi, two_pi = math.pi, 2.0 * math.pi
    sqrt, atan2, hypot, cos, sin = math.sqrt, math.atan2, math.hypot, math.cos, math.sin
    reach_hi, reach_lo = d3 + d5 + 1e-12, abs(d3 - d5) - 1e-12

    def joint(j, t):
        v = sg[j] * t
        if not -pi <= v < pi:
            v = (v + pi) % two_pi - pi
        return v if lo[j] - 1e-9 <= v <= hi[j] + 1e-9 else None

    def solve(R, p, seed):
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R
        sx, sy, sz = p[0] - d7 * r02, p[1] - d7 * r12, p[2] - d7 * r22 - d1     # W - S
        L = sqrt(sx * sx + sy * sy + sz * sz)
        if not (reach_lo < L < reach_hi) or L < _TINY:
            return None, 0
        w0, w1, w2 = sx / L, sy / L, sz / L
        if abs(w2) < 0.99:          # n: world z (world x when S-W is vertical) made normal to w
            k = w2
            n0, n1, n2 = -k * w0, -k * w1, 1.0 - k * w2
        else:
            k = w0
            n0, n1, n2 = 1.0 - k * w0, -k * w1, -k * w2
        nn = sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        n0, n1, n2 = n0 / nn, n1 / nn, n2 / nn
        m0, m1, m2 = w1 * n2 - w2 * n1, w2 * n0 - w0 * n2, w0 * n1 - w1 * n0
        ca = (d3 * d3 + L * L - d5 * d5) / (2.0 * d3 * L)
        ca = 1.0 if ca > 1.0 else -1.0 if ca < -1.0 else ca
        sa = sqrt(1.0 - ca * ca)
        # the seed's swivel: its upper arm direction Rz(t1) Ry(t2) z about the S-W line
        g1, g2 = sg[0] * seed[0], sg[1] * seed[1]
        us0, us1, us2 = cos(g1) * sin(g2), sin(g1) * sin(g2), cos(g2)
        uw = us0 * w0 + us1 * w1 + us2 * w2
        v0, v1, v2 = us0 - uw * w0, us1 - uw * w1, us2 - uw * w2
        psi0 = atan2(v0 * m0 + v1 * m1 + v2 * m2, v0 * n0 + v1 * n1 + v2 * n2)
        e0, e1, e2, e3, e4, e5, e6 = seed
        tried = 0
        for k in range(_GRID):
            step = (k + 1) // 2 * _FAST_STEP
            psi = psi0 + (step if k % 2 else -step)
            tried += 1
            cp, sp = cos(psi), sin(psi)
            u0 = ca * w0 + sa * (cp * n0 + sp * m0)
            u1 = ca * w1 + sa * (cp * n1 + sp * m1)
            u2 = ca * w2 + sa * (cp * n2 + sp * m2)
            f0, f1, f2 = (sx - d3 * u0) / d5, (sy - d3 * u1) / d5, (sz - d3 * u2) / d5
            rxy = hypot(u0, u1)
            if rxy < 1e-9:
                continue
            c1, s1 = u0 / rxy, u1 / rxy
            c2 = -1.0 if u2 < -1.0 else 1.0 if u2 > 1.0 else u2
            s2 = rxy
            gx = c1 * c2 * f0 + s1 * c2 * f1 - s2 * f2
            gy = -s1 * f0 + c1 * f1
            gz = c1 * s2 * f0 + s1 * s2 * f1 + c2 * f2
            hxy = hypot(gx, gy)
            if hxy < 1e-9:
                continue
            s3, c3 = gx / hxy, -gy / hxy
            c4 = -1.0 if gz < -1.0 else 1.0 if gz > 1.0 else gz
            s4 = hxy
            # C = Rz(t1) Ry(t2) Rz(t3) Rx(t4); the wrist solves C^T R = Rz(t5) Rx(t6) Rz(t7)
            a00, a10, a20 = c1 * c2, s1 * c2, -s2
            a02, a12, a22 = c1 * s2, s1 * s2, c2
            b01, b02, b11, b12 = -s3 * c4, s3 * s4, c3 * c4, -c3 * s4
            C00, C10, C20 = a00 * c3 - s1 * s3, a10 * c3 + c1 * s3, a20 * c3
            C01 = a00 * b01 - s1 * b11 + a02 * s4
            C11 = a10 * b01 + c1 * b11 + a12 * s4
            C21 = a20 * b01 + a22 * s4
            C02 = a00 * b02 - s1 * b12 + a02 * c4
            C12 = a10 * b02 + c1 * b12 + a12 * c4
            C22 = a20 * b02 + a22 * c4
            x02 = C00 * r02 + C10 * r12 + C20 * r22
            x12 = C01 * r02 + C11 * r12 + C21 * r22
            x22 = C02 * r02 + C12 * r12 + C22 * r22
            x20 = C02 * r00 + C12 * r10 + C22 * r20
            x21 = C02 * r01 + C12 * r11 + C22 * r21
            sb = hypot(x02, x12)
            if sb < 1e-9:
                continue
            t1, t2, t3, t4 = atan2(s1, c1), atan2(s2, c2), atan2(s3, c3), atan2(s4, c4)
            t5, t6, t7 = atan2(x02, -x12), atan2(sb, x22), atan2(x20, x21)
            # joint values of the flips (see _branch_angles): group (1, 2) by a, 3 by the
            # parity of a + b, 4 by b, 5 by the parity of c - b, 6 and 7 by c
            # each group's values and its share of the distance to the seed
            A = []
            for a in (0, 1):
                q1 = joint(0, t1 + pi if a else t1)
                q2 = joint(1, -t2 if a else t2) if q1 is not None else None
                A.append(None if q2 is None else (q1, q2, (q1 - e0) ** 2 + (q2 - e1) ** 2))
            if A[0] is None and A[1] is None:
                continue
            J3 = (joint(2, t3), joint(2, t3 + pi))
            J4 = (joint(3, t4), joint(3, -t4))
            J5 = (joint(4, t5), joint(4, t5 + pi))
            J67 = []
            for c in (0, 1):
                q6 = joint(5, -t6 if c else t6)
                q7 = joint(6, t7 + pi if c else t7) if q6 is not None else None
                J67.append(None if q7 is None else (q6, q7, (q6 - e5) ** 2 + (q7 - e6) ** 2))
            best, best_cost = None, math.inf
            for a in (0, 1):
                qa = A[a]
                if qa is None:
                    continue
                for b in (0, 1):
                    q3, q4 = J3[(a + b) & 1], J4[b]
                    if q3 is None or q4 is None:
                        continue
                    cost_ab = qa[2] + (q3 - e2) ** 2 + (q4 - e3) ** 2
                    for c in (0, 1):
                        q5, q67 = J5[(c + b) & 1], J67[c]
                        if q5 is None or q67 is None:
                            continue
                        cost = cost_ab + (q5 - e4) ** 2 + q67[2]
                        if cost < best_cost:
                            best = (qa[0], qa[1], q3, q4, q5, q67[0], q67[1])
                            best_cost = cost
            if best is not None:
                return best, tried
        return None, tried
    return solve


@functools.lru_cache(maxsize=16)
def _model_solver(model):
    return _scalar_solver(geometry(model))


def ik_fast(model, T_target, q_seed=None):
    """
    Return (q (7-tuple) or None, swivels tried): an in-limit closed-form solution, fast.

    The scalar path for one full-pose target (plain floats): the swivel angle nearest the
    seed's (default model.home) whose best branch is in the limits, the branch nearest the
    seed. None when no swivel on the grid has one (``solve_ik`` then searches finer and falls
    back to iterative IK). Not verified here: callers check the pose by FK.
    """
    T = T_target.tolist() if hasattr(T_target, 'tolist') else T_target
    seed = [float(x) for x in (model.home if q_seed is None else q_seed)]
    return _model_solver(model)([T[0][:3], T[1][:3], T[2][:3]],
                                (T[0][3], T[1][3], T[2][3]), seed)


def unreachable_reason(model, T_target: np.ndarray, mode: str) -> str:
    """Explain in words why a target has no closed-form candidate ('' if unknown)."""
    g = geometry(model)
    T = np.asarray(T_target, dtype=float)
    if mode == 'position':
        d = float(np.linalg.norm(T[:3, 3] - np.array([0.0, 0.0, g.d1])))
        reach = g.d3 + g.d5 + g.d7
        return f'target is {d - reach:.4g} m beyond reach' if d > reach else ''
    W = T[:3, 3] - g.d7 * T[:3, 2]
    L = float(np.linalg.norm(W - np.array([0.0, 0.0, g.d1])))
    if L > g.d3 + g.d5:
        return (f'wrist point is {L - g.d3 - g.d5:.4g} m beyond reach of the shoulder '
                f'(|W - S| = {L:.4g} m > d3 + d5)')
    if L < abs(g.d3 - g.d5):
        return f'wrist point is {abs(g.d3 - g.d5) - L:.4g} m too close to the shoulder'
    return ''


__all__ = ['candidates', 'unreachable_reason', 'geometry', 'solve_swivel', 'swivel_angle',
           'search_swivel', 'SrsGeometry', 'complete', 'ik_fast']
