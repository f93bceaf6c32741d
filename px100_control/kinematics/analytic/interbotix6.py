"""
Closed-form IK of 6-DOF Interbotix X-Series arms (wx250s, vx300s, mobile/aloha variants).

Joints: waist (z), shoulder and elbow (pitch, y), forearm_roll (x), wrist_angle (y),
wrist_rotate (x). In the Modern Robotics description (interbotix_api.md section 6) the
forearm_roll and wrist_rotate axes are the line z = h, y = 0 and the wrist_angle axis passes
through (d_wrist, 0, h): the three wrist axes meet in one point, an exact spherical wrist
(checked from ``S_list`` when the model loads). So the wrist centre W = p - L_tool x_tool depends
on (waist, shoulder, elbow) only:

- waist: azimuth of W, or that + pi (over the top);
- shoulder/elbow: planar two-link (type 8 equation), two elbow signs;
- wrist: Rz(waist) Ry(shoulder + elbow) Rx(forearm_roll) Ry(wrist_angle) Rx(wrist_rotate) = R
  gives Rx Ry Rx Euler angles of (Rz Ry)^T R, two branches (wrist_angle sign).

Up to 8 candidates. If a model of this family has wrist axes that miss each other (offset up
to 5 mm), the same formulas give initial guesses that a few Gauss-Newton steps refine
(``details`` of the geometry say so); beyond that the solver refuses the model.

Modes: 'full' and 'pitch' (a 6-DOF arm reaches the whole pose); 'position': closed-form
candidates for a set of tool orientations (azimuth-facing, pitched on a grid), refined by
``solve_ik``'s null-space task toward ``q_nominal``. Units: m, rad.
"""
import functools
import math
from typing import List

import numpy as np

from px100_control.errors import RobotModelError
from px100_control.kinematics.analytic.interbotix5 import (ArmPlane, planar_solutions,
                                                           plane_geometry,
                                                           position_reach_words, reach_words,
                                                           waist_angles)
from px100_control.kinematics.trig_equations import wrap_angle

#: every closed-form branch is returned: solve_ik needs no iterative fallback
complete = True

_EXACT = 1e-12          # wrist axes offset below which the closed form is exact [m]
_MAX_OFFSET = 5e-3      # offsets up to this are handled by guess + refinement [m]
_POSITION_PITCHES = 12


@functools.lru_cache(maxsize=64)
def geometry(model) -> ArmPlane:
    """Return the (cached) geometry; raise RobotModelError if the family does not apply."""
    g = plane_geometry(model, 'zyyxyx')
    if g.offset > _MAX_OFFSET:
        raise RobotModelError(f"'{model.name}': the wrist axes miss each other by "
                              f'{g.offset:.3g} m; not a (near-)spherical wrist')
    return g


def is_exact(model) -> bool:
    """Return True when the wrist is exactly spherical (no refinement needed)."""
    return geometry(model).offset <= _EXACT


def _wrist_xyx(Rw: np.ndarray) -> List[tuple]:
    """Return [(a, b, c)] with Rx(a) Ry(b) Rx(c) = Rw, both branches (b and -b)."""
    cb = max(-1.0, min(1.0, Rw[0, 0]))
    sb = math.hypot(Rw[0, 1], Rw[0, 2])
    out = []
    if sb > 1e-10:
        for sgn in (1.0, -1.0):
            s = sgn * sb
            b = math.atan2(s, Rw[0, 0])
            a = math.atan2(Rw[1, 0] / s, -Rw[2, 0] / s)
            c = math.atan2(Rw[0, 1] / s, Rw[0, 2] / s)
            out.append((a, b, c))
    elif cb > 0:
        # b = 0: Rx(a + c); keep a = 0
        out.append((0.0, 0.0, math.atan2(Rw[2, 1], Rw[1, 1])))
    else:
        # b = pi: Rx(a - c) Ry(pi); keep a = 0
        out.append((0.0, math.pi, -math.atan2(Rw[2, 1], Rw[1, 1])))
    return out


