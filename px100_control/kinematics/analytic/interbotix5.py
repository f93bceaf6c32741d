"""
Closed-form IK of 5-DOF Interbotix X-Series arms (px150, rx150, rx200, wx200, wx250, vx250, ...).

Joints: waist (about z), shoulder, elbow, wrist_angle (three parallel pitch axes, about y) and
wrist_rotate (roll about x). The geometry is read from the model's ``S_list`` and ``M`` (any arm
of this family works, e.g. mobile_wx200): the arm lies in the vertical plane of the waist, the
roll axis passes through the wrist pitch axis and the end effector lies on the roll axis, so

    R = Rz(waist) Ry(shoulder + elbow + wrist_angle) Rx(wrist_rotate)

and the wrist point W = p - L_tool x_tool depends on (waist, shoulder, elbow) only. The arm
reaches position + pitch + wrist roll, not an arbitrary yaw. Branches: the waist takes the
azimuth of W or that + pi (reaching over the top), the planar shoulder/elbow pair has two elbow
signs (a type 8 equation, ``trig_equations.solve_type8``): up to 4 candidates.

Modes: 'full' and 'pitch' (``solve.pitch_target`` has already forced the yaw to the target
azimuth, so both solve the given pose); 'position': the pitch is free: ``position_solutions``
minimises |q - q_nominal| exactly on every branch (the first four joints are a px100-family arm,
solved by ``analytic.px100``; the wrist roll takes its nominal value), and ``candidates`` gives
the closed-form branches on a grid of pitches (roll 0). Units: m, rad.
"""
from dataclasses import dataclass
import functools
import math
from typing import List, Tuple

import numpy as np

from px100_control.errors import RobotModelError
from px100_control.kinematics.analytic import px100
from px100_control.kinematics.kernels import wrap_angle

#: every closed-form branch is returned: solve_ik needs no iterative fallback
complete = True

_POSITION_GRID = 36
_AXIS_TOL = 1e-9


@dataclass(frozen=True)
class ArmPlane:
    """
    Planar geometry of an Interbotix-style arm, derived from (S_list, M).

    Points are (x, z) in the arm plane at q = 0 (y = 0); a pitch rotation g about +y turns a
    direction at plane angle a to a - g. ``signs`` turn geometric angles into joint values.
    """

    x1: float   # shoulder axis point [m]
    z1: float
    L1: float   # shoulder -> elbow [m], its plane angle at q = 0 [rad]
    b1: float
    L2: float   # elbow -> wrist (pitch) point [m], angle
    b2: float
    x3: float   # wrist point [m]
    z3: float
    Lt: float   # wrist point -> end effector along the tool x axis [m]
    signs: Tuple[float, ...]
    offset: float  # distance of the roll axes / end effector from the wrist point [m]


