"""
trajectory_server: action-style joint trajectory execution over standard messages.

Topics and services are those of docs/ros_interfaces.md, relative to
``/<robot_name>``; the math lives in :mod:`px100_control.control.trajectory`.

Goal semantics (what a client relies on):

- A goal is a trajectory_msgs/JointTrajectory on ``trajectory/goal``; ``header.stamp`` is its id
  (``'sec.nanosec'``; the GoalStatus UUID is ``stamp_uuid(stamp)``). ``joint_names`` is a subset
  of the arm's joints in any order; arm joints not named hold where they are.
- **One point** = a move from where the arm is (the setpoint being sent when a goal runs, else the
  measured position) with the ``profile`` parameter. Its duration (Interbotix ``moving_time``)
  is the point's ``time_from_start`` when > 0, else the ``moving_time`` parameter;
  ``trapezoidal`` ramps take the ``accel_time`` parameter (clipped to duration/2);
  ``linear_max_step`` lengthens the move if a setpoint step would exceed ``max_joint_step``
  and advances one step per setpoint sent (a late setpoint never makes a bigger step).
  ``profile``, ``moving_time`` and ``accel_time`` are read when a goal arrives, so a client
  selects them per move with a SetParameters call answered before it publishes the goal
  (sticky, like Interbotix ``set_trajectory_time``).
- **Several points** = waypoints reached at their ``time_from_start`` with continuous velocity
  (cubic Hermite; the given ``velocities``, else shape-preserving slopes, zero at the end;
  quintic when velocities and accelerations are given). With ``profile: linear_max_step`` they
  are joined linearly instead. A first point at t = 0 is the start: it must lie within
  ``start_tolerance`` of the current position.
- Status on ``trajectory/status`` (transient local, the last ``status_history`` goals) on every
  transition: a valid goal goes ACCEPTED then EXECUTING; it ends SUCCEEDED once its time has
  elapsed and every measured arm joint is within ``goal_tolerance`` of the end (ABORTED if that
  takes longer than ``goal_time_tolerance``); ``trajectory/cancel`` makes it CANCELING while the
  arm decelerates to rest (``stop_deceleration``) where it is, then CANCELED; a new goal
  preempts it (CANCELED at once, the new move starting from the current setpoint and velocity).
  An invalid goal (unknown joint, NaN, out of limits, times not increasing, too fast, or no
  ``joint_states`` received yet) is ABORTED at once and nothing of it is sent; it does not
  disturb a running goal. While ``joint_states`` are older than ``hold_after`` a goal pauses: no
  setpoints are sent and its clock stops, so it resumes where it paused when they return. A
  stall is ABORTED: no ``joint_states`` for ``state_timeout`` (steady clock, so also when a sim
  clock stops; a state read late because this node stalled counts from its stamp, and an
  abort noticed late says so), or a joint farther than ``path_tolerance`` from the
  setpoints of the ``path_window`` before its measurement's stamp (the reason names the joint,
  the measured value and the setpoint; the arm is then held where it was measured, a joint
  measured outside its limits at its last setpoint). ``joint_states`` with a non-finite arm
  position are ignored (logged).
  Re-sending the running goal's id is ignored (reported on /diagnostics); an id that has ended
  may be reused. Names and array lengths are checked on the serialized goal before it is
  deserialized (a goal of 800 MB of wrongly sized arrays is refused in tens of ms); bytes that
  are not a JointTrajectory are logged and dropped.
- Every terminal status is published on ``/diagnostics`` (DiagnosticArray): name
  ``<robot_name>/trajectory_server``, ``hardware_id`` = the goal id, ``message`` = the reason,
  level OK (SUCCEEDED), WARN (CANCELED) or ERROR (ABORTED); it is logged too.
- While a goal runs (until its terminal status) and is not paused, setpoints (all arm joints,
  position and velocity feed-forward, stamped with their sample time) go to
  ``commands/joint_setpoints`` at ``rate`` and, identical, to ``trajectory/feedback``. Timing
  follows the node clock (``use_sim_time`` honoured).
"""
from collections import OrderedDict
from dataclasses import dataclass, field
import math
import threading
import time
from typing import Optional

