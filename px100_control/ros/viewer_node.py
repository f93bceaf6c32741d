"""
viewer: a live 3D page of the robot and its world in the browser (viser), with teleoperation.

``ros2 run px100_control viewer`` serves http://127.0.0.1:8080 (parameters ``host``, ``port``).
The node is a thin adapter over :mod:`px100_control.viewer` (state + viser scene, no rclpy):

- it subscribes to ``robot_description``, ``joint_states``, ``world/markers``,
  ``world/held_object``, the trajectory action's goal events and status and ``compute_ik``'s
  events (:mod:`px100_control.ros.viewer_calls`), ``/diagnostics`` (docs/ros_interfaces.md)
  and the camera (:mod:`px100_control.ros.viewer_camera`) and shows them on the page;
- controls act only through the interfaces a script uses: goals of the action
  ``arm_controller/follow_joint_trajectory`` (sliders, Home/Sleep), ``compute_ik`` then a goal
  to its solution (gizmo), ``commands/joint_setpoints`` (gripper effort), ``world/reset`` and
  ``torque_enable``.

Parameters: :data:`px100_control.parameters.VIEWER` (``--help`` lists them); a host other than
loopback forces read-only unless ``allow_remote_control``. Sliders, limits and goals follow the
arm of the received URDF; ``robot_model`` gives Home/Sleep when its arm is that URDF's. Every
callback runs through a :class:`~px100_control.viewer.guard.Guard`: in a process shared with
sim_driver (``bringup --viewer``) a viewer fault is logged and never stops the executor.
With ``--bag BAG`` it plays a recorded bag in the page instead (no ROS graph needed).
"""
import collections
import math
import sys
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from px100_control.parameters import VIEWER
from px100_control.ros.common import (declare_robot_parameters, frame_id,
                                      ignore_further_interrupts, init_robot_node,
                                      install_stop_signals, LATCHED_QOS, parse_cli, robot_name,
                                      robot_topic, spin_node, stop_requested)
from px100_control.ros.parameter_schema import declare_schema
from px100_control.ros.viewer_calls import ViewerCalls
from px100_control.ros.viewer_camera import ViewerCamera
from px100_control.viewer.bag_view import serve_bag
from px100_control.viewer.controls import (check_settings, DRAG_PERIOD, forced_read_only,
                                           goal_move, GRIPPER_EFFORT, gripper_joint,
                                           model_matches, named_poses)
from px100_control.viewer.guard import Guard
from px100_control.viewer.scene import ViewerScene
from px100_control.viewer.state import RateLimit, stamp_seconds, Throttle, ViewerState
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import MarkerArray


