"""
Joint-space trajectories: time scalings, multi-waypoint splines, a smooth stop, validation.

Pure numpy (no rclpy, no clock): time is always an argument, ``t`` [s] from the trajectory's
start; positions [rad or m], velocities [rad/s], accelerations [rad/s^2]. A :class:`Trajectory`
is a list of segments over ``[0, duration]``; ``sample(t)`` returns ``(q, qd, qdd)`` each (n,),
holding the end position (zero velocity) after ``duration`` and the start before 0.

Profiles of a point-to-point move (``PROFILES``):

- ``trapezoidal``: the Dynamixel / Interbotix time-based profile. The move lasts
  ``moving_time`` T; the velocity ramps up with constant acceleration during ``accel_time``
  Ta, cruises, and ramps down during the last Ta. Ta is clipped to [0, T/2] as the servo does
  (Ta = T/2 is a triangle, Ta = 0 a velocity step). Peak speed ``|dq| / (T - Ta)``.
- ``minimum_jerk``: the quintic 10 tau^3 - 15 tau^4 + 6 tau^5 (zero boundary velocity and
  acceleration). Peak speed ``1.875 |dq| / T``.
- ``linear_max_step``: linear in time: the path is cut into
  N = ceil(max |dq| / max_joint_step) equal steps and lasts at least N sample periods, so no
  joint moves more than ``max_joint_step`` between two setpoints sampled at that period.
  Peak speed ``|dq| / T`` (velocity steps at the ends).

Several waypoints are joined by Hermite splines with continuous velocity: cubic, or quintic
when accelerations are given; interior velocities, when not given, are the shape-preserving
PCHIP slopes (zero at a local extremum, so the path never overshoots a waypoint). The
``linear_max_step`` profile joins waypoints linearly instead.
"""
from dataclasses import dataclass
import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from px100_control.errors import InvalidInputError

PROFILES = ('trapezoidal', 'minimum_jerk', 'linear_max_step')

#: relative slack on velocity limits (float rounding of a move planned exactly at the limit)
VELOCITY_LIMIT_SLACK = 1e-6
#: position-limit slack [rad]
POSITION_LIMIT_SLACK = 1e-9


# ---------------------------------------------------------------------------------------------
# Time scalings s(t) in [0, 1] over [0, T]: each returns (s, sd, sdd), arrays like t
# ---------------------------------------------------------------------------------------------

def trapezoidal_scaling(t, T: float, accel_time: float):
    """
    Return (s, sd, sdd) of the time-based trapezoidal profile at time t [s].

    :param T: moving time [s] (> 0)
    :param accel_time: ramp time [s], clipped to [0, T/2] (the Dynamixel rule)

    Example Input: t = 1.0, T = 2.0, accel_time = 0.5
    Output: (0.5, 0.6667, 0.0)
    """
    t = np.clip(np.asarray(t, dtype=float), 0.0, T)
    ta = min(max(float(accel_time), 0.0), T / 2.0)
    v = 1.0 / (T - ta)
    if ta <= 0.0:
        return t / T, np.full_like(t, v), np.zeros_like(t)
    a = v / ta
    up = t < ta
    down = t > T - ta
    tr = T - t
    s = np.where(up, 0.5 * a * t * t,
                 np.where(down, 1.0 - 0.5 * a * tr * tr, v * (t - 0.5 * ta)))
    sd = np.where(up, a * t, np.where(down, a * tr, v))
    sdd = np.where(up, a, np.where(down, -a, 0.0))
    return s, sd, sdd


def minimum_jerk_scaling(t, T: float):
    """
    Return (s, sd, sdd) of the minimum-jerk (quintic) scaling at time t [s] over [0, T].

    Example Input: t = 0.5, T = 1.0
    Output: (0.5, 1.875, 0.0)
    """
    tau = np.clip(np.asarray(t, dtype=float), 0.0, T) / T
    t2 = tau * tau
    s = t2 * tau * (10.0 - 15.0 * tau + 6.0 * t2)
    sd = 30.0 * t2 * (1.0 - 2.0 * tau + t2) / T
    sdd = 60.0 * tau * (1.0 - 3.0 * tau + 2.0 * t2) / (T * T)
    return s, sd, sdd


