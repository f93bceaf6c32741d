"""
The ik_service's answers on plain values (no ROS): parameter checks, status texts, paths.

A request's reply is an IkResult turned into a message and ``values`` (the solver's figures as
(key, text) pairs), for the ``compute_ik`` service (:func:`ik_answer`);
a path request's reply is a joint path timed for the trajectory server. Units: positions [m],
angles [rad], times [s], speeds [rad/s] (m/s for prismatic joints).
"""
from dataclasses import dataclass, field
import math
from typing import Callable, List, Optional, Sequence, Tuple

from px100_control.control.path_timing import joint_speed_bounds, path_times
from px100_control.errors import InvalidInputError
from px100_control.kinematics.ik_types import IkResult
from px100_control.kinematics.solve import METHODS, solve_ik, solve_path
from px100_control.parameters import bound_error, IK_SERVICE

#: orientation_mode parameter value -> solve_ik mode
MODES = {'pitch': 'pitch', 'strict': 'full'}


def parameter_error(name: str, value, dof: int) -> Optional[str]:
    """
    Return why ``value`` is refused for the ik_service parameter ``name``, or None.

    Number ranges are the schema's (:data:`px100_control.parameters.IK_SERVICE`).
    """
    if name == 'orientation_mode' and value not in MODES:
        return f"orientation_mode must be 'pitch' or 'strict', got {value!r}"
    if name == 'method' and value not in METHODS:
        return f'method must be one of {METHODS}, got {value!r}'
    error = bound_error(IK_SERVICE, name, value)
    if error:
        return error
    if name == 'nominal_pose':
        vals = list(value or [])
        if len(vals) != dof or not all(math.isfinite(x) for x in vals):
            return f'nominal_pose needs {dof} finite values, got {vals}'
    return None


def request_mode(orientation_mode: str, default: str) -> str:
    """
    Return the solve_ik mode of a service request's ``orientation_mode`` ('' = ``default``).

    :raises InvalidInputError: not 'pitch', 'strict' or ''
    """
    if orientation_mode == '':
        return default
    if orientation_mode not in MODES:
        raise InvalidInputError(f"orientation_mode must be 'pitch', 'strict' or '' (the "
                                f"node's parameter), got {orientation_mode!r}")
    return MODES[orientation_mode]


def request_seed(seed: Sequence[float], dof: int, fallback):
    """
    Return a service request's seed [rad] (one per arm joint), ``fallback`` when it is empty.

    :raises InvalidInputError: a length other than ``dof`` or a non-finite value
    """
    if len(seed) == 0:
        return fallback
    values = [float(x) for x in seed]
    if len(values) != dof:
        raise InvalidInputError(f'seed needs {dof} values (one per arm joint) or none, got '
                                f'{len(values)}')
    if not all(math.isfinite(x) for x in values):
        raise InvalidInputError(f'seed must be finite, got {values}')
    return values


@dataclass
class IkAnswer:
    """One IK request's answer: the solution [rad] (None on failure), its text and values."""

    ok: bool
    q: Optional[List[float]]
    message: str
    values: List[Tuple[str, str]]
    result: Optional[IkResult] = None


def ik_answer(model, T, mode: str, seed, nominal, solver_kwargs: dict,
              orientation_tol: float) -> IkAnswer:
    """
    Solve one request with ``solve_ik`` and word its answer (``compute_ik``'s message).

    :param T: (4, 4) target of the end effector in the base frame [m]
    :param mode: solve_ik mode ('pitch', 'full' or 'position')
    :param seed: the solution closest to it is returned [rad]
    :return: refused input ('invalid request: ...'), no solution (solve_ik's reason) or
        'solved' (naming dropped roll/yaw above ``orientation_tol`` [rad])
    """
    try:
        res = solve_ik(model, T, mode=mode, q_seed=seed, q_nominal=nominal, **solver_kwargs)
    except InvalidInputError as exc:
        return IkAnswer(False, None, f'invalid request: {exc}', [])
    values = result_values(res, mode)
    if res.success:
        return IkAnswer(True, [float(x) for x in res.q],
                        solved_message(res, mode, orientation_tol, model.dof), values, res)
    return IkAnswer(False, None, res.reason or 'no solution', values, res)


