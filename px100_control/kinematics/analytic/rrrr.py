"""
Closed-form IK of a 4-DOF RRRR arm in standard DH with a wrist offset d4 (registry 'rrrr').

Forward model (C23 = cos(q2 + q3), S23 = sin(q2 + q3)):

    X = C1 (a2 C2 + a3 C23 + d4 S23), Y = S1 (...), Z = d1 + a2 S2 + a3 S23 - d4 C23

It holds for the standard DH table with twists +90 deg on joints 1 and 3 (a table with twists
-90/+90 deg, as it is sometimes printed, does not produce it: see config/robots/rrrr.yaml).
Position IK: q1 = atan2(Y, X); with Px = sqrt(X^2 + Y^2), Pz = Z - d1,
D = Px^2 + Pz^2 - a2^2 - a3^2 - d4^2, Rk = sqrt(a3^2 + d4^2), gamma = atan2(d4, a3):
q3 = gamma +- acos(D / (2 a2 Rk)) (elbow up / down); with A = a3 c3 + d4 s3, B = a3 s3 - d4 c3:
q2 = atan2(-B Px + (a2 + A) Pz, (a2 + A) Px + B Pz). This module also returns the branch the
elbow-up/elbow-down pair leaves out, q1 + pi with Px -> -Px (reaching over the top): up to
4 arm solutions.

The joint q4 rotates about the approach axis z4 = z3 and does not move the end-effector origin,
so the position alone fixes q1..q3 and the approach direction; only the roll q4 is left:

- 'full': q4 from the orientation, R03^T R = Rz(q4) (unreachable unless the target approach
  axis is the one the position dictates; ``unreachable_reason`` says by how much);
- 'pitch' (``solve_ik``'s <= 4-DOF semantics: position + tool x axis direction): q4 turns x4
  toward the target x axis, reachable when that axis is perpendicular to z4;
- 'position': ``candidates`` gives q4 = the model's home value; the ``position_solutions``
  hook gives q4 = q_nominal's (exact minimiser of |q - q_nominal|). Units: m, rad.
"""
from dataclasses import dataclass
import functools
import math
from typing import List, Tuple

import numpy as np

from px100_control.errors import RobotModelError
from px100_control.kinematics.kernels import wrap_angle

#: every closed-form branch is returned: solve_ik needs no iterative fallback
complete = True

_REACH_EPS = 1e-12


@dataclass(frozen=True)
class RrrrParameters:
    """RRRR dimensions d1, a2, a3, d4 [m]."""

    d1: float
    a2: float
    a3: float
    d4: float


def fk_position(P: RrrrParameters, q) -> np.ndarray:
    """Return (X, Y, Z) [m] from the closed-form forward-kinematics equations."""
    q1, q2, q3 = q[0], q[1], q[2]
    c23, s23 = math.cos(q2 + q3), math.sin(q2 + q3)
    r = P.a2 * math.cos(q2) + P.a3 * c23 + P.d4 * s23
    return np.array([math.cos(q1) * r, math.sin(q1) * r,
                     P.d1 + P.a2 * math.sin(q2) + P.a3 * s23 - P.d4 * c23])


@functools.lru_cache(maxsize=16)
def parameters(model) -> RrrrParameters:
    """
    Return (d1, a2, a3, d4) of an RRRR-family model, read from its standard DH table.

    The model's FK is checked against these equations at a few configurations.
    :raises RobotModelError: the model is not this robot family
    """
    kin = (model.extra or {}).get('kinematics') or {}
    joints = kin.get('joints') or []
    if kin.get('convention') != 'dh' or len(joints) != 4 or kin.get('tool') or kin.get('base'):
        raise RobotModelError(f"'{model.name}': the rrrr solver needs a 4-joint standard DH "
                              'table without base/tool transforms')
    P = RrrrParameters(d1=float(joints[0].get('d', 0.0)), a2=float(joints[1].get('a', 0.0)),
                       a3=float(joints[2].get('a', 0.0)), d4=float(joints[3].get('d', 0.0)))
    rng = np.random.default_rng(4)
    for q in rng.uniform(model.lower, model.upper, size=(4, 4)):
        if np.abs(fk_position(P, q) - model.fk(q)[:3, 3]).max() > 1e-9:
            raise RobotModelError(f"'{model.name}' does not follow the FK equations of an "
                                  'RRRR arm (standard DH, wrist offset d4)')
    if abs(P.a2) < 1e-12 or math.hypot(P.a3, P.d4) < 1e-12:
        raise RobotModelError(f"'{model.name}': degenerate link lengths")
    return P


