"""
Goal executor: the trajectory server's engine (plan, sample, hold/resume, verdicts, watchdog).

No ROS here: ``ros/trajectory_server_node.py`` turns messages into ``GoalRequest`` and
measurements, calls this engine with the time, and publishes what it returns. Two clocks are
arguments of every call: ``now_ns`` the goal clock (the node clock; sim time when the node uses
it) and ``steady_ns`` (state freshness and the watchdog, so a stopped sim clock cannot hide a
dead driver). Units: rad, rad/s, s (ns for clock readings).

Goal semantics (docs/ros_interfaces.md states them for clients):

- A goal names a subset of the arm's joints in any order; the others hold where they are.
- **One point** = a move from where the arm is (the setpoint being sent when a goal runs, else
  the measured position) with ``settings.profile``; its duration is the point's time when > 0,
  else ``moving_time``; ``trapezoidal`` ramps take ``accel_time`` (clipped to duration/2);
  ``linear_max_step`` lengthens the move so that no setpoint step exceeds ``max_joint_step``
  and advances one step per setpoint sent (a late tick never makes a bigger step).
- **Several points** = waypoints reached at their times with continuous velocity (cubic Hermite;
  the given velocities, else shape-preserving slopes, zero at the end; quintic when velocities
  and accelerations are given); ``linear_max_step`` joins them linearly. A first point at t = 0
  is the start: it must lie within ``start_tolerance`` of the current position.
- Invalid goals (unknown joint, NaN, out of limits, times not increasing, too fast, no
  measurement yet, measurements older than ``state_timeout`` with no goal running) raise
  ``InvalidInputError`` from ``start`` and change nothing.
- A running goal is preempted by a new one (CANCELED; the new move starts from the current
  setpoint and velocity). ``cancel`` decelerates it to rest (``stop_deceleration``), then
  CANCELED.
- ``tick``: while measurements are older than ``hold_after`` the goal pauses (nothing sent, its
  clock stopped) and resumes where it paused. Ticks further apart than ``hold_after`` (the
  caller was not scheduled: no setpoint went out, the arm held the last one) pause it the same
  way: it goes on from where it was instead of jumping ahead. During the trajectory, a joint
  farther than ``path_tolerance`` from the setpoints of the ``path_window`` before its
  measurement's stamp ABORTs it (the arm is then held where measured; a joint measured outside
  its limits at its last setpoint). After the trajectory: SUCCEEDED once every joint is within
  ``goal_tolerance`` of the end, ABORTED after ``goal_time_tolerance`` more.
- ``watchdog``: no measurement for ``state_timeout`` on two consecutive checks ABORTs the goal.
"""
from dataclasses import dataclass, field
import math
from typing import Any, List, Optional, Sequence, Tuple

import numpy as np

from px100_control.control import trajectory as tj
from px100_control.errors import InvalidInputError
from px100_control.parameters import bound_error, TRAJECTORY_SERVER

SUCCEEDED, CANCELED, ABORTED = 'SUCCEEDED', 'CANCELED', 'ABORTED'
#: pauses of a goal kept to place late measurements on its time (older ones are long past)
MAX_PAUSES = 8
#: the shortest hold_after [s] (the schema's bound): a goal pauses while measurements are
#: older, so it must exceed the driver's publish period (20 Hz here; sim_driver publishes at
#: 100 Hz)
MIN_HOLD_AFTER = TRAJECTORY_SERVER['hold_after'].low


@dataclass
class Settings:
    """The engine's parameters (the node's ROS parameters of the same names; units in SI)."""

    rate: float                 # setpoint rate [Hz]
    profile: str                # one-point move profile (trajectory.PROFILES)
    moving_time: float          # [s]
    accel_time: float           # [s]
    max_joint_step: float       # [rad]
    state_timeout: float        # [s]
    hold_after: float           # [s]
    path_tolerance: float       # [rad]
    path_window: float          # [s]
    goal_tolerance: float       # [rad]
    goal_time_tolerance: float  # [s]
    stop_deceleration: float    # [rad/s^2]
    start_tolerance: float      # [rad]


