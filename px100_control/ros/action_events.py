"""
Service introspection for action servers: every goal, cancel and result call as events.

rclpy 7.1.6's ``ActionServer`` has no ``configure_introspection`` (its services are inside
rcl_action, out of reach of rclpy's service introspection). :class:`IntrospectedActionServer`
publishes what rcl's introspection would, in CONTENTS mode: for each of the action's internal
services ``<action>/_action/send_goal``, ``cancel_goal`` and ``get_result`` an event on
``<service>/_service_event`` of the generated ``<Service>_Event`` type (e.g.
``control_msgs/action/FollowJointTrajectory_SendGoal_Event``,
``action_msgs/srv/CancelGoal_Event``):
REQUEST_RECEIVED with the request when the server takes it, RESPONSE_SENT with the response
when it answers; ``info.stamp`` the node clock then, ``info.sequence_number`` the request's
(rmw request id), ``info.client_gid`` zeros (rclpy does not expose the client's gid).

The server also runs goals without an execute coroutine (an accepted goal's ``execute()``
calls ``on_execute(goal_handle)``; the caller later ends it with :meth:`complete`): a goal
executed by another node's engine needs no task polling a future.
"""
from action_msgs.msg import GoalStatus
from rclpy.action import ActionServer, CancelResponse
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from service_msgs.msg import ServiceEventInfo

#: the events' QoS: reliable, volatile, deep enough for a burst of calls
EVENT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


class ServiceEvents:
    """Publish one service's introspection events on ``<service>/_service_event``."""

    def __init__(self, node, srv_type, service_name: str):
        """Create the publisher of ``srv_type.Event`` for the fully qualified service name."""
        self._node = node
        self._type = srv_type
        self.topic = service_name + '/_service_event'
        self._pub = node.create_publisher(srv_type.Event, self.topic, EVENT_QOS)

    def publish(self, event_type: int, header, request=None, response=None) -> None:
        """Publish one event; ``header`` is the rmw request id the server took."""
        msg = self._type.Event()
        msg.info = ServiceEventInfo(event_type=event_type,
                                    stamp=self._node.get_clock().now().to_msg(),
                                    sequence_number=int(header.sequence_number))
        if request is not None:
            msg.request = [request]
        if response is not None:
            msg.response = [response]
        self._pub.publish(msg)


