"""
Closed-form inverse geometric model of an RRRP robot (modified DH): type 3 and 5 equations.

Modified DH (alpha, a, theta, r): 1: (0, 0, q1, r1); 2: (0, a2, q2 + pi/2, 0);
3: (pi/2, 0, q3, r3); 4: (pi/2, 0, 0, q4) prismatic; tool Tz(r4). The direct model:

    0M4 = [[-s12 c3, c12, -s3 s12, a2 c1 - q4 s3 s12 + r3 c12],
           [ c3 c12, s12,  s3 c12, a2 s1 + q4 s3 c12 + r3 s12],
           [ s3,     0,   -c3,     -q4 c3 + r1],
           [ 0,      0,    0,      1]]

Inverse ('full' pose), with fMw = fMe Tz(r4)^-1 = [x y z t]:

- q3 from the type 3 pair s3 = x_z, -c3 = z_z; q12 = q1 + q2 from the type 3 pair
  c12 = y_x, s12 = y_y;
- if |cos q3| > |sin q3|: q4 = (r1 - t_z) / cos q3, then q1 from the type 3 pair
  a2 c1 = t_x + q4 s3 s12 - r3 c12, a2 s1 = t_y - q4 s3 c12 - r3 s12;
- else (q1, q4) from the type 5 pair a2 s1 = (t_y - r3 s12) - c12 s3 q4,
  a2 c1 = (t_x - r3 c12) + s12 s3 q4 (two roots: t_z is not used, so one root is spurious
  unless cos q3 = 0; the FK check of ``solve_ik`` drops it, the usual add-candidate step);
- q2 = q12 - q1.

Every candidate is returned; ``solve_ik`` verifies each by FK and filters the limits.
Other modes (same building blocks): 'pitch' (``solve_ik``'s 4-DOF semantics:
position + the tool x axis = (-s12 c3, c3 c12, s3)): q3 and q12 from that axis (two signs of
c3), then as above; 'position': q4 on a grid over its travel, cos q3 = (r1 - z) / (q4 + r4),
then (q1, q12) from a type 8 pair, as starting points for ``solve_ik``'s null-space refinement.
Units: m, rad.
"""
from dataclasses import dataclass
import functools
import math
from typing import List

import numpy as np

from px100_control.errors import RobotModelError
from px100_control.kinematics.trig_equations import (solve_type3, solve_type5, solve_type8,
                                                     wrap_angle)

#: every closed-form candidate is returned ('full', 'pitch'): no iterative fallback needed
complete = True

_POSITION_GRID = 24
_HALF_PI = math.pi / 2.0


@dataclass(frozen=True)
class RrrpParameters:
    """RRRP dimensions r1, a2, r3, r4 [m]."""

    r1: float
    a2: float
    r3: float
    r4: float


def _dgm(P: RrrpParameters, q) -> np.ndarray:
    """Return fMe from the direct geometric model (for the structure check)."""
    q1, q2, q3, q4 = q
    s12, c12 = math.sin(q1 + q2), math.cos(q1 + q2)
    s3, c3 = math.sin(q3), math.cos(q3)
    T = np.array([[-s12 * c3, c12, -s3 * s12, P.a2 * math.cos(q1) - q4 * s3 * s12 + P.r3 * c12],
                  [c3 * c12, s12, s3 * c12, P.a2 * math.sin(q1) + q4 * s3 * c12 + P.r3 * s12],
                  [s3, 0.0, -c3, -q4 * c3 + P.r1],
                  [0.0, 0.0, 0.0, 1.0]])
    T[:3, 3] += P.r4 * T[:3, 2]
    return T


