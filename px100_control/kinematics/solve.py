"""
The single IK entry point for every robot model: ``solve_ik``, ``solve_ik_batch``, ``solve_path``.

Targets are (4, 4) poses of the end effector in ``model.base_frame`` [m]. Modes:

- 'full': the whole pose.
- 'pitch': position + the reachable part of the orientation (Interbotix semantics for arms with
  fewer than 6 joints): the target's static 'sxyz' (roll, pitch, yaw) is taken in the form with
  |roll| <= pi/2, the yaw is forced to the target azimuth about the first joint axis (or that
  + pi: the waist can reach over the top), and on <= 4-joint arms the roll is dropped, so only
  the tool x axis direction is constrained. ``details['unreachable_roll']`` and
  ``details['unreachable_yaw']`` report what was dropped [rad]. Of the configurations meeting
  that, the ones with the target's tool roll come first; the waist + pi "over the top" one
  (tool upside down) is returned only when nothing else is in the limits, with
  ``details['roll_flipped']`` and the roll it drops (about pi). 6+ joints, and arms that are
  not a waist + planar chain (:func:`pitch_applies`): same as 'full'.
- 'position': orientation free; the free angles are chosen by the null-space task toward
  ``q_nominal`` (null-space secondary task; default ``model.home``).

Methods: 'analytic' (the model's ``ik.analytic`` plug-in, see ``kinematics.analytic``), 'dls'
(damped least squares), 'newton' (Newton-Raphson, step limiting, limit projection), 'auto'
(analytic if the model has one, falling back to DLS when it finds nothing valid and is not
known to be complete).
Solutions are ordered by Euclidean distance to ``q_seed`` (the closest-to-nominal cost; default
``model.home``). No robot specifics here.
"""
import functools
import math
from typing import List, Sequence

import numpy as np

from px100_control.errors import InvalidInputError
from px100_control.kinematics.analytic import get_solver
from px100_control.kinematics.analytic import px100
from px100_control.kinematics.ik_types import IkResult
from px100_control.kinematics.iterative import (chain, fk_and_jacobian, solve_dls,
                                                solve_newton, Task)
from px100_control.kinematics.kernels import euler_sxyz, fk_py, rpy_rows, wrap

MODES = ('full', 'pitch', 'position')
METHODS = ('auto', 'analytic', 'dls', 'newton')
_POLISH_LIMIT = 1e-6      # analytic candidates this close get a few DLS iterations of polish
_RESTARTS = 24            # iterative starts (see _starts)


@functools.lru_cache(maxsize=None)
def _solver(name: str):
    """Return the analytic module ``name`` (cached: importlib costs a lookup per call)."""
    return get_solver(name)


def check_pose(T_target, what: str = 'pose') -> np.ndarray:
    """
    Return T_target as a float (4, 4) array; raise InvalidInputError if it is not a rigid pose.

    Checks shape, NaN/inf, the bottom row and that the rotation is orthonormal with det +1.
    """
    try:
        T = np.array(T_target, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f'{what} is not numeric: {T_target!r}') from exc
    if T.shape != (4, 4):
        raise InvalidInputError(f'{what} must be a (4, 4) matrix, got shape {T.shape}')
    L = T.tolist()
    flat = L[0] + L[1] + L[2] + L[3]
    if any(x != x for x in flat):
        raise InvalidInputError(f'{what} contains NaN')
    if any(x in (math.inf, -math.inf) for x in flat):
        raise InvalidInputError(f'{what} contains inf')
    if max(abs(L[3][0]), abs(L[3][1]), abs(L[3][2]), abs(L[3][3] - 1.0)) > 1e-9:
        raise InvalidInputError(f'{what} bottom row must be [0, 0, 0, 1], got {L[3]}')
    c = [[L[0][j], L[1][j], L[2][j]] for j in range(3)]          # columns of R
    err = max(abs(sum(a * b for a, b in zip(c[i], c[j])) - (1.0 if i == j else 0.0))
              for i in range(3) for j in range(i, 3))
    x, y, z = c
    det = (x[0] * (y[1] * z[2] - y[2] * z[1]) - x[1] * (y[0] * z[2] - y[2] * z[0])
           + x[2] * (y[0] * z[1] - y[1] * z[0]))
    if err > 1e-6 or det < 0:
        raise InvalidInputError(f'{what} rotation is not a rotation matrix (|R^T R - I| = '
                                f'{err:.3g}, det = {det:.3g})')
    return T