def _axis_point(w: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Return the point of the axis (w, v = -w x p) closest to the origin."""
    return np.cross(w, v)


def plane_geometry(model, pattern: str) -> ArmPlane:
    """
    Return the ArmPlane of a model whose axes at q = 0 follow ``pattern`` (e.g. 'zyyyx').

    :raises RobotModelError: the model is not of this Interbotix family
    """
    S = np.asarray(model.S_list, dtype=float)
    n = len(pattern)
    if S.shape != (6, n) or any(t != 'revolute' for t in model.joint_types):
        raise RobotModelError(f"'{model.name}' is not a {n}-revolute-joint arm; the "
                              f'Interbotix {n}-DOF solver does not apply')
    unit = {'x': np.array([1.0, 0.0, 0.0]), 'y': np.array([0.0, 1.0, 0.0]),
            'z': np.array([0.0, 0.0, 1.0])}
    signs = []
    pts = []
    for i, a in enumerate(pattern):
        w = S[:3, i]
        s = float(w @ unit[a])
        if abs(abs(s) - 1.0) > _AXIS_TOL:
            raise RobotModelError(f"'{model.name}': joint {model.joint_names[i]} axis is "
                                  f'{w.tolist()}, the solver needs +-{a}')
        signs.append(math.copysign(1.0, s))
        pts.append(_axis_point(w, S[3:, i]))
    if abs(pts[0][0]) > _AXIS_TOL or abs(pts[0][1]) > _AXIS_TOL:
        raise RobotModelError(f"'{model.name}': the waist axis must be the base z axis")
    M = np.asarray(model.M, dtype=float)
    if np.abs(M[:3, :3] - np.eye(3)).max() > _AXIS_TOL or abs(M[1, 3]) > _AXIS_TOL:
        raise RobotModelError(f"'{model.name}': M must be an identity rotation in the x-z "
                              'plane')
    pitch = [i for i, a in enumerate(pattern) if a == 'y']
    roll = [i for i, a in enumerate(pattern) if a == 'x']
    if len(pitch) != 3:
        raise RobotModelError(f"'{model.name}': needs exactly three pitch joints")
    P1, P2, P3 = (pts[i] for i in pitch)
    offset = abs(M[2, 3] - P3[2])
    for i in roll:
        offset = max(offset, math.hypot(pts[i][1], pts[i][2] - P3[2]))
    return ArmPlane(
        x1=float(P1[0]), z1=float(P1[2]),
        L1=float(math.hypot(P2[0] - P1[0], P2[2] - P1[2])),
        b1=float(math.atan2(P2[2] - P1[2], P2[0] - P1[0])),
        L2=float(math.hypot(P3[0] - P2[0], P3[2] - P2[2])),
        b2=float(math.atan2(P3[2] - P2[2], P3[0] - P2[0])),
        x3=float(P3[0]), z3=float(P3[2]), Lt=float(M[0, 3] - P3[0]),
        signs=tuple(signs), offset=float(offset))


@functools.lru_cache(maxsize=64)
def geometry(model) -> ArmPlane:
    """Return the (cached) 5-DOF geometry; raise RobotModelError if it does not apply."""
    g = plane_geometry(model, 'zyyyx')
    if g.offset > 1e-12:
        raise RobotModelError(f"'{model.name}': the wrist_rotate axis or the end effector is "
                              f'{g.offset:.3g} m off the wrist point; the 5-DOF closed form '
                              'needs them on it')
    return g


def waist_angles(wx: float, wy: float, R) -> List[float]:
    """
    Return the two waist angles [rad] putting the wrist point (wx, wy) in the arm plane.

    ``R``: the target rotation (3 rows of 3, nested lists or an array).
    """
    if wx * wx + wy * wy > 1e-24:
        a = math.atan2(wy, wx)
    elif R[0][0] * R[0][0] + R[1][0] * R[1][0] > 1e-24:
        a = math.atan2(R[1][0], R[0][0])   # wrist on the waist axis: face the tool x axis
    else:
        a = 0.0
    return [wrap_angle(a), wrap_angle(a + math.pi)]


def planar_solutions(g: ArmPlane, t1: float, wx: float, wy: float, wz: float,
                     tol: float = 1e-10):
    """
    Return [(g2, g3)] geometric shoulder/elbow angles putting the wrist point at W.

    ``tol``: relative slack on the reach (larger for initial guesses that get refined).
    """
    X = math.cos(t1) * wx + math.sin(t1) * wy - g.x1
    Z = wz - g.z1
    L1, L2 = g.L1, g.L2
    # the type 8 equation (trig_equations.solve_type8) in closed form: cos b from the law of
    # cosines, a = atan2(Z, X) - atan2(L2 sin b, L1 + L2 cos b)
    d2 = X * X + Z * Z
    cb = (d2 - L1 * L1 - L2 * L2) / (2.0 * L1 * L2)
    if cb > 1.0 or cb < -1.0:
        if abs(cb) - 1.0 > tol * max(1.0, d2 / (2.0 * L1 * L2)):
            return []
        cb = 1.0 if cb > 0.0 else -1.0
    sb = math.sqrt(1.0 - cb * cb)
    base = math.atan2(Z, X)
    out = []
    for s in ((sb, -sb) if sb > 0.0 else (0.0,)):
        b = math.atan2(s, cb)
        a = base - math.atan2(L2 * s, L1 + L2 * cb)
        out.append((g.b1 - a, g.b2 - g.b1 - b))
    return out


def rows_of(T) -> Tuple[list, list]:
    """Return (R as 3 rows of 3 floats, p as 3 floats) of a (4, 4) pose (array or rows)."""
    L = T.tolist() if hasattr(T, 'tolist') else T
    return [L[0][:3], L[1][:3], L[2][:3]], [L[0][3], L[1][3], L[2][3]]


def pitch_grid_candidates(solve_pose, g, p, count: int) -> list:
    """
    Return the branches ``solve_pose(g, R, p)`` of ``count`` poses at position p [m].

    The 'position' mode's candidates: tool roll 0, the tool x axis along the azimuth of p (0
    on the z axis), pitched by ``count`` angles evenly over [-pi, pi): R = Rz(azimuth)
    Ry(pitch), given as 3 rows of 3 floats.
    """
    x, y, z = (float(v) for v in p[:3])
    a = math.atan2(y, x) if x * x + y * y > 1e-24 else 0.0
    ca, sa = math.cos(a), math.sin(a)
    out: list = []
    for k in range(count):
        pitch = -math.pi + 2.0 * math.pi * k / count
        cp, sp = math.cos(pitch), math.sin(pitch)
        out += solve_pose(g, [[ca * cp, -sa, ca * sp], [sa * cp, ca, sa * sp], [-sp, 0.0, cp]],
                          [x, y, z])
    return out


def _solve_pose(g: ArmPlane, R, p) -> List[List[float]]:
    """Return the closed-form branches of a pose: R 3 rows of 3, p (x, y, z) [m]."""
    (r00, r01, r02), (r10, r11, r12), (r20, _, _) = R
    wx, wy, wz = p[0] - g.Lt * r00, p[1] - g.Lt * r10, p[2] - g.Lt * r20
    out = []
    s = g.signs
    for t1 in waist_angles(wx, wy, R):
        c, sn = math.cos(t1), math.sin(t1)
        # R' = Rz(-t1) R = Ry(phi) Rx(rho) when reachable
        phi = math.atan2(-r20, c * r00 + sn * r10)
        rho = math.atan2(sn * r02 - c * r12, -sn * r01 + c * r11)
        for g2, g3 in planar_solutions(g, t1, wx, wy, wz):
            g4 = phi - g2 - g3
            out.append([s[0] * t1, wrap_angle(s[1] * g2), wrap_angle(s[2] * g3),
                        wrap_angle(s[3] * g4), wrap_angle(s[4] * rho)])
    return out


def candidates_rows(model, T_rows, mode: str = 'full') -> List[List[float]]:
    """Return the 'full'/'pitch' candidates of ``candidates`` as lists (plain floats)."""
    return _solve_pose(geometry(model), *rows_of(T_rows))


def candidates(model, T_target: np.ndarray, mode: str) -> np.ndarray:
    """
    Return every closed-form candidate (k, 5) for a (4, 4) target, before limit filtering.

    'full'/'pitch': up to 4 (waist a or a + pi, two elbows); 'position': those branches on a
    grid of pitches with roll 0, as starting points for solve_ik's refinement.
    """
    g = geometry(model)
    T = np.asarray(T_target, dtype=float)
    if mode in ('full', 'pitch'):
        return np.array(_solve_pose(g, *rows_of(T)), dtype=float).reshape(-1, 5)
    if mode != 'position':
        raise ValueError(f'unknown IK mode {mode!r}')
    Q = pitch_grid_candidates(_solve_pose, g, T[:3, 3], _POSITION_GRID)
    return np.array(Q, dtype=float).reshape(-1, 5)


@functools.lru_cache(maxsize=64)
def _arm4(model):
    """Return the 4-joint sub-model (waist + three pitch joints) of a 5-DOF model."""
    # the model's own class (the models layer sits above kinematics)
    return type(model)(
        name=f'{model.name}:arm4', joint_names=tuple(model.joint_names[:4]),
        joint_types=tuple(model.joint_types[:4]), S_list=np.asarray(model.S_list)[:, :4],
        M=np.asarray(model.M), lower=np.asarray(model.lower)[:4],
        upper=np.asarray(model.upper)[:4], velocity_limits=np.asarray(model.velocity_limits)[:4],
        effort_limits=np.asarray(model.effort_limits)[:4], home=np.asarray(model.home)[:4],
        sleep=np.asarray(model.sleep)[:4], base_frame=model.base_frame, ee_frame=model.ee_frame)


def position_solutions(model, T_target: np.ndarray, q_nominal=None,
                       check_limits: bool = True) -> np.ndarray:
    """
    Return (k, 5) position-only solutions with the exact secondary task toward q_nominal.

    The end effector lies on the wrist_rotate axis, so the position depends on the first four
    joints only: they form a px100-family arm, solved by ``analytic.px100.position_solutions``
    (the free pitch minimising |q - q_nominal| on every branch); wrist_rotate = q_nominal's value
    (wrapped into its limits), which minimises its own term exactly.
    """
    geometry(model)
    qn = np.asarray(model.home if q_nominal is None else q_nominal, dtype=float)
    Q4 = px100.position_solutions(_arm4(model), T_target, qn[:4], check_limits=check_limits)
    q5 = float(qn[4])
    lo, hi = float(model.lower[4]), float(model.upper[4])
    for shift in (0.0, 2.0 * math.pi, -2.0 * math.pi):
        if lo <= q5 + shift <= hi:
            q5 += shift
            break
    return np.column_stack([np.asarray(Q4, float).reshape(-1, 4), np.full(len(Q4), q5)])


def reach_words(g: ArmPlane, T: np.ndarray) -> str:
    """Return why the wrist point of a pose is out of the shoulder/elbow annulus ('' if not)."""
    R, p = T[:3, :3], T[:3, 3]
    wx, wy, wz = p - g.Lt * R[:, 0]
    best = -math.inf
    for sign in (1.0, -1.0):
        d = math.hypot(sign * math.hypot(wx, wy) - g.x1, wz - g.z1)
        best = max(best, min(g.L1 + g.L2 - d, d - abs(g.L1 - g.L2)))
    if best >= 0.0:
        return ''
    return f'target is {-best:.4g} m beyond reach (wrist point outside the arm annulus)'


def position_reach_words(g: ArmPlane, p) -> str:
    """Say by how much a position [m] is beyond the arm's reach ('' if it is not)."""
    d = math.hypot(math.hypot(p[0], p[1]) - g.x1, p[2] - g.z1)
    reach = g.L1 + g.L2 + abs(g.Lt)
    return f'target is {d - reach:.4g} m beyond reach' if d > reach else ''