@functools.lru_cache(maxsize=16)
def parameters(model) -> RrrpParameters:
    """
    Return (r1, a2, r3, r4) of an RRRP-family model, read from its MDH table.

    The model's FK is checked against the direct model at a few configurations.
    :raises RobotModelError: the model is not this robot family
    """
    kin = (model.extra or {}).get('kinematics') or {}
    joints = kin.get('joints') or []
    if kin.get('convention') != 'mdh' or len(joints) != 4:
        raise RobotModelError(f"'{model.name}': the rrrp solver needs a 4-joint MDH table")
    tool = kin.get('tool') or {}
    xyz = tool.get('xyz', (0.0, 0.0, 0.0)) if isinstance(tool, dict) else (
        np.asarray(tool, float)[:3, 3])
    P = RrrpParameters(r1=float(joints[0].get('d', 0.0)), a2=float(joints[1].get('a', 0.0)),
                       r3=float(joints[2].get('d', 0.0)), r4=float(xyz[2]))
    rng = np.random.default_rng(2)
    for q in rng.uniform(model.lower, model.upper, size=(4, 4)):
        if np.abs(_dgm(P, q) - model.fk(q)).max() > 1e-9:
            raise RobotModelError(f"'{model.name}' does not match the RRRP direct model")
    if abs(P.a2) < 1e-12:
        raise RobotModelError(f"'{model.name}': a2 = 0, the rrrp solver needs a2 != 0")
    return P


def _from_q3_q12(P: RrrpParameters, q3: float, q12: float, tx: float, ty: float, tz: float,
                 out: List[list]) -> None:
    """Append the (q1, q2, q3, q4) candidates for known q3 and q12 (wrist point t)."""
    s3, c3 = math.sin(q3), math.cos(q3)
    c12, s12 = math.cos(q12), math.sin(q12)
    if abs(c3) > abs(s3):
        q4 = (P.r1 - tz) / c3
        for q1 in solve_type3(0.0, P.a2, tx + q4 * s3 * s12 - P.r3 * c12,
                              P.a2, 0.0, ty - q4 * s3 * c12 - P.r3 * s12):
            out.append([q1, wrap_angle(q12 - q1), q3, q4])
    else:
        for q1, q4 in solve_type5(P.a2, ty - P.r3 * s12, -c12 * s3,
                                  P.a2, tx - P.r3 * c12, s12 * s3):
            out.append([q1, wrap_angle(q12 - q1), q3, q4])


def _full(P: RrrpParameters, T) -> List[list]:
    """Return the 'full' candidates of a pose given as 4 rows of 4 floats."""
    (_, yx, zx, px), (_, yy, zy, py), (xz, _, zz, pz) = T[0], T[1], T[2]
    # wrist: fMw = fMe Tz(r4)^-1
    tx, ty, tz = px - P.r4 * zx, py - P.r4 * zy, pz - P.r4 * zz
    out: List[list] = []
    for q3 in solve_type3(1.0, 0.0, xz, 0.0, -1.0, zz):
        for q12 in solve_type3(0.0, 1.0, yx, 1.0, 0.0, yy):
            _from_q3_q12(P, q3, q12, tx, ty, tz, out)
    return out


def _pitch(P: RrrpParameters, T: np.ndarray) -> List[list]:
    """Candidates for position + tool x axis d = (-s12 c3, c3 c12, s3)."""
    d = T[:3, 0]
    p = T[:3, 3]
    h = math.hypot(d[0], d[1])
    out: List[list] = []
    for c3 in ((h, -h) if h > 1e-12 else (0.0,)):
        q3 = math.atan2(d[2], c3)
        if abs(c3) > 1e-12:
            q12s = [math.atan2(-d[0] / c3, d[1] / c3)]
        else:
            # x axis vertical: q12 is free; keep the azimuth of the target as a start
            q12s = [math.atan2(p[1], p[0])]
        for q12 in q12s:
            s3, s12, c12 = math.sin(q3), math.sin(q12), math.cos(q12)
            z_axis = np.array([-s3 * s12, s3 * c12, -math.cos(q3)])
            t = p - P.r4 * z_axis
            _from_q3_q12(P, q3, q12, t[0], t[1], t[2], out)
    return out