def pose_rows(T_target, what: str = 'pose') -> list:
    """
    Return a rigid pose as 4 rows of 4 floats; raise InvalidInputError as ``check_pose`` does.

    The plain-float check of the IK hot path (a float (4, 4) array or nested lists): finite,
    bottom row [0, 0, 0, 1], rotation orthonormal (1e-6) with det +1; anything else goes
    through ``check_pose`` for the exact error.
    """
    try:
        L = T_target.tolist() if isinstance(T_target, np.ndarray) else [
            [float(x) for x in row] for row in T_target]
        (a, b, c, x), (d, e, f, y), (g, h, k, z), (m, n, o, w) = L
        s = a + b + c + x + d + e + f + y + g + h + k + z + m + n + o + w
    except (TypeError, ValueError):
        return check_pose(T_target, what).tolist()
    if (s - s != 0.0 or m != 0.0 or n != 0.0 or o != 0.0 or w != 1.0
            or type(a) is not float):
        return check_pose(T_target, what).tolist()
    # columns (a, d, g), (b, e, h), (c, f, k): unit and orthogonal, det = +1
    if max(abs(a * a + d * d + g * g - 1.0), abs(b * b + e * e + h * h - 1.0),
           abs(c * c + f * f + k * k - 1.0), abs(a * b + d * e + g * h),
           abs(a * c + d * f + g * k), abs(b * c + e * f + h * k)) > 1e-6 or (
            a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g)) < 0.0:
        return check_pose(T_target, what).tolist()
    return L


def target_azimuth(model, p) -> float:
    """
    Return the azimuth [rad] of a point about the first joint axis (atan2(y, x) on Interbotix).

    Used when the yaw of a < 6-DOF arm is forced; falls back to atan2(y, x) in the base frame.
    """
    c = _first_axis_point(model)
    x, y = float(p[0]), float(p[1])
    if c is not None:
        dx, dy = x - c[0], y - c[1]
        if dx * dx + dy * dy > 1e-24:
            return math.atan2(dy, dx)
        return 0.0
    return math.atan2(y, x)


@functools.lru_cache(maxsize=64)
def _first_axis_point(model):
    """Return (x, y) of the first joint axis when it is a vertical revolute axis, else None."""
    S = np.asarray(model.S_list, float)
    w, v = S[:3, 0], S[3:, 0]
    if model.joint_types[0] == 'prismatic' or abs(abs(w[2]) - 1.0) >= 1e-9:
        return None
    # a point on the axis: w x v
    return (float(w[1] * v[2] - w[2] * v[1]), float(w[2] * v[0] - w[0] * v[2]))


