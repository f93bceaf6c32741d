"""
ik_service: inverse kinematics on request, one reply per request, matched by stamp.

Topics (docs/ros_interfaces.md, relative to ``/<robot_name>``):

- ``ik/request`` (geometry_msgs/PoseStamped): ``header.stamp`` is the request id, ``frame_id``
  empty or ``<robot_name>/base_link`` (``base_link`` is accepted too). An all-zero quaternion
  means "orientation free": position-only IK, the free angles chosen toward ``nominal_pose``.
- ``ik/solution`` (sensor_msgs/JointState): same stamp; the arm joint names and the solution
  closest to the last measured ``joint_states`` (to ``nominal_pose`` before any state arrived);
  ``position`` empty when there is none or the request was refused.
- ``ik/status`` (diagnostic_msgs/DiagnosticStatus): exactly one per request, refused ones too.
  ``name`` ``<robot_name>/ik_service``, ``hardware_id`` the request id ``'sec.nanosec'``,
  ``level`` OK or ERROR, ``message`` 'solved' (with a warning appended when roll/yaw the arm
  cannot reach were dropped) or the reason; ``values``: mode, method, iterations,
  position_error [m], orientation_error [rad], solutions (count), and in 'pitch' mode
  unreachable_roll / unreachable_yaw [rad].
- ``ik/path_request`` (geometry_msgs/PoseArray) -> ``ik/path_solution``
  (trajectory_msgs/JointTrajectory, same stamp): one point per pose, each seeded by the
  previous one (no branch jumps), ``time_from_start`` from the current joint state so no joint
  exceeds ``max_path_joint_velocity`` nor its URDF velocity limit, points at least
  ``min_path_point_time`` apart (the reply can be sent as a trajectory goal as is). A pose
  that fails stops the path: the reply then holds the points solved before it, and the
  ik/status (ERROR, same id) says which pose (value ``failed_index``) and why.

Services ``compute_ik`` and ``compute_cartesian_path`` (px100_control_msgs) answer the same
requests with the same checks and texts: :mod:`px100_control.ros.ik_services`.

Parameters: ``orientation_mode`` 'pitch' (solve position + pitch, report the roll/yaw a
4/5-DOF arm cannot reach; a residual above ``orientation_tolerance`` [rad] is named in the
message) or 'strict' (the whole pose or nothing); ``method`` ('auto' analytic where the robot
has one, iterative otherwise or as a fallback); ``tol_position`` [m], ``tol_orientation``
[rad], ``max_iterations``; ``nominal_pose`` (default: the model's home pose).
The IK itself is :func:`px100_control.kinematics.solve.solve_ik` / ``solve_path``.

Every request goes through ``solve_ik`` (the function the client and the benchmarks call: closed
forms first on plain floats, the iterative search only where needed). Throughput: requests are
read serialized (header, frame and pose straight from the CDR bytes) and every request already
queued is answered in the same executor wake-up. Replies are written as CDR bytes (``ros.cdr``,
checked at start against the middleware's deserializer; preallocated messages otherwise). The
node spins single-threaded.
"""
import sys
import threading

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseArray, PoseStamped
import numpy as np
from px100_control.control.ik_requests import (ik_answer, MODES, parameter_error, path_targets,
                                               plan_path)
from px100_control.errors import InvalidInputError
from px100_control.parameters import IK_SERVICE
from px100_control.ros import cdr
from px100_control.ros.common import (declare_robot_parameters, frame_id, robot_name,
                                      robot_node_kwargs, robot_topic, spin_node)
from px100_control.ros.conversions import pose_values_to_matrix, stamp_id
from px100_control.ros.ik_messages import IkReplies, parse_pose_stamped
from px100_control.ros.ik_services import IkServices, pose_values
from px100_control.ros.parameter_schema import declare_schema
from px100_control.wire.private_api import take_serialized
from rcl_interfaces.msg import SetParametersResult
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, qos_profile_sensor_data, QoSProfile,
                       ReliabilityPolicy)
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

NODE_NAME = 'ik_service'

#: requests and replies: reliable and deep, so bursts from many clients lose nothing
REQUEST_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)

__all__ = ['IkServiceNode', 'main', 'parse_pose_stamped', 'REQUEST_QOS']