@dataclass
class GoalRequest:
    """
    A goal without messages: its id, the joints it names, and per point its time [s] and values.

    ``velocities`` / ``accelerations``: one sequence per point, empty when not given.
    """

    key: Any
    label: str
    names: Sequence[str]
    times: Sequence[float]
    positions: Sequence[Sequence[float]]
    velocities: Sequence[Sequence[float]]
    accelerations: Sequence[Sequence[float]]
    #: per-joint overrides {joint: rad} (FollowJointTrajectory semantics: 0 = the server's
    #: default, < 0 = not checked); None = the settings' for every joint
    path_tolerance: Optional[dict] = None
    goal_tolerance: Optional[dict] = None
    goal_time_tolerance: Optional[float] = None    # [s]; None or 0 = the settings'


@dataclass
class Goal:
    """A goal being executed; ``tag`` is the caller's (e.g. its status message)."""

    key: Any
    label: str
    traj: tj.Trajectory
    t_start: int                          # goal clock [ns] of t = 0
    info: dict
    tag: Any = None
    phase: str = 'executing'              # executing | canceling
    stepped: bool = False                 # linear_max_step: one period per setpoint sent
    ticks: int = 0
    hold_since: Optional[int] = None      # goal clock [ns] when it paused
    last_tick_ns: Optional[int] = None    # goal clock [ns] of the last tick that ran it
    pauses: list = field(default_factory=list)   # the last pauses: (from, to) [ns] goal clock
    last_q: Optional[np.ndarray] = None
    last_qd: Optional[np.ndarray] = None
    path_tol: Optional[np.ndarray] = None    # (n,) [rad], inf = not checked; None = settings'
    goal_tol: Optional[np.ndarray] = None
    goal_time_tol: Optional[float] = None    # [s]; None = settings'


#: why a goal ABORTED, for callers that report codes (FollowJointTrajectory's error_code)
PATH_TOLERANCE, GOAL_TOLERANCE = 'PATH_TOLERANCE', 'GOAL_TOLERANCE'