def _pose_sxyz(p, roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Return the (4, 4) pose Rz(yaw) Ry(pitch) Rx(roll) [rad] at position p [m]."""
    r0, r1, r2 = rpy_rows(roll, pitch, yaw)
    return np.array([r0 + [p[0]], r1 + [p[1]], r2 + [p[2]], [0.0, 0.0, 0.0, 1.0]])


def pitch_target(model, T: np.ndarray):
    """
    Return (T_forced (4, 4), details) for 'pitch' mode (see module docstring).

    details: unreachable_roll, unreachable_yaw [rad] dropped from the target, and the kept
    'pitch' [rad] and forced 'yaw' [rad].
    """
    n = model.dof
    if n >= 6:
        return T, {'unreachable_roll': 0.0, 'unreachable_yaw': 0.0}
    r, p, y = euler_sxyz(T[:3, :3].tolist())
    if abs(r) > math.pi / 2:
        r, p, y = wrap(r + math.pi), wrap(math.pi - p), wrap(y + math.pi)
    a = target_azimuth(model, T[:3, 3])
    dy = wrap(y - a)
    y_forced = a if abs(dy) <= math.pi / 2 else wrap(a + math.pi)
    keep_roll = n == 5
    Tf = _pose_sxyz(T[:3, 3], r if keep_roll else 0.0, p, y_forced)
    return Tf, {'unreachable_roll': 0.0 if keep_roll else float(r),
                'unreachable_yaw': float(wrap(y - y_forced)),
                'pitch': float(p), 'yaw': float(y_forced)}


@functools.lru_cache(maxsize=64)
def pitch_applies(model) -> bool:
    """
    Return True when 'pitch' mode means what it means on Interbotix arms.

    That is: revolute joints 1-4 (or 1-3 on a 3-joint arm), joints 2-4 with axes parallel to
    each other and perpendicular to the first (a waist, then a planar shoulder/elbow/wrist
    chain), so the reachable tool orientations are Rz(waist) Ry(pitch) (and a roll on 5-joint
    arms). Other arms (the RRRP, the RRRR) solve 'pitch' requests as 'full'.
    """
    k = min(4, model.dof)
    if k < 3 or any(t == 'prismatic' for t in model.joint_types[:k]):
        return False
    W = np.asarray(model.S_list, float)[:3, :k]
    w0 = W[:, 0]
    return all(abs(float(w0 @ W[:, i])) < 1e-9 and
               float(np.linalg.norm(np.cross(W[:, 1], W[:, i]))) < 1e-9 for i in range(1, k))


def make_task(model, T: np.ndarray, mode: str):
    """Return (Task, details) for a validated (4, 4) target and mode."""
    details = {}
    if mode == 'pitch':
        Tf, details = pitch_target(model, T)
        kind = 'axis' if model.dof <= 4 else 'full'
        return Task(Tf[:3, 3].copy(), Tf[:3, :3].copy(), kind), details, Tf
    if mode == 'position':
        return Task(T[:3, 3].copy(), T[:3, :3].copy(), 'position'), details, T
    return Task(T[:3, 3].copy(), T[:3, :3].copy(), 'full'), details, T


def _wrap_into_limits(model, Q: np.ndarray) -> np.ndarray:
    """Shift revolute joint values by +-2 pi where that brings them inside their limits."""
    c = chain(model)
    rows = Q.tolist()
    changed = False
    for row in rows:
        for j, (x, a, b, joint) in enumerate(zip(row, c.lo, c.hi, c.py)):
            if a - 1e-9 <= x <= b + 1e-9 or not joint[4]:
                continue
            for shift in (2.0 * math.pi, -2.0 * math.pi):
                if a - 1e-9 <= x + shift <= b + 1e-9:
                    row[j] = x + shift
                    changed = True
                    break
    return np.array(rows, dtype=float).reshape(Q.shape) if changed else Q


def _limit_reason(model, Q: np.ndarray) -> str:
    """Return words for the least-violating candidate's worst joint."""
    lo, hi = np.asarray(model.lower), np.asarray(model.upper)
    excess = np.maximum(lo - Q, Q - hi)
    worst = excess.max(axis=1)
    k = int(np.argmin(worst))
    j = int(np.argmax(excess[k]))
    name = model.joint_names[j]
    return (f"joint '{name}' would be {Q[k, j]:.4g} rad, outside "
            f'[{lo[j]:.4g}, {hi[j]:.4g}]' + (
                f' (best of {len(Q)} solutions)' if len(Q) > 1 else ''))


def _order(solutions: List[np.ndarray], q_seed: np.ndarray,
           same: float = 1e-9) -> List[np.ndarray]:
    """Return the distinct solutions (max difference > same) sorted by distance to q_seed."""
    out: List[np.ndarray] = []
    for q in sorted(solutions, key=lambda s: float(np.sum((s - q_seed) ** 2))):
        if all(np.abs(q - o).max() > same for o in out):
            out.append(q)
    return out


def _analytic(model, T_eff, mode, task, q_seed, q_nominal, check_limits, tol_p, tol_o,
              max_iterations, module, upright_first: bool = True) -> IkResult:
    name = f'analytic:{model.analytic_ik}'
    if mode == 'position' and hasattr(module, 'position_solutions'):
        # the module minimises |q - q_nominal| over the free angle itself (exact secondary task)
        C = np.asarray(module.position_solutions(model, T_eff, q_nominal,
                                                 check_limits=check_limits),
                       dtype=float).reshape(-1, model.dof)
        if len(C) == 0:
            G = np.asarray(module.candidates(model, T_eff, mode), dtype=float).reshape(
                -1, model.dof)
            if len(G):     # reachable, but only outside the joint limits
                return IkResult(False, None, [], name, 0, reason=_limit_reason(
                    model, _wrap_into_limits(model, G)), details={'candidates': int(len(G))})
    else:
        C = np.asarray(module.candidates(model, T_eff, mode), dtype=float).reshape(
            -1, model.dof)
    if not math.isfinite(float(C.sum())):      # one reduction; filter only when needed
        C = C[np.all(np.isfinite(C), axis=1)]
    if len(C) and check_limits:
        C = _wrap_into_limits(model, C)
    if mode == 'position' and not hasattr(module, 'position_solutions'):
        return _refine_position(model, C, task, q_seed, q_nominal, check_limits, tol_p, tol_o,
                                max_iterations, name, module, T_eff)
    c = chain(model)
    verified = []          # (q list, position error, orientation error, roll flipped)
    best_err = (math.inf, math.inf)
    # 'axis' task (pitch mode, <= 4 joints): the tool x axis alone also accepts the waist + pi
    # "over the top" configuration, upside down; it is flagged to come after the upright ones.
    # With the x axes equal, the rotation between the two is about x by the angle between the
    # y axes: flipped (more than pi/2) when they point apart.
    y_t = [row[1] for row in task.R.tolist()] if task.kind == 'axis' else None
    for q in C.tolist():
        R, p = fk_py(c, q)
        pe, oe = task.errors_py(R, p)
        if pe > tol_p or oe > tol_o:
            if pe < _POLISH_LIMIT and oe < _POLISH_LIMIT:      # near-singular rounding
                res = solve_dls(model, task, q, tol_position=tol_p, tol_orientation=tol_o,
                                max_iterations=10, check_limits=False)
                if res.success:
                    q, pe, oe = res.q.tolist(), res.position_error, res.orientation_error
            if pe > tol_p or oe > tol_o:
                if pe + oe < sum(best_err):
                    best_err = (pe, oe)
                continue
            R, p = fk_py(c, q)
        flipped = y_t is not None and \
            R[0][1] * y_t[0] + R[1][1] * y_t[1] + R[2][1] * y_t[2] < 0.0
        verified.append((q, pe, oe, flipped))
    valid = verified
    if check_limits and verified:
        lo = [v - 1e-9 for v in c.lo]
        hi = [v + 1e-9 for v in c.hi]
        valid = [v for v in verified if all(a <= x <= b for x, a, b in zip(v[0], lo, hi))]
    if valid:
        sd = [float(x) for x in q_seed]
        # upright before roll-flipped (unless told otherwise), then closest to the seed
        valid.sort(key=lambda v: (upright_first and v[3],
                                  sum((x - y) ** 2 for x, y in zip(v[0], sd))))
        kept = []
        for v in valid:
            if all(max(abs(x - y) for x, y in zip(v[0], k[0])) > 1e-9 for k in kept):
                kept.append(v)
        sols = [np.array(v[0]) for v in kept]
        details = {'candidates': int(len(C)), 'in_limits': len(sols)}
        if kept[0][3]:
            details['roll_flipped'] = True
        return IkResult(True, sols[0], sols, name, 0, kept[0][1], kept[0][2], '', details)
    verified = [np.array(v[0]) for v in verified]
    if verified:
        reason = _limit_reason(model, np.array(verified))
        return IkResult(False, None, [], name, 0, reason=reason,
                        details={'candidates': int(len(C)), 'outside_limits': len(verified),
                                 'rejected': [q.tolist() for q in verified]})
    reason = ''
    if hasattr(module, 'unreachable_reason'):
        reason = module.unreachable_reason(model, T_eff, mode)
    if not reason:
        if len(C):
            reason = (f'no closed-form solution reproduces the target (best position error '
                      f'{best_err[0]:.3g} m, orientation error {best_err[1]:.3g} rad)')
        else:
            reason = 'target is out of reach (no closed-form solution)'
    return IkResult(False, None, [], name, 0, reason=reason,
                    details={'candidates': int(len(C)), 'unreachable': True})


def _distinct_starts(C: np.ndarray, ref: np.ndarray, count: int, sep: float = 0.3):
    order = np.argsort(np.sum((C - ref) ** 2, axis=1))
    starts: list = []
    for i in order:
        if all(np.linalg.norm(C[i] - s) > sep for s in starts):
            starts.append(C[i])
            if len(starts) == count:
                break
    return starts


def _refine_position(model, C, task, q_seed, q_nominal, check_limits, tol_p, tol_o,
                     max_iterations, name, module, T_eff) -> IkResult:
    """Position mode: refine closed-form samples with the null-space task toward q_nominal."""
    if check_limits and len(C):
        lo, hi = np.asarray(model.lower) - 1e-9, np.asarray(model.upper) + 1e-9
        inside = np.all((C >= lo) & (C <= hi), axis=1)
        if not inside.any():
            return IkResult(False, None, [], name, 0, reason=_limit_reason(model, C),
                            details={'candidates': int(len(C))})
        C = C[inside]
    if not len(C):
        reason = ''
        if hasattr(module, 'unreachable_reason'):
            reason = module.unreachable_reason(model, T_eff, 'position')
        return IkResult(False, None, [], name, 0,
                        reason=reason or 'target is out of reach (no closed-form solution)',
                        details={'candidates': 0, 'unreachable': True})
    sols, iters = [], 0
    last = None
    for start in _distinct_starts(C, q_nominal, 4):
        res = solve_dls(model, task, start, q_nominal=q_nominal, secondary='nominal',
                        tol_position=tol_p, tol_orientation=tol_o,
                        max_iterations=max_iterations, check_limits=check_limits)
        iters += res.iterations
        last = res
        if res.success:
            sols.append(res.q)
    if not sols:
        return IkResult(False, None, [], name, iters, reason=last.reason, details={})
    sols = _order(sols, q_seed, same=1e-6)
    c = chain(model)
    T, _ = fk_and_jacobian(c, sols[0])
    pe, oe = task.errors(T)
    return IkResult(True, sols[0], sols, name + '+dls', iters, pe, oe, '',
                    {'candidates': int(len(C)), 'secondary': 'nominal'})


def _starts(model, q_seed, q_nominal, azimuth=None):
    """
    Yield distinct iterative starts.

    The seed, nominal, home and sleep poses, the seed with the first joint turned toward the
    target (azimuth, azimuth + pi; or +-120 deg as Interbotix does), then random
    configurations in the limits (fixed RNG: deterministic).
    """
    lo, hi = np.asarray(model.lower, float), np.asarray(model.upper, float)
    fixed = [np.asarray(x, float) for x in (q_seed, q_nominal, model.home, model.sleep)]
    if model.joint_types[0] != 'prismatic':
        turns = ([azimuth, azimuth + math.pi] if azimuth is not None
                 else [q_seed[0] + 2 * math.pi / 3, q_seed[0] - 2 * math.pi / 3])
        for t in turns:
            s = np.array(q_seed, float)
            s[0] = wrap(t)
            fixed.append(np.clip(s, lo, hi))
    rng = np.random.default_rng(0)
    seen: list = []
    for k in range(_RESTARTS):
        s = fixed[k] if k < len(fixed) else rng.uniform(lo, hi)
        if any(np.abs(s - u).max() <= 1e-6 for u in seen):
            continue
        seen.append(s)
        yield s


def _iterative(model, task, method, q_seed, q_nominal, check_limits, tol_p, tol_o,
               max_iterations) -> IkResult:
    secondary = 'nominal' if task.kind == 'position' else None
    total, tried, best = 0, 0, None
    azimuth = target_azimuth(model, task.p) if model.joint_types[0] != 'prismatic' else None
    for s in _starts(model, q_seed, q_nominal, azimuth):
        tried += 1
        if method == 'newton':
            res = solve_newton(model, task, s, tol_position=tol_p, tol_orientation=tol_o,
                               max_iterations=max_iterations, check_limits=check_limits)
        else:
            res = solve_dls(model, task, s, q_nominal=q_nominal, secondary=secondary,
                            tol_position=tol_p, tol_orientation=tol_o,
                            max_iterations=max_iterations, check_limits=check_limits)
        total += res.iterations
        if res.success:
            res.iterations = total
            res.details['starts'] = tried
            return res
        if best is None or (res.q is not None and res.position_error + res.orientation_error
                            < best.position_error + best.orientation_error):
            best = res
    best.iterations = total
    best.details['starts'] = tried
    best.reason = (f'{best.method} found no solution from {tried} starts (best position '
                   f'error {best.position_error:.3g} m, orientation error '
                   f'{best.orientation_error:.3g} rad); the target may be out of reach')
    return best


# ---------------------------------------------------------------------------------------------
# closed forms first: the default path on plain floats
# ---------------------------------------------------------------------------------------------

@functools.lru_cache(maxsize=64)
def _fast_module(model):
    """Return the analytic module when it has a plain-float entry for full poses, else None."""
    if not model.analytic_ik:
        return None
    module = _solver(model.analytic_ik)
    if hasattr(module, 'ik_fast') or hasattr(module, 'candidates_rows'):
        return module
    return None


@functools.lru_cache(maxsize=64)
def _home_list(model) -> list:
    return [float(x) for x in model.home]


def pose_errors(R, p, L):
    """
    Return (position error [m], rotation angle [rad]) between a pose and a target.

    R: 3 rows of 3, p: (x, y, z); L: the target as 4 rows of 4 (plain floats, base frame).
    """
    (t00, t01, t02, tx), (t10, t11, t12, ty), (t20, t21, t22, tz) = L[0], L[1], L[2]
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R
    dp = math.sqrt((tx - p[0]) ** 2 + (ty - p[1]) ** 2 + (tz - p[2]) ** 2)
    # E = R^T R_t: its trace and skew part give the angle
    e00 = r00 * t00 + r10 * t10 + r20 * t20
    e11 = r01 * t01 + r11 * t11 + r21 * t21
    e22 = r02 * t02 + r12 * t12 + r22 * t22
    e01 = r00 * t01 + r10 * t11 + r20 * t21
    e10 = r01 * t00 + r11 * t10 + r21 * t20
    e02 = r00 * t02 + r10 * t12 + r20 * t22
    e20 = r02 * t00 + r12 * t10 + r22 * t20
    e12 = r01 * t02 + r11 * t12 + r21 * t22
    e21 = r02 * t01 + r12 * t11 + r22 * t21
    s = 0.5 * math.sqrt((e21 - e12) ** 2 + (e02 - e20) ** 2 + (e10 - e01) ** 2)
    return dp, math.atan2(s, 0.5 * (e00 + e11 + e22 - 1.0))


def _in_limits_by_seed(c, C, seed) -> list:
    """
    Return the candidates (lists) inside the joint limits, closest to the seed first.

    Revolute values outside their limits are shifted by +-2 pi when that brings them in (as
    ``_wrap_into_limits``); non-finite candidates drop out; duplicates (1e-9) are dropped.
    """
    lo, hi, py = c.lo, c.hi, c.py
    two_pi = 2.0 * math.pi
    keep = []
    for q in C:
        q = list(q)
        for j, x in enumerate(q):
            a, b = lo[j] - 1e-9, hi[j] + 1e-9
            if a <= x <= b:
                continue
            if py[j][4]:
                if a <= x + two_pi <= b:
                    q[j] = x + two_pi
                    continue
                if a <= x - two_pi <= b:
                    q[j] = x - two_pi
                    continue
            break
        else:
            keep.append(q)
    if len(keep) > 1:
        scored = sorted([(sum([(x - y) * (x - y) for x, y in zip(q, seed)]), q) for q in keep],
                        key=lambda t: t[0])
        keep = []
        kept_d = []
        for d, q in scored:
            # a duplicate has the same distance to the seed: compare only those
            if any(abs(d - e) < 1e-6 and max([abs(x - y) for x, y in zip(q, o)]) <= 1e-9
                   for e, o in zip(kept_d, keep)):
                continue
            keep.append(q)
            kept_d.append(d)
    return keep


def _verified(c, Q, L, tol_p: float, tol_o: float) -> list:
    """Return the configurations of Q (lists) whose FK meets the target L, as arrays."""
    out = []
    for q in Q:
        R, p = fk_py(c, q)
        pe, oe = pose_errors(R, p, L)
        if pe <= tol_p and oe <= tol_o:
            out.append(np.array(q, dtype=float))
    return out


def _solve_full_fast(model, L, seed, tol_p: float, tol_o: float):
    """
    Solve a full pose in closed form on plain floats; None when the general path must decide.

    Every closed-form candidate (``candidates_rows``) is shifted into the joint limits, the
    in-limit ones are ordered by distance to the seed, and the first that FK verifies is
    ``solve_ik``'s answer (a 4/5-DOF arm's candidates may miss an unreachable orientation);
    the ones after it are verified when ``solutions`` is first read. A 7-DOF
    swivel module (``ik_fast``) gives its in-limit solution at the swivel nearest the seed's;
    the other branches come from the general swivel search on first read. None (the general
    path then gives the exact answer or reason): no verified candidate in the limits, or one
    within rounding of the target that the general path polishes (singular and unreachable
    targets end here).
    """
    module = _fast_module(model)
    if module is None:
        return None
    c = chain(model)
    name = f'analytic:{model.analytic_ik}'
    if hasattr(module, 'ik_fast'):
        q, _ = module.ik_fast(model, L, seed)
        if q is None:
            return None
        q = list(q)
        R, p = fk_py(c, q)
        pe, oe = pose_errors(R, p, L)
        if pe > tol_p or oe > tol_o:
            return None

        def more():
            res = _analytic(model, np.array(L), 'full', Task(np.array(L[:3])[:, 3],
                                                             np.array(L[:3])[:, :3], 'full'),
                            np.array(seed), np.asarray(model.home, float), True, tol_p, tol_o,
                            200, module)
            return [s for s in res.solutions if np.abs(s - np.array(q)).max() > 1e-9]
        return IkResult(True, np.array(q), None, name, 0, pe, oe, '', {'swivel': True},
                        more=more)
    if getattr(module, 'prunes_by_limits', False):
        C = module.candidates_rows(model, L, 'full', (c.lo, c.hi))
    else:
        C = module.candidates_rows(model, L, 'full')
    ordered = _in_limits_by_seed(c, C, seed)
    for i, q in enumerate(ordered):
        R, p = fk_py(c, q)
        pe, oe = pose_errors(R, p, L)
        if pe <= tol_p and oe <= tol_o:
            rest = ordered[i + 1:]
            return IkResult(True, np.array(q, dtype=float), None, name, 0, pe, oe, '',
                            {'candidates': len(C)},
                            more=lambda: _verified(c, rest, L, tol_p, tol_o))
        if pe < _POLISH_LIMIT and oe < _POLISH_LIMIT:
            return None            # near-singular rounding: the general path polishes it
    return None


def _solve_pitch_fast(model, L, seed, tol_p: float, tol_o: float):
    """'pitch' mode of a px100-family arm on plain floats (``solve_pitch_scalar``), or None."""
    out = solve_pitch_scalar(model, L[0][3], L[1][3], L[2][3], [L[0][:3], L[1][:3], L[2][:3]],
                             seed, tol_p, tol_o)
    if out is None:
        return None
    sols, pe, oe, roll, yaw, flipped, (pitch, forced) = out
    details = {'unreachable_roll': roll, 'unreachable_yaw': yaw, 'pitch': pitch,
               'yaw': forced}
    if flipped:
        details['roll_flipped'] = True
    return IkResult(True, np.array(sols[0], dtype=float),
                    [np.array(s, dtype=float) for s in sols], f'analytic:{model.analytic_ik}',
                    0, pe, oe, '', details)


def _check_tolerances(tol_position, tol_orientation) -> None:
    for name, tol in (('tol_position', tol_position), ('tol_orientation', tol_orientation)):
        if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0):
            raise InvalidInputError(f'{name} must be a positive finite number, not {tol!r}')


