"""
The viewer's side of the trajectory action and the IK service: what it shows, what it sends.

Shown (every client's calls, from what the servers publish; docs/ros_interfaces.md):

- goals: ``arm_controller/follow_joint_trajectory/_action/send_goal/_service_event`` (each
  goal request the action server took, with its trajectory) and the action's
  ``_action/status``; a goal is named by the stamp of its request event [s];
- IK: ``compute_ik/_service_event``: the target of each request, the reason of each refusal.

Sent (controls, unless read-only): a goal is a call of the action's goal service
``<action>/_action/send_goal`` (FollowJointTrajectory's SendGoal: a random goal id and the
goal; trajectory stamp zero = start on receipt), as an action client sends it; the viewer
needs no result (the status shows it), and an rclpy service client works in the
EventsExecutor the viewer spins in, where rclpy 7.1's ActionClient does not. The gizmo calls
``compute_ik`` and sends a goal to its solution when it succeeds.
"""
import math
from typing import Callable, Dict, Sequence
import uuid

from action_msgs.msg import GoalStatusArray
from builtin_interfaces.msg import Time
from control_msgs.action import FollowJointTrajectory
from px100_control.ros.action_events import EVENT_QOS
from px100_control.ros.common import LATCHED_QOS, robot_topic
from px100_control.ros.viewer_messages import goal_message, ik_request_message
from px100_control.viewer.state import GOAL_STATUS_NAMES, stamp_seconds
from px100_control_msgs.srv import ComputeIK
from unique_identifier_msgs.msg import UUID

ARM_ACTION = 'arm_controller/follow_joint_trajectory'
SEND_GOAL = FollowJointTrajectory.Impl.SendGoalService
REQUEST_RECEIVED, RESPONSE_SENT = 1, 2


def goal_request(frame: str, names: Sequence[str], target: Sequence[float],
                 seconds: float) -> SEND_GOAL.Request:
    """Return a SendGoal request (new random id) of a one-point goal reached after seconds."""
    request = SEND_GOAL.Request(goal_id=UUID(uuid=list(uuid.uuid4().bytes)))
    request.goal.trajectory = goal_message(Time(), frame, names, target, seconds)
    return request


class ViewerCalls:
    """
    Subscribe a viewer node to the goal and IK events; its goal and IK clients.

    :param node: the ViewerNode (its guarded create_subscription, state and lock)
    :param on_solution: called (executor thread) with {joint: position} of a solved gizmo IK
    """

    def __init__(self, node, on_solution: Callable[[Dict[str, float]], None]):
        self._node = node
        self._on_solution = on_solution
        self._goal_ids: Dict[bytes, float] = {}
        action = robot_topic(node, ARM_ACTION)
        node.create_subscription(SEND_GOAL.Event, action + '/_action/send_goal/_service_event',
                                 self._on_goal_event, EVENT_QOS)
        node.create_subscription(GoalStatusArray, action + '/_action/status', self._on_status,
                                 LATCHED_QOS)
        node.create_subscription(ComputeIK.Event, robot_topic(node, 'compute_ik/_service_event'),
                                 self._on_ik_event, EVENT_QOS)
        if not node.read_only:
            self.cli_goal = node.create_client(SEND_GOAL, action + '/_action/send_goal')
            self.cli_ik = node.create_client(ComputeIK, robot_topic(node, 'compute_ik'))

    # -- shown ------------------------------------------------------------------------------
    def _on_goal_event(self, msg) -> None:
        if msg.info.event_type != REQUEST_RECEIVED or not msg.request:
            return
        goal_id = stamp_seconds(msg.info.stamp)
        request = msg.request[0]
        self._goal_ids[bytes(request.goal_id.uuid)] = goal_id
        while len(self._goal_ids) > 100:
            self._goal_ids.pop(next(iter(self._goal_ids)))
        traj = request.goal.trajectory
        with self._node._lock:
            self._node.state.set_goal(goal_id, traj.joint_names,
                                      [list(p.positions) for p in traj.points])

    def _on_status(self, msg: GoalStatusArray) -> None:
        if not msg.status_list:
            return
        latest = max(msg.status_list, key=lambda s: stamp_seconds(s.goal_info.stamp))
        goal_id = self._goal_ids.get(bytes(latest.goal_info.goal_id.uuid),
                                     stamp_seconds(latest.goal_info.stamp))
        with self._node._lock:
            self._node.state.set_goal_status(
                goal_id, GOAL_STATUS_NAMES.get(latest.status, str(latest.status)))

    def _on_ik_event(self, msg) -> None:
        if msg.info.event_type == REQUEST_RECEIVED and msg.request:
            pose = msg.request[0].target.pose
            p, q = pose.position, pose.orientation
            with self._node._lock:
                self._node.state.set_ik_target((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
        elif msg.info.event_type == RESPONSE_SENT and msg.response and \
                not msg.response[0].success:
            with self._node._lock:
                self._node.state.set_error(f'ik: {msg.response[0].message}')

    # -- sent -------------------------------------------------------------------------------
    def send_goal(self, frame: str, names, target, seconds: float) -> bytes:
        """Send a one-point goal (as the action's goal service call); return its goal id."""
        request = goal_request(frame, names, target, seconds)
        self._call(self.cli_goal, request, 'goal', self._goal_answered)
        return bytes(request.goal_id.uuid)

    def send_ik(self, frame: str, position, quat_xyzw=None) -> None:
        """Call compute_ik (quat None = orientation free); its solution becomes a goal."""
        request = ComputeIK.Request(target=ik_request_message(Time(), frame, position,
                                                              quat_xyzw))
        self._call(self.cli_ik, request, 'ik', self._ik_answered)

    def _call(self, client, request, what: str, answered) -> None:
        if not client.service_is_ready():
            raise ValueError(f'{what}: service {client.srv_name} is not available')
        future = client.call_async(request)
        future.add_done_callback(self._node.guard.wrap(answered, what))

    def _goal_answered(self, future) -> None:
        if not future.result().accepted:
            with self._node._lock:
                self._node.state.set_error('goal: not accepted by the action server')

    def _ik_answered(self, future) -> None:
        res = future.result()
        sol = res.solution
        if res.success and len(sol.position) and all(math.isfinite(v) for v in sol.position):
            self._on_solution(dict(zip(sol.name, sol.position)))
