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
from px100_control.kinematics.analytic.interbotix5 import (ArmPlane, pitch_grid_candidates,
                                                           planar_solutions, plane_geometry,
                                                           position_reach_words,
                                                           reach_words, rows_of,
                                                           waist_angles)
from px100_control.kinematics.iterative import chain, fk_and_jacobian
from px100_control.kinematics.kernels import wrap_angle
from px100_control.kinematics.se3 import log_so3

#: every closed-form branch is returned: solve_ik needs no iterative fallback
complete = True
#: candidates_rows takes the joint limits and leaves out arm branches outside them
prunes_by_limits = True

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


def _wrist_xyx(Rw) -> List[tuple]:
    """Return [(a, b, c)] with Rx(a) Ry(b) Rx(c) = Rw (3 rows of 3), both branches (b, -b)."""
    (w00, w01, w02), (w10, w11, _), (w20, w21, _) = Rw
    cb = max(-1.0, min(1.0, w00))
    sb = math.hypot(w01, w02)
    out = []
    if sb > 1e-10:
        for sgn in (1.0, -1.0):
            s = sgn * sb
            b = math.atan2(s, w00)
            a = math.atan2(w10 / s, -w20 / s)
            c = math.atan2(w01 / s, w02 / s)
            out.append((a, b, c))
    elif cb > 0:
        # b = 0: Rx(a + c); keep a = 0
        out.append((0.0, 0.0, math.atan2(w21, w11)))
    else:
        # b = pi: Rx(a - c) Ry(pi); keep a = 0
        out.append((0.0, math.pi, -math.atan2(w21, w11)))
    return out


def _fits(x: float, lo: float, hi: float) -> bool:
    """Return True when x, or x +- 2 pi, lies in [lo, hi] (+- 1e-9)."""
    lo, hi = lo - 1e-9, hi + 1e-9
    return lo <= x <= hi or lo <= x + 2.0 * math.pi <= hi or lo <= x - 2.0 * math.pi <= hi


def _solve_pose(g: ArmPlane, R, p, limits=None) -> List[List[float]]:
    """
    Return the closed-form branches of a pose: R 3 rows of 3, p (x, y, z) [m].

    ``limits`` (lower, upper): skip the arm branches whose waist, shoulder or elbow value fits
    no +-2 pi copy into its limits (their wrist solutions would be dropped anyway).
    """
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R
    wx, wy, wz = p[0] - g.Lt * r00, p[1] - g.Lt * r10, p[2] - g.Lt * r20
    s = g.signs
    # a near-spherical wrist only gives guesses: accept a wrist point slightly out of reach
    tol = 1e-10 if g.offset <= _EXACT else 4.0 * g.offset / min(g.L1, g.L2)
    out = []
    pi = math.pi
    for t1 in waist_angles(wx, wy, R):
        c1, s1 = math.cos(t1), math.sin(t1)
        q1 = s[0] * t1
        if limits is not None and not _fits(q1, limits[0][0], limits[1][0]):
            continue
        for g2, g3 in planar_solutions(g, t1, wx, wy, wz, tol):
            q2, q3 = wrap_angle(s[1] * g2), wrap_angle(s[2] * g3)
            if limits is not None and not (_fits(q2, limits[0][1], limits[1][1])
                                           and _fits(q3, limits[0][2], limits[1][2])):
                continue
            ph = g2 + g3
            cp, sp = math.cos(ph), math.sin(ph)
            # (Rz(t1) Ry(ph))^T R, rows a, b, c
            a0, a1, a2 = c1 * cp, s1 * cp, -sp
            b0, b1 = -s1, c1
            k0, k1, k2 = c1 * sp, s1 * sp, cp
            Rw = ((a0 * r00 + a1 * r10 + a2 * r20, a0 * r01 + a1 * r11 + a2 * r21,
                   a0 * r02 + a1 * r12 + a2 * r22),
                  (b0 * r00 + b1 * r10, b0 * r01 + b1 * r11, 0.0),
                  (k0 * r00 + k1 * r10 + k2 * r20, k0 * r01 + k1 * r11 + k2 * r21, 0.0))
            for a, b, c in _wrist_xyx(Rw):
                # atan2 values times +-1 lie in [-pi, pi]: wrapped to (-pi, pi] by hand
                q4, q5, q6 = s[3] * a, s[4] * b, s[5] * c
                out.append([q1, q2, q3, pi if q4 == -pi else q4, pi if q5 == -pi else q5,
                            pi if q6 == -pi else q6])
    return out


def _refine(model, Q: np.ndarray, T: np.ndarray, iterations: int = 10) -> np.ndarray:
    """Gauss-Newton polish of guesses for a near-spherical wrist (base-frame pose error)."""
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
        Q = np.array(_solve_pose(g, *rows_of(T)), dtype=float).reshape(-1, 6)
        return Q if g.offset <= _EXACT else _refine(model, Q, T)
    if mode != 'position':
        raise ValueError(f'unknown IK mode {mode!r}')
    Q = pitch_grid_candidates(_solve_pose, g, T[:3, 3], _POSITION_PITCHES)
    return np.array(Q, dtype=float).reshape(-1, 6)


def candidates_rows(model, T_rows, mode: str = 'full', limits=None) -> List[List[float]]:
    """
    Return the 'full'/'pitch' candidates of ``candidates`` as lists (plain floats).

    ``limits`` (lower, upper): leave out candidates whose arm joints fit no +-2 pi copy into
    the limits (the rest still need the caller's limit check).
    """
    g = geometry(model)
    if g.offset > _EXACT:
        return candidates(model, np.array(T_rows, dtype=float), mode).tolist()
    return _solve_pose(g, *rows_of(T_rows), limits)


def unreachable_reason(model, T_target: np.ndarray, mode: str) -> str:
    """Explain in words why a target has no closed-form candidate ('' if unknown)."""
    g = geometry(model)
    T = np.asarray(T_target, dtype=float)
    if mode == 'position':
        return position_reach_words(g, T[:3, 3])
    return reach_words(g, T)


__all__ = ['candidates', 'candidates_rows', 'unreachable_reason', 'geometry', 'is_exact',
           'complete']