def solve_ik(model, T_target, *, mode: str = 'full', q_seed=None, q_nominal=None,
             check_limits: bool = True, method: str = 'auto', tol_position: float = 1e-9,
             tol_orientation: float = 1e-9, max_iterations: int = 200,
             upright_first: bool = True) -> IkResult:
    """
    Solve the IK of ``model`` for a (4, 4) end-effector target in ``model.base_frame`` [m].

    :param mode: 'full' | 'pitch' | 'position' (module docstring)
    :param q_seed: (n,) solutions are ordered by distance to it (default model.home)
    :param q_nominal: (n,) secondary-task target for free angles (default model.home)
    :param check_limits: drop solutions outside the joint limits
    :param method: 'auto' | 'analytic' | 'dls' | 'newton'
    :param tol_position: [m]; tol_orientation: [rad] of the constrained orientation part
    :param max_iterations: per start of an iterative method
    :param upright_first: 'pitch' mode, <= 4 joints: rank the configurations with the target's
        tool roll before the roll-flipped ones (False: by distance to q_seed only, as a path
        continues its branch)
    :return: IkResult (success False with ``reason`` when there is no valid solution)
    :raises InvalidInputError: malformed pose (NaN, inf, shape, not a rotation), bad seed,
        unknown mode or method
    """
    if mode not in MODES:
        raise InvalidInputError(f'mode must be one of {MODES}, not {mode!r}')
    if method not in METHODS:
        raise InvalidInputError(f'method must be one of {METHODS}, not {method!r}')
    L = pose_rows(T_target, 'target pose')
    seed = _home_list(model) if q_seed is None else model.check_vector(
        q_seed, 'q_seed').tolist()
    if q_nominal is not None:
        q_nominal = model.check_vector(q_nominal, 'q_nominal')
    _check_tolerances(tol_position, tol_orientation)
    if method == 'auto' and check_limits and mode != 'position':
        # closed forms first, on plain floats; None: the general path below decides
        res = None
        if mode == 'full' or model.dof >= 6:
            res = _solve_full_fast(model, L, seed, tol_position, tol_orientation)
            if res is not None and mode == 'pitch':
                res.details.update(unreachable_roll=0.0, unreachable_yaw=0.0)
        elif upright_first and scalar_pitch_solver(model) is not None:
            res = _solve_pitch_fast(model, L, seed, tol_position, tol_orientation)
        if res is not None:
            return res
    T = np.array(L, dtype=float)
    q_seed = np.array(seed, dtype=float)
    if q_nominal is None:
        q_nominal = np.asarray(model.home, float)
    as_full = mode == 'pitch' and model.dof < 6 and not pitch_applies(model)
    if as_full:
        mode = 'full'
    task, details, T_eff = make_task(model, T, mode)
    if as_full:
        details['pitch_mode'] = 'full pose (the joints after the first are not parallel)'
    if method in ('auto', 'analytic') and model.analytic_ik:
        module = _solver(model.analytic_ik)
        res = _analytic(model, T_eff, mode, task, q_seed, q_nominal, check_limits,
                        tol_position, tol_orientation, max_iterations, module, upright_first)
        if res.success or method == 'analytic' or getattr(module, 'complete', False):
            if res.details.pop('roll_flipped', False):
                # only the upside-down configuration is in the limits: say so
                details['unreachable_roll'] = wrap(details['unreachable_roll'] - math.pi)
                details['roll_flipped'] = True
            res.details.update(details)
            return res
        fallback = _iterative(model, task, 'dls', q_seed, q_nominal, check_limits,
                              tol_position, tol_orientation, max_iterations)
        if fallback.success:
            fallback.method = 'dls (analytic fallback)'
            fallback.details.update(details)
            return fallback
        res.details.update(details)
        return res
    if method == 'analytic':
        return IkResult(False, None, method='analytic', reason=(
            f"robot model '{model.name}' has no analytic IK solver"), details=details)
    res = _iterative(model, task, 'newton' if method == 'newton' else 'dls', q_seed, q_nominal,
                     check_limits, tol_position, tol_orientation, max_iterations)
    res.details.update(details)
    return res


