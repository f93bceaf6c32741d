"""
The client's calls to the nodes: the FollowJointTrajectory action and the IK services.

Moves are goals of ``<robot>/arm_controller/follow_joint_trajectory``
(control_msgs/FollowJointTrajectory, served by trajectory_server), as a ros2_control arm is
driven; IK goes through ``compute_ik`` / ``compute_cartesian_path`` (px100_control_msgs,
ik_service). The servers publish every call as service introspection events, so a recorder
holds each goal, cancel, result and IK request / reply.

rclpy 7.1's EventsExecutor (the client node's) does not serve action clients, so the action
client lives on a helper node ``<client>_actions`` spun by a SingleThreadedExecutor in a
thread of its own. Goals, cancels and result requests are sent from that thread (a task of
its executor): sent from another thread, the server's answer can arrive before rclpy has
registered the request and is then lost (rclpy issue #1123). A cancel is a call of the
action's own service ``<action>/_action/cancel_goal`` (action_msgs/CancelGoal, by goal id)
from the client node: rclpy's service clients are thread-safe, and the cancel skips a hop
through the helper thread (Ctrl-C stops the arm sooner). Callers wait on a threading.Event,
never on spin_until_future_complete.
"""
import threading
import time
from typing import Optional
import uuid

from action_msgs.msg import GoalStatus
from action_msgs.srv import CancelGoal
from control_msgs.action import FollowJointTrajectory
from px100_control.client.robot import SpinThread
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from unique_identifier_msgs.msg import UUID

ARM_ACTION = 'arm_controller/follow_joint_trajectory'
FJT = FollowJointTrajectory
TERMINAL = (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_CANCELED, GoalStatus.STATUS_ABORTED)
#: result codes of a goal refused before it ran (nothing executed)
INVALID_CODES = (FJT.Result.INVALID_GOAL, FJT.Result.INVALID_JOINTS)


class GoalCall:
    """One FollowJointTrajectory goal of this client, filled in by the executor thread."""

    def __init__(self, key):
        """Create the record of the goal numbered ``key`` (the client's ordering key)."""
        self.key = key
        self.event = threading.Event()
        self.handle = None
        self.status: Optional[int] = None
        self.code: Optional[int] = None
        self.reason = ''
        #: the goal id (sent with the goal), and its first 8 hex digits as the server logs it
        self.uuid = uuid.uuid4().bytes
        self.label = self.uuid.hex()[:8]
        self.sent_monotonic = time.monotonic()

    def current_status(self) -> Optional[int]:
        """Return the goal's GoalStatus code: the result's, else the live one, else None."""
        if self.status in TERMINAL or self.handle is None:
            return self.status
        live = self.handle.status
        return live if live != GoalStatus.STATUS_UNKNOWN else self.status


def result_reason(status: int, code: int, text: str) -> str:
    """Return the reason words of an ended goal (refused goals say 'invalid goal: ...')."""
    if status == GoalStatus.STATUS_ABORTED and code in INVALID_CODES:
        return f'invalid goal: {text}'
    return text


class ArmActionLink:
    """The FollowJointTrajectory client of one robot, on its own node and executor thread."""

    def __init__(self, node, node_name: str, action_name: str, callback_group=None):
        """
        Create the helper node ``node_name`` and the action client of ``action_name``.

        :param node: the client's node (it calls the action's cancel service)
        """
        context = node.context
        self.cancel_client = node.create_client(CancelGoal, action_name + '/_action/cancel_goal',
                                                callback_group=callback_group)
        self.node = Node(node_name, context=context, use_global_arguments=False,
                         start_parameter_services=False)
        self.client = ActionClient(self.node, FJT, action_name)
        self.action_name = action_name
        self._executor = SingleThreadedExecutor(context=context)
        self._executor.add_node(self.node)
        self._spin = SpinThread(self._executor, 'interbotix_actions').start()
        self._closed = False

    def ready(self) -> bool:
        """Return True when the action server is discovered (goal, cancel and result)."""
        return self.client.server_is_ready()

    def send(self, goal, call: GoalCall) -> None:
        """Send ``goal`` from the executor thread; ``call`` is filled in as it goes."""
        self._executor.create_task(self._send, goal, call)

    def _send(self, goal, call: GoalCall) -> None:
        future = self.client.send_goal_async(goal, feedback_callback=lambda _fb: _executing(call),
                                             goal_uuid=UUID(uuid=list(call.uuid)))
        future.add_done_callback(lambda f: self._answered(f, call))

    def _answered(self, future, call: GoalCall) -> None:
        handle = future.result() if future.exception() is None else None
        if handle is None or not handle.accepted:
            call.status, call.code = GoalStatus.STATUS_ABORTED, FJT.Result.INVALID_GOAL
            call.reason = 'the goal was rejected by the action server'
            call.event.set()
            return
        call.handle = handle
        if call.status is None:
            call.status = GoalStatus.STATUS_ACCEPTED
        handle.get_result_async().add_done_callback(lambda f: _ended(f, call))

    def cancel(self, call: GoalCall, timeout: float) -> bool:
        """Ask the server to cancel ``call`` (waits for its handle); True if it accepted."""
        end = time.monotonic() + timeout
        while call.handle is None and not call.event.is_set() and time.monotonic() < end:
            time.sleep(0.002)
        if call.handle is None or call.status in TERMINAL or self._closed:
            return False
        request = CancelGoal.Request()
        request.goal_info.goal_id = call.handle.goal_id
        response = call_service(self.cancel_client, request, max(0.0, end - time.monotonic()))
        return response is not None and \
            response.return_code == CancelGoal.Response.ERROR_NONE and \
            len(response.goals_canceling) > 0

    def close(self) -> None:
        """Stop the executor thread; destroy the client and the helper node."""
        if self._closed:
            return
        self._closed = True
        self._spin.stop()
        try:
            self.client.destroy()
            self.node.destroy_node()
        except Exception:  # noqa: B902 - the context was shut down already
            pass


def _executing(call: GoalCall) -> None:
    if call.status not in TERMINAL:
        call.status = GoalStatus.STATUS_EXECUTING


def _ended(future, call: GoalCall) -> None:
    """Record a goal's result (status, error code, reason) and wake its waiters."""
    wrapped = future.result() if future.exception() is None else None
    if wrapped is None:
        call.status, call.reason = GoalStatus.STATUS_ABORTED, 'no result from the action server'
    else:
        call.code = wrapped.result.error_code
        call.reason = result_reason(wrapped.status, call.code, wrapped.result.error_string)
        call.status = wrapped.status
    call.event.set()


def call_service(client, request, timeout: float):
    """Call a service from any thread; return the response, None when none came in time."""
    done = threading.Event()
    future = client.call_async(request)
    future.add_done_callback(lambda _f: done.set())
    if not done.wait(timeout):
        client.remove_pending_request(future)
        return None
    return future.result()