def arm_solutions(P: RrrrParameters, X: float, Y: float,
                  Z: float) -> List[Tuple[float, float, float]]:
    """Return every (q1, q2, q3) [rad] putting the end-effector origin at (X, Y, Z) [m]."""
    Pxy = math.hypot(X, Y)
    q1 = math.atan2(Y, X) if Pxy > 1e-12 else 0.0
    Pz = Z - P.d1
    Rk = math.hypot(P.a3, P.d4)
    gamma = math.atan2(P.d4, P.a3)
    out = []
    for t1, Px in ((q1, Pxy), (q1 + math.pi, -Pxy)):
        D = Px * Px + Pz * Pz - P.a2 * P.a2 - P.a3 * P.a3 - P.d4 * P.d4
        c = D / (2.0 * P.a2 * Rk)
        if abs(c) > 1.0:
            if abs(c) > 1.0 + _REACH_EPS:
                continue
            c = math.copysign(1.0, c)
        e = math.acos(c)
        for q3 in ((gamma + e, gamma - e) if e > 0.0 else (gamma,)):
            A = P.a3 * math.cos(q3) + P.d4 * math.sin(q3)
            B = P.a3 * math.sin(q3) - P.d4 * math.cos(q3)
            q2 = math.atan2(-B * Px + (P.a2 + A) * Pz, (P.a2 + A) * Px + B * Pz)
            out.append((wrap_angle(t1), wrap_angle(q2), wrap_angle(q3)))
        if Pxy <= 1e-12:
            break   # on the base axis the two waist branches coincide
    return out


def _R03(q1: float, q23: float) -> np.ndarray:
    """Return R03 = Rz(q1) Rx(90) Rz(q2 + q3) Rx(90) (standard DH, twists +90 deg)."""
    c1, s1, c, s = math.cos(q1), math.sin(q1), math.cos(q23), math.sin(q23)
    # Rx(90) Rz(q23) Rx(90) = [[c, 0, s], [0, -1, 0], [s, 0, -c]]
    return np.array([[c1 * c, s1, c1 * s], [s1 * c, -c1, s1 * s], [s, 0.0, -c]])


def candidates_rows(model, T_rows, mode: str = 'full') -> List[list]:
    """Return every closed-form candidate for a pose given as 4 rows of 4 floats."""
    P = parameters(model)
    if mode not in ('full', 'pitch', 'position'):
        raise ValueError(f'unknown IK mode {mode!r}')
    (r00, r01, _, px), (r10, r11, _, py), (r20, r21, _, pz) = T_rows[0], T_rows[1], T_rows[2]
    out = []
    for q1, q2, q3 in arm_solutions(P, px, py, pz):
        if mode == 'position':
            q4 = float(model.home[3])
        else:
            # Rp = R03^T R, R03 = [[c1 c, s1, c1 s], [s1 c, -c1, s1 s], [s, 0, -c]]
            c1, s1, c, s = math.cos(q1), math.sin(q1), math.cos(q2 + q3), math.sin(q2 + q3)
            p00 = c1 * c * r00 + s1 * c * r10 + s * r20
            p10 = s1 * r00 - c1 * r10
            if mode == 'full':
                # nearest rotation about z to R03^T R (equal to it when reachable)
                p01 = c1 * c * r01 + s1 * c * r11 + s * r21
                p11 = s1 * r01 - c1 * r11
                q4 = math.atan2(p10 - p01, p00 + p11)
            else:
                q4 = math.atan2(p10, p00)
        out.append([q1, q2, q3, wrap_angle(q4)])
    return out