from action_msgs.msg import GoalInfo, GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
import numpy as np
from px100_control.control import trajectory as tj
from px100_control.errors import InvalidInputError
from px100_control.ros import cdr
from px100_control.ros.common import declare_robot_parameters, robot_name, robot_topic, spin_node
from px100_control.ros.conversions import seconds, stamp_id, stamp_key, stamp_uuid
from px100_control.tools.latency import QueueDelay
from px100_control.tools.stall import StallMeter
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, qos_profile_sensor_data, QoSProfile,
                       ReliabilityPolicy)
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

NODE_NAME = 'trajectory_server'
STATUS_NAMES = {GoalStatus.STATUS_ACCEPTED: 'ACCEPTED', GoalStatus.STATUS_EXECUTING: 'EXECUTING',
                GoalStatus.STATUS_CANCELING: 'CANCELING',
                GoalStatus.STATUS_SUCCEEDED: 'SUCCEEDED',
                GoalStatus.STATUS_CANCELED: 'CANCELED', GoalStatus.STATUS_ABORTED: 'ABORTED'}
TERMINAL = (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_CANCELED, GoalStatus.STATUS_ABORTED)
DIAG_LEVEL = {GoalStatus.STATUS_SUCCEEDED: DiagnosticStatus.OK,
              GoalStatus.STATUS_CANCELED: DiagnosticStatus.WARN,
              GoalStatus.STATUS_ABORTED: DiagnosticStatus.ERROR}

#: trajectory/status: transient local like common.LATCHED_QOS, deeper so that live readers see
#: every transition (ACCEPTED and EXECUTING are published back to back)
STATUS_QOS = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                        reliability=ReliabilityPolicy.RELIABLE)

#: the stale-state watchdog's period [s]; a watchdog check this much later than the previous one
#: means the node was not scheduled (logged with what ran longest meanwhile)
WATCHDOG_PERIOD = 0.02
STALL_WARN = 0.25
#: the shortest hold_after [s]: a goal pauses while joint_states are older, so it must exceed
#: the driver's publish period (20 Hz here; sim_driver publishes at 100 Hz)
MIN_HOLD_AFTER = 0.05

#: parameter -> (default, description); defaults mirror config/px100.yaml
PARAMETERS = {
    'rate': (200.0, 'setpoint rate [Hz] (read at start)'),
    'profile': ('trapezoidal', 'one-point move profile: ' + ', '.join(tj.PROFILES)),
    'moving_time': (2.0, 'duration of a one-point goal whose time_from_start is 0 [s]'),
    'accel_time': (0.3, 'trapezoidal ramp time [s], clipped to moving_time/2'),
    'max_joint_step': (0.01, 'linear_max_step: largest joint step between setpoints [rad]'),
    'state_timeout': (1.0, 'abort a goal when joint_states stop for this long [s]'),
    'hold_after': (0.25, 'pause a goal (no setpoints, its clock stopped) while joint_states '
                         'are older than this [s]; it resumes where it paused. At least '
                         "0.05 s and longer than the driver's publish period"),
    'path_tolerance': (0.2, 'abort when a joint is this far from its setpoints [rad]'),
    'path_window': (0.2, 'a measurement may lag its setpoints by this much [s]'),
    'goal_tolerance': (0.002, 'success when every joint is this close to the end [rad]'),
    'goal_time_tolerance': (1.0, 'time allowed after the trajectory to settle [s]'),
    'stop_deceleration': (10.0, 'deceleration of a canceled goal [rad/s^2]'),
    'start_tolerance': (0.05, 'a first point at t=0 must be this close to the start [rad]'),
    'status_history': (50, 'number of recent goals kept in trajectory/status'),
}


@dataclass
class _Goal:
    """A goal being executed (node-side bookkeeping)."""

    key: tuple
    status: GoalStatus
    traj: tj.Trajectory
    t_start: int  # node-clock ns
    phase: str = 'executing'  # executing | canceling
    stepped: bool = False  # linear_max_step: advance one period per setpoint sent
    ticks: int = 0
    hold_since: Optional[int] = None  # node-clock ns when the goal paused for stale joint_states
    last_q: Optional[np.ndarray] = None
    last_qd: Optional[np.ndarray] = None
    info: dict = field(default_factory=dict)


