"""
sim_driver: the simulated joint-state driver (joint dynamics + one PID loop per joint).

A thin rclpy adapter over :class:`px100_control.sim.simulator.ArmSimulator` and xs_sdk's
interface (:mod:`px100_control.ros.xs_interface`; docs/ros_interfaces.md). In the robot ns:

- pub ``joint_states`` (sensor_msgs/JointState, ``publish_rate``): arm joints, gripper,
  left_finger, right_finger; position, velocity, effort (N*m; fingers m, m/s, N);
- pub ``ee_pose`` (geometry_msgs/PoseStamped, same rate, frame ``<robot_name>/base_link``);
- pub ``robot_description`` (std_msgs/String, transient local), link names ``<robot_name>/...``;
- sub ``commands/joint_setpoints`` (sensor_msgs/JointState): position (+ optional velocity
  feed-forward) for any subset of joints, or effort [N*m] for the gripper alone; a refused
  message is logged and published on ``/diagnostics`` and nothing of it is applied;
- services ``sim/torque_enable`` (std_srvs/SetBool: every joint), ``reset`` (Trigger: the
  arm to its sleep pose and the scene's objects to their initial poses);
- the world of the ``scene`` parameter: pub ``world/markers`` (visualization_msgs/MarkerArray,
  transient local, ``world_rate``: one marker per body, poses in ``<robot_name>/base_link``),
  pub ``world/held_object`` (std_msgs/String, transient local, on every change: the name of the
  object between the fingers, '' for none), service ``world/reset`` (std_srvs/Trigger: objects
  back to their initial poses, the arm untouched).

Torque per joint: parameter ``torque_enable.<joint>`` (bool, every arm joint and the gripper;
``ros2 param set /px100/sim_driver torque_enable.gripper false`` switches off only the
gripper); the ``sim/torque_enable`` service sets all of them, ``reset`` turns them all on.

Control mode per joint: parameter ``operating_mode.<joint>`` (string): '' (default: position;
the gripper takes position or effort), 'position', 'velocity', 'torque' or 'duty'. The joint's
setpoints on ``commands/joint_setpoints`` are then ``position`` [rad] (+ ``velocity``
feed-forward), ``velocity`` alone [rad/s], ``effort`` [N*m] (torque: DYNAMIXEL current
control) or ``effort`` as PWM duty in [-1, 1]; a setpoint of another kind is refused with the
reason (never executed as something else). Changing the mode makes the joint hold (position:
where it is; velocity: 0 rad/s; torque, duty: zero output). A new ``scene`` keeps both.

Time: the physics runs at ``control_rate`` in fixed steps (:mod:`px100_control.sim.stepper`,
paced by :mod:`px100_control.ros.sim_physics`). With ``real_time_factor`` 1 and
``publish_clock`` false (default) it follows the node clock (wall time, or ``/clock`` with
``use_sim_time``) and stamps with it. Otherwise the driver owns the clock: simulated time from
0 at ``real_time_factor`` x wall time (0 or inf: as fast as possible; changeable live), stamps
with it and publishes ``/clock`` (rosgraph_msgs/Clock) at ``clock_rate`` of simulated time.

Parameters (:data:`px100_control.parameters.SIM_DRIVER`, defaults in config/px100.yaml,
validated live): rates, clock, ``object_width`` [m] (a finger stop, no object; 0 = off), scene
(a bad one is refused with the loader's reason: at start the node exits non-zero), gains
units, and per joint ``gains.<joint>.<field>``, ``torque_enable.<joint>``,
``operating_mode.<joint>``.
"""
import collections
from dataclasses import replace
import sys
import time
from typing import List, Optional

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from px100_control.errors import Px100Error
from px100_control.models.urdf_prefix import prefix_urdf
from px100_control.parameters import SIM_DRIVER
from px100_control.ros.common import (declare_robot_parameters, frame_id, init_robot_node,
                                      LATCHED_QOS, robot_name, robot_topic, spin_node)
from px100_control.ros.conversions import time_from_ns
from px100_control.ros.parameter_schema import declare_schema
from px100_control.ros.peers import new_duplicates
from px100_control.ros.sim_joint_parameters import JointParameters
from px100_control.ros.sim_messages import (error_array, Outbox, pose_stamped, shown_names,
                                            StateMessages)