def unreachable_reason(model, T_target: np.ndarray, mode: str) -> str:
    """Explain in words why a target has no closed-form candidate ('' if unknown)."""
    g = geometry(model)
    T = np.asarray(T_target, dtype=float)
    if mode == 'position':
        return position_reach_words(g, T[:3, 3])
    words = reach_words(g, T)
    if words:
        return words
    R, p = T[:3, :3], T[:3, 3]
    wx, wy, _ = p - g.Lt * R[:, 0]
    t1 = waist_angles(wx, wy, R)[0]
    # the tool y axis must stay horizontal up to the roll: y_arm = Rz(t1) y must be in the
    # tool y-z plane, i.e. perpendicular to the tool x axis
    yaw_err = math.asin(max(-1.0, min(1.0, -math.sin(t1) * R[0, 0] + math.cos(t1) * R[1, 0])))
    if abs(yaw_err) > 1e-9:
        return (f'orientation not reachable by a 5-DOF arm: the tool x axis is {yaw_err:.4g} '
                'rad off the vertical plane through the wrist point (use mode pitch)')
    return ''


__all__ = ['candidates', 'candidates_rows', 'rows_of', 'pitch_grid_candidates',
           'unreachable_reason', 'position_solutions', 'geometry',
           'plane_geometry', 'ArmPlane',
           'waist_angles', 'planar_solutions', 'complete']