@functools.lru_cache(maxsize=64)
def scalar_pitch_solver(model):
    """Return the px100-family scalar solver when 'pitch' requests can use it, else None."""
    if model.analytic_ik != 'px100' or model.dof != 4 or not pitch_applies(model):
        return None
    g = px100.geometry(model)
    # the arm frame must be the base frame up to a translation (same azimuths) and the tool
    # frame at q = 0 aligned with it (front branch = tool roll 0)
    if not (np.allclose(g.R_F, np.eye(3), atol=1e-12) and g.tool_is_identity):
        return None
    return px100._model_solver(model)


def solve_pitch_scalar(model, x: float, y: float, z: float, R, q_seed: Sequence[float],
                       tol_position: float = 1e-9, tol_orientation: float = 1e-9):
    """
    Solve one 'pitch'-mode target on plain floats; return None when it needs ``solve_ik``.

    The same answer as ``solve_ik(model, T, mode='pitch', q_seed=q_seed)`` for px100-family
    arms, without numpy: the target's roll/yaw handled as ``pitch_target`` does, every
    closed-form branch in the limits, the ones with the target's tool roll first, each group by
    distance to q_seed, the first verified by FK. None means "not settled here" (another arm,
    a target on the Euler singularity, no solution in the limits, or the first solution not
    within tolerance): ``solve_ik`` gives the exact answer and reason.

    :param x, y, z: target position [m], base frame; R: rotation, 3 rows of 3 (finite, valid)
    :return: (solutions [tuples], position_error [m], orientation_error [rad],
        unreachable_roll [rad], unreachable_yaw [rad], roll_flipped, (pitch, yaw) kept and
        forced [rad]) or None; roll_flipped:
        only configurations with the tool upside down are in the limits (solve_ik's
        ``details['roll_flipped']``, the dropped roll then measured from them)
    """
    solver = scalar_pitch_solver(model)
    if solver is None:
        return None
    if math.hypot(R[0][0], R[1][0]) <= 1e-9:       # on the Euler singularity (pitch +-pi/2)
        return None
    pi = math.pi
    roll, pitch, yaw = euler_sxyz(R)
    if abs(roll) > pi / 2:
        roll, pitch, yaw = wrap(roll + pi), wrap(pi - pitch), wrap(yaw + pi)
    a = target_azimuth(model, (x, y, z))
    outward = abs(wrap(yaw - a)) <= pi / 2
    forced = a if outward else wrap(a + pi)
    # the solver's pitch is measured from the outward direction
    front, back = solver(x, y, z, pitch if outward else pi - pitch, 1e-9)
    upright, other = (front, back) if outward else (back, front)
    flipped = not upright
    if flipped:
        if not other:
            return None
        roll = wrap(roll - pi)          # only the upside-down configurations are in limits
    s0, s1, s2, s3 = (float(v) for v in q_seed)

    def cost(q):
        return (q[0] - s0) ** 2 + (q[1] - s1) ** 2 + (q[2] - s2) ** 2 + (q[3] - s3) ** 2
    upright.sort(key=cost)
    other.sort(key=cost)
    sols: list = []
    for q in upright + other:
        if all(max(abs(q[0] - o[0]), abs(q[1] - o[1]), abs(q[2] - o[2]),
                   abs(q[3] - o[3])) > 1e-9 for o in sols):
            sols.append(q)
    Rq, p = fk_py(chain(model), sols[0])
    pe = math.sqrt((p[0] - x) ** 2 + (p[1] - y) ** 2 + (p[2] - z) ** 2)
    cp = math.cos(pitch)
    d0, d1, d2 = cp * math.cos(forced), cp * math.sin(forced), -math.sin(pitch)
    x0, x1, x2 = Rq[0][0], Rq[1][0], Rq[2][0]
    c0, c1, c2 = x1 * d2 - x2 * d1, x2 * d0 - x0 * d2, x0 * d1 - x1 * d0
    oe = math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), x0 * d0 + x1 * d1 + x2 * d2)
    if pe > tol_position or oe > tol_orientation:
        return None
    return sols, pe, oe, roll, wrap(yaw - forced), flipped, (pitch, forced)


