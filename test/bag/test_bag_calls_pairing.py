"""
Calls are paired from their events per client: two clients sharing sequence numbers stay two.

The action servers' events carry no client id (zeros: rclpy does not give it to them), so two
action clients' goals with the same sequence number must not merge; a service's events with
client ids are one call per (client, sequence number) however many sides recorded them.
Synthetic events (serialized, written to a bag, read back); no ROS graph.
"""
from builtin_interfaces.msg import Time
from control_msgs.action import FollowJointTrajectory
from px100_control.bag.calls import EventInfo, pair_events, read_calls, summarise_calls
from px100_control.bag.reader import BagReader
from px100_control.bag.writer import BagWriter
from px100_control_msgs.srv import ComputeIK
from rclpy.serialization import serialize_message
from unique_identifier_msgs.msg import UUID

T0 = 1_700_000_000
GOAL_EV = '/px100/arm_controller/follow_joint_trajectory/_action/send_goal/_service_event'
IK_EV = '/px100/compute_ik/_service_event'
SEND_GOAL = FollowJointTrajectory.Impl.SendGoalService
REQ_SENT, REQ_RECEIVED, RES_SENT, RES_RECEIVED = 0, 1, 2, 3
CLIENT_X, CLIENT_Y = b'\x01' * 16, b'\x02' * 16


def _event(srv, kind: int, t_ms: int, seq: int, gid: bytes = bytes(16), request=None,
           response=None) -> bytes:
    msg = srv.Event()
    msg.info.event_type, msg.info.sequence_number = kind, seq
    msg.info.stamp = Time(sec=T0 + t_ms // 1000, nanosec=(t_ms % 1000) * 1_000_000)
    msg.info.client_gid = list(gid)
    if request is not None:
        msg.request = [request]
    if response is not None:
        msg.response = [response]
    return serialize_message(msg)


def _goal(kind: int, t_ms: int, seq: int, goal: bytes) -> bytes:
    return _event(SEND_GOAL, kind, t_ms, seq, request=SEND_GOAL.Request(
        goal_id=UUID(uuid=list(goal))))


def _answer(t_ms: int, seq: int) -> bytes:
    return _event(SEND_GOAL, RES_SENT, t_ms, seq, response=SEND_GOAL.Response(accepted=True))


def _write(bag_dir: str) -> None:
    """Two action clients (goals a1, b1 with sequence number 1, a2 with 2) and two IK clients."""
    rows = [
        (GOAL_EV, 1, _goal(REQ_RECEIVED, 1, 1, b'a1' * 8)),
        (GOAL_EV, 2, _goal(REQ_RECEIVED, 2, 1, b'b1' * 8)),
        (GOAL_EV, 3, _answer(3, 1)),
        (GOAL_EV, 4, _answer(4, 1)),
        (GOAL_EV, 5, _goal(REQ_RECEIVED, 5, 2, b'a2' * 8)),      # never answered
    ]
    for gid, t in ((CLIENT_X, 10), (CLIENT_Y, 11)):    # each seen by its client and the server
        request = ComputeIK.Request()
        rows += [(IK_EV, t, _event(ComputeIK, REQ_SENT, t, 1, gid, request=request)),
                 (IK_EV, t + 2, _event(ComputeIK, REQ_RECEIVED, t + 2, 1, gid, request=request))]
        response = ComputeIK.Response(success=True)
        rows += [(IK_EV, t + 4, _event(ComputeIK, RES_SENT, t + 4, 1, gid, response=response)),
                 (IK_EV, t + 6, _event(ComputeIK, RES_RECEIVED, t + 6, 1, gid,
                                       response=response))]
    with BagWriter(bag_dir) as bag:
        bag.add_topic(GOAL_EV, 'control_msgs/action/FollowJointTrajectory_SendGoal_Event')
        bag.add_topic(IK_EV, 'px100_control_msgs/srv/ComputeIK_Event')
        for topic, t_ms, data in sorted(rows, key=lambda r: r[1]):
            bag.write(topic, data, T0 * 10**9 + t_ms * 1_000_000)


def test_two_clients_with_the_same_sequence_numbers_are_counted_apart(tmp_path):
    """Three goals (two answered), two IK calls each seen from both sides."""
    bag = str(tmp_path / 'calls')
    _write(bag)
    with BagReader(bag) as reader:
        counts = {s.name: s.counts for s in summarise_calls(reader)}
        goals = read_calls(reader, GOAL_EV, key=lambda r: bytes(r.goal_id.uuid).decode())
        ik = read_calls(reader, IK_EV)
    assert counts['/px100/arm_controller/follow_joint_trajectory'] == {'goal': (3, 2)}
    assert counts['/px100/compute_ik'] == {'call': (2, 2)}
    assert {c.key[:2]: c.answered for c in goals} == {'a1': True, 'b1': True, 'a2': False}
    assert sorted(c.client_gid for c in ik) == [CLIENT_X, CLIENT_Y]
    assert all(c.answered for c in ik)


def test_responses_in_another_order_and_a_response_without_request():
    """Each response answers the oldest open request of its number; a stray one is a call."""
    zero = bytes(16)
    events = [(EventInfo(REQ_RECEIVED, 1, zero, 7), 'a'),
              (EventInfo(REQ_RECEIVED, 2, zero, 7), 'b'),
              (EventInfo(RES_SENT, 3, zero, 7), None), (EventInfo(RES_SENT, 4, zero, 9), None)]
    calls = pair_events(reversed(events))       # stamp order, not list order
    assert [(c.key, c.request_ns, c.response_ns) for c in calls] == [
        ('a', 1, 3), ('b', 2, None), (None, None, 4)]