def fmt(x: float) -> str:
    """Return a status value's text: 3 significant decimals in e-notation, or inf/nan."""
    return f'{x:.3e}' if math.isfinite(x) else str(x)


def solved_message(res, mode: str, orientation_tol: float, dof: int) -> str:
    """Return 'solved', naming the roll/yaw [rad] above ``orientation_tol`` that were dropped."""
    if mode != 'pitch':
        return 'solved'
    roll = abs(float(res.details.get('unreachable_roll', 0.0)))
    yaw = abs(float(res.details.get('unreachable_yaw', 0.0)))
    if max(roll, yaw) <= orientation_tol:
        return 'solved'
    return (f'solved (warning: the target roll {roll:.4g} rad and yaw {yaw:.4g} rad that a '
            f'{dof}-DOF arm cannot reach were dropped; position and pitch met)')


def result_values(res, mode: str) -> List[Tuple[str, str]]:
    """Return the solver's figures of one request's IkResult as (key, text) pairs."""
    vals = [('mode', mode), ('method', res.method), ('iterations', str(res.iterations)),
            ('position_error', fmt(res.position_error)),
            ('orientation_error', fmt(res.orientation_error)),
            ('solutions', str(len(res.solutions)))]
    if mode == 'pitch':
        for key in ('unreachable_roll', 'unreachable_yaw'):
            if key in res.details:
                vals.append((key, fmt(float(res.details[key]))))
    return vals


def path_targets(poses: Sequence, target: Callable) -> Tuple[list, str]:
    """
    Return (targets, mode) of a path's poses, each turned into (T, mode) by ``target(pose)``.

    :raises InvalidInputError: no poses, a pose ``target`` refuses (named by index), or
        position-only poses mixed with oriented ones
    """
    if not poses:
        raise InvalidInputError('the path has no poses')
    targets, modes = [], set()
    for i, pose in enumerate(poses):
        try:
            T, mode = target(pose)
        except InvalidInputError as exc:
            raise InvalidInputError(f'pose {i}: {exc}') from None
        targets.append(T)
        modes.add(mode)
    if len(modes) > 1:
        raise InvalidInputError('the path mixes position-only poses (all-zero quaternion) '
                                'with oriented ones')
    return targets, modes.pop()


@dataclass
class PathReply:
    """A path request's answer: ``points`` (q [rad], time_from_start [s]) and its status."""

    ok: bool
    message: str
    values: List[Tuple[str, str]]
    points: List[Tuple[List[float], float]] = field(default_factory=list)


def plan_path(model, targets: list, mode: str, seed, nominal, solver_kwargs: dict,
              max_joint_velocity: float, min_point_time: float) -> PathReply:
    """
    Solve a path pose by pose from ``seed`` and time it (see :mod:`.path_timing`).

    The path stops at the first pose without a solution: the reply then holds the points
    before it, and ``values`` names the pose (``failed_index``).

    :raises InvalidInputError: a target or a setting solve_path refuses
    """
    results = solve_path(model, targets, seed, mode=mode,
                         q_nominal=nominal if mode == 'position' else None, **solver_kwargs)
    ok = [r for r in results if r.success]
    points = []
    if ok:
        times = path_times([r.q for r in ok], seed,
                           joint_speed_bounds(model.velocity_limits, max_joint_velocity),
                           min_point_time)
        points = [([float(x) for x in r.q], float(t)) for r, t in zip(ok, times)]
    values = [('poses', str(len(targets))), ('solved', str(len(ok))), ('mode', mode),
              ('method', results[-1].method),
              ('iterations', str(sum(r.iterations for r in results))),
              ('position_error', fmt(max((r.position_error for r in ok), default=0.0))),
              ('orientation_error', fmt(max((r.orientation_error for r in ok), default=0.0)))]
    if len(ok) == len(targets):
        return PathReply(True, 'solved', values, points)
    bad = results[-1]
    values.append(('failed_index', str(bad.details.get('index', len(ok)))))
    return PathReply(False, bad.reason or 'no solution', values, points)