def linear_scaling(t, T: float):
    """Return (s, sd, sdd) of the constant-speed scaling at time t [s] over [0, T]."""
    t = np.clip(np.asarray(t, dtype=float), 0.0, T)
    return t / T, np.full_like(t, 1.0 / T), np.zeros_like(t)


def scaling_at(profile: str, t: float, T: float, accel_time: float = 0.0):
    """
    Return (s, sd, sdd) of a profile at one time t [s] (plain floats: the per-setpoint path).

    Same values as the array functions above ('linear_max_step' is the linear scaling).
    """
    t = min(max(float(t), 0.0), T)
    if profile == 'trapezoidal':
        ta = min(max(float(accel_time), 0.0), T / 2.0)
        v = 1.0 / (T - ta)
        if ta <= 0.0:
            return t / T, v, 0.0
        a = v / ta
        if t < ta:
            return 0.5 * a * t * t, a * t, a
        if t > T - ta:
            tr = T - t
            return 1.0 - 0.5 * a * tr * tr, a * tr, -a
        return v * (t - 0.5 * ta), v, 0.0
    if profile == 'minimum_jerk':
        tau = t / T
        t2 = tau * tau
        return (t2 * tau * (10.0 - 15.0 * tau + 6.0 * t2), 30.0 * t2 * (1.0 - 2.0 * tau + t2) / T,
                60.0 * tau * (1.0 - 3.0 * tau + 2.0 * t2) / (T * T))
    return t / T, 1.0 / T, 0.0


def peak_speed_factor(profile: str, T: float, accel_time: float = 0.0) -> float:
    """Return max sd [1/s] of a profile: peak joint speed = factor * |dq|."""
    if profile == 'trapezoidal':
        return 1.0 / (T - min(max(accel_time, 0.0), T / 2.0))
    if profile == 'minimum_jerk':
        return 1.875 / T
    if profile == 'linear_max_step':
        return 1.0 / T
    raise InvalidInputError(f"unknown profile '{profile}' (known: {', '.join(PROFILES)})")


def linear_steps(q0, q1, max_joint_step: float) -> np.ndarray:
    """
    Return the (N + 1, n) linear interpolation with no joint step above max_joint_step.

    N = ceil(max |q1 - q0| / max_joint_step), at least 1.

    Example Input: q0 = [0, 0], q1 = [0.25, -0.1], max_joint_step = 0.1
    Output: 4 rows [0, 0], [0.0833, -0.0333], [0.1667, -0.0667], [0.25, -0.1]
    """
    if not max_joint_step > 0.0:
        raise InvalidInputError(f'max_joint_step must be > 0, got {max_joint_step}')
    q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
    n_steps = max(1, int(math.ceil(float(np.max(np.abs(q1 - q0))) / max_joint_step - 1e-12)))
    return q0 + np.linspace(0.0, 1.0, n_steps + 1)[:, None] * (q1 - q0)


def linear_max_step_duration(q0, q1, max_joint_step: float, period: float,
                             min_duration: float = 0.0) -> float:
    """
    Return the duration [s] of a linear move whose setpoints, ``period`` apart, step <= max.

    It is ``max(min_duration, N * period)`` with N the step count of :func:`linear_steps`.
    """
    n_steps = linear_steps(q0, q1, max_joint_step).shape[0] - 1
    return max(float(min_duration), n_steps * float(period))


# ---------------------------------------------------------------------------------------------
# Segments
# ---------------------------------------------------------------------------------------------

class Segment:
    """A piece of trajectory over [t0, t0 + T]; ``sample`` takes the local time in [0, T]."""

    t0: float
    T: float
    q0: np.ndarray
    q1: np.ndarray

    def evaluate(self, tl) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (q, qd, qdd), each (k, n), at the local times tl (k,) [s]."""
        raise NotImplementedError

    def sample(self, tl: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (q, qd, qdd), each (n,), at local time tl [s]."""
        q, qd, qdd = self.evaluate(np.array([float(tl)]))
        return q[0], qd[0], qdd[0]