class TrajectoryServerNode(Node):
    """Execute joint trajectories action-style: goal topic, status, cancel service, setpoints."""

    def __init__(self, **node_kwargs):
        super().__init__(NODE_NAME, **node_kwargs)
        self.model = declare_robot_parameters(self)
        for name, (default, description) in PARAMETERS.items():
            self.declare_parameter(name, default)
        self.add_on_set_parameters_callback(self._check_parameters)
        bad = self._check_parameters(
            [self.get_parameter(name) for name in PARAMETERS]).reason
        if bad:
            raise InvalidInputError(f'trajectory_server parameters: {bad}')
        self._n = self.model.dof
        self._names = list(self.model.joint_names)
        self._index = {name: i for i, name in enumerate(self._names)}
        self._lock = threading.RLock()
        self._rate = float(self.get_parameter('rate').value)
        self._diag_name = f'{robot_name(self) or "px100"}/{NODE_NAME}'
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        # measured state (arm joints in group order) and when it arrived (steady ns)
        self._meas = np.full(self._n, np.nan)
        self._meas_steady_ns: Optional[int] = None
        self._meas_stamp_ns = 0  # header stamp of the measurement (node clock domain)
        # a joint_states read late (this node stalled) counts from when it was stamped, not read
        self._queue_delay = QueueDelay()
        self._js_map_names = None
        self._js_map = None
        self._active: Optional[_Goal] = None
        self._stale_checks = 0
        # late watchdog checks (the node not scheduled, a publish blocked): logged with their cause
        self._stalls = StallMeter(WATCHDOG_PERIOD, STALL_WARN)
        self._last_stall = None   # (steady ns when noticed, Stall)
        self._history: 'OrderedDict[tuple, GoalStatus]' = OrderedDict()

        # deep enough that a reader stalled for a moment loses no setpoint (200 Hz)
        self._pub_setpoint = self.create_publisher(
            JointState, robot_topic(self, 'commands/joint_setpoints'), 100)
        self._pub_feedback = self.create_publisher(
            JointState, robot_topic(self, 'trajectory/feedback'), 100)
        self._pub_status = self.create_publisher(
            GoalStatusArray, robot_topic(self, 'trajectory/status'), STATUS_QOS)
        self._pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.create_subscription(JointState, robot_topic(self, 'joint_states'),
                                 self._on_joint_states, qos_profile_sensor_data)
        # goals arrive serialized: names and array lengths are checked on the bytes, so a goal
        # with wrong names or huge arrays is refused without deserializing it (measured: 16-30
        # ms in the server for 8-800 MB goals; converting them first took seconds)
        self._pre_read = cdr.trajectory_shape_matches_rclpy()
        self.create_subscription(JointTrajectory, robot_topic(self, 'trajectory/goal'),
                                 self._on_goal_serialized, QoSProfile(depth=10), raw=True)
        self.create_service(CancelGoal, robot_topic(self, 'trajectory/cancel'), self._on_cancel)
        self._timer = self.create_timer(1.0 / self._rate, self._on_tick)
        self._watchdog = self.create_timer(WATCHDOG_PERIOD, self._on_watchdog,
                                           clock=self._steady)
        self._duplicates = ''
        self.create_timer(2.0, self._check_peers, clock=self._steady)
        self._setpoint = JointState()
        self._setpoint.name = list(self._names)
        self._publish_status()
        self.get_logger().info(
            f'trajectory_server ready: {self.model.name} joints {self._names}, '
            f'{self._rate:g} Hz, profile {self.get_parameter("profile").value}')

    # ------------------------------------------------------------------ parameters
    def _check_parameters(self, params) -> SetParametersResult:
        for p in params:
            v = p.value
            if p.name == 'profile' and v not in tj.PROFILES:
                return SetParametersResult(
                    successful=False,
                    reason=f"profile must be one of {', '.join(tj.PROFILES)}, got '{v}'")
            if p.name == 'hold_after' and isinstance(v, (int, float)) and v < MIN_HOLD_AFTER:
                # shorter than the gap between two samples: every goal would stay paused
                return SetParametersResult(
                    successful=False, reason=f'hold_after must be >= {MIN_HOLD_AFTER} s (longer '
                    f"than the driver's publish period), got {v!r}")
            if p.name in ('rate', 'moving_time', 'max_joint_step', 'state_timeout', 'hold_after',
                          'path_tolerance', 'goal_tolerance', 'stop_deceleration'):
                if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                    return SetParametersResult(successful=False,
                                               reason=f'{p.name} must be > 0, got {v!r}')
            if p.name in ('accel_time', 'goal_time_tolerance', 'start_tolerance', 'path_window'):
                if not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                    return SetParametersResult(successful=False,
                                               reason=f'{p.name} must be >= 0, got {v!r}')
            if p.name == 'status_history' and (not isinstance(v, int) or v < 1):
                return SetParametersResult(successful=False,
                                           reason=f'status_history must be >= 1, got {v!r}')
        return SetParametersResult(successful=True)

    def _param(self, name):
        return self.get_parameter(name).value

    # ------------------------------------------------------------------ inputs
    def _on_joint_states(self, msg: JointState) -> None:
        names = msg.name
        if names != self._js_map_names:
            self._js_map_names = list(names)
            self._js_map = [(i, self._index[x]) for i, x in enumerate(names) if x in self._index]
        pos = msg.position
        values = [(j, pos[i]) for i, j in self._js_map if i < len(pos)]
        if not all(math.isfinite(v) for _, v in values):
            self.get_logger().warning(
                'joint_states with a non-finite arm position ignored (a driver fault or a '
                'second publisher?)', throttle_duration_sec=5.0)
            return
        with self._lock:
            for j, v in values:
                self._meas[j] = v
            steady = self._steady.now().nanoseconds
            now = self.get_clock().now().nanoseconds
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            # states queued while this node was stalled are as old as their stamps say
            waited = self._queue_delay.update(steady, now - stamp) if stamp else 0
            self._meas_steady_ns = max(self._meas_steady_ns or 0, steady - waited)
            self._meas_stamp_ns = stamp or now

    def _state_age(self) -> float:
        """Return seconds since the last joint_states was stamped (inf if none yet)."""
        if self._meas_steady_ns is None:
            return math.inf
        return (self._steady.now().nanoseconds - self._meas_steady_ns) * 1e-9

    def _on_goal_serialized(self, data: bytes) -> None:
        """Refuse a goal with wrong names or array lengths on its bytes; else deserialize it."""
        t0 = time.monotonic_ns()
        try:
            self._take_goal(data)
        finally:
            self._stalls.note(f'a goal of {len(data)} bytes', time.monotonic_ns() - t0)

    def _take_goal(self, data: bytes) -> None:
        if self._pre_read:
            try:
                (sec, nanosec), names, lengths = cdr.trajectory_shape(data)
            except ValueError:
                pass   # deserialize_message below says what is wrong
            else:
                reason = tj.validate_shape(self._names, names, lengths)
                if reason:
                    msg = JointTrajectory()
                    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
                    self._on_goal(msg, invalid=reason)
                    return
        try:
            msg = deserialize_message(data, JointTrajectory)
        except Exception as exc:  # noqa: B902 - bytes from a raw publisher may be anything
            self.get_logger().error(f'goal of {len(data)} bytes ignored: not a '
                                    f'JointTrajectory ({exc})')
            return
        self._on_goal(msg)

    def _on_goal(self, msg: JointTrajectory, invalid: str = '') -> None:
        """Start a goal (preempting the running one), or refuse it (``invalid``: why)."""
        key = stamp_key(msg.header.stamp)
        with self._lock:
            if self._active is not None and self._active.key == key:
                self._diagnose(key, DiagnosticStatus.ERROR,
                               f'duplicate goal id {stamp_id(msg.header.stamp)} ignored: that '
                               'goal is still running', 'IGNORED')
                return
            if invalid:
                self._reject(msg.header.stamp, invalid)
                return
            try:
                traj, info = self._plan(msg)
            except (InvalidInputError, ValueError, TypeError) as exc:
                self._reject(msg.header.stamp, str(exc))
                return
            except Exception as exc:  # noqa: B902 - a bad goal must never stop the node
                self._reject(msg.header.stamp, f'internal error planning the goal: {exc!r}')
                return
            now = self.get_clock().now().nanoseconds
            if self._active is not None:
                old = self._active
                self._active = None
                self._finish(old, GoalStatus.STATUS_CANCELED,
                             f'preempted by goal {stamp_id(msg.header.stamp)}')
            status = self._new_status(msg.header.stamp, GoalStatus.STATUS_ACCEPTED)
            self._publish_status()
            goal = _Goal(key=key, status=status, traj=traj, t_start=now, info=info,
                         stepped=str(self._param('profile')) == 'linear_max_step')
            status.status = GoalStatus.STATUS_EXECUTING
            self._publish_status()
            self._active = goal
            self.get_logger().info(
                f'goal {stamp_id(msg.header.stamp)} accepted: {info["kind"]}, '
                f'{traj.duration:.3f} s')
            self._on_tick()

    def _plan(self, msg: JointTrajectory):
        """Validate a goal and plan it from the current state; raise InvalidInputError."""
        names = list(msg.joint_names)
        pts = msg.points
        times = [seconds(p.time_from_start) for p in pts]
        # the message's arrays themselves (no copies): validate_points checks every length
        # before reading values, so a goal with huge arrays is rejected without converting them
        positions = [p.positions for p in pts]
        vels = [p.velocities for p in pts]
        accs = [p.accelerations for p in pts]
        m = self.model
        reason = tj.validate_points(self._names, names, times, positions, vels, accs,
                                    m.lower, m.upper, m.velocity_limits)
        if reason:
            raise InvalidInputError(reason)
        if np.any(np.isnan(self._meas)):
            missing = [n for n, v in zip(self._names, self._meas) if math.isnan(v)]
            raise InvalidInputError(f'no joint_states from the driver yet (for {missing}): '
                                    'the start of the move is unknown')
        age = self._state_age()
        if self._active is None and age > float(self._param('state_timeout')):
            # e.g. the driver died: its last state is not where a restarted driver is
            raise InvalidInputError(
                f'the last joint_states are {age:.3g} s old (state_timeout '
                f'{self._param("state_timeout")} s): is sim_driver running? The start of the '
                'move is unknown')
        if self._active is not None:
            q0, v0 = self._current_setpoint(self._active)
        else:
            q0, v0 = self._meas.copy(), np.zeros(self._n)
        idx = [self._index[x] for x in names]
        profile = str(self._param('profile'))
        period = 1.0 / self._rate
        step = float(self._param('max_joint_step'))
        if len(pts) == 1:
            q1 = q0.copy()
            q1[idx] = positions[0]
            T = times[0] if times[0] > 0.0 else float(self._param('moving_time'))
            accel = float(self._param('accel_time'))
            traj = tj.plan_move(q0, q1, T, profile, accel, v_start=v0, max_joint_step=step,
                                period=period)
            info = {'kind': f'one-point {profile} move (moving_time {T:g} s'
                            + (f', accel_time {min(accel, T / 2):g} s)'
                               if profile == 'trapezoidal' else ')')}
        else:
            if times[0] <= 0.0:
                gap = float(np.max(np.abs(np.asarray(positions[0]) - q0[idx])))
                if gap > float(self._param('start_tolerance')):
                    raise InvalidInputError(
                        f'point 0 at t=0 is {gap:.4g} rad from the current position '
                        f'(start_tolerance {self._param("start_tolerance")} rad)')
                times, positions, vels, accs = times[1:], positions[1:], vels[1:], accs[1:]
            full = np.tile(q0, (len(times), 1))
            full[:, idx] = np.asarray(positions, dtype=float)
            given_v = all(len(v) == len(names) for v in vels)
            given_a = given_v and all(len(a) == len(names) for a in accs)
            vfull = afull = None
            if given_v:
                vfull = np.zeros_like(full)
                vfull[:, idx] = np.asarray(vels, dtype=float)
            if given_a:
                afull = np.zeros_like(full)
                afull[:, idx] = np.asarray(accs, dtype=float)
            linear = profile == 'linear_max_step'
            traj = tj.plan_waypoints(q0, times, full, vfull, afull, v_start=v0,
                                     interpolation='linear' if linear else 'spline',
                                     max_joint_step=step if linear else 0.0, period=period)
            info = {'kind': f'{len(times)}-waypoint {"linear" if linear else "spline"} '
                            'trajectory'}
        reason = tj.check_trajectory(traj, self._names, m.lower, m.upper, m.velocity_limits,
                                     dt=min(period, 1e-3))
        if reason:
            raise InvalidInputError(reason)
        return traj, info

    def _current_setpoint(self, goal: _Goal):
        """Return (q, qd) of the last setpoint sent for a goal (where the driver is headed)."""
        if goal.last_q is not None:
            return goal.last_q.copy(), goal.last_qd.copy()
        q, qd, _ = goal.traj.sample(0.0)
        return q, qd

    def _on_cancel(self, request, response):
        """Cancel per action_msgs/srv/CancelGoal (by UUID, by stamp, or all when zero)."""
        uuid = _uuid_bytes(request.goal_info.goal_id.uuid)
        stamp = stamp_key(request.goal_info.stamp)
        by_id, by_stamp = any(uuid), stamp != (0, 0)
        with self._lock:
            g = self._active
            if g is not None and ((not by_id and not by_stamp)
                                  or (by_id and _uuid_bytes(g.status.goal_info.goal_id.uuid)
                                      == uuid)
                                  or (by_stamp and g.key <= stamp)):
                if g.phase != 'canceling':
                    self._start_cancel(g)
                response.goals_canceling = [g.status.goal_info]
                response.return_code = CancelGoal.Response.ERROR_NONE
                return response
            named = None
            for key, st in self._history.items():
                if (by_id and _uuid_bytes(st.goal_info.goal_id.uuid) == uuid) or (
                        not by_id and by_stamp and key == stamp):
                    named = st
            if named is not None and named.status in TERMINAL:
                response.return_code = CancelGoal.Response.ERROR_GOAL_TERMINATED
            elif by_id:
                response.return_code = CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID
            else:
                response.return_code = CancelGoal.Response.ERROR_REJECTED
            return response

    def _start_cancel(self, goal: _Goal) -> None:
        q, qd = self._current_setpoint(goal)
        goal.traj = tj.plan_stop(q, qd, float(self._param('stop_deceleration')))
        goal.t_start = self.get_clock().now().nanoseconds
        goal.phase = 'canceling'
        goal.status.status = GoalStatus.STATUS_CANCELING
        self._publish_status()
        self.get_logger().info(f'goal {self._id(goal)} canceling: stopping in '
                               f'{goal.traj.duration:.3f} s')

    # ------------------------------------------------------------------ execution
    def _on_tick(self) -> None:
        t0 = time.monotonic_ns()
        try:
            self._tick()
        finally:
            self._stalls.note('a setpoint tick', time.monotonic_ns() - t0)

    def _tick(self) -> None:
        with self._lock:
            g = self._active
            if g is None:
                return
            now = self.get_clock().now()
            if not self._hold_for_state(g, now.nanoseconds):
                return
            t = (now.nanoseconds - g.t_start) * 1e-9
            if g.stepped and g.phase == 'executing':
                # seed 001: one step per setpoint, however late the tick (never a bigger step)
                t = g.ticks / self._rate
                g.ticks += 1
            q, qd, _ = g.traj.sample(t)
            g.last_q, g.last_qd = q, qd
            self._send(q, qd, now)
            if g.phase == 'canceling':
                if t >= g.traj.duration:
                    self._active = None
                    self._finish(g, GoalStatus.STATUS_CANCELED,
                                 'canceled: at rest at ' + self._fmt(q))
                return
            if t < g.traj.duration:
                err = self._tracking_error(g, t, now.nanoseconds)
                j = int(np.argmax(err))
                if err[j] > float(self._param('path_tolerance')):
                    self._active = None
                    self._hold_measured(g)
                    lag = (now.nanoseconds - self._meas_stamp_ns) * 1e-9
                    self._finish(g, GoalStatus.STATUS_ABORTED,
                                 f"tracking error of joint '{self._names[j]}' is "
                                 f'{err[j]:.4g} rad (path_tolerance '
                                 f'{self._param("path_tolerance")} rad) at t = {t:.3f} s: '
                                 f'measured {self._meas[j]:.4f} rad ({lag:.3f} s before), '
                                 f'setpoint {q[j]:.4f} rad; joint blocked or driver not '
                                 'following')
                return
            err = np.abs(self._meas - q)
            tol = float(self._param('goal_tolerance'))
            if float(np.max(err)) <= tol:
                self._active = None
                self._finish(g, GoalStatus.STATUS_SUCCEEDED,
                             f'reached within {float(np.max(err)):.2g} rad at t = {t:.3f} s '
                             f'(trajectory {g.traj.duration:.3f} s)')
            elif t > g.traj.duration + float(self._param('goal_time_tolerance')):
                j = int(np.argmax(err))
                self._active = None
                self._finish(g, GoalStatus.STATUS_ABORTED,
                             f"joint '{self._names[j]}' did not settle: error {err[j]:.4g} rad "
                             f'> goal_tolerance {tol} rad, '
                             f'{t - g.traj.duration:.2f} s after the trajectory ended')

    def _hold_for_state(self, goal: _Goal, now_ns: int) -> bool:
        """
        Return False (send nothing) while joint_states are older than hold_after.

        A silent driver gets no setpoints: it cannot use them, and pushing into the
        shared-memory port of a killed peer can block this node for 1 s in Fast DDS
        (measured: a setpoint publish took 1.002 s after a sim_driver SIGKILL, in ~1 of 20
        kills). The goal's clock stops meanwhile: when states return it resumes where it
        paused (no jump); the watchdog aborts it after state_timeout.
        """
        age = self._state_age()
        if age > float(self._param('hold_after')):
            if goal.hold_since is None:
                goal.hold_since = now_ns
                self.get_logger().warning(
                    f'goal {self._id(goal)} paused: no joint_states for {age:.2f} s '
                    f'(hold_after {self._param("hold_after")} s), no setpoints until they '
                    'return')
            return False
        if goal.hold_since is not None:
            held = now_ns - goal.hold_since
            goal.t_start += held
            goal.hold_since = None
            self.get_logger().info(f'goal {self._id(goal)} resumed after a {held * 1e-9:.2f} s '
                                   'pause')
        return True

    def _tracking_error(self, goal: _Goal, t: float, now_ns: int) -> np.ndarray:
        """
        Return (n,) how far each measured joint lies outside its setpoints [rad].

        The measurement is compared with the setpoints of the ``path_window`` seconds before it
        was taken (its header stamp: transport and scheduling delays are not errors); being
        anywhere within the span of those setpoints (the driver lagging) is no error.
        """
        w = float(self._param('path_window'))
        t_meas = t - max(0.0, (now_ns - self._meas_stamp_ns) * 1e-9)
        q_a = goal.traj.sample(t_meas - w)[0]
        q_b = goal.traj.sample(t_meas - 0.5 * w)[0]
        q_c = goal.traj.sample(t_meas)[0]
        lo = np.minimum(np.minimum(q_a, q_b), q_c)
        hi = np.maximum(np.maximum(q_a, q_b), q_c)
        return np.maximum(np.maximum(self._meas - hi, lo - self._meas), 0.0)

    def _check_peers(self) -> None:
        """Log (once per change) a second trajectory server in the namespace, by name."""
        from px100_control.ros.peers import duplicates_message, has_unknown, live_peers
        ns = '/' + robot_name(self) if robot_name(self) else self.get_namespace()
        peers = live_peers(self, ns)
        if has_unknown(peers):
            return  # a node being discovered: named on the next check
        message = duplicates_message({'trajectory_servers': peers['trajectory_servers']}, ns)
        if message and message != self._duplicates:
            self.get_logger().error(message)
        self._duplicates = message

    def _on_watchdog(self) -> None:
        """
        Abort the running goal when joint_states stopped for longer than state_timeout.

        Runs on the steady clock (also when a sim clock stops). A stale state must be seen on
        two consecutive checks, so that joint_states still queued behind this timer after a
        scheduling stall of this process are read before the driver is declared dead. A check
        that comes late (the node was not scheduled) is logged with what ran longest meanwhile,
        and an abort noticed late says so in its reason.
        """
        now_ns = self._steady.now().nanoseconds
        stall = self._stalls.check(now_ns)
        if stall is not None:
            self._last_stall = (now_ns, stall)
            self.get_logger().warning(f'trajectory_server {stall.describe()}')
        with self._lock:
            g = self._active
            age = self._state_age()
            if g is None or age <= float(self._param('state_timeout')):
                self._stale_checks = 0
                return
            self._stale_checks += 1
            if self._stale_checks < 2:
                return
            self._stale_checks = 0
            self._active = None
            reason = (f'driver not publishing joint_states (none for {age:.2f} s, '
                      f'state_timeout {self._param("state_timeout")} s)')
            if self._last_stall is not None and self._last_stall[0] >= (self._meas_steady_ns
                                                                        or 0):
                reason += f'; noticed late: this node was {self._last_stall[1].describe()}'
            self._finish(g, GoalStatus.STATUS_ABORTED, reason)

    def _send(self, q, qd, now=None) -> None:
        """Publish a setpoint (and the same as feedback), stamped with its sample time."""
        msg = self._setpoint
        msg.header.stamp = (now or self.get_clock().now()).to_msg()
        msg.position = q.tolist()
        msg.velocity = qd.tolist()
        t0 = time.monotonic_ns()
        self._pub_setpoint.publish(msg)
        t1 = time.monotonic_ns()
        self._pub_feedback.publish(msg)
        self._stalls.note('publishing a setpoint', t1 - t0)
        self._stalls.note('publishing feedback', time.monotonic_ns() - t1)

    def _hold_measured(self, goal: _Goal) -> None:
        """
        Hold the arm where it is measured: that position as the setpoint, at rest.

        A joint measured outside its limits (a faulty or lying joint_states) holds the goal's
        last setpoint instead: never an out-of-limit setpoint, nor a jump to the limit.
        """
        last = goal.last_q if goal.last_q is not None else goal.traj.sample(0.0)[0]
        q = self._meas
        ok = np.isfinite(q) & (q >= self.model.lower) & (q <= self.model.upper)
        if not ok.all():
            self.get_logger().warning(
                'holding the last setpoint of joint(s) '
                f'{[n for n, good in zip(self._names, ok) if not good]}: measured outside '
                f'the limits ({self._fmt(q)})')
        self._send(np.where(ok, q, last), np.zeros(self._n))

    # ------------------------------------------------------------------ status
    def _id(self, goal: _Goal) -> str:
        return stamp_id(goal.status.goal_info.stamp)

    def _new_status(self, stamp, status: int) -> GoalStatus:
        key = stamp_key(stamp)
        st = GoalStatus()
        st.goal_info = GoalInfo()
        st.goal_info.stamp = stamp
        st.goal_info.goal_id.uuid = list(stamp_uuid(stamp))
        st.status = status
        self._history.pop(key, None)
        self._history[key] = st
        limit = int(self._param('status_history'))
        while len(self._history) > limit:
            self._history.popitem(last=False)
        return st

    def _publish_status(self) -> None:
        msg = GoalStatusArray()
        msg.status_list = list(self._history.values())
        self._pub_status.publish(msg)

    def _reject(self, stamp, reason: str) -> None:
        self._new_status(stamp, GoalStatus.STATUS_ABORTED)
        self._publish_status()
        self._diagnose(stamp_key(stamp), DiagnosticStatus.ERROR, f'invalid goal: {reason}',
                       'ABORTED')
        self.get_logger().error(f'goal {stamp_id(stamp)} ABORTED (invalid, nothing sent): '
                                f'{reason}')

    def _finish(self, goal: _Goal, status: int, reason: str) -> None:
        goal.status.status = status
        self._publish_status()
        name = STATUS_NAMES[status]
        self._diagnose(goal.key, DIAG_LEVEL[status], reason, name)
        log = self.get_logger()
        text = f'goal {self._id(goal)} {name}: {reason}'
        if status == GoalStatus.STATUS_ABORTED:
            log.error(text)
        elif status == GoalStatus.STATUS_CANCELED:
            log.warning(text)
        else:
            log.info(text)

    def _diagnose(self, key: tuple, level: int, message: str, status: str) -> None:
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        arr.status = [DiagnosticStatus(
            level=level, name=self._diag_name, message=message,
            hardware_id=f'{key[0]}.{key[1]:09d}',
            values=[KeyValue(key='status', value=status)])]
        self._pub_diag.publish(arr)

    @staticmethod
    def _fmt(q) -> str:
        return '[' + ', '.join(f'{x:.4f}' for x in q) + ']'

    # ------------------------------------------------------------------ introspection
    def goal_statuses(self) -> dict:
        """Return {goal id: status name} of the recent goals (for tests and tools)."""
        with self._lock:
            return {f'{k[0]}.{k[1]:09d}': STATUS_NAMES.get(v.status, str(v.status))
                    for k, v in self._history.items()}


def _uuid_bytes(uuid) -> bytes:
    """Return a unique_identifier_msgs/UUID field as 16 bytes."""
    return np.asarray(uuid, dtype=np.uint8).tobytes()


def main(args=None):
    """Run the trajectory_server node (``ros2 run px100_control trajectory_server``)."""
    return spin_node(lambda options: TrajectoryServerNode(), args,
                     description='Action-style joint trajectory server of px100_control '
                                 '(trajectory/goal, trajectory/status, trajectory/cancel).')


if __name__ == '__main__':
    import sys
    sys.exit(main())