class ViewerNode(Node):
    """The viewer node (see the module doc); ``scene`` is built from the parameters."""

    def __init__(self, **kwargs):
        self.guard = Guard(self._report_fault)      # before any callback is registered
        init_robot_node(self, 'viewer', kwargs)
        self.model = declare_robot_parameters(self)
        declare_schema(self, VIEWER)
        value = self.get_parameter
        host, port = value('host').value, value('port').value
        read_only, remote = value('read_only').value, value('allow_remote_control').value
        rate, trail = float(value('rate').value), int(value('trail_length').value)
        self.moving_time = float(value('moving_time').value)
        check_settings(rate, trail, port)
        if forced_read_only(host, read_only, remote):
            self.get_logger().warning(
                f'host {host} is not loopback: read-only (set allow_remote_control to keep '
                'the controls)')
            read_only = True
        self.read_only = bool(read_only)
        self.period = 1.0 / rate
        self.state = ViewerState(trail_points=trail)
        self._lock = threading.Lock()
        self._actions = collections.deque(maxlen=100)
        self._pending_goal = self._pending_ik = None
        self._goal_throttle, self._ik_throttle = Throttle(DRAG_PERIOD), Throttle(DRAG_PERIOD)
        self._render_limit = RateLimit(rate)
        self._last_joints = -math.inf           # arrival of the last joint_states [s]
        self.arm, self.poses, self.gripper = None, {}, None     # from robot_description
        self.scene = ViewerScene(host=str(host), port=int(port), read_only=self.read_only,
                                 actions=self._on_action, guard=self.guard,
                                 title=f'{robot_name(self) or self.model.name} viewer')
        self.scene.attach(self.state)
        self.url = self.scene.url
        if self.scene.port != int(port):
            self.get_logger().warning(f'port {port} is busy: serving on {self.scene.port}')
        self._base_frame = frame_id(self, self.model.base_frame)
        self.camera = ViewerCamera(self, self.scene, self._base_frame)
        self.create_subscription(String, robot_topic(self, 'robot_description'),
                                 self._on_description, LATCHED_QOS)
        self.create_subscription(JointState, robot_topic(self, 'joint_states'),
                                 self._on_joint_states, 10)
        self.create_subscription(MarkerArray, robot_topic(self, 'world/markers'),
                                 self._on_markers, LATCHED_QOS)
        self.create_subscription(String, robot_topic(self, 'world/held_object'),
                                 self._on_held, LATCHED_QOS)
        self.calls = ViewerCalls(self, self.send_goal)
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics, 10)
        if not self.read_only:
            self.pub_setpoints = self.create_publisher(
                JointState, robot_topic(self, 'commands/joint_setpoints'), 10)
            self.cli_torque = self.create_client(SetBool, robot_topic(self, 'sim/torque_enable'))
            self.cli_world_reset = self.create_client(Trigger, robot_topic(self, 'world/reset'))
        self.create_timer(self.period, self._on_timer)
        self.get_logger().info(f'viewer on {self.url} '
                               f"({'read-only' if self.read_only else 'with controls'})")

    # -- every callback guarded -------------------------------------------------------------
    def create_subscription(self, msg_type, topic, callback, *args, **kwargs):
        """Create a subscription whose callback's faults are logged, never raised."""
        return super().create_subscription(msg_type, topic, self.guard.wrap(callback),
                                           *args, **kwargs)

    def create_timer(self, period, callback, *args, **kwargs):
        """Create a timer whose callback's faults are logged, never raised."""
        return super().create_timer(period, self.guard.wrap(callback), *args, **kwargs)

    def _report_fault(self, text: str) -> None:
        self.get_logger().error(text)
        if self._lock.acquire(timeout=1.0):
            try:
                self.state.set_error(f'viewer {text}')
            finally:
                self._lock.release()

    # -- ROS -> state -----------------------------------------------------------------------
    def _now(self) -> float:
        return time.monotonic()

    def _on_description(self, msg: String) -> None:
        if msg.data == self.state.urdf_xml and self.scene.kin is not None:
            return
        with self._lock:
            self.state.set_robot(msg.data)
            self.scene.load_robot(self.state)
            self._take_arm(self.scene.kin)
        if self.state.robot_error:
            self.get_logger().error(self.state.robot_error)

    def _take_arm(self, kin) -> None:
        """Take the arm, Home/Sleep and gripper of the URDF just loaded (kin None: none)."""
        self.arm = kin.arm if kin is not None else None
        self.poses = named_poses(kin.arm, self.model) if kin is not None else {}
        self.gripper = gripper_joint(self.model, kin.actuated) if kin is not None else None
        self.scene.show_button('sleep', self.poses.get('sleep') is not None)
        if kin is not None and not model_matches(kin.arm, self.model):
            self.get_logger().warning(
                f'robot_description arm {list(kin.arm.joint_names)} is not robot_model '
                f'{self.model.name}: sliders from the URDF, Home = zeros, no Sleep')

    def _on_joint_states(self, msg: JointState) -> None:
        with self._lock:
            self.state.set_joints(msg.name, msg.position, stamp_seconds(msg.header.stamp))
        self._last_joints = self._now()
        self._render()          # at once when the rate allows: no wait for the timer

    def _on_markers(self, msg: MarkerArray) -> None:
        with self._lock:
            self.state.set_markers(msg.markers)

    def _on_held(self, msg: String) -> None:
        with self._lock:
            self.state.set_held(msg.data)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        errors = [s for s in msg.status if s.level >= DiagnosticStatus.ERROR]
        if errors:
            with self._lock:
                self.state.set_error(f'{errors[-1].name}: {errors[-1].message}')

    # -- rendering --------------------------------------------------------------------------
    def _render(self) -> None:
        """Draw what changed if a page is open, at most ``rate`` page updates a second."""
        now = self._now()
        if not self._render_limit.due(now):
            return
        with self._lock:
            sent = self.scene.render(self.state, now)
        if sent:        # only a real update spends the rate
            self._render_limit.mark(now)

    def _on_timer(self) -> None:
        self._run_actions()
        if self._now() - self._last_joints >= self.period:
            self._render()      # joint_states slower than the page (or none): draw here

    # -- page -> ROS ------------------------------------------------------------------------
    def _on_action(self, name: str, **values) -> None:
        """Queue a page action for the executor's thread (viser calls this in its threads)."""
        self._actions.append((name, values))

    def _run_actions(self) -> None:
        now = self._now()
        while self._actions:
            name, values = self._actions.popleft()
            self.guard.call(name, self._act, name, values)
        if self._pending_goal is not None and self._goal_throttle.due(now):
            self._goal_throttle.mark(now)
            self.send_goal(self._pending_goal)
            self._pending_goal = None
        if self._pending_ik is not None and self._ik_throttle.due(now):
            self._ik_throttle.mark(now)
            self.send_ik_request(*self._pending_ik)
            self._pending_ik = None

    def _act(self, name: str, values: dict) -> None:
        if self.read_only:
            return
        if name == 'joint_goal':
            self._pending_goal = dict(values['positions'])
        elif name == 'ee_target':
            self._pending_ik = (values['position'], values.get('quat_xyzw'))
        elif name in ('home', 'sleep'):
            if self.poses.get(name) is None:
                raise ValueError(f'no {name} pose for this robot (robot_model '
                                 f'{self.model.name}, no robot_description or another arm)')
            self.send_goal(dict(zip(self.arm.joint_names, self.poses[name])))
        elif name in ('gripper_open', 'gripper_close'):
            self.send_gripper(GRIPPER_EFFORT if name == 'gripper_open' else -GRIPPER_EFFORT)
        elif name == 'reset_scene':
            self._call(self.cli_world_reset, Trigger.Request(), 'scene reset')
        elif name in ('torque_on', 'torque_off'):
            self._call(self.cli_torque, SetBool.Request(data=name == 'torque_on'),
                       name.replace('_', ' '))
        else:
            raise ValueError(f'unknown action {name!r}')

    def send_goal(self, positions: dict) -> bytes:
        """Send a one-point goal to positions (joint -> rad/m); return its goal id (UUID)."""
        if self.arm is None:
            raise ValueError('no robot_description received yet: no arm to move')
        names, target, t = goal_move(self.arm, positions, self.state.joints, self.moving_time)
        return self.calls.send_goal(self._base_frame, names, target, t)

    def send_ik_request(self, position, quat_xyzw=None) -> None:
        """Call compute_ik (quat None = orientation free); its solution becomes a goal."""
        self.calls.send_ik(self._base_frame, position, quat_xyzw)

    def send_gripper(self, effort: float) -> None:
        """Drive the gripper with effort [N*m] (> 0 opens), as the client's release/grasp."""
        if self.gripper is None:
            raise ValueError(f'no gripper joint (robot_model {self.model.name}) in the URDF')
        msg = JointState(name=[self.gripper], effort=[float(effort)])
        msg.header.stamp = self.get_clock().now().to_msg()
        self.pub_setpoints.publish(msg)

    def _call(self, client, request, what: str) -> None:
        if not client.service_is_ready():
            with self._lock:
                self.state.set_error(f'{what}: service {client.srv_name} is not available')
            return

        def done(future):
            try:
                res = future.result()
                text = f'{what}: ' + ('done' if res.success else f'refused ({res.message})')
            except Exception as exc:  # noqa: B902 - the call failed in the middleware
                text = f'{what}: failed ({exc})'
            with self._lock:
                self.state.set_note(text)
        client.call_async(request).add_done_callback(self.guard.wrap(done, what))

    def destroy_node(self):
        """Stop the web server too."""
        self.scene.close()
        return super().destroy_node()


def _add_arguments(parser) -> None:
    parser.add_argument('--bag', default=None,
                        help='play this bag in the page (time slider) instead of the live graph')
    parser.add_argument('--host', default='127.0.0.1', help='with --bag: bind address')
    parser.add_argument('--port', type=int, default=8080, help='with --bag: port')


def main(args=None) -> int:
    """Run the viewer (``ros2 run px100_control viewer``), or play a bag with ``--bag``."""
    description = 'Serve the live 3D page of the robot and its world, or play a bag with --bag.'
    options, _ = parse_cli(description, args, _add_arguments, (VIEWER,))
    if options.bag:     # no node: SIGINT / SIGTERM end the page loop as they end a spin
        install_stop_signals()
        try:
            return serve_bag(options.bag, host=options.host, port=options.port,
                             stop=stop_requested)
        finally:
            ignore_further_interrupts()
    return spin_node(lambda opts: ViewerNode(), args, description, _add_arguments,
                     schema=VIEWER)


if __name__ == '__main__':
    sys.exit(main())
