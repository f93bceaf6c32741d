"""
End-effector waypoint paths: straight Cartesian segments cut so that no joint step exceeds a max.

Between two waypoints the end-effector position moves on a straight line, s = k / N, k = 1..N,
and its orientation either by linear 'sxyz' roll, pitch, yaw (``orientation='rpy'``, the
default and Interbotix's convention: a tool with zero roll keeps zero roll, which a 4-DOF arm
needs), by 'sxyz' angles with the yaw measured from the azimuth atan2(y, x) of the position
(``'azimuth'``: for arms with fewer than 6 joints, whose heading follows the position, as
Interbotix sets yaw = atan2(y, x) for them), or on the shortest rotation (``'geodesic'``,
R0 exp(s log(R0^T R1))). Each point is
solved by IK seeded with the previous point's solution (no branch jumps). N starts at
ceil(max_i |q1_i - q0_i| / max_joint_step) from the waypoints' own IK solutions (joint-space
distance over the step bound) and grows segment by segment until every joint step between
consecutive points is at most ``max_joint_step``: the straight line in Cartesian space is not
straight in joint space, so the endpoint count alone can exceed the bound mid-segment.

The IK is a callable ``solve(poses, q_start) -> (Q, reason)``: Q (k, n) holds the solutions of
the first k poses in order (k < len(poses) when pose k has none; ``reason`` says why). Plain
functions here give it from a model (``model_path_solver``); the client gives it from
ik_service. Poses are (4, 4) in the base frame [m]; joints [rad] (prismatic [m]).
"""
from dataclasses import dataclass, field
import math
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np

from px100_control.errors import InvalidInputError, Px100Error
from px100_control.kinematics.kernels import wrap_array
from px100_control.kinematics.rotations import euler_sxyz_to_matrix, matrix_to_euler_sxyz
from px100_control.kinematics.se3 import exp_so3, log_so3
from px100_control.kinematics.solve import check_pose, solve_path

#: solve(poses, q_start) -> (Q (k, n), reason)
PathSolver = Callable[[Sequence[np.ndarray], np.ndarray], Tuple[np.ndarray, str]]


class CartesianPathError(Px100Error):
    """A waypoint path cannot be planned: a pose has no IK solution or the steps do not shrink."""


@dataclass
class WaypointPath:
    """
    A planned end-effector waypoint path.

    :param q: (N + 1, n) joint values [rad], row 0 the start, every step <= max_joint_step
    :param poses: N + 1 (4, 4) end-effector poses [m], pose 0 the start
    :param segment: (N + 1,) index of the waypoint each point moves toward (-1 for the start)
    :param counts: steps per segment; ``first_counts`` the counts from the waypoints' IK alone
    """

    q: np.ndarray
    poses: List[np.ndarray]
    segment: np.ndarray
    counts: List[int]
    first_counts: List[int] = field(default_factory=list)

    @property
    def max_step(self) -> float:
        """Return the largest joint step between consecutive points [rad]."""
        return float(np.abs(np.diff(self.q, axis=0)).max()) if len(self.q) > 1 else 0.0


ORIENTATIONS = ('rpy', 'azimuth', 'geodesic')


def interpolate_pose(T0: np.ndarray, T1: np.ndarray, s: float,
                     orientation: str = 'rpy') -> np.ndarray:
    """
    Return the pose a fraction s in [0, 1] of the way from T0 to T1.

    Position linear; rotation by linear 'sxyz' angles (each difference taken in [-pi, pi)),
    'sxyz' angles with yaw relative to the position's azimuth, or along the geodesic.
    """
    T = np.eye(4)
    T[:3, 3] = (1.0 - s) * T0[:3, 3] + s * T1[:3, 3]
    if orientation in ('rpy', 'azimuth'):
        a0 = np.array(matrix_to_euler_sxyz(T0[:3, :3]))
        a1 = np.array(matrix_to_euler_sxyz(T1[:3, :3]))
        if orientation == 'azimuth':
            a0[2] -= math.atan2(T0[1, 3], T0[0, 3])
            a1[2] -= math.atan2(T1[1, 3], T1[0, 3])
        d = wrap_array(a1 - a0)
        a = a0 + s * d
        if orientation == 'azimuth':
            a[2] += math.atan2(T[1, 3], T[0, 3])
        T[:3, :3] = euler_sxyz_to_matrix(*a)
        return T
    if orientation != 'geodesic':
        raise InvalidInputError(f'orientation must be one of {ORIENTATIONS}, got {orientation!r}')
    w = log_so3(T0[:3, :3].T @ T1[:3, :3])
    angle = float(np.linalg.norm(w))
    T[:3, :3] = T0[:3, :3] if angle < 1e-12 else T0[:3, :3] @ exp_so3(w / angle, s * angle)
    return T


def segment_poses(T0: np.ndarray, T1: np.ndarray, count: int,
                  orientation: str = 'rpy') -> List[np.ndarray]:
    """Return the ``count`` poses k / count of the way from T0 to T1, k = 1..count (T1 exact)."""
    out = [interpolate_pose(T0, T1, k / count, orientation) for k in range(1, count)]
    out.append(np.array(T1, dtype=float))
    return out


def step_count(q0, q1, max_joint_step: float) -> int:
    """Return N = ceil(max |q1 - q0| / max_joint_step), at least 1."""
    d = float(np.max(np.abs(np.asarray(q1, float) - np.asarray(q0, float))))
    return max(1, int(math.ceil(d / max_joint_step - 1e-12)))