def _position(P: RrrpParameters, T: np.ndarray, q4_lo: float, q4_hi: float) -> List[list]:
    """
    Return starting points for position-only IK: q4 on a grid over its travel, the rest closed.

    z = r1 - (q4 + r4) cos q3 gives q3 = +-acos((r1 - z) / (q4 + r4)); then (x, y) =
    a2 u(q1) + L u(q12 + g) with L u(g) = (r3, (q4 + r4) sin q3), a type 8 pair in (q1, q12).
    """
    x, y, z = T[:3, 3]
    out: List[list] = []
    for k in range(_POSITION_GRID):
        q4 = q4_lo + (q4_hi - q4_lo) * (k + 0.5) / _POSITION_GRID
        rho = q4 + P.r4
        if abs(rho) < 1e-9:
            continue
        c3 = (P.r1 - z) / rho
        if abs(c3) > 1.0:
            continue
        for q3 in {math.acos(c3), -math.acos(c3)}:
            s3 = math.sin(q3)
            L = math.hypot(P.r3, rho * s3)
            g = math.atan2(rho * s3, P.r3)
            for q1, b in solve_type8(P.a2, L, x, y):
                q12 = q1 + b - g
                out.append([q1, wrap_angle(q12 - q1), wrap_angle(q3), q4])
    return out


def candidates(model, T_target: np.ndarray, mode: str) -> np.ndarray:
    """Return every closed-form candidate (k, 4) for a (4, 4) target, before limit filtering."""
    P = parameters(model)
    T = np.asarray(T_target, dtype=float)
    if mode == 'full':
        out = _full(P, T.tolist())
    elif mode == 'pitch':
        out = _pitch(P, T)
    elif mode == 'position':
        out = _position(P, T, float(model.lower[3]), float(model.upper[3]))
    else:
        raise ValueError(f'unknown IK mode {mode!r}')
    return np.array(out, dtype=float).reshape(-1, 4)


def candidates_rows(model, T_rows, mode: str = 'full') -> List[list]:
    """Return the candidates of ``candidates`` as lists; T_rows: 4 rows of 4 floats."""
    if mode == 'full':
        return _full(parameters(model), T_rows)
    return candidates(model, np.array(T_rows, dtype=float), mode).tolist()


def unreachable_reason(model, T_target: np.ndarray, mode: str) -> str:
    """Explain in words why a target has no closed-form candidate ('' if unknown)."""
    P = parameters(model)
    T = np.asarray(T_target, dtype=float)
    if mode == 'pitch':
        C = candidates(model, T, 'pitch')
        if not len(C):
            return 'the wrist point is out of reach for this tool x axis'
        return ('position and tool x axis not reachable together by the RRRP (the pitch mode '
                'forces the x axis heading to the target azimuth; use mode full or position)')
    if mode == 'full' and abs(T[2, 1]) > 1e-9:
        return (f'orientation not reachable by the RRRP: its y axis stays horizontal '
                f'(target y_z = {T[2, 1]:.4g})')
    if mode == 'full':
        C = candidates(model, T, 'full')
        if len(C):
            q4 = C[:, 3]
            lo, hi = float(model.lower[3]), float(model.upper[3])
            if np.all((q4 < lo) | (q4 > hi)):
                return (f'prismatic joint would need {q4[np.argmin(np.abs(q4 - lo))]:.4g} m, '
                        f'outside [{lo:.4g}, {hi:.4g}]')
        t = T[:3, 3] - P.r4 * T[:3, 2]
        return (f'the wrist point ({t[0]:.4g}, {t[1]:.4g}, {t[2]:.4g}) m is not reachable with '
                'this orientation')
    return ''


__all__ = ['candidates', 'candidates_rows', 'unreachable_reason', 'parameters',
           'RrrpParameters', 'complete']