@dataclass
class Outcome:
    """What a call decided: setpoints to send (in order), a finished goal, log lines."""

    sends: List[Tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    finished: Optional[Tuple[Goal, str, str]] = None      # (goal, status, reason)
    notes: List[Tuple[str, str]] = field(default_factory=list)   # (level, text)
    code: str = ''       # PATH_TOLERANCE | GOAL_TOLERANCE for such aborts, else ''


class GoalExecutor:
    """Execute one goal at a time for an arm with the given joints and limits."""

    def __init__(self, names: Sequence[str], lower, upper, velocity_limits,
                 settings: Settings):
        """Set up for arm joints ``names`` with position limits and velocity limits [rad/s]."""
        self.names = list(names)
        self.n = len(self.names)
        self.index = {name: i for i, name in enumerate(self.names)}
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        self.velocity_limits = np.asarray(velocity_limits, dtype=float)
        self.settings = settings
        self.meas = np.full(self.n, np.nan)
        self.meas_steady_ns: Optional[int] = None   # when the last state was taken
        self.meas_stamp_ns = 0                      # its stamp (goal clock)
        self.active: Optional[Goal] = None
        self._stale_checks = 0

    # ------------------------------------------------------------------ inputs
    def measure(self, values, steady_ns: int, stamp_ns: int) -> bool:
        """
        Take a measurement: (joint index, position) pairs; False (ignored) if one is not finite.

        ``steady_ns``: when it was taken on the steady clock (a caller that read it late
        subtracts the queueing delay); ``stamp_ns``: its stamp on the goal clock.
        """
        values = list(values)
        if not all(math.isfinite(v) for _, v in values):
            return False
        for j, v in values:
            self.meas[j] = v
        self.meas_steady_ns = max(self.meas_steady_ns or 0, steady_ns)
        self.meas_stamp_ns = stamp_ns
        return True

    def has_state(self) -> bool:
        """Return True once every joint has been measured (a goal can then be planned)."""
        return not bool(np.isnan(self.meas).any())

    def state_age(self, steady_ns: int) -> float:
        """Return seconds since the last measurement was taken (inf before any)."""
        if self.meas_steady_ns is None:
            return math.inf
        return (steady_ns - self.meas_steady_ns) * 1e-9

    def is_running(self, key) -> bool:
        """Return True when the goal ``key`` is the one executing."""
        return self.active is not None and self.active.key == key

    # ------------------------------------------------------------------ goals
    def start(self, req: GoalRequest, now_ns: int, steady_ns: int,
              tag=None) -> Tuple[Goal, Optional[Goal]]:
        """
        Plan and start a goal; return (goal, the preempted goal or None).

        :raises InvalidInputError: the goal is invalid (nothing changes)
        """
        s = self.settings
        path_tol = self.tolerances('path_tolerance', s.path_tolerance, req.path_tolerance)
        goal_tol = self.tolerances('goal_tolerance', s.goal_tolerance, req.goal_tolerance)
        time_tol = req.goal_time_tolerance
        if time_tol is not None and not (math.isfinite(time_tol) and time_tol >= 0.0):
            raise InvalidInputError(f'goal_time_tolerance must be a finite duration >= 0 s, '
                                    f'got {time_tol!r}')
        traj, info = self.plan(req, steady_ns)
        old, self.active = self.active, None
        goal = Goal(key=req.key, label=req.label, traj=traj, t_start=now_ns, info=info,
                    tag=tag, stepped=s.profile == 'linear_max_step', path_tol=path_tol,
                    goal_tol=goal_tol, goal_time_tol=time_tol or None)
        self.active = goal
        return goal, old

    def tolerances(self, what: str, default: float, given: Optional[dict]):
        """
        Return (n,) per-joint tolerances [rad] from ``default`` and overrides {joint: value}.

        An override of 0 keeps the default, a negative one means "not checked" (inf).
        :raises InvalidInputError: an unknown joint or a value that is not a number
        """
        tol = np.full(self.n, float(default))
        for name, value in (given or {}).items():
            if name not in self.index:
                raise InvalidInputError(f"{what} names joint '{name}', which is not one of "
                                        f'{self.names}')
            if not math.isfinite(value):
                raise InvalidInputError(f"{what} of joint '{name}' is {value!r}")
            if value != 0.0:
                tol[self.index[name]] = value if value > 0.0 else math.inf
        return tol

    def plan(self, req: GoalRequest, steady_ns: int):
        """Validate a goal and plan it from the current state: (Trajectory, info)."""
        s = self.settings
        times, positions = list(req.times), list(req.positions)
        vels, accs = list(req.velocities), list(req.accelerations)
        reason = tj.validate_points(self.names, list(req.names), times, positions, vels, accs,
                                    self.lower, self.upper, self.velocity_limits)
        if reason:
            raise InvalidInputError(reason)
        self._check_start_state(steady_ns)
        if self.active is not None:
            q0, v0 = self.current_setpoint(self.active)
        else:
            q0, v0 = self.meas.copy(), np.zeros(self.n)
        idx = [self.index[x] for x in req.names]
        period = 1.0 / s.rate
        if len(positions) == 1:
            traj, info = self._plan_move(q0, v0, idx, times[0], positions[0], period)
        else:
            traj, info = self._plan_waypoints(q0, v0, idx, times, positions, vels, accs,
                                              period)
        reason = tj.check_trajectory(traj, self.names, self.lower, self.upper,
                                     self.velocity_limits, dt=min(period, 1e-3))
        if reason:
            raise InvalidInputError(reason)
        return traj, info

    def _check_start_state(self, steady_ns: int) -> None:
        if np.any(np.isnan(self.meas)):
            missing = [n for n, v in zip(self.names, self.meas) if math.isnan(v)]
            raise InvalidInputError(f'no joint_states from the driver yet (for {missing}): '
                                    'the start of the move is unknown')
        age = self.state_age(steady_ns)
        if self.active is None and age > self.settings.state_timeout:
            # e.g. the driver died: its last state is not where a restarted driver is
            raise InvalidInputError(
                f'the last joint_states are {age:.3g} s old (state_timeout '
                f'{self.settings.state_timeout} s): is sim_driver running? The start of the '
                'move is unknown')

    def _plan_move(self, q0, v0, idx, time, position, period):
        s = self.settings
        q1 = q0.copy()
        q1[idx] = position
        T = time if time > 0.0 else s.moving_time
        traj = tj.plan_move(q0, q1, T, s.profile, s.accel_time, v_start=v0,
                            max_joint_step=s.max_joint_step, period=period)
        info = {'kind': f'one-point {s.profile} move (moving_time {T:g} s'
                        + (f', accel_time {min(s.accel_time, T / 2):g} s)'
                           if s.profile == 'trapezoidal' else ')')}
        return traj, info

    def _plan_waypoints(self, q0, v0, idx, times, positions, vels, accs, period):
        s = self.settings
        if times[0] <= 0.0:
            gap = float(np.max(np.abs(np.asarray(positions[0]) - q0[idx])))
            if gap > s.start_tolerance:
                raise InvalidInputError(
                    f'point 0 at t=0 is {gap:.4g} rad from the current position '
                    f'(start_tolerance {s.start_tolerance} rad)')
            times, positions, vels, accs = times[1:], positions[1:], vels[1:], accs[1:]
        full = np.tile(q0, (len(times), 1))
        full[:, idx] = np.asarray(positions, dtype=float)
        given_v = all(len(v) == len(idx) for v in vels)
        given_a = given_v and all(len(a) == len(idx) for a in accs)
        vfull = afull = None
        if given_v:
            vfull = np.zeros_like(full)
            vfull[:, idx] = np.asarray(vels, dtype=float)
        if given_a:
            afull = np.zeros_like(full)
            afull[:, idx] = np.asarray(accs, dtype=float)
        linear = s.profile == 'linear_max_step'
        traj = tj.plan_waypoints(q0, times, full, vfull, afull, v_start=v0,
                                 interpolation='linear' if linear else 'spline',
                                 max_joint_step=s.max_joint_step if linear else 0.0,
                                 period=period)
        return traj, {'kind': f'{len(times)}-waypoint {"linear" if linear else "spline"} '
                              'trajectory'}

    def current_setpoint(self, goal: Goal):
        """Return (q, qd) of the last setpoint sent for a goal (where the driver is headed)."""
        if goal.last_q is not None:
            return goal.last_q.copy(), goal.last_qd.copy()
        q, qd, _ = goal.traj.sample(0.0)
        return q, qd

    def cancel(self, now_ns: int) -> Optional[Goal]:
        """Start decelerating the running goal to rest; return it (None when there is none)."""
        g = self.active
        if g is None or g.phase == 'canceling':
            return g
        q, qd = self.current_setpoint(g)
        g.traj = tj.plan_stop(q, qd, self.settings.stop_deceleration)
        g.t_start = now_ns
        g.last_tick_ns = None
        g.phase = 'canceling'
        return g

    # ------------------------------------------------------------------ execution
    def tick(self, now_ns: int, steady_ns: int) -> Outcome:
        """Advance the running goal to ``now_ns``: the setpoint to send and any verdict."""
        out = Outcome()
        g = self.active
        if g is None:
            return out
        # a stall first: the states it left unread then pause the goal from its end on
        self._skip_stall(g, now_ns, out)
        if not self._hold_for_state(g, now_ns, steady_ns, out):
            return out
        t = (now_ns - g.t_start) * 1e-9
        if g.stepped and g.phase == 'executing':
            # one step per setpoint, however late the tick (never a bigger step)
            t = g.ticks / self.settings.rate
            g.ticks += 1
        q, qd, _ = g.traj.sample(t)
        g.last_q, g.last_qd = q, qd
        out.sends.append((q, qd))
        if g.phase == 'canceling':
            if t >= g.traj.duration:
                self._finish(out, CANCELED, 'canceled: at rest at ' + fmt(q))
        elif t < g.traj.duration:
            self._check_tracking(g, t, q, now_ns, out)
        else:
            self._check_settled(g, t, q, out)
        return out

    def _check_tracking(self, g: Goal, t: float, q, now_ns: int, out: Outcome) -> None:
        err = self.tracking_error(g, t, now_ns)
        tols = g.path_tol if g.path_tol is not None else np.full(self.n,
                                                                 self.settings.path_tolerance)
        j = int(np.argmax(err - tols))
        tol = tols[j]
        if err[j] > tol:
            out.sends.append(self._hold_measured(g, out))
            lag = (now_ns - self.meas_stamp_ns) * 1e-9
            out.code = PATH_TOLERANCE
            self._finish(out, ABORTED,
                         f"tracking error of joint '{self.names[j]}' is {err[j]:.4g} rad "
                         f'(path_tolerance {tol:g} rad) at t = {t:.3f} s: measured '
                         f'{self.meas[j]:.4f} rad ({lag:.3f} s before), setpoint '
                         f'{q[j]:.4f} rad; joint blocked or driver not following')

    def _check_settled(self, g: Goal, t: float, q, out: Outcome) -> None:
        err = np.abs(self.meas - q)
        tols = g.goal_tol if g.goal_tol is not None else np.full(self.n,
                                                                 self.settings.goal_tolerance)
        j = int(np.argmax(err - tols))
        time_tol = g.goal_time_tol or self.settings.goal_time_tolerance
        if err[j] <= tols[j]:
            self._finish(out, SUCCEEDED,
                         f'reached within {float(np.max(err)):.2g} rad at t = {t:.3f} s '
                         f'(trajectory {g.traj.duration:.3f} s)')
        elif t > g.traj.duration + time_tol:
            out.code = GOAL_TOLERANCE
            self._finish(out, ABORTED,
                         f"joint '{self.names[j]}' did not settle: error {err[j]:.4g} rad "
                         f'> goal_tolerance {tols[j]:g} rad, {t - g.traj.duration:.2f} s after '
                         'the trajectory ended')

    def _finish(self, out: Outcome, status: str, reason: str) -> None:
        out.finished = (self.active, status, reason)
        self.active = None

    def _skip_stall(self, g: Goal, now_ns: int, out: Outcome) -> None:
        """
        Pause the goal's clock over a gap between ticks longer than hold_after.

        The caller was not scheduled (a starved process): no setpoint went out and the driver
        held the last one, so the trajectory goes on from there rather than from where the gap
        would put it (a jump, and a tracking error against setpoints never sent). Measurements
        stamped during the gap are placed before it on the goal's time (``pauses``).
        """
        last, g.last_tick_ns = g.last_tick_ns, now_ns
        if last is None or g.hold_since is not None or (g.stepped and g.phase == 'executing'):
            return           # a first tick, paused already, or one step per tick already
        gap = now_ns - last
        if gap * 1e-9 <= self.settings.hold_after:
            return
        _pause(g, last + int(round(1e9 / self.settings.rate)), now_ns)
        out.notes.append(('warning', f'goal {g.label}: no tick for {gap * 1e-9:.2f} s (this node '
                                     'was not scheduled): the trajectory goes on from where it '
                                     'was'))

    def _hold_for_state(self, goal: Goal, now_ns: int, steady_ns: int, out: Outcome) -> bool:
        """
        Return False (send nothing) while measurements are older than hold_after.

        A silent driver gets no setpoints (it cannot use them; a publisher pushing into a dead
        peer's shared-memory port can block for a second in Fast DDS). The goal's clock stops
        meanwhile: when states return it resumes where it paused; the watchdog aborts it after
        state_timeout.
        """
        age = self.state_age(steady_ns)
        hold_after = self.settings.hold_after
        if age > hold_after:
            if goal.hold_since is None:
                goal.hold_since = now_ns
                out.notes.append(('warning', f'goal {goal.label} paused: no joint_states for '
                                             f'{age:.2f} s (hold_after {hold_after} s), no '
                                             'setpoints until they return'))
            return False
        if goal.hold_since is not None:
            held = now_ns - goal.hold_since
            _pause(goal, goal.hold_since, now_ns)
            goal.hold_since = None
            goal.last_tick_ns = now_ns      # the pause is counted: not a gap between ticks too
            out.notes.append(('info', f'goal {goal.label} resumed after a {held * 1e-9:.2f} s '
                                      'pause'))
        return True

    def tracking_error(self, goal: Goal, t: float, now_ns: int) -> np.ndarray:
        """
        Return (n,) how far each measured joint lies outside its setpoints [rad].

        The measurement is compared with the setpoints of the ``path_window`` seconds before it
        was taken (its stamp: transport and scheduling delays are not errors); being anywhere
        within the span of those setpoints (the driver lagging) is no error. The goal's clock
        stood still while it paused: a measurement taken before a pause (a sample the driver
        stamped then, read after the goal resumed) is placed before the pause on the goal's time.
        """
        w = self.settings.path_window
        stamp = self.meas_stamp_ns
        paused_ns = sum(max(0, min(end, now_ns) - max(begin, stamp))
                        for begin, end in goal.pauses)
        lag_ns = max(0, now_ns - stamp) - paused_ns
        t_meas = t - max(0.0, lag_ns * 1e-9)
        q_a = goal.traj.sample(t_meas - w)[0]
        q_b = goal.traj.sample(t_meas - 0.5 * w)[0]
        q_c = goal.traj.sample(t_meas)[0]
        lo = np.minimum(np.minimum(q_a, q_b), q_c)
        hi = np.maximum(np.maximum(q_a, q_b), q_c)
        return np.maximum(np.maximum(self.meas - hi, lo - self.meas), 0.0)

    def _hold_measured(self, goal: Goal, out: Outcome):
        """
        Return the setpoint that holds the arm where measured, at rest.

        A joint measured outside its limits (a faulty or lying measurement) holds the goal's
        last setpoint instead: never an out-of-limit setpoint, nor a jump to the limit.
        """
        last = goal.last_q if goal.last_q is not None else goal.traj.sample(0.0)[0]
        q = self.meas
        ok = np.isfinite(q) & (q >= self.lower) & (q <= self.upper)
        if not ok.all():
            out.notes.append(('warning', 'holding the last setpoint of joint(s) '
                                         f'{[n for n, good in zip(self.names, ok) if not good]}'
                                         f': measured outside the limits ({fmt(q)})'))
        return np.where(ok, q, last), np.zeros(self.n)

    def watchdog(self, steady_ns: int, stall_ns: Optional[int] = None,
                 stall_words: str = '') -> Outcome:
        """
        Abort the running goal when no measurement came for state_timeout (steady clock).

        A stale state must be seen on two consecutive checks, so that measurements still queued
        behind the check after a scheduling stall are taken first. ``stall_ns``: when the
        caller last noticed that it was not scheduled (``stall_words`` says how): an abort
        after it says it was noticed late.
        """
        out = Outcome()
        age = self.state_age(steady_ns)
        if self.active is None or age <= self.settings.state_timeout:
            self._stale_checks = 0
            return out
        self._stale_checks += 1
        if self._stale_checks < 2:
            return out
        self._stale_checks = 0
        reason = (f'driver not publishing joint_states (none for {age:.2f} s, state_timeout '
                  f'{self.settings.state_timeout} s)')
        if stall_ns is not None and stall_ns >= (self.meas_steady_ns or 0):
            reason += f'; noticed late: this node was {stall_words}'
        self._finish(out, ABORTED, reason)
        return out


def _pause(goal: Goal, begin_ns: int, end_ns: int) -> None:
    """Stop the goal's clock from begin_ns to end_ns (goal clock [ns]) and keep the pause."""
    goal.t_start += end_ns - begin_ns
    goal.pauses = goal.pauses[-(MAX_PAUSES - 1):] + [(begin_ns, end_ns)]


def settings_error(name: str, v) -> str:
    """
    Return why a value of setting ``name`` is refused ('' when it is valid).

    Ranges are the schema's (:data:`px100_control.parameters.TRAJECTORY_SERVER`).
    """
    if name == 'profile' and v not in tj.PROFILES:
        return f"profile must be one of {', '.join(tj.PROFILES)}, got '{v}'"
    error = bound_error(TRAJECTORY_SERVER, name, v)
    if error and name == 'hold_after':
        # shorter than the gap between two samples: every goal would stay paused
        return (f"hold_after must be >= {MIN_HOLD_AFTER} s (longer than the driver's publish "
                f'period), got {v!r}')
    return error or ''


def fmt(q) -> str:
    """Return joint values as '[a, b, ...]' with 4 decimals."""
    return '[' + ', '.join(f'{x:.4f}' for x in q) + ']'