class IkServiceNode(Node):
    """Answer ik/request and ik/path_request with the IK of the robot model."""

    def __init__(self, **node_kwargs):
        super().__init__(NODE_NAME, **robot_node_kwargs(NODE_NAME, node_kwargs))
        self.model = declare_robot_parameters(self)
        declare_schema(self, IK_SERVICE,
                       defaults={'nominal_pose': [float(x) for x in self.model.home]})
        self.add_on_set_parameters_callback(self._check_parameters)
        bad = self._check_parameters([self.get_parameter(n) for n in IK_SERVICE.names
                                      if n not in ('robot_model', 'robot_name')]).reason
        if bad:
            raise InvalidInputError(f'ik_service parameters: {bad}')
        self._names = list(self.model.joint_names)
        self._index = {name: i for i, name in enumerate(self._names)}
        self._frames = ('', frame_id(self, self.model.base_frame), self.model.base_frame)
        self._diag_name = f'{robot_name(self) or "px100"}/{NODE_NAME}'
        self._lock = threading.Lock()
        self._meas = np.full(self.model.dof, np.nan)
        self._have_state = False
        self._js_names = None
        self._js_map = None
        self._max_batch = 256         # queued requests answered per executor wake-up
        self._load_parameters()
        self.add_post_set_parameters_callback(lambda params: self._load_parameters())
        self._raw_replies = cdr.matches_rclpy()
        self._raw_requests = cdr.pose_stamped_matches_rclpy()
        self._replies = IkReplies(self._names, self._diag_name)
        self._pub_solution = self.create_publisher(JointState, robot_topic(self, 'ik/solution'),
                                                   REQUEST_QOS)
        self._pub_status = self.create_publisher(DiagnosticStatus,
                                                 robot_topic(self, 'ik/status'), REQUEST_QOS)
        self._pub_path = self.create_publisher(JointTrajectory,
                                               robot_topic(self, 'ik/path_solution'), 100)
        self.create_subscription(JointState, robot_topic(self, 'joint_states'),
                                 self._on_joint_states, qos_profile_sensor_data)
        self._request_sub = self.create_subscription(
            PoseStamped, robot_topic(self, 'ik/request'), self._on_request, REQUEST_QOS,
            raw=True)
        self.create_subscription(PoseArray, robot_topic(self, 'ik/path_request'),
                                 self._on_path_request, 100)
        self._ik_services = IkServices(self)
        self.get_logger().info(
            f'ik_service ready: {self.model.name} ({self.model.dof} joints, analytic '
            f'{self.model.analytic_ik or "none"}), orientation_mode {self._mode_param}')

    # ------------------------------------------------------------------ parameters
    def _check_parameters(self, params) -> SetParametersResult:
        for p in params:
            error = parameter_error(p.name, p.value, self.model.dof)
            if error:
                return SetParametersResult(successful=False, reason=error)
        return SetParametersResult(successful=True)

    def _load_parameters(self) -> None:
        """Freeze the parameters into plain attributes (read on every request)."""
        get = self.get_parameter
        self._mode_param = str(get('orientation_mode').value)
        self._mode = MODES[self._mode_param]
        self._orientation_tol = float(get('orientation_tolerance').value)
        self._nominal = np.asarray(get('nominal_pose').value, float)
        self._kwargs = {'method': str(get('method').value),
                        'tol_position': float(get('tol_position').value),
                        'tol_orientation': float(get('tol_orientation').value),
                        'max_iterations': int(get('max_iterations').value)}

    # ------------------------------------------------------------------ inputs
    def _on_joint_states(self, msg: JointState) -> None:
        if msg.name != self._js_names:
            self._js_names = list(msg.name)
            self._js_map = [(i, self._index[x]) for i, x in enumerate(msg.name)
                            if x in self._index]
        pos = msg.position
        with self._lock:
            for i, j in self._js_map:
                if i < len(pos):
                    self._meas[j] = pos[i]
            self._have_state = not np.any(np.isnan(self._meas))

    def _seed(self) -> np.ndarray:
        """Return the current measured arm state, or the nominal pose before any arrived."""
        with self._lock:
            return self._meas.copy() if self._have_state else self._nominal

    def _target(self, frame: str, values):
        """Return (T, mode) of a request pose; raise InvalidInputError when it is malformed."""
        if frame not in self._frames:
            raise InvalidInputError(
                f"frame_id '{frame}' is not the base frame '{self._frames[1]}' "
                '(no tf lookup here: send targets in the base frame)')
        T, free = pose_values_to_matrix(values, allow_zero_quaternion=True)
        return T, ('position' if free else self._mode)

    def _on_request(self, raw: bytes) -> None:
        """Answer this request and every other one already queued (one executor wake-up)."""
        seed = self._seed()
        for req in self._batch(raw):
            try:
                stamp, frame, values = parse_pose_stamped(req, self._raw_requests)
            except Exception as exc:  # noqa: B902 - unreadable bytes: no id to answer to
                self.get_logger().error(f'unreadable ik/request dropped: {exc!r}')
                continue
            try:
                T, mode = self._target(frame, values)
            except InvalidInputError as exc:
                self._reply(stamp, None, DiagnosticStatus.ERROR, f'invalid request: {exc}', ())
                continue
            self._solve_one(stamp, T, mode, seed)

    def _batch(self, raw: bytes) -> list:
        """Return [raw] and the requests waiting in the subscription queue (up to a batch)."""
        batch = [raw]
        while len(batch) < self._max_batch:
            try:
                taken = take_serialized(self._request_sub)
            except Exception:  # noqa: B902 - draining is an optimisation; the executor takes it
                taken = None
            if taken is None:
                break
            batch.append(taken[0])
        return batch

    def _solve_one(self, stamp, T, mode: str, seed) -> None:
        """Solve one request with solve_ik (``ik_answer``) and publish its reply."""
        try:
            ans = ik_answer(self.model, T, mode, seed, self._nominal, self._kwargs,
                            self._orientation_tol)
        except Exception as exc:  # noqa: B902 - a request must never stop the node
            self.get_logger().error(f'ik request {stamp_id(stamp)}: internal error {exc!r}')
            self._reply(stamp, None, DiagnosticStatus.ERROR, f'internal error: {exc!r}', ())
            return
        self._reply(stamp, ans.q, DiagnosticStatus.OK if ans.ok else DiagnosticStatus.ERROR,
                    ans.message, ans.values)

    def _reply(self, stamp, q, level: int, message: str, values) -> None:
        """Publish the solution and the status of one request (CDR bytes or reused messages)."""
        pair = None
        if self._raw_replies:
            try:
                pair = self._replies.raw(stamp, q, level, message, values)
            except Exception as exc:  # noqa: B902 - the message path below still answers
                self.get_logger().error(f'ik request {stamp_id(stamp)}: CDR reply failed '
                                        f'({exc!r})')
        if pair is None:
            pair = self._replies.messages(stamp, q, level, message, values)
        self._pub_solution.publish(pair[0])
        self._pub_status.publish(pair[1])
        if level != DiagnosticStatus.OK:
            self.get_logger().warning(f'ik request {stamp_id(stamp)}: {message}',
                                      throttle_duration_sec=1.0)

    # ------------------------------------------------------------------ paths
    def _on_path_request(self, msg: PoseArray) -> None:
        reply = JointTrajectory(header=msg.header, joint_names=list(self._names))
        try:
            targets, mode = path_targets([pose_values(p) for p in msg.poses],
                                         lambda pose: self._target(msg.header.frame_id, pose))
            plan = plan_path(self.model, targets, mode, self._seed(), self._nominal,
                             self._kwargs, self.get_parameter('max_path_joint_velocity').value,
                             self.get_parameter('min_path_point_time').value)
        except InvalidInputError as exc:
            self._pub_path.publish(reply)
            return self._path_status(msg.header.stamp, f'invalid path request: {exc}',
                                     [('poses', str(len(msg.poses))), ('solved', '0')])
        except Exception as exc:  # noqa: B902 - a request must never stop the node
            self._pub_path.publish(reply)
            return self._path_status(msg.header.stamp, f'internal error: {exc!r}', [])
        reply.points = [JointTrajectoryPoint(positions=q, time_from_start=Duration(
            seconds=t).to_msg()) for q, t in plan.points]
        self._pub_path.publish(reply)
        self._path_status(msg.header.stamp, plan.message, plan.values, plan.ok)

    def _path_status(self, stamp, message: str, values, ok: bool = False) -> None:
        level = DiagnosticStatus.OK if ok else DiagnosticStatus.ERROR
        st = DiagnosticStatus(level=level, name=self._diag_name, message=message,
                              hardware_id=stamp_id(stamp),
                              values=[KeyValue(key=k, value=v) for k, v in values])
        self._pub_status.publish(st)
        if not ok:
            self.get_logger().warning(f'ik path request {st.hardware_id}: {message}')


def main(args=None):
    """Run the ik_service node (``ros2 run px100_control ik_service``)."""
    return spin_node(lambda options: IkServiceNode(), args, schema=IK_SERVICE,
                     description='Inverse kinematics service of px100_control '
                                 '(ik/request -> ik/solution + ik/status, ik/path_request).')


if __name__ == '__main__':
    sys.exit(main())