def _solve_pose(g: ArmPlane, T: np.ndarray) -> List[List[float]]:
    R, p = T[:3, :3], T[:3, 3]
    wx, wy, wz = p - g.Lt * R[:, 0]
    s = g.signs
    # a near-spherical wrist only gives guesses: accept a wrist point slightly out of reach
    tol = 1e-10 if g.offset <= _EXACT else 4.0 * g.offset / min(g.L1, g.L2)
    out = []
    for t1 in waist_angles(wx, wy, R):
        c1, s1 = math.cos(t1), math.sin(t1)
        for g2, g3 in planar_solutions(g, t1, wx, wy, wz, tol):
            ph = g2 + g3
            cp, sp = math.cos(ph), math.sin(ph)
            # (Rz(t1) Ry(ph))^T
            A = np.array([[c1 * cp, s1 * cp, -sp], [-s1, c1, 0.0], [c1 * sp, s1 * sp, cp]])
            for a, b, c in _wrist_xyx(A @ R):
                out.append([s[0] * t1, wrap_angle(s[1] * g2), wrap_angle(s[2] * g3),
                            wrap_angle(s[3] * a), wrap_angle(s[4] * b),
                            wrap_angle(s[5] * c)])
    return out


def _refine(model, Q: np.ndarray, T: np.ndarray, iterations: int = 10) -> np.ndarray:
    """Gauss-Newton polish of guesses for a near-spherical wrist (base-frame pose error)."""
    from px100_control.kinematics.iterative import chain, fk_and_jacobian
    from px100_control.kinematics.se3 import log_so3
    c = chain(model)
    out = []
    for q in Q:
        q = q.copy()
        for _ in range(iterations):
            Tq, J = fk_and_jacobian(c, q)
            e = np.concatenate([log_so3(T[:3, :3] @ Tq[:3, :3].T), T[:3, 3] - Tq[:3, 3]])
            if np.abs(e).max() < 1e-15:
                break
            q = q + np.linalg.lstsq(J, e, rcond=None)[0]
        out.append(q)
    return np.array(out).reshape(-1, model.dof)


def candidates(model, T_target: np.ndarray, mode: str) -> np.ndarray:
    """
    Return every closed-form candidate (k, 6) for a (4, 4) target, before limit filtering.

    'full'/'pitch': up to 8 (2 waists x 2 elbows x 2 wrists); 'position': the same for a set of
    tool orientations, as starting points for solve_ik's refinement.
    """
    g = geometry(model)
    T = np.asarray(T_target, dtype=float)
    if mode in ('full', 'pitch'):
        Q = np.array(_solve_pose(g, T), dtype=float).reshape(-1, 6)
        return Q if g.offset <= _EXACT else _refine(model, Q, T)
    if mode != 'position':
        raise ValueError(f'unknown IK mode {mode!r}')
    p = T[:3, 3]
    a = math.atan2(p[1], p[0]) if p[0] * p[0] + p[1] * p[1] > 1e-24 else 0.0
    ca, sa = math.cos(a), math.sin(a)
    out = []
    for k in range(_POSITION_PITCHES):
        pitch = -math.pi + 2.0 * math.pi * k / _POSITION_PITCHES
        cp, sp = math.cos(pitch), math.sin(pitch)
        Tk = np.eye(4)
        Tk[:3, :3] = [[ca * cp, -sa, ca * sp], [sa * cp, ca, sa * sp], [-sp, 0.0, cp]]
        Tk[:3, 3] = p
        out += _solve_pose(g, Tk)
    return np.array(out, dtype=float).reshape(-1, 6)


def unreachable_reason(model, T_target: np.ndarray, mode: str) -> str:
    """Explain in words why a target has no closed-form candidate ('' if unknown)."""
    g = geometry(model)
    T = np.asarray(T_target, dtype=float)
    if mode == 'position':
        return position_reach_words(g, T[:3, 3])
    return reach_words(g, T)


__all__ = ['candidates', 'unreachable_reason', 'geometry', 'is_exact', 'complete']
