"""
sim_driver: the simulated joint-state driver (joint dynamics + one PID loop per joint).

A thin rclpy adapter over :class:`px100_control.control.simulator.ArmSimulator`
(docs/ros_interfaces.md, sim_driver section). Topics under ``/<robot_name>``:

- pub ``joint_states`` (sensor_msgs/JointState, ``publish_rate``): arm joints, gripper,
  left_finger, right_finger; position, velocity, effort (N*m; fingers m, m/s, N);
- pub ``ee_pose`` (geometry_msgs/PoseStamped, same rate, frame ``<robot_name>/base_link``);
- pub ``robot_description`` (std_msgs/String, transient local), link names ``<robot_name>/...``;
- sub ``commands/joint_setpoints`` (sensor_msgs/JointState): position (+ optional velocity
  feed-forward) for any subset of joints, or effort [N*m] for the gripper alone; a refused
  message is logged and published on ``/diagnostics`` and nothing of it is applied;
- services ``torque_enable`` (std_srvs/SetBool: every joint), ``reset`` (std_srvs/Trigger: the
  arm to its sleep pose and the scene's objects to their initial poses);
- the world of the ``scene`` parameter: pub ``world/markers`` (visualization_msgs/MarkerArray,
  transient local, ``world_rate``: one marker per body, poses in ``<robot_name>/base_link``),
  pub ``world/held_object`` (std_msgs/String, transient local, on every change: the name of the
  object between the fingers, '' for none), service ``world/reset`` (std_srvs/Trigger: objects
  back to their initial poses, the arm untouched).

Torque per joint: parameter ``torque_enable.<joint>`` (bool, every arm joint and the gripper;
``ros2 param set /px100/sim_driver torque_enable.gripper false`` switches off only the
gripper); the ``torque_enable`` service sets all of them, ``reset`` turns them all on.

Control mode per joint: parameter ``operating_mode.<joint>`` (string): '' (default: position;
the gripper takes position or effort), 'position', 'velocity', 'torque' or 'duty'. The joint's
setpoints on ``commands/joint_setpoints`` are then ``position`` [rad] (+ ``velocity``
feed-forward), ``velocity`` alone [rad/s], ``effort`` [N*m] (torque: DYNAMIXEL current
control) or ``effort`` as PWM duty in [-1, 1]; a setpoint of another kind is refused with the
reason (never executed as something else). Changing the mode makes the joint hold (position:
where it is; velocity: 0 rad/s; torque, duty: zero output). A new ``scene`` keeps both.

Time. The physics runs at ``control_rate`` in fixed steps, advanced by the elapsed time in chunks
(no dependence on timer precision):

- ``real_time_factor`` = 1 and ``publish_clock`` false (default): the simulation follows the
  node clock (wall time, or ``/clock`` when ``use_sim_time`` is true); a ``publish_rate`` timer
  advances the physics to "now" and publishes; stamps are the node clock. Behind the clock by
  more than a chunk (a starved process), the driver drops simulated time instead of falling
  further behind; a ``control_rate`` whose physics would need over 0.8 of a core (the step cost
  is measured while running: about 44 us here, so at most ~18 kHz) is refused.
- otherwise the driver owns the clock: it advances simulated time at ``real_time_factor`` x wall
  time (0 or inf: as fast as possible), publishes ``/clock`` (rosgraph_msgs/Clock) at
  ``clock_rate`` of simulated time, and stamps with simulated time starting at 0, so nodes
  started with ``use_sim_time:=true`` follow it. ``real_time_factor`` can change live in this
  mode; the mode itself is chosen at startup.

Parameters (defaults in config/px100.yaml, validated live): ``publish_rate`` [Hz],
``control_rate`` [Hz], ``real_time_factor``, ``publish_clock``, ``clock_rate`` [Hz],
``dynamics_divider``, ``object_width`` [m] (an object between the fingers, 0 = none),
``scene`` (a name in config/scenes, a path to a .yaml, '' = no objects; a bad one is refused
with the loader's reason: at start the node exits non-zero), ``world_rate`` [Hz],
``gains_units`` (read-only: ``si`` or ``dynamixel``: p/i/d as Position P/I/D Gain registers),
``gains.<joint>.p|i|d|i_clamp|u_clamp|ff_velocity`` for every arm joint and the gripper.
"""
import collections
import math
import threading
import time
from typing import List, Optional

from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from px100_control.control.pid import GAIN_FIELDS, PidGains
from px100_control.control.simulator import ArmSimulator, MODES, parse_setpoints, SimConfig
from px100_control.errors import Px100Error
from px100_control.models.urdf_prefix import prefix_urdf
from px100_control.ros.common import (declare_robot_parameters, declare_schema, frame_id,
                                      LATCHED_QOS, robot_name, robot_node_kwargs, robot_topic,
                                      spin_node)