def _pitch_rows_to_poses(model, rows: np.ndarray) -> np.ndarray:
    return np.array([_pose_sxyz((x, y, z), 0.0, pitch, target_azimuth(model, (x, y, z)))
                     for x, y, z, pitch in rows])


def solve_ik_batch(model, targets, q_seed=None, check_limits: bool = True,
                   return_all: bool = False):
    """
    Return (Q (N, n), ok (N,)): the best 'pitch'-mode solution of each of N targets.

    :param targets: (N, 4, 4) poses, or (N, 4) rows (x, y, z, pitch) [m, rad] in the base frame
    :param q_seed: (n,) solutions closest to it win (default model.home)
    :param return_all: (analytic batch solvers only) return every branch (N, k, n), (N, k)
    Vectorised when the model's analytic module has ``solve_batch``; otherwise a loop over
    ``solve_ik(mode='pitch')``. Rows of Q without a solution are NaN.
    :raises InvalidInputError: wrong shape or NaN/inf in the targets
    """
    try:
        X = np.asarray(targets, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError('targets are not numeric') from exc
    if not ((X.ndim == 3 and X.shape[1:] == (4, 4)) or (X.ndim == 2 and X.shape[1] == 4)):
        raise InvalidInputError(f'targets must be (N, 4, 4) poses or (N, 4) rows (x, y, z, '
                                f'pitch), got shape {X.shape}')
    finite = np.isfinite(X.reshape(len(X), -1)).all(axis=1)
    if not finite.all():
        raise InvalidInputError(f'target {int(np.argmin(finite))} contains NaN or inf')
    seed = None if q_seed is None else model.check_vector(q_seed, 'q_seed')
    module = _solver(model.analytic_ik) if model.analytic_ik else None
    if module is not None and hasattr(module, 'solve_batch'):
        return module.solve_batch(model, X, q_seed=seed, check_limits=check_limits,
                                  return_all=return_all)
    if return_all:
        raise InvalidInputError(f"return_all needs an analytic batch solver; '{model.name}' "
                                'has none')
    poses = X if X.ndim == 3 else _pitch_rows_to_poses(model, X)
    Q = np.full((len(poses), model.dof), np.nan)
    ok = np.zeros(len(poses), dtype=bool)
    for i, T in enumerate(poses):
        res = solve_ik(model, T, mode='pitch', q_seed=seed, check_limits=check_limits)
        if res.success:
            Q[i], ok[i] = res.q, True
    return Q, ok


def solve_path(model, T_list: Sequence, q_start, mode: str = 'pitch',
               **kwargs) -> List[IkResult]:
    """
    Solve a sequence of poses, each seeded by the previous solution (no branch jumps).

    Each IkResult's ``q`` is the solution closest to the previous one (``q_start`` for the
    first). Stops at the first pose without a solution: the last result then has
    ``success=False`` and its ``reason`` (``details['index']`` says which pose).
    Extra keyword arguments go to ``solve_ik``.
    """
    prev = model.check_vector(q_start, 'q_start')
    q_nominal = kwargs.pop('q_nominal', None)
    out: List[IkResult] = []
    for i, T in enumerate(T_list):
        # position mode: the free angles stay near the previous solution unless told otherwise
        nominal = q_nominal if q_nominal is not None else (prev if mode == 'position' else None)
        res = solve_ik(model, T, mode=mode, q_seed=prev, q_nominal=nominal,
                       upright_first=False, **kwargs)
        res.details['index'] = i
        out.append(res)
        if not res.success:
            res.reason = f'pose {i}: {res.reason}'
            break
        prev = res.q
    return out