@dataclass
class ScaledSegment(Segment):
    """
    Straight joint-space move q0 -> q1 along a time scaling, plus a decaying start velocity.

    ``v0`` (n,) [rad/s] is blended in with h(t) = T tau (1 - tau)^2 (h(0) = h(T) = 0,
    h'(0) = 1, h'(T) = 0), so a move started while the arm moves has continuous velocity.
    """

    t0: float
    T: float
    q0: np.ndarray
    q1: np.ndarray
    profile: str
    accel_time: float = 0.0
    v0: Optional[np.ndarray] = None

    def scaling(self, tl):
        """Return (s, sd, sdd) of this segment's profile at local time tl."""
        if self.profile == 'trapezoidal':
            return trapezoidal_scaling(tl, self.T, self.accel_time)
        if self.profile == 'minimum_jerk':
            return minimum_jerk_scaling(tl, self.T)
        return linear_scaling(tl, self.T)

    def sample(self, tl: float):
        """Return (q, qd, qdd), each (n,), at local time tl [s] (scalar fast path)."""
        s, sd, sdd = scaling_at(self.profile, tl, self.T, self.accel_time)
        d = self.q1 - self.q0
        q, qd, qdd = self.q0 + s * d, sd * d, sdd * d
        if self.v0 is not None:
            tau = min(max(float(tl) / self.T, 0.0), 1.0)
            q = q + self.T * tau * (1.0 - tau) ** 2 * self.v0
            qd = qd + (1.0 - tau) * (1.0 - 3.0 * tau) * self.v0
            qdd = qdd + (6.0 * tau - 4.0) / self.T * self.v0
        return q, qd, qdd

    def evaluate(self, tl):
        """Return (q, qd, qdd), each (k, n), at the local times tl (k,) [s]."""
        tl = np.asarray(tl, dtype=float).reshape(-1)
        s, sd, sdd = (np.broadcast_to(x, tl.shape)[:, None] for x in self.scaling(tl))
        d = (self.q1 - self.q0)[None, :]
        q, qd, qdd = self.q0[None, :] + s * d, sd * d, sdd * d
        if self.v0 is not None:
            tau = np.clip(tl / self.T, 0.0, 1.0)[:, None]
            h = self.T * tau * (1.0 - tau) ** 2
            hd = (1.0 - tau) * (1.0 - 3.0 * tau)
            hdd = (6.0 * tau - 4.0) / self.T
            v0 = self.v0[None, :]
            q, qd, qdd = q + h * v0, qd + hd * v0, qdd + hdd * v0
        return q, qd, qdd


@dataclass
class HermiteSegment(Segment):
    """Cubic Hermite segment (quintic when both boundary accelerations are given)."""

    t0: float
    T: float
    q0: np.ndarray
    q1: np.ndarray
    v0: np.ndarray
    v1: np.ndarray
    a0: Optional[np.ndarray] = None
    a1: Optional[np.ndarray] = None

    def __post_init__(self):
        """Precompute the polynomial coefficients in local time (highest power last)."""
        T, dq = self.T, self.q1 - self.q0
        if self.a0 is None or self.a1 is None:
            c2 = (3.0 * dq - (2.0 * self.v0 + self.v1) * T) / T ** 2
            c3 = (-2.0 * dq + (self.v0 + self.v1) * T) / T ** 3
            self.coeffs = [self.q0, self.v0, c2, c3]
        else:
            a0, a1 = self.a0, self.a1
            c3 = (20 * dq - (8 * self.v1 + 12 * self.v0) * T - (3 * a0 - a1) * T ** 2) / (
                2 * T ** 3)
            c4 = (-30 * dq + (14 * self.v1 + 16 * self.v0) * T + (3 * a0 - 2 * a1) * T ** 2) / (
                2 * T ** 4)
            c5 = (12 * dq - 6 * (self.v1 + self.v0) * T - (a0 - a1) * T ** 2) / (2 * T ** 5)
            self.coeffs = [self.q0, self.v0, 0.5 * a0, c3, c4, c5]

    def evaluate(self, tl):
        """Return (q, qd, qdd), each (k, n), at the local times tl (k,) [s]."""
        tl = np.clip(np.asarray(tl, dtype=float).reshape(-1), 0.0, self.T)[:, None]
        c = [x[None, :] for x in self.coeffs]
        q = c[0] + c[1] * tl
        qd = np.broadcast_to(c[1], q.shape).copy()
        qdd = np.zeros_like(q)
        for k in range(2, len(c)):
            q = q + c[k] * tl ** k
            qd = qd + k * c[k] * tl ** (k - 1)
            qdd = qdd + k * (k - 1) * c[k] * tl ** (k - 2)
        return q, qd, qdd