from px100_control.ros.parameter_schema import SIM_DRIVER
from px100_control.ros.peers import new_duplicates
from px100_control.ros.world import WorldPublisher
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger

#: physics chunk timer in clock-master mode [Hz]
TICK_RATE = 100.0
#: below this publish_rate [Hz] an extra timer advances the physics in follow-clock mode
#: (setpoints and service calls also catch the physics up to "now" before they apply)
FOLLOW_TICK_RATE = 20.0
#: most simulated time one chunk may integrate before the driver drops time [s]
MAX_CHUNK = 0.5
#: following the system clock, samples missed by a stall up to this long are still published
#: (each integrated to and stamped with its own time) [s]; longer stalls drop them
CATCH_UP = 2.0
#: wall-time budget of one chunk in clock-master mode [s]
CHUNK_BUDGET = 0.008
#: most of a CPU core the physics may need to follow the clock at a requested control_rate
MAX_PHYSICS_LOAD = 0.8
#: how often the graph is searched for a second driver in the namespace [s]
PEER_CHECK_PERIOD = 2.0

_CORE_PARAMS = ('publish_rate', 'control_rate', 'real_time_factor', 'publish_clock',
                'clock_rate', 'dynamics_divider', 'object_width', 'gains_units', 'world_rate')


def _time_msg(ns: int) -> TimeMsg:
    sec, nanosec = divmod(int(ns), 1_000_000_000)
    return TimeMsg(sec=sec, nanosec=nanosec)