from px100_control.ros.sim_physics import PhysicsThread, YieldingLock
from px100_control.ros.world import WorldPublisher
from px100_control.ros.xs_interface import XsInterface
from px100_control.sim.driver_parameters import (core_change_error, core_error, CORE_PARAMS,
                                                 GAINS_UNITS)
from px100_control.sim.simulator import ArmSimulator, parse_setpoints, SimConfig
from px100_control.sim.stepper import Stepper
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger

#: how often the graph is searched for a second driver in the namespace [s]
PEER_CHECK_PERIOD = 2.0


class SimDriverNode(Node):
    """The simulated PX100 driver node ('sim_driver'); kwargs go to rclpy Node."""

    def __init__(self, **node_kwargs):
        init_robot_node(self, 'sim_driver', node_kwargs)
        self.model = declare_robot_parameters(self)
        declare_schema(self, SIM_DRIVER)
        p = {name: self.get_parameter(name).value for name in CORE_PARAMS}
        if p['gains_units'] not in GAINS_UNITS:
            raise Px100Error(f"gains_units must be 'si' or 'dynamixel', not "
                             f"{p['gains_units']!r}")
        error = core_error(p)
        if error:
            raise Px100Error(error)
        self.sim = ArmSimulator(self.model, SimConfig(
            control_rate=float(p['control_rate']), dynamics_divider=int(p['dynamics_divider']),
            object_width=float(p['object_width'])),
            scene=WorldPublisher.load(self.get_parameter('scene').value, self.model))
        self.joint_parameters = JointParameters(self, p['gains_units'],
                                                self.sim.command_joints)
        self.joint_parameters.declare(self.sim)
        for note in self.sim.dynamics.notes:
            self.get_logger().info(f'dynamics: {note}')
        self._lock = YieldingLock()
        # One reentrant group for every callback, serialised by self._lock: a mutually
        # exclusive group drops a busy timer from the multi-threaded executor's wait set and
        # it then fires late, in pairs (p50 publish jitter 8 ms instead of 0.2 ms).
        self._group = ReentrantCallbackGroup()
        self.stepper = Stepper(
            self.sim, float(p['control_rate']), float(p['publish_rate']), float(p['clock_rate']),
            float(p['real_time_factor']),
            master=float(p['real_time_factor']) != 1.0 or bool(p['publish_clock']),
            warn=lambda text: self.get_logger().warning(text, throttle_duration_sec=5.0))
        self._names = list(self.sim.joint_state().name)
        self._base_frame = frame_id(self, self.model.base_frame)
        self._make_interfaces(float(p['world_rate']))
        self._pending_scene = None
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._publish_description()
        self._start_clock()
        self._duplicates = ''
        self.create_timer(PEER_CHECK_PERIOD, self._check_peers, callback_group=self._group)
        s = self.stepper
        mode = (f'own clock, real_time_factor {s.rtf:g}, /clock at {s.clock_rate:g} Hz'
                if s.master else 'following the node clock')
        self.get_logger().info(
            f'sim_driver for {self.model.name}: {len(self._names)} joints, physics at '
            f'{1e9 / s.dt_ns:g} Hz, joint_states at {s.publish_rate:g} Hz, {mode}')

    def _make_interfaces(self, world_rate: float) -> None:
        """Create the publishers, the setpoint subscription, the services and the world."""
        self.pub_js = self.create_publisher(JointState, robot_topic(self, 'joint_states'), 10)
        self._out = StateMessages(self._names)        # joint_states and /clock to publish
        self._outbox = Outbox()                       # batched while running as fast as possible
        self.pub_ee = self.create_publisher(PoseStamped, robot_topic(self, 'ee_pose'), 10)
        self.pub_desc = self.create_publisher(String, robot_topic(self, 'robot_description'),
                                              LATCHED_QOS)
        self.pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.pub_clock = (self.create_publisher(ClockMsg, '/clock', QoSProfile(depth=10))
                          if self.stepper.master else None)
        self.create_subscription(JointState, robot_topic(self, 'commands/joint_setpoints'),
                                 self._on_setpoints, 50, callback_group=self._group)
        for srv, name, callback in ((SetBool, 'sim/torque_enable', self._on_torque),
                                    (Trigger, 'reset', self._on_reset),
                                    (Trigger, 'world/reset', self._on_world_reset)):
            self.create_service(srv, robot_topic(self, name), callback,
                                callback_group=self._group)
        self.world = WorldPublisher(self, self._base_frame, world_rate, self._outbox)
        self.xs = XsInterface(self, self._group)

    def _start_clock(self) -> None:
        """Anchor the simulated time on the node clock; start the physics thread."""
        self.stepper.start_ns = self.get_clock().now().nanoseconds
        if self.stepper.master:
            self._publish_clock(0)
        #: monotonic wall times [s] of the last joint_states publications (for timing checks)
        self.publish_times = collections.deque(maxlen=10000)
        self.physics = PhysicsThread(
            self, self.stepper, self._lock, bool(self.get_parameter('use_sim_time').value),
            self._group, publish={'state': self._publish_state, 'clock': self._publish_clock},
            outbox=self._outbox)
        self.physics.start()

    # --- parameters ----------------------------------------------------------------------------
    def _current(self, name: str):
        return self.get_parameter(name).value

    def _validate_parameters(self, params: List[Parameter]) -> SetParametersResult:
        changed = {prm.name: prm.value for prm in params}
        error = (self.joint_parameters.error(self.sim, changed)
                 or self._scene_error(changed)
                 or core_change_error(changed, self._current, self.sim, self.stepper))
        if error:
            return SetParametersResult(successful=False, reason=error)
        return SetParametersResult(successful=True)

    def _scene_error(self, changed: dict) -> Optional[str]:
        """Load a changed ``scene`` (applied after the change is accepted); return why not."""
        if 'scene' not in changed:
            return None
        try:
            self._pending_scene = WorldPublisher.load(changed['scene'], self.model)
        except Px100Error as exc:
            return f'scene: {exc}'
        return None

    def _apply_parameters(self, params: List[Parameter]) -> None:
        changed = {prm.name: prm.value for prm in params}
        with self._lock:
            self.joint_parameters.apply(self.sim, changed, self.physics.catch_up)
            if 'object_width' in changed:
                self.sim.set_object_width(float(changed['object_width']))
            if 'world_rate' in changed:
                self.world.rate = float(changed['world_rate'])
            if 'scene' in changed:
                self._load_scene(changed['scene'])
            self._apply_rates(changed)

    def _load_scene(self, value: str) -> None:
        """Build a new plant with the pending scene: the arm at its sleep pose, same gains."""
        scene, self._pending_scene = self._pending_scene, None
        old = self.sim
        self.sim = self.stepper.sim = ArmSimulator(self.model, old.config, scene=scene, gains={
            joint: old.gains(joint) for joint in self.joint_parameters.joints})
        self.joint_parameters.carry_over(self.sim)
        self.world.publish_now(self.sim, self.stepper.stamp_ns)
        self.get_logger().info(f'scene {value!r} loaded; the arm is at its sleep pose, the '
                               'objects at their initial poses')

    def _apply_rates(self, changed: dict) -> None:
        """Apply dynamics_divider, control_rate, clock_rate, real_time_factor, publish_rate."""
        if 'dynamics_divider' in changed:
            self.sim.config = replace(self.sim.config,
                                      dynamics_divider=int(changed['dynamics_divider']))
        if 'control_rate' in changed:
            self.stepper.set_control_rate(float(changed['control_rate']))
        if 'clock_rate' in changed:
            self.stepper.clock_rate = float(changed['clock_rate'])
        if 'real_time_factor' in changed:
            self.stepper.set_rtf(float(changed['real_time_factor']))
        if 'publish_rate' in changed:
            self.stepper.publish_rate = float(changed['publish_rate'])
            self.physics.retime()

    # --- timing -------------------------------------------------------------------------------
    def sim_time_ns(self) -> int:
        """Return the simulated time integrated so far [ns] (own-clock mode: the stamp)."""
        return self.stepper.sim_ns

    @property
    def achieved_rtf(self) -> float:
        """Return the real-time factor of the last own-clock tick (NaN before one)."""
        return self.stepper.achieved_rtf

    def stop_physics(self) -> None:
        """Stop the physics thread (the node then only answers services and parameters)."""
        self.physics.stop()

    def destroy_node(self):
        """Stop the physics thread, then destroy the node."""
        self.stop_physics()
        return super().destroy_node()

    # --- publishing ----------------------------------------------------------------------------
    def _publish_clock(self, stamp_ns: int) -> None:
        self._outbox.publish(self.pub_clock, self._out.clock(stamp_ns))

    def _publish_state(self, stamp_ns: int) -> None:
        self.publish_times.append(time.monotonic())
        self._outbox.publish(self.pub_js, self._out.joint_state(stamp_ns, self.sim.joint_state()))
        self.world.tick(self.sim, stamp_ns)
        if self.pub_ee.get_subscription_count():  # forward kinematics only when someone listens
            self.pub_ee.publish(pose_stamped(time_from_ns(stamp_ns), self._base_frame,
                                             *self.sim.ee_pose_quaternion()))

    def _publish_description(self) -> None:
        if not self.model.urdf_xml:
            self.get_logger().warning(f'robot {self.model.name} has no URDF: '
                                      'robot_description not published')
            return
        self.pub_desc.publish(String(data=prefix_urdf(self.model.urdf_xml, robot_name(self))))

    def _publish_error(self, what: str, message: str, values=()) -> None:
        """Publish an ERROR status '<node>: <what>' on /diagnostics."""
        self.pub_diag.publish(error_array(
            self.get_clock().now().to_msg(), f'{self.get_fully_qualified_name()}: {what}',
            message, robot_name(self) or self.model.name, values))

    def _check_peers(self) -> None:
        """Log (once per change) and report on /diagnostics a second driver in the namespace."""
        ns = self.get_namespace()    # where its topics are (robot_name may differ)
        message = new_duplicates(self, 'drivers', ns, self._duplicates)
        if message and message != self._duplicates:
            self._publish_error('peers', message)
        self._duplicates = message

    # --- callbacks -----------------------------------------------------------------------------
    def _on_setpoints(self, msg: JointState) -> None:
        try:
            # without modes set, the position-only parser (and its messages) as before
            cmd = parse_setpoints(msg.name, msg.position, msg.velocity, msg.effort,
                                  self.sim.command_joints, self.sim.gripper_name,
                                  dict(self.sim.modes) or None)
            self.sim.check(cmd)
            with self._lock:
                self.physics.catch_up()
                self.sim.apply(cmd)
        except Px100Error as exc:
            self.get_logger().warning(f'setpoint refused: {exc}', throttle_duration_sec=0.5)
            self._publish_error('joint_setpoints', f'setpoint refused: {exc}',
                                [('names', shown_names(msg.name))])

    def _on_torque(self, request, response):
        self._set_all_torque(bool(request.data))
        response.success = True
        response.message = 'torque on' if request.data else 'torque off'
        self.get_logger().info(f'{response.message} (all joints)')
        return response

    def _set_all_torque(self, on: bool) -> None:
        """Set every ``torque_enable.<joint>`` parameter (the callback applies them)."""
        self.set_parameters([Parameter(f'torque_enable.{j}', value=on)
                             for j in self.joint_parameters.joints])

    def _on_reset(self, request, response):
        with self._lock:
            self.physics.catch_up()
            self.sim.reset()
            self.xs.driver.stop(self.xs.driver.joints)
            self.world.publish_now(self.sim, self.stepper.stamp_ns)
        self._set_all_torque(True)
        response.success = True
        response.message = ('reset to the sleep pose, objects to their initial poses'
                            if self.world.has_objects else 'reset to the sleep pose')
        self.get_logger().info(response.message)
        return response

    def _on_world_reset(self, request, response):
        with self._lock:
            self.physics.catch_up()
            self.sim.reset_scene()
            self.world.publish_now(self.sim, self.stepper.stamp_ns)
        response.success = True
        response.message = ('objects back to their initial poses' if self.world.has_objects
                            else 'no objects in this scene')
        self.get_logger().info(response.message)
        return response


def main(args=None):
    """Run the sim_driver node until SIGINT; exit 1 with the reason when it cannot start."""
    try:
        return spin_node(lambda options: SimDriverNode(), args, schema=SIM_DRIVER,
                         description='Simulated PincherX-100 joint-state driver: MuJoCo physics, '
                                     'XL430 servo model and one PID loop per joint, a scene of '
                                     'objects.')
    except Px100Error as exc:
        print(f'sim_driver: error: {exc}', file=sys.stderr)
        return 1


if __name__ == '__main__':
    sys.exit(main())