@dataclass
class StopSegment(Segment):
    """
    Bring every joint from velocity v0 to rest: qd(t) = v0 (1 - t/T)^2.

    Velocity is continuous at the start, velocity and acceleration are zero at the end; the
    peak deceleration is 2 |v0| / T at the start and the arm travels v0 T / 3.
    """

    t0: float
    T: float
    q0: np.ndarray
    v0: np.ndarray

    def __post_init__(self):
        """Compute the rest position."""
        self.q1 = self.q0 + self.v0 * self.T / 3.0

    def evaluate(self, tl):
        """Return (q, qd, qdd), each (k, n), at the local times tl (k,) [s]."""
        tl = np.asarray(tl, dtype=float).reshape(-1)
        if self.T <= 0.0:
            q = np.broadcast_to(self.q0, (tl.size, self.q0.size)).copy()
            return q, np.zeros_like(q), np.zeros_like(q)
        r = (1.0 - np.clip(tl, 0.0, self.T) / self.T)[:, None]
        v0 = self.v0[None, :]
        return (self.q0[None, :] + v0 * self.T / 3.0 * (1.0 - r ** 3), v0 * r * r,
                -2.0 * v0 * r / self.T)


# ---------------------------------------------------------------------------------------------
# Trajectory
# ---------------------------------------------------------------------------------------------