class SimDriverNode(Node):
    """The simulated PX100 driver node ('sim_driver'); kwargs go to rclpy Node."""

    def __init__(self, **node_kwargs):
        super().__init__('sim_driver', **robot_node_kwargs('sim_driver', node_kwargs))
        self.model = declare_robot_parameters(self)
        declare_schema(self, SIM_DRIVER)
        units = self.get_parameter('gains_units').value
        scene_name = self.get_parameter('scene').value
        dyn = ParameterDescriptor(dynamic_typing=True, description=SIM_DRIVER.groups[0][1])
        if units not in ('si', 'dynamixel'):
            raise Px100Error(f"gains_units must be 'si' or 'dynamixel', not {units!r}")
        self._units = units
        p = {name: self.get_parameter(name).value for name in _CORE_PARAMS}
        error = self._core_error(p)
        if error:
            raise Px100Error(error)
        self.sim = ArmSimulator(self.model, SimConfig(
            control_rate=float(p['control_rate']), dynamics_divider=int(p['dynamics_divider']),
            object_width=float(p['object_width'])),
            scene=WorldPublisher.load(scene_name, self.model))
        self._gain_joints = list(self.sim.command_joints)
        for joint in self._gain_joints:
            base = self.sim.gains(joint)      # defaults scaled to the joint's servo
            reg = base.to_dynamixel() if units == 'dynamixel' else None
            values = {}
            for k, f in enumerate(GAIN_FIELDS):
                default = float(getattr(base, f))
                if reg is not None and k < 3:
                    default = float(round(reg[k]))
                values[f] = self.declare_parameter(f'gains.{joint}.{f}', default, dyn).value
            error = self._gains_error(joint, values)
            if error:
                raise Px100Error(error)
            self.sim.set_gains(joint, self._to_gains(values, joint))
        for joint in self._gain_joints:
            self.declare_parameter(f'torque_enable.{joint}', True, ParameterDescriptor(
                description=f'torque of {joint} on (false: the servo coasts)'))
            mode = self.declare_parameter(f'operating_mode.{joint}', '', ParameterDescriptor(
                description="'' (default), 'position', 'velocity', 'torque' [N*m] or 'duty' "
                            '[-1, 1]: what commands/joint_setpoints carries for this joint'))
            if mode.value:
                error = self._mode_error(mode.name, mode.value)
                if error:
                    raise Px100Error(error)
                self._set_mode(joint, mode.value)
        for note in self.sim.dynamics.notes:
            self.get_logger().info(f'dynamics: {note}')
        self._lock = threading.Lock()
        # One reentrant group for every callback, serialised by self._lock: a mutually
        # exclusive group drops a busy timer from the multi-threaded executor's wait set and
        # it then fires late, in pairs (p50 publish jitter 8 ms instead of 0.2 ms).
        self._group = ReentrantCallbackGroup()
        self._rtf = float(p['real_time_factor'])
        self._master = self._rtf != 1.0 or bool(p['publish_clock'])
        self._publish_rate = float(p['publish_rate'])
        self._clock_rate = float(p['clock_rate'])
        self._dt_ns = int(round(1e9 / float(p['control_rate'])))
        self._steps_done = 0
        #: wall seconds of one physics step (fastest chunk seen; None until measured)
        self._step_cost: Optional[float] = None
        self._names = list(self.sim.joint_state().name)
        self._base_frame = frame_id(self, self.model.base_frame)
        self._timers: List = []
        # publishers, subscription, services
        self.pub_js = self.create_publisher(JointState, robot_topic(self, 'joint_states'), 10)
        self.pub_ee = self.create_publisher(PoseStamped, robot_topic(self, 'ee_pose'), 10)
        self.pub_desc = self.create_publisher(String, robot_topic(self, 'robot_description'),
                                              LATCHED_QOS)
        self.pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.pub_clock = (self.create_publisher(ClockMsg, '/clock', QoSProfile(depth=10))
                          if self._master else None)
        self.create_subscription(JointState, robot_topic(self, 'commands/joint_setpoints'),
                                 self._on_setpoints, 50, callback_group=self._group)
        self.create_service(SetBool, robot_topic(self, 'torque_enable'), self._on_torque,
                            callback_group=self._group)
        self.create_service(Trigger, robot_topic(self, 'reset'), self._on_reset,
                            callback_group=self._group)
        self.world = WorldPublisher(self, self._base_frame, float(p['world_rate']))
        self.create_service(Trigger, robot_topic(self, 'world/reset'), self._on_world_reset,
                            callback_group=self._group)
        self._pending_scene = None
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._publish_description()
        # time keeping
        self._sim_ns = 0
        self._start_ns = self.get_clock().now().nanoseconds
        self._wall_anchor = time.monotonic()
        self._sim_anchor_ns = 0
        self._next_pub_ns = int(round(1e9 / self._publish_rate))
        self._next_clock_ns = int(round(1e9 / self._clock_rate))
        if self._master:
            self.pub_clock.publish(ClockMsg(clock=_time_msg(0)))
        self.achieved_rtf = math.nan
        #: monotonic wall times [s] of the last joint_states publications (for timing checks)
        self.publish_times = collections.deque(maxlen=10000)
        self._jobs = set()
        self._jobs_cv = threading.Condition()
        self._stopping = False
        self._use_sim_time = bool(self.get_parameter('use_sim_time').value)
        self._physics_thread = threading.Thread(target=self._physics_loop, daemon=True,
                                                name='sim_driver_physics')
        self._physics_thread.start()
        self._make_timers()
        self._duplicates = ''
        self.create_timer(PEER_CHECK_PERIOD, self._check_peers, callback_group=self._group)
        mode = (f'own clock, real_time_factor {self._rtf:g}, /clock at {self._clock_rate:g} Hz'
                if self._master else 'following the node clock')
        self.get_logger().info(
            f'sim_driver for {self.model.name}: {len(self._names)} joints, physics at '
            f'{1e9 / self._dt_ns:g} Hz, joint_states at {self._publish_rate:g} Hz, {mode}')

    # --- parameters ----------------------------------------------------------------------------
    def _servo(self, joint: str):
        if joint == self.sim.gripper_name:
            return self.sim.gripper_servo
        return self.sim.servos[self.sim.names.index(joint)]

    def _to_gains(self, values: dict, joint: str) -> PidGains:
        values = {k: float(v) for k, v in values.items()}
        if self._units == 'dynamixel':
            clamps = {k: values[k] for k in ('i_clamp', 'u_clamp', 'ff_velocity')}
            return PidGains.from_dynamixel(values['p'], values['i'], values['d'],
                                           stall_torque=self._servo(joint).stall_torque,
                                           **clamps)
        return PidGains(**values)

    def _gains_error(self, joint: str, values: dict) -> Optional[str]:
        for f, v in values.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                return f'gains.{joint}.{f} must be a number, not {v!r}'
            if math.isinf(v):
                # found by the full fuzz campaign: an infinite i_clamp/u_clamp was accepted
                return (f'gains.{joint}.{f} must be finite, not {v!r} (for no clamp give a '
                        'value above the servo torque)')
        try:
            gains = self._to_gains(values, joint)
        except Px100Error as exc:
            return f'gains.{joint}: {exc}'
        return self._stability_error(joint, gains, self.sim.dt)

    def _stability_error(self, joint: str, gains: PidGains, dt: float) -> Optional[str]:
        """Refuse gains the explicit discrete loop cannot take (J = the servo's armature)."""
        inertia = max(self._servo(joint).armature, 1e-6)
        if gains.d * dt > inertia:
            return (f'gains.{joint}.d = {gains.d:.6g} would make the control loop unstable at '
                    f'{1.0 / dt:g} Hz (needs d < J/dt = {inertia / dt:.6g})')
        if gains.p * dt * dt > inertia:
            return (f'gains.{joint}.p = {gains.p:.6g} would make the control loop unstable at '
                    f'{1.0 / dt:g} Hz (needs p < J/dt^2 = {inertia / dt / dt:.6g})')
        return None

    def _core_error(self, p: dict) -> Optional[str]:
        def number(name, lo, hi, allow_inf=False):
            v = p[name]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v):
                return f'{name} must be a number, not {v!r}'
            if math.isinf(v) and allow_inf:
                return None
            if not lo <= v <= hi:
                return f'{name} = {v} is outside [{lo}, {hi}]'
            return None
        for err in (number('control_rate', 10.0, 100000.0),
                    number('publish_rate', 0.1, 1000.0),
                    number('real_time_factor', 0.0, 1e6, allow_inf=True),
                    number('clock_rate', 1.0, 10000.0),
                    number('object_width', 0.0, 10.0),
                    number('world_rate', 0.1, 1000.0)):
            if err:
                return err
        if p['publish_rate'] > p['control_rate']:
            return (f"publish_rate {p['publish_rate']} Hz is above control_rate "
                    f"{p['control_rate']} Hz")
        div = p['dynamics_divider']
        if isinstance(div, bool) or not isinstance(div, int) or div < 1:
            return f'dynamics_divider must be an integer >= 1, not {div!r}'
        sim = getattr(self, 'sim', None)
        if sim is not None and sim.linkage is not None:
            try:
                sim.linkage.check_object_width(float(p['object_width']))
            except Px100Error as exc:
                return str(exc)
        elif sim is not None and p['object_width']:
            return 'this robot has no gripper to hold an object'
        return None

    def _mode_error(self, name: str, value) -> Optional[str]:
        if value not in ('',) + tuple(MODES):
            return (f"{name} must be '' (default) or one of {', '.join(MODES)}, not {value!r} "
                    '(Interbotix modes map to these: current -> torque, pwm -> duty)')
        return None

    def _set_mode(self, joint: str, mode: str) -> None:
        """Put a joint in a control mode ('' = its default); the joint then holds."""
        self.sim.set_mode(joint, mode or 'position')
        if not mode:
            self.sim.modes.pop(joint, None)  # the default (the gripper: position or effort)
        self.get_logger().info(f"{joint}: {mode or 'default'} mode")

    def _validate_parameters(self, params: List[Parameter]) -> SetParametersResult:
        changed = {prm.name: prm.value for prm in params}
        for name, value in changed.items():
            if name.startswith('operating_mode.'):
                error = self._mode_error(name, value)
                if error:
                    return SetParametersResult(successful=False, reason=error)
        if any(name.startswith('gains.') for name in changed):
            for joint in self._gain_joints:
                keys = [f'gains.{joint}.{f}' for f in GAIN_FIELDS]
                if not any(k in changed for k in keys):
                    continue
                values = {f: changed.get(k, self.get_parameter(k).value)
                          for f, k in zip(GAIN_FIELDS, keys)}
                error = self._gains_error(joint, values)
                if error:
                    return SetParametersResult(successful=False, reason=error)
        if 'scene' in changed:
            try:
                self._pending_scene = WorldPublisher.load(changed['scene'], self.model)
            except Px100Error as exc:
                return SetParametersResult(successful=False, reason=f'scene: {exc}')
        core = [n for n in changed if n in _CORE_PARAMS]
        if core:
            p = {n: changed.get(n, self.get_parameter(n).value) for n in _CORE_PARAMS}
            error = self._core_error(p)
            if error:
                return SetParametersResult(successful=False, reason=error)
            if 'real_time_factor' in changed and not self._master \
                    and float(changed['real_time_factor']) != 1.0:
                return SetParametersResult(successful=False, reason=(
                    'this driver follows the node clock; start it with real_time_factor != 1 '
                    'or publish_clock:=true to run on its own clock'))
            if 'control_rate' in changed:
                rate = float(changed['control_rate'])
                if self._step_cost is not None and not self._master \
                        and rate * self._step_cost > MAX_PHYSICS_LOAD:
                    return SetParametersResult(successful=False, reason=(
                        f'control_rate {rate:g} Hz: one physics step takes '
                        f'{self._step_cost * 1e6:.0f} us here, so the simulation could not '
                        f'keep up with the clock (at most '
                        f'{MAX_PHYSICS_LOAD / self._step_cost:.0f} Hz on this machine)'))
                dt = 1.0 / rate
                for joint in self._gain_joints:
                    error = self._stability_error(joint, self.sim.gains(joint), dt)
                    if error:
                        return SetParametersResult(successful=False, reason=(
                            f"control_rate {changed['control_rate']} Hz: {error}"))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: List[Parameter]) -> None:
        changed = {prm.name: prm.value for prm in params}
        with self._lock:
            for joint in self._gain_joints:
                keys = [f'gains.{joint}.{f}' for f in GAIN_FIELDS]
                if any(k in changed for k in keys):
                    values = {f: self.get_parameter(k).value for f, k in zip(GAIN_FIELDS, keys)}
                    self.sim.set_gains(joint, self._to_gains(values, joint))
                    self.get_logger().info(f'gains of {joint}: {self.sim.gains(joint)}')
            torque = {n[len('torque_enable.'):]: bool(v) for n, v in changed.items()
                      if n.startswith('torque_enable.')}
            modes = {n[len('operating_mode.'):]: str(v) for n, v in changed.items()
                     if n.startswith('operating_mode.')}
            if modes:
                self._catch_up()
                for joint, mode in modes.items():
                    self._set_mode(joint, mode)
            if torque:
                self._catch_up()
                for joint, on in torque.items():
                    self.sim.set_torque_enabled(on, [joint])
                if len(torque) < len(self._gain_joints):
                    self.get_logger().info('torque ' + ', '.join(
                        f"{j} {'on' if on else 'off'}" for j, on in torque.items()))
            if 'object_width' in changed:
                self.sim.set_object_width(float(changed['object_width']))
            if 'world_rate' in changed:
                self.world.rate = float(changed['world_rate'])
            if 'scene' in changed:
                scene, self._pending_scene = self._pending_scene, None
                old = self.sim       # a new plant: the arm at its sleep pose, the same gains
                self.sim = ArmSimulator(self.model, old.config, scene=scene, gains={
                    joint: old.gains(joint) for joint in self._gain_joints})
                for joint in self._gain_joints:  # the joints' modes and torque carry over
                    mode = str(self.get_parameter(f'operating_mode.{joint}').value)
                    if mode:
                        self._set_mode(joint, mode)
                    if not self.get_parameter(f'torque_enable.{joint}').value:
                        self.sim.set_torque_enabled(False, [joint])
                self.world.publish_now(self.sim, self._stamp_now())
                self.get_logger().info(f"scene {changed['scene']!r} loaded; the arm is at its "
                                       'sleep pose, the objects at their initial poses')
            if 'dynamics_divider' in changed:
                self.sim.config = _replace_config(self.sim.config,
                                                  dynamics_divider=int(
                                                      changed['dynamics_divider']))
            if 'control_rate' in changed:
                rate = float(changed['control_rate'])
                self.sim.dt = 1.0 / rate
                self._dt_ns = int(round(1e9 / rate))
            retime = False
            if 'publish_rate' in changed:
                self._publish_rate = float(changed['publish_rate'])
                retime = True
            if 'clock_rate' in changed:
                self._clock_rate = float(changed['clock_rate'])
            if 'real_time_factor' in changed:
                self._rtf = float(changed['real_time_factor'])
                self._wall_anchor = time.monotonic()
                self._sim_anchor_ns = self._sim_ns
            if retime:
                self._make_timers()

    # --- timing --------------------------------------------------------------------------------
    def _make_timers(self) -> None:
        """
        Create or retime the ROS timers: only when following ``/clock`` (use_sim_time).

        On wall time the physics thread paces itself (see _physics_loop); a timer would only
        wake it.
        """
        if self._master or not self._use_sim_time:
            with self._jobs_cv:
                self._jobs_cv.notify()           # a new publish_rate applies at once
            return
        # timers are created once and retimed, never destroyed while spinning (rclpy 7.1's
        # EventsExecutor fails when an entity is destroyed under it)
        period_ns = int(round(1e9 / self._publish_rate))
        if not self._timers:
            self._timers = [
                self.create_timer(period_ns * 1e-9, lambda: self._wake('publish'),
                                  callback_group=self._group),
                self.create_timer(1.0 / FOLLOW_TICK_RATE, lambda: self._wake('follow'),
                                  callback_group=self._group)]
        elif self._timers[0].timer_period_ns != period_ns:
            self._timers[0].timer_period_ns = period_ns
            self._timers[0].reset()
        follow = self._timers[1]
        if self._publish_rate < FOLLOW_TICK_RATE:
            if follow.is_canceled():
                follow.reset()
        else:
            follow.cancel()

    def _wake(self, job: str) -> None:
        with self._jobs_cv:
            self._jobs.add(job)
            self._jobs_cv.notify()

    def _physics_loop(self) -> None:
        """
        Run the physics chunks and the publishing, in this thread.

        On wall time the thread sleeps to each sample time itself: inside rclpy's
        multi-threaded executor a 100 Hz timer whose callback integrates and publishes (1-2 ms)
        fired late and in pairs (periods 1.5 ms / 18.5 ms), and a timer that only woke a thread
        fired every 20 ms. Following the system clock, each sample is integrated up to its
        nominal time and stamped with it (after a stall the missed samples follow at once, each
        with its own state, up to MAX_CHUNK late); with its own clock, ticks advance simulated
        time. Following ``/clock`` (use_sim_time), ROS timers on the node clock wake it.
        """
        try:
            if self._master:
                self._paced(lambda: 1.0 / TICK_RATE, self._on_master_tick)
            elif not self._use_sim_time:
                self._paced_follow()
            else:
                self._woken()
        except Exception as exc:  # pragma: no cover - reported, the node keeps its services
            self.get_logger().fatal(f'physics thread stopped: {exc!r}')

    def _paced(self, period_of, work) -> None:
        period = period_of()
        next_t = time.monotonic() + period
        while True:
            with self._jobs_cv:
                while not self._stopping:
                    if period_of() != period:          # publish_rate changed
                        period = period_of()
                        next_t = time.monotonic() + period
                    remaining = next_t - time.monotonic()
                    if remaining <= 0.0:
                        break
                    self._jobs_cv.wait(remaining)
                if self._stopping:
                    return
            self._run(work)
            next_t += period
            now = time.monotonic()
            if now - next_t > period:                      # fell behind: skip, do not burst
                next_t = now + period

    def _woken(self) -> None:
        work = {'publish': self._on_publish_tick, 'follow': self._on_follow_tick}
        while True:
            with self._jobs_cv:
                while not self._jobs and not self._stopping:
                    self._jobs_cv.wait()
                if self._stopping:
                    return
                jobs, self._jobs = self._jobs, set()
            for job in ('follow', 'publish'):
                if job in jobs:
                    self._run(work[job])

    def _run(self, work) -> None:
        try:
            work()
        except Exception as exc:   # keep simulating; say why once a second
            if not self.context.ok():          # shutting down (SIGINT): stop quietly
                with self._jobs_cv:
                    self._stopping = True
                return
            self.get_logger().error(f'physics step failed: {exc!r}', throttle_duration_sec=1.0)

    def stop_physics(self) -> None:
        """Stop the physics thread (the node then only answers services and parameters)."""
        with self._jobs_cv:
            self._stopping = True
            self._jobs_cv.notify()
        if self._physics_thread.is_alive() and \
                threading.current_thread() is not self._physics_thread:
            self._physics_thread.join(timeout=5.0)

    def destroy_node(self):
        """Stop the physics thread, then destroy the node."""
        self.stop_physics()
        return super().destroy_node()

    def _advance_steps(self, steps: int) -> None:
        step = self.sim.step
        t0 = time.perf_counter()
        for _ in range(steps):
            step()
        self._sim_ns += steps * self._dt_ns
        if steps >= 5:   # the fastest chunk seen: what this machine needs per step, unloaded
            cost = (time.perf_counter() - t0) / steps
            if self._step_cost is None or cost < self._step_cost:
                self._step_cost = cost

    def _capped_steps(self, behind_ns: int) -> int:
        """
        Return the physics steps to integrate ``behind_ns`` of simulated time.

        At most MAX_CHUNK, or one publish period if longer (between two samples that much is
        normally pending: publish_rate goes down to 0.1 Hz).

        Further behind (a starved process, or a control_rate this machine cannot integrate in
        real time), the rest of the time is dropped (``_start_ns`` moves on) instead of making
        the next chunk longer still: lateness and the time the lock is held stay bounded.
        """
        steps = behind_ns // self._dt_ns
        limit_s = max(MAX_CHUNK, 1.0 / self._publish_rate)
        max_steps = int(limit_s * 1e9 // self._dt_ns)
        if steps > max_steps:
            self.get_logger().warning(
                f'simulation fell {behind_ns * 1e-9:.3f} s behind the clock; skipping ahead',
                throttle_duration_sec=5.0)
            self._start_ns += (steps - max_steps) * self._dt_ns
            steps = max_steps
        return int(steps)

    def _advance_to_clock(self) -> int:
        """Advance the physics to the node clock's now; return now [ns]."""
        now = self.get_clock().now().nanoseconds
        if self._start_ns == 0 and self._sim_ns == 0:
            self._start_ns = now    # use_sim_time: the first /clock message sets the origin
        target = now - self._start_ns
        if target < self._sim_ns:   # the clock jumped back (e.g. /clock restarted)
            self._start_ns = now - self._sim_ns
            return now
        self._advance_steps(self._capped_steps(target - self._sim_ns))
        return now

    def _on_follow_tick(self) -> None:
        with self._lock:
            self._advance_to_clock()

    def _on_publish_tick(self) -> None:
        with self._lock:
            now = self._advance_to_clock()
            self._publish_state(now)

    def _publish_at(self, stamp_ns: int) -> None:
        """
        Integrate up to the sample time stamp_ns (node clock) and publish the state there.

        The stamp is the simulated state's time: the nominal sample time, or later when a
        command already made the physics catch up beyond it.
        """
        with self._lock:
            steps = self._capped_steps(stamp_ns - self._start_ns - self._sim_ns)
            if steps > 0:
                self._advance_steps(steps)
            self._publish_state(self._start_ns + self._sim_ns)

    def _paced_follow(self) -> None:
        """Publish at publish_rate on the node clock (wall time), sleeping to each sample."""
        clock = self.get_clock()
        period = int(round(1e9 / self._publish_rate))
        next_stamp = clock.now().nanoseconds + period
        while True:
            with self._jobs_cv:
                while not self._stopping:
                    if int(round(1e9 / self._publish_rate)) != period:    # rate changed
                        period = int(round(1e9 / self._publish_rate))
                        next_stamp = clock.now().nanoseconds + period
                    remaining = (next_stamp - clock.now().nanoseconds) * 1e-9
                    if remaining <= 0.0:
                        break
                    self._jobs_cv.wait(remaining)
                if self._stopping:
                    return
            late = clock.now().nanoseconds - next_stamp
            if late > CATCH_UP * 1e9:
                # starved for longer than a chunk: drop the missed samples, do not burst
                self.get_logger().warning(f'publishing {late * 1e-9:.3f} s late; skipping '
                                          'the missed samples', throttle_duration_sec=5.0)
                next_stamp += (late // period) * period
            self._run(lambda: self._publish_at(next_stamp))
            next_stamp += period

    def _on_master_tick(self) -> None:
        with self._lock:
            wall0 = time.monotonic()
            fast = self._rtf == 0.0 or math.isinf(self._rtf)
            if fast:
                target = math.inf
            else:
                target = self._sim_anchor_ns + (wall0 - self._wall_anchor) * self._rtf * 1e9
            pub_period = int(round(1e9 / self._publish_rate))
            clock_period = int(round(1e9 / self._clock_rate))
            start_ns = self._sim_ns
            budget_end = wall0 + (CHUNK_BUDGET if fast else 0.8 / TICK_RATE)
            while self._sim_ns + self._dt_ns <= target:
                next_event = min(self._next_pub_ns, self._next_clock_ns)
                steps = max(1, (next_event - self._sim_ns) // self._dt_ns)
                if not fast:
                    steps = min(steps, int((target - self._sim_ns) // self._dt_ns))
                self._advance_steps(int(min(steps, 50)))
                if self._sim_ns >= self._next_clock_ns:
                    self.pub_clock.publish(ClockMsg(clock=_time_msg(self._sim_ns)))
                    self._next_clock_ns += clock_period * max(
                        1, (self._sim_ns - self._next_clock_ns) // clock_period + 1)
                if self._sim_ns >= self._next_pub_ns:
                    self._publish_state(self._sim_ns)
                    self._next_pub_ns += pub_period * max(
                        1, (self._sim_ns - self._next_pub_ns) // pub_period + 1)
                if time.monotonic() > budget_end:
                    break
            wall1 = time.monotonic()
            if not fast and self._sim_ns + 2 * self._dt_ns < target:
                # cannot keep up: re-anchor so the debt does not grow without bound
                self._wall_anchor, self._sim_anchor_ns = wall1, self._sim_ns
            if wall1 > wall0:
                self.achieved_rtf = (self._sim_ns - start_ns) * 1e-9 / (wall1 - wall0)

    def sim_time_ns(self) -> int:
        """Return the simulated time integrated so far [ns] (own-clock mode: the stamp)."""
        return self._sim_ns

    # --- publishing ----------------------------------------------------------------------------
    def _publish_state(self, stamp_ns: int) -> None:
        self.publish_times.append(time.monotonic())
        sample = self.sim.joint_state()
        stamp = _time_msg(stamp_ns)
        js = JointState()
        js.header.stamp = stamp
        js.name = self._names
        js.position = sample.position
        js.velocity = sample.velocity
        js.effort = sample.effort
        self.pub_js.publish(js)
        self.world.tick(self.sim, stamp_ns)
        if not self.pub_ee.get_subscription_count():
            return          # forward kinematics only when someone listens
        pose = PoseStamped()
        pose.header.stamp = stamp
        pose.header.frame_id = self._base_frame
        (x, y, z), (qx, qy, qz, qw) = self.sim.ee_pose_quaternion()
        p, o = pose.pose.position, pose.pose.orientation
        p.x, p.y, p.z = x, y, z
        o.x, o.y, o.z, o.w = qx, qy, qz, qw
        self.pub_ee.publish(pose)

    def _publish_description(self) -> None:
        if not self.model.urdf_xml:
            self.get_logger().warning(f'robot {self.model.name} has no URDF: '
                                      'robot_description not published')
            return
        self.pub_desc.publish(String(data=prefix_urdf(self.model.urdf_xml, robot_name(self))))

    def _refuse(self, reason: str, names) -> None:
        self.get_logger().warning(f'setpoint refused: {reason}', throttle_duration_sec=0.5)
        status = DiagnosticStatus(level=DiagnosticStatus.ERROR,
                                  name=f'{self.get_fully_qualified_name()}: joint_setpoints',
                                  message=f'setpoint refused: {reason}',
                                  hardware_id=robot_name(self) or self.model.name)
        names = [str(n) for n in names]
        shown = ','.join(names[:20]) + (f',... ({len(names)} names)' if len(names) > 20 else '')
        status.values = [KeyValue(key='names', value=shown)]
        diag = DiagnosticArray(status=[status])
        diag.header.stamp = self.get_clock().now().to_msg()
        self.pub_diag.publish(diag)

    def _check_peers(self) -> None:
        """Log (once per change) and report on /diagnostics a second driver in the namespace."""
        ns = '/' + robot_name(self) if robot_name(self) else self.get_namespace()
        message = new_duplicates(self, 'drivers', ns, self._duplicates)
        if message and message != self._duplicates:
            status = DiagnosticStatus(level=DiagnosticStatus.ERROR,
                                      name=f'{self.get_fully_qualified_name()}: peers',
                                      message=message,
                                      hardware_id=robot_name(self) or self.model.name)
            diag = DiagnosticArray(status=[status])
            diag.header.stamp = self.get_clock().now().to_msg()
            self.pub_diag.publish(diag)
        self._duplicates = message

    # --- callbacks -----------------------------------------------------------------------------
    def _catch_up(self) -> None:
        """Follow-clock mode: integrate up to now, so a command applies at its arrival time."""
        if not self._master:
            self._advance_to_clock()

    def _on_setpoints(self, msg: JointState) -> None:
        try:
            # without modes set, the position-only parser (and its messages) as before
            cmd = parse_setpoints(msg.name, msg.position, msg.velocity, msg.effort,
                                  self.sim.command_joints, self.sim.gripper_name,
                                  dict(self.sim.modes) or None)
            self.sim.check(cmd)
            with self._lock:
                self._catch_up()
                self.sim.apply(cmd)
        except Px100Error as exc:
            self._refuse(str(exc), msg.name)

    def _on_torque(self, request, response):
        self._set_all_torque(bool(request.data))
        response.success = True
        response.message = 'torque on' if request.data else 'torque off'
        self.get_logger().info(f'{response.message} (all joints)')
        return response

    def _set_all_torque(self, on: bool) -> None:
        """Set every ``torque_enable.<joint>`` parameter (the callback applies them)."""
        self.set_parameters([Parameter(f'torque_enable.{j}', value=on)
                             for j in self._gain_joints])

    def _stamp_now(self) -> int:
        """Return the stamp [ns] of the current state (simulated time when owning the clock)."""
        return self._sim_ns if self._master else self._start_ns + self._sim_ns

    def _on_reset(self, request, response):
        with self._lock:
            self._catch_up()
            self.sim.reset()
            self.world.publish_now(self.sim, self._stamp_now())
        self._set_all_torque(True)
        response.success = True
        response.message = ('reset to the sleep pose, objects to their initial poses'
                            if self.world.has_objects else 'reset to the sleep pose')
        self.get_logger().info(response.message)
        return response

    def _on_world_reset(self, request, response):
        with self._lock:
            self._catch_up()
            self.sim.reset_scene()
            self.world.publish_now(self.sim, self._stamp_now())
        response.success = True
        response.message = ('objects back to their initial poses' if self.world.has_objects
                            else 'no objects in this scene')
        self.get_logger().info(response.message)
        return response


def _replace_config(config: SimConfig, **changes) -> SimConfig:
    from dataclasses import replace
    return replace(config, **changes)


def main(args=None):
    """Run the sim_driver node until SIGINT; exit 1 with the reason when it cannot start."""
    import sys
    try:
        return spin_node(lambda options: SimDriverNode(), args, schema=SIM_DRIVER,
                         description='Simulated PincherX-100 joint-state driver: MuJoCo physics, '
                                     'XL430 servo model and one PID loop per joint, a scene of '
                                     'objects.')
    except Px100Error as exc:
        print(f'sim_driver: error: {exc}', file=sys.stderr)
        return 1


if __name__ == '__main__':
    import sys
    sys.exit(main())