class IntrospectedActionServer(ActionServer):
    """An rclpy ActionServer that publishes its service events and completes goals on demand."""

    def __init__(self, node, action_type, action_name: str, on_execute, *, goal_callback,
                 cancel_callback):
        """
        Serve ``action_name`` (fully qualified) with ``node``.

        Goals are accepted or not by ``goal_callback`` (rclpy's), and an accepted goal is
        executed at once: ``on_execute(goal_handle)`` starts it; end it with :meth:`complete`.
        """
        self._on_execute = on_execute
        self._cancel_user = cancel_callback
        self._cancel_accepted = set()
        self._answered = set()
        super().__init__(node, action_type, action_name, on_execute, goal_callback=goal_callback,
                         cancel_callback=self._on_cancel_request,
                         handle_accepted_callback=self._on_accepted)
        impl = action_type.Impl
        base = action_name + '/_action/'
        self._goal_events = ServiceEvents(node, impl.SendGoalService, base + 'send_goal')
        self._cancel_events = ServiceEvents(node, impl.CancelGoalService, base + 'cancel_goal')
        self._result_events = ServiceEvents(node, impl.GetResultService, base + 'get_result')
        self._headers = {}

    @property
    def event_topics(self):
        """Return the three ``_service_event`` topic names."""
        return [e.topic for e in (self._goal_events, self._cancel_events, self._result_events)]

    # ------------------------------------------------------------------ execution
    def notify_execute(self, goal_handle, execute_callback):
        """Start an accepted goal (rclpy calls this from ``goal_handle.execute()``)."""
        self._on_execute(goal_handle)

    def complete(self, goal_handle, result) -> None:
        """Send ``result`` for a goal whose handle is in a terminal state."""
        response = self._action_type.Impl.GetResultService.Response()
        response.status = goal_handle.status
        response.result = result
        future = self._result_futures.get(bytes(goal_handle.goal_id.uuid))
        if future is not None and not future.done():
            future.set_result(response)

    def end(self, goal_handle, status: int, result) -> None:
        """
        Move a goal to ``status`` (SUCCEEDED, ABORTED, CANCELED) and send ``result``.

        CANCELED from EXECUTING (a preempted goal) passes through CANCELING, as rclcpp's
        ``canceled()`` of a running goal does.
        """
        if status == GoalStatus.STATUS_SUCCEEDED:
            goal_handle.succeed()
        elif status == GoalStatus.STATUS_ABORTED:
            goal_handle.abort()
        else:
            if goal_handle.status == GoalStatus.STATUS_EXECUTING:
                goal_handle._update_state(_rclpy.GoalEvent.CANCEL_GOAL)
            goal_handle.canceled()
        self.complete(goal_handle, result)

    def _on_accepted(self, goal_handle) -> None:
        uuid = bytes(goal_handle.goal_id.uuid)
        header = self._headers.pop(uuid, None)
        if header is not None:
            self._answered.add(uuid)
            response = self._action_type.Impl.SendGoalService.Response(
                accepted=True, stamp=goal_handle._goal_info.stamp)
            self._goal_events.publish(ServiceEventInfo.RESPONSE_SENT, header, response=response)
        goal_handle.execute()

    def _on_cancel_request(self, goal_handle):
        response = self._cancel_user(goal_handle)
        if response == CancelResponse.ACCEPT:
            self._cancel_accepted.add(bytes(goal_handle.goal_id.uuid))
        return response

    # ------------------------------------------------------------------ the three services
    async def _execute_goal_request(self, request_header_and_message):
        header, request = request_header_and_message
        uuid = bytes(request.goal_id.uuid)
        self._goal_events.publish(ServiceEventInfo.REQUEST_RECEIVED, header, request=request)
        self._headers[uuid] = header
        await super()._execute_goal_request(request_header_and_message)
        self._headers.pop(uuid, None)
        if uuid in self._answered:
            self._answered.discard(uuid)
        else:   # refused (or a duplicate id): the server answered accepted = False
            response = self._action_type.Impl.SendGoalService.Response(accepted=False)
            self._goal_events.publish(ServiceEventInfo.RESPONSE_SENT, header, response=response)

    async def _execute_cancel_request(self, request_header_and_message):
        header, request = request_header_and_message
        self._cancel_events.publish(ServiceEventInfo.REQUEST_RECEIVED, header, request=request)
        impl = self._action_type.Impl.CancelGoalService
        with self._lock:   # the response rclpy starts from (no side effects)
            response = self._handle.process_cancel_request(request, impl.Response)
        self._cancel_accepted.clear()
        await super()._execute_cancel_request(request_header_and_message)
        response.goals_canceling = [
            g for g in response.goals_canceling if bytes(g.goal_id.uuid) in self._cancel_accepted
            and self._canceled_state(bytes(g.goal_id.uuid))]
        self._cancel_events.publish(ServiceEventInfo.RESPONSE_SENT, header, response=response)

    def _canceled_state(self, uuid: bytes) -> bool:
        handle = self._goal_handles.get(uuid)
        return handle is not None and handle.status in (GoalStatus.STATUS_CANCELING,
                                                        GoalStatus.STATUS_CANCELED)

    async def _execute_get_result_request(self, request_header_and_message):
        header, request = request_header_and_message
        self._result_events.publish(ServiceEventInfo.REQUEST_RECEIVED, header, request=request)
        known = bytes(request.goal_id.uuid) in self._goal_handles
        await super()._execute_get_result_request(request_header_and_message)
        if not known:
            response = self._action_type.Impl.GetResultService.Response(
                status=GoalStatus.STATUS_UNKNOWN)
            self._result_events.publish(ServiceEventInfo.RESPONSE_SENT, header,
                                        response=response)

    def _send_result_response(self, request_header, future):
        super()._send_result_response(request_header, future)
        self._result_events.publish(ServiceEventInfo.RESPONSE_SENT, request_header,
                                    response=future.result())