class Trajectory:
    """
    A joint trajectory made of consecutive segments, sampled at a time passed in.

    :param segments: non-empty, contiguous (each starts where and when the previous ends)
    """

    def __init__(self, segments: Sequence[Segment]):
        if not segments:
            raise InvalidInputError('a trajectory needs at least one segment')
        self.segments: List[Segment] = list(segments)
        self._starts = [s.t0 for s in self.segments]
        last = self.segments[-1]
        self.duration = float(last.t0 + last.T)

    @property
    def start(self) -> np.ndarray:
        """Return the start position (n,)."""
        return self.segments[0].q0.copy()

    @property
    def end(self) -> np.ndarray:
        """Return the final position (n,)."""
        return self.segments[-1].q1.copy()

    @property
    def dof(self) -> int:
        """Return the number of joints."""
        return int(self.segments[0].q0.size)

    def sample(self, t: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """
        Return (q, qd, qdd), each (n,), at time t [s] from the start.

        Before 0 this is the start state of the first segment; at or after ``duration`` the end
        position with zero velocity and acceleration.
        """
        t = float(t)
        if not math.isfinite(t):
            raise InvalidInputError(f'sample time must be finite, got {t}')
        if t >= self.duration:
            zero = np.zeros(self.dof)
            return self.end, zero, zero.copy()
        i = max(0, int(np.searchsorted(self._starts, t, side='right')) - 1)
        seg = self.segments[i]
        return seg.sample(t - seg.t0)

    def sample_many(self, times) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (q, qd, qdd), each (k, n), at the k times given (vectorised per segment)."""
        t = np.asarray(times, dtype=float).reshape(-1)
        if not np.all(np.isfinite(t)):
            raise InvalidInputError('sample times must be finite')
        n = self.dof
        q, qd, qdd = np.empty((t.size, n)), np.zeros((t.size, n)), np.zeros((t.size, n))
        which = np.clip(np.searchsorted(self._starts, t, side='right') - 1, 0, None)
        for i, seg in enumerate(self.segments):
            mask = (which == i) & (t < self.duration)
            if np.any(mask):
                q[mask], qd[mask], qdd[mask] = seg.evaluate(t[mask] - seg.t0)
        q[t >= self.duration] = self.end
        return q, qd, qdd

    def check_times(self, dt: float = 1e-3, max_samples: int = 20000) -> np.ndarray:
        """Return the times of a dense check grid (step >= dt, segment ends and middles)."""
        dt = max(float(dt), self.duration / max_samples)
        grid = [np.arange(0.0, self.duration, dt)]
        for seg in self.segments:
            grid.append(np.array([seg.t0, seg.t0 + 0.5 * seg.T, seg.t0 + seg.T]))
        return np.unique(np.clip(np.concatenate(grid), 0.0, self.duration))

    def peak_velocity(self, dt: float = 1e-3) -> np.ndarray:
        """Return the (n,) largest |qd| per joint on a dense grid of step dt [s]."""
        if self.duration <= 0.0:
            return np.zeros(self.dof)
        _, qd, _ = self.sample_many(self.check_times(dt))
        return np.max(np.abs(qd), axis=0)


# ---------------------------------------------------------------------------------------------
# Planners
# ---------------------------------------------------------------------------------------------

def _vec(x, n: int, what: str) -> np.ndarray:
    arr = np.asarray(x, dtype=float).reshape(-1)
    if arr.size != n:
        raise InvalidInputError(f'{what} has {arr.size} values, expected {n}')
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(f'{what} contains NaN or inf: {arr.tolist()}')
    return arr


def plan_move(q_start, q_goal, moving_time: float, profile: str = 'trapezoidal',
              accel_time: float = 0.3, v_start=None, max_joint_step: float = 0.0,
              period: float = 0.0) -> Trajectory:
    """
    Return a point-to-point move q_start -> q_goal with one of ``PROFILES``.

    :param moving_time: duration T [s] (> 0); ``linear_max_step`` may lengthen it so that no
        setpoint sampled every ``period`` [s] steps more than ``max_joint_step`` [rad]
    :param accel_time: ramp time of ``trapezoidal`` [s], clipped to [0, T/2]
    :param v_start: (n,) velocity at the start [rad/s] (a preempted move), blended out
    """
    q0 = _vec(q_start, np.asarray(q_start).size, 'q_start')
    q1 = _vec(q_goal, q0.size, 'q_goal')
    if profile not in PROFILES:
        raise InvalidInputError(f"unknown profile '{profile}' (known: {', '.join(PROFILES)})")
    if not (math.isfinite(moving_time) and moving_time > 0.0):
        raise InvalidInputError(f'moving_time must be > 0 s, got {moving_time}')
    if not (math.isfinite(accel_time) and accel_time >= 0.0):
        raise InvalidInputError(f'accel_time must be >= 0 s, got {accel_time}')
    T = float(moving_time)
    if profile == 'linear_max_step':
        if not (max_joint_step > 0.0 and period > 0.0):
            raise InvalidInputError('linear_max_step needs max_joint_step > 0 and period > 0')
        T = linear_max_step_duration(q0, q1, max_joint_step, period, T)
    v0 = None
    if v_start is not None:
        v0 = _vec(v_start, q0.size, 'v_start')
        if not np.any(v0):
            v0 = None
    return Trajectory([ScaledSegment(0.0, T, q0, q1, profile, float(accel_time), v0)])


def pchip_slopes(times, positions) -> np.ndarray:
    """
    Return (k, n) shape-preserving (PCHIP, Fritsch-Carlson) slopes at the interior knots.

    The first and last rows are zero (the caller sets the boundary velocities). Where two
    adjacent secants differ in sign or one is zero the slope is 0, else the weighted harmonic
    mean of the secants, so a cubic Hermite spline through the knots never overshoots them.
    """
    t = np.asarray(times, dtype=float)
    q = np.asarray(positions, dtype=float)
    m = np.zeros_like(q)
    if t.size < 3:
        return m
    h = np.diff(t)[:, None]
    d = np.diff(q, axis=0) / h
    d_prev, d_next = d[:-1], d[1:]
    h_prev, h_next = h[:-1], h[1:]
    w1 = 2.0 * h_next + h_prev
    w2 = h_next + 2.0 * h_prev
    same = (d_prev * d_next) > 0.0
    with np.errstate(divide='ignore', invalid='ignore'):
        mean = (w1 + w2) / (w1 / d_prev + w2 / d_next)
    m[1:-1] = np.where(same, mean, 0.0)
    return m


def plan_waypoints(q_start, times, positions, velocities=None, accelerations=None,
                   v_start=None, interpolation: str = 'spline', max_joint_step: float = 0.0,
                   period: float = 0.0) -> Trajectory:
    """
    Return a trajectory from q_start through waypoints reached at the given times.

    :param times: (k,) strictly increasing times from start [s], the first > 0 (a first point
        at t = 0 is the start itself: drop it before calling)
    :param positions: (k, n) waypoints
    :param velocities: (k, n) velocities at the waypoints, or None: PCHIP slopes inside, 0 at
        the end; accelerations (k, n) or None (with velocities: quintic segments)
    :param v_start: (n,) start velocity [rad/s] (default 0)
    :param interpolation: 'spline' (continuous velocity) or 'linear' (constant velocity per
        segment; each segment lengthened as in ``linear_max_step`` when max_joint_step > 0)
    """
    q0 = _vec(q_start, np.asarray(q_start).size, 'q_start')
    n = q0.size
    t = np.asarray(times, dtype=float).reshape(-1)
    if t.size == 0:
        raise InvalidInputError('no waypoints')
    if not np.all(np.isfinite(t)) or t[0] <= 0.0 or np.any(np.diff(t) <= 0.0):
        raise InvalidInputError(f'waypoint times must be finite, > 0 and strictly increasing: '
                                f'{t.tolist()}')
    q = np.asarray(positions, dtype=float)
    if q.shape != (t.size, n) or not np.all(np.isfinite(q)):
        raise InvalidInputError(f'positions must be finite with shape ({t.size}, {n})')
    knots_t = np.concatenate([[0.0], t])
    knots_q = np.vstack([q0, q])
    v0 = np.zeros(n) if v_start is None else _vec(v_start, n, 'v_start')
    if interpolation == 'linear':
        segs, t0 = [], 0.0
        for i in range(t.size):
            T = knots_t[i + 1] - knots_t[i]
            if max_joint_step > 0.0 and period > 0.0:
                T = linear_max_step_duration(knots_q[i], knots_q[i + 1], max_joint_step,
                                             period, T)
            segs.append(ScaledSegment(t0, T, knots_q[i], knots_q[i + 1], 'linear_max_step',
                                      0.0, v0 if i == 0 and np.any(v0) else None))
            t0 += T
        return Trajectory(segs)
    if interpolation != 'spline':
        raise InvalidInputError(f"unknown interpolation '{interpolation}'")
    if velocities is not None:
        v = np.asarray(velocities, dtype=float)
        if v.shape != q.shape or not np.all(np.isfinite(v)):
            raise InvalidInputError(f'velocities must be finite with shape {q.shape}')
        knots_v = np.vstack([v0, v])
    else:
        knots_v = pchip_slopes(knots_t, knots_q)
        knots_v[0] = v0
        knots_v[-1] = 0.0
    knots_a = None
    if accelerations is not None and velocities is not None:
        a = np.asarray(accelerations, dtype=float)
        if a.shape != q.shape or not np.all(np.isfinite(a)):
            raise InvalidInputError(f'accelerations must be finite with shape {q.shape}')
        knots_a = np.vstack([np.zeros(n), a])
    segs = []
    for i in range(t.size):
        segs.append(HermiteSegment(
            knots_t[i], knots_t[i + 1] - knots_t[i], knots_q[i], knots_q[i + 1],
            knots_v[i], knots_v[i + 1],
            None if knots_a is None else knots_a[i], None if knots_a is None else knots_a[i + 1]))
    return Trajectory(segs)


def plan_stop(q, qd, max_deceleration: float, min_duration: float = 0.0) -> Trajectory:
    """
    Return the trajectory bringing the arm from (q, qd) to rest within a deceleration limit.

    All joints stop together after T = max(min_duration, 2 max|qd| / max_deceleration), each
    with qd(t) = qd (1 - t/T)^2, so no joint decelerates faster than max_deceleration
    [rad/s^2] and none exceeds its starting speed.
    """
    q = _vec(q, np.asarray(q).size, 'q')
    v = _vec(qd, q.size, 'qd')
    if not max_deceleration > 0.0:
        raise InvalidInputError(f'max_deceleration must be > 0, got {max_deceleration}')
    T = max(float(min_duration), 2.0 * float(np.max(np.abs(v), initial=0.0)) / max_deceleration)
    return Trajectory([StopSegment(0.0, T, q, v)])


# ---------------------------------------------------------------------------------------------
# Validation: each returns '' when fine, else the reason in words
# ---------------------------------------------------------------------------------------------

def _first_few(items: list, limit: int = 8) -> list:
    """Return items, or its first ``limit`` and a count (a reason must stay readable)."""
    return items if len(items) <= limit else items[:limit] + [f'... ({len(items)} in all)']


def _names_reason(known_joints: Sequence[str], names: list) -> str:
    """Return why a goal's joint names are invalid (none, duplicates, unknown), or ''."""
    if not names:
        return 'goal has no joint names'
    if len(set(names)) != len(names):
        seen, dup = set(), set()
        for x in names:  # linear: names.count() per name stalled the node on huge input
            (dup if x in seen else seen).add(x)
        return f'duplicate joint names: {_first_few(sorted(dup))}'
    unknown = [x for x in names if x not in known_joints]
    if unknown:
        return f"unknown joint(s) {_first_few(unknown)} (known: {', '.join(known_joints)})"
    return ''


def validate_shape(known_joints: Sequence[str], joint_names: Sequence[str], lengths) -> str:
    """
    Return why a goal is invalid from its names and array lengths alone, or ''.

    Values, times and limits are not checked (:func:`validate_points` checks everything and
    refuses every goal this refuses): this is what can be read before deserializing a goal.

    :param lengths: per point, the counts (positions, velocities, accelerations[, effort])
    """
    names = list(joint_names)
    reason = _names_reason(known_joints, names)
    if reason:
        return reason
    n = len(names)
    for k, sizes in enumerate(lengths):
        if sizes[0] != n:
            return f'point {k}: {sizes[0]} positions for {n} joints'
        for label, size in zip(('velocities', 'accelerations'), sizes[1:3]):
            if size not in (0, n):
                return f'point {k}: {size} {label} for {n} joints'
    return ''


def validate_points(known_joints: Sequence[str], joint_names: Sequence[str], times,
                    positions, velocities=None, accelerations=None, lower=None, upper=None,
                    velocity_limits=None) -> str:
    """
    Return why a joint trajectory goal is invalid, or '' if it is well formed and in limits.

    :param known_joints: the arm's joint names (group order); lower/upper/velocity_limits are
        (n,) in that order, or None to skip those checks
    :param joint_names: the goal's joints (a subset of known_joints, any order)
    :param times: (k,) time_from_start of each point [s]
    :param positions: k sequences of len(joint_names) values; velocities/accelerations: k
        sequences, each empty or of len(joint_names), or None
    """
    names = list(joint_names)
    reason = _names_reason(known_joints, names)
    if reason:
        return reason
    times = [float(x) for x in times]
    if not times:
        return 'goal has no points'
    if len(positions) != len(times):
        return f'{len(times)} times but {len(positions)} position rows'
    idx = [list(known_joints).index(x) for x in names]
    for k, tk in enumerate(times):
        if not math.isfinite(tk):
            return f'point {k}: time_from_start is {tk}'
        if tk < 0.0:
            return f'point {k}: negative time_from_start {tk:g} s'
        if k and tk <= times[k - 1]:
            return (f'point {k}: time_from_start {tk:g} s is not after point {k - 1} '
                    f'({times[k - 1]:g} s): times must be strictly increasing')
        row = positions[k]   # lengths are checked before any value is read: huge rows are cheap
        if len(row) != len(names):
            return f'point {k}: {len(row)} positions for {len(names)} joints'
        for label, rows in (('velocities', velocities), ('accelerations', accelerations)):
            if rows is not None and k < len(rows) and len(rows[k]) not in (0, len(names)):
                return f'point {k}: {len(rows[k])} {label} for {len(names)} joints'
            if rows is not None and k < len(rows):
                bad = [names[j] for j, x in enumerate(rows[k]) if not math.isfinite(float(x))]
                if bad:
                    return f'point {k}: {label} of {bad} are NaN or inf'
        bad = [names[j] for j, x in enumerate(row) if not math.isfinite(float(x))]
        if bad:
            return f'point {k}: position of {bad} is NaN or inf'
        if lower is not None and upper is not None:
            for j, x in enumerate(row):
                lo, hi = float(lower[idx[j]]), float(upper[idx[j]])
                if not lo - POSITION_LIMIT_SLACK <= float(x) <= hi + POSITION_LIMIT_SLACK:
                    return (f"point {k}: joint '{names[j]}' = {float(x):.6g} rad is outside its "
                            f'limits [{lo:.6g}, {hi:.6g}]')
        if velocity_limits is not None and velocities is not None and k < len(velocities):
            for j, x in enumerate(velocities[k]):
                lim = float(velocity_limits[idx[j]])
                if abs(float(x)) > lim * (1.0 + VELOCITY_LIMIT_SLACK):
                    return (f"point {k}: joint '{names[j]}' velocity {float(x):.6g} rad/s is "
                            f'above its limit {lim:.6g} rad/s')
    return ''


def shortest_move_time(q_start, q_goal, velocity_limits, accel_time: float, v_start=None,
                       at_least: float = 0.0, growth: float = 1.05) -> float:
    """
    Return the shortest duration [s] of a move that keeps within ``velocity_limits`` [rad/s].

    The first duration from ``at_least`` up, in steps of ``growth``, whose :func:`plan_move`
    (trapezoidal, ``accel_time`` [s], ``v_start`` [rad/s] blended in) passes
    :func:`check_trajectory`'s velocity check. A move planned while the arm moves carries its
    present velocity into its first part: a duration from the travel alone can be too short.
    """
    q0, q1 = np.asarray(q_start, dtype=float), np.asarray(q_goal, dtype=float)
    lim = np.asarray(velocity_limits, dtype=float)
    names = [str(i) for i in range(q0.size)]
    T = max(float(at_least), 1e-3)
    for _ in range(64):             # up to about 23 x at_least
        traj = plan_move(q0, q1, T, 'trapezoidal', accel_time, v_start=v_start)
        if not check_trajectory(traj, names, velocity_limits=lim):
            return T
        T *= growth
    raise InvalidInputError(f'no move of at most {T:.3g} s keeps within the velocity limits '
                            f'(accel_time {accel_time:g} s, v_start {v_start})')


def check_trajectory(traj: Trajectory, joint_names: Sequence[str], lower=None, upper=None,
                     velocity_limits=None, dt: float = 1e-3) -> str:
    """
    Return why a planned trajectory breaks the limits along the way, or '' when it does not.

    Sampled every dt [s] (and at every segment's ends and middle): positions within
    [lower, upper] and |velocity| within velocity_limits (each (n,) or None to skip).
    """
    if traj.duration <= 0.0:
        return ''
    q, qd, _ = traj.sample_many(traj.check_times(dt))
    if velocity_limits is not None:
        peak = np.max(np.abs(qd), axis=0)
        lim = np.asarray(velocity_limits, dtype=float)
        over = np.nonzero(peak > lim * (1.0 + VELOCITY_LIMIT_SLACK))[0]
        if over.size:
            j = int(over[np.argmax(peak[over] / lim[over])])
            return (f"joint '{joint_names[j]}' would move at {peak[j]:.4g} rad/s, above its "
                    f'velocity limit {lim[j]:.4g} rad/s (take more time)')
    if lower is not None and upper is not None:
        lo = np.asarray(lower, dtype=float) - POSITION_LIMIT_SLACK
        hi = np.asarray(upper, dtype=float) + POSITION_LIMIT_SLACK
        bad = np.nonzero(np.any(q < lo, axis=0) | np.any(q > hi, axis=0))[0]
        if bad.size:
            j = int(bad[0])
            return (f"joint '{joint_names[j]}' would leave its limits [{lower[j]:.6g}, "
                    f'{upper[j]:.6g}] between the waypoints (reaching {q[:, j].min():.6g} .. '
                    f'{q[:, j].max():.6g})')
    return ''
