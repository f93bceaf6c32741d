"""
Times for a joint path (IK solutions of a Cartesian path) that a trajectory goal can use.

Each point gets the earliest time at which no joint moves faster than its velocity bound on the
way from the previous point (straight lines in joint space, as the trajectory server
interpolates between points), and at least ``min_dt`` after it. Units: rad (m for prismatic
joints), rad/s (m/s), s. No ROS here.
"""
import math
from typing import Optional, Sequence

import numpy as np


def joint_speed_bounds(velocity_limits: Sequence[float], max_velocity: float) -> np.ndarray:
    """
    Return per joint min(max_velocity, its velocity limit); a limit <= 0 or not finite is ignored.

    :raises ValueError: max_velocity is not a number > 0
    """
    if not (isinstance(max_velocity, (int, float)) and max_velocity > 0
            and math.isfinite(max_velocity)):
        raise ValueError(f'max_velocity must be a finite number > 0, got {max_velocity!r}')
    limits = np.asarray(velocity_limits, float)
    bounds = np.full(limits.shape, float(max_velocity))
    usable = np.isfinite(limits) & (limits > 0)
    bounds[usable] = np.minimum(bounds[usable], limits[usable])
    return bounds


def path_times(points: Sequence[Sequence[float]], start: Optional[Sequence[float]],
               speed_bounds: Sequence[float], min_dt: float = 0.0) -> np.ndarray:
    """
    Return time_from_start [s] of every point of a joint path.

    :param points: (m, n) joint positions
    :param start: (n,) where the arm is when the path starts (None: the first point is at t = 0)
    :param speed_bounds: (n,) largest joint speed (see :func:`joint_speed_bounds`)
    :param min_dt: least time between two points [s] (the first point: after ``start``, when
        it differs from it)
    :return: (m,) strictly increasing times (non-decreasing only when min_dt is 0 and points
        repeat)
    """
    if len(points) == 0:
        return np.zeros(0)
    q = np.asarray(points, float).reshape(len(points), -1)
    v = np.asarray(speed_bounds, float)
    if q.shape[1] != v.shape[0]:
        raise ValueError(f'{q.shape[1]} joints per point but {v.shape[0]} speed bounds')
    first = np.zeros((1, q.shape[1])) if start is None else \
        np.abs(q[:1] - np.asarray(start, float).reshape(1, -1))
    steps = np.vstack([first, np.abs(np.diff(q, axis=0))])
    dt = np.max(steps / v, axis=1)
    if start is not None and np.max(steps[0]) > 0:
        dt[0] = max(dt[0], float(min_dt))
    dt[1:] = np.maximum(dt[1:], float(min_dt))
    return np.cumsum(dt)