def model_path_solver(model, mode: str = 'pitch', **kwargs) -> PathSolver:
    """
    Return a PathSolver over ``solve_path`` on a robot model (each pose seeded by the last).

    ``mode`` as ``solve_ik`` ('full', 'pitch' = position + tool x axis, 'position'); extra
    keyword arguments go to ``solve_ik``. Redundant arms (more than 6 joints) default to the
    local method 'dls', which stays on the self-motion branch of the previous point; a closed
    form picks its own swivel angle per pose and the path would jump.
    """
    if model.dof > 6:
        kwargs.setdefault('method', 'dls')

    def solve(poses, q_start):
        results = solve_path(model, list(poses), q_start, mode=mode, **kwargs)
        Q = np.array([r.q for r in results if r.success], dtype=float).reshape(-1, model.dof)
        reason = '' if all(r.success for r in results) else results[-1].reason
        return Q, reason
    return solve


def _check_inputs(q_start, T_start, waypoints, max_joint_step):
    try:
        step = float(max_joint_step)
    except (TypeError, ValueError):
        raise InvalidInputError(f'max_joint_step must be a number, got {max_joint_step!r}') \
            from None
    if not (math.isfinite(step) and step > 0.0):
        raise InvalidInputError(f'max_joint_step must be finite and > 0, got {max_joint_step!r}')
    q0 = np.asarray(q_start, dtype=float).reshape(-1)
    if not np.all(np.isfinite(q0)):
        raise InvalidInputError(f'q_start must be finite, got {q0.tolist()}')
    if waypoints is None or len(waypoints) == 0:
        raise InvalidInputError('the path has no waypoints')
    T0 = check_pose(T_start, 'start pose')
    Ws = [check_pose(T, f'waypoint {i}') for i, T in enumerate(waypoints)]
    return q0, T0, Ws, step


def plan_ee_waypoints(solve: PathSolver, q_start, T_start, waypoints, max_joint_step: float,
                      max_points: int = 5000, max_rounds: int = 16,
                      orientation: str = 'rpy') -> WaypointPath:
    """
    Plan straight Cartesian segments through ``waypoints`` with every joint step bounded.

    :param solve: the IK of a pose sequence (see module docstring)
    :param q_start: (n,) joint values at the start [rad]; T_start: their end-effector pose
    :param waypoints: (4, 4) poses [m] in the base frame, in order
    :param max_joint_step: the largest allowed change of any joint between points [rad] (> 0)
    :param max_points: refuse paths that would need more points than this
    :param orientation: 'rpy' or 'geodesic' (see module docstring)
    :raises InvalidInputError: malformed input (names what was wrong)
    :raises CartesianPathError: a waypoint or an interpolated pose has no IK solution, or the
        steps near some point do not shrink below the bound (a singularity or branch change)
    """
    q0, T0, Ws, step = _check_inputs(q_start, T_start, waypoints, max_joint_step)
    if orientation not in ORIENTATIONS:
        raise InvalidInputError(f'orientation must be one of {ORIENTATIONS}, got {orientation!r}')
    Qw, reason = solve(Ws, q0)
    if len(Qw) < len(Ws):
        raise CartesianPathError(f'waypoint {len(Qw)} has no IK solution: {reason}')
    ends = np.vstack([q0[None, :], Qw])
    counts = [step_count(ends[k], ends[k + 1], step) for k in range(len(Ws))]
    first = list(counts)
    starts = [T0] + Ws[:-1]
    for _ in range(max_rounds):
        if sum(counts) > max_points:
            raise CartesianPathError(
                f'the path needs more than {max_points} points to keep every joint step under '
                f'{step:g} rad (a singularity or a branch change along segment '
                f'{int(np.argmax(counts))}?)')
        poses, seg = [], []
        for k, (Ta, Tb) in enumerate(zip(starts, Ws)):
            poses += segment_poses(Ta, Tb, counts[k], orientation)
            seg += [k] * counts[k]
        Q, reason = solve(poses, q0)
        if len(Q) < len(poses):
            k = seg[len(Q)]
            raise CartesianPathError(
                f'segment {k} (toward waypoint {k}): point {len(Q)} of the path has no IK '
                f'solution: {reason}')
        Qall = np.vstack([q0[None, :], Q])
        steps = np.abs(np.diff(Qall, axis=0)).max(axis=1)
        seg_arr = np.array(seg)
        worst = [float(steps[seg_arr == k].max()) for k in range(len(Ws))]
        if all(w <= step * (1.0 + 1e-9) for w in worst):
            return WaypointPath(q=Qall, poses=[T0] + poses,
                                segment=np.concatenate([[-1], seg_arr]), counts=counts,
                                first_counts=first)
        # at most doubling: a branch jump at a coarse spacing must not inflate the count
        counts = [c if w <= step * (1.0 + 1e-9) else
                  max(c + 1, min(2 * c, int(math.ceil(c * w / step * 1.05))))
                  for c, w in zip(counts, worst)]
    raise CartesianPathError(
        f'the joint steps did not shrink under {step:g} rad in {max_rounds} refinements '
        '(a singularity or a branch change along the path?)')


def ee_waypoint_path(model, q_start, waypoints, max_joint_step: float, mode: str = 'pitch',
                     max_points: int = 5000, orientation: Optional[str] = None,
                     **ik_kwargs) -> WaypointPath:
    """
    Return ``plan_ee_waypoints`` from q_start on a robot model, with its own ``solve_path``.

    ``orientation`` defaults to 'azimuth' for arms with fewer than 6 joints, else 'rpy'.
    """
    if orientation is None:
        orientation = 'azimuth' if model.dof < 6 else 'rpy'
    q0 = model.check_vector(q_start, 'q_start')
    return plan_ee_waypoints(model_path_solver(model, mode, **ik_kwargs), q0, model.fk(q0),
                             waypoints, max_joint_step, max_points=max_points,
                             orientation=orientation)