def candidates(model, T_target: np.ndarray, mode: str) -> np.ndarray:
    """Return every closed-form candidate (k, 4) for a (4, 4) target, before limit filtering."""
    rows = np.asarray(T_target, dtype=float).tolist()
    return np.array(candidates_rows(model, rows, mode), dtype=float).reshape(-1, 4)


def position_solutions(model, T_target: np.ndarray, q_nominal=None,
                       check_limits: bool = True) -> np.ndarray:
    """
    Return the exact position-mode solutions (k, 4): every arm branch, q4 = q_nominal's.

    q4 does not move the end-effector origin, so q4 = q_nominal[3] (wrapped into the limits
    when possible) minimises |q - q_nominal| exactly on every branch.
    """
    P = parameters(model)
    T = np.asarray(T_target, dtype=float)
    q4 = float((model.home if q_nominal is None else q_nominal)[3])
    lo, hi = float(model.lower[3]), float(model.upper[3])
    for shift in (0.0, 2.0 * math.pi, -2.0 * math.pi):
        if lo <= q4 + shift <= hi:
            q4 += shift
            break
    out = np.array([[q1, q2, q3, q4] for q1, q2, q3 in arm_solutions(P, *T[:3, 3])],
                   dtype=float).reshape(-1, 4)
    lo_all, hi_all = np.asarray(model.lower), np.asarray(model.upper)
    for shift in (2.0 * math.pi, -2.0 * math.pi):      # e.g. joint2 spans [-30, 210] deg
        moved = out + shift
        better = ((out < lo_all) | (out > hi_all)) & (moved >= lo_all) & (moved <= hi_all)
        out = np.where(better, moved, out)
    if check_limits and len(out):
        inside = np.all((out >= lo_all - 1e-9) & (out <= hi_all + 1e-9), axis=1)
        out = out[inside]
    return out


def unreachable_reason(model, T_target: np.ndarray, mode: str) -> str:
    """Explain in words why a target has no closed-form candidate ('' if unknown)."""
    P = parameters(model)
    T = np.asarray(T_target, dtype=float)
    X, Y, Z = T[:3, 3]
    sols = arm_solutions(P, X, Y, Z)
    if not sols:
        d = math.hypot(math.hypot(X, Y), Z - P.d1)
        reach = P.a2 + math.hypot(P.a3, P.d4)
        inner = abs(P.a2 - math.hypot(P.a3, P.d4))
        if d > reach:
            return f'target is {d - reach:.4g} m beyond reach'
        return f'target is {inner - d:.4g} m inside the inner workspace boundary'
    if mode == 'full':
        errs = []
        for q1, q2, q3 in sols:
            z4 = _R03(q1, q2 + q3)[:, 2]
            errs.append(math.acos(max(-1.0, min(1.0, float(z4 @ T[:3, 2])))))
        return (f'orientation not reachable by the 4-DOF RRRR: the position fixes the approach '
                f'axis, {min(errs):.4g} rad away from the target z axis')
    if mode == 'pitch':
        errs = []
        for q1, q2, q3 in sols:
            z4 = _R03(q1, q2 + q3)[:, 2]
            errs.append(abs(math.asin(max(-1.0, min(1.0, float(z4 @ T[:3, 0]))))))
        return (f'tool x axis not reachable by the 4-DOF RRRR: it must be perpendicular to the '
                f'approach axis the position fixes (off by {min(errs):.4g} rad); use mode '
                'full or position')
    return ''


__all__ = ['candidates', 'candidates_rows', 'unreachable_reason', 'parameters',
           'arm_solutions',
           'position_solutions',
           'fk_position', 'RrrrParameters', 'complete']
