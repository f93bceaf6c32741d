"""
A recorder is ready only once the servers' processes have matched its subscriptions themselves.

The recorder's participant knows ik_service's event publisher (it saw it before); ik_service's
process is stopped (SIGSTOP) before the recorder subscribes, so it cannot learn of the
subscription: the recorder's side of the match is complete at once, the server's is not, and
an event the server published now would never reach the bag. Ready must wait until the server
answers (px100_control.ros.writer_match); after SIGCONT it does, and the first call is
recorded. On the code before the check, ready came at once while the server was stopped.
"""
import os
import signal
import time

from bag_ros_support import wait_until
import pytest

pytestmark = pytest.mark.ros


def _named(probe, events: str) -> bool:
    """
    Return True once the graph names the node of the server's event publisher.

    Its participant's node list comes apart from the endpoints: a server stopped before it
    arrived could not be asked (px100_control.ros.writer_match waits for the list).
    """
    pubs = probe.get_publishers_info_by_topic(events)
    return len(pubs) == 1 and pubs[0].node_name == 'ik_service'


def test_ready_waits_for_the_servers_side_of_the_match(rclpy_context, node_process, tmp_path):
    """Server stopped: not ready; resumed: ready, and its first call's events are in the bag."""
    from geometry_msgs.msg import PoseStamped
    from px100_control.bag.reader import open_bag
    from px100_control.ros.recorder import Recorder
    from px100_control_msgs.srv import ComputeIK
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    ns = f'px100_ws_{os.getpid()}'
    events = f'/{ns}/compute_ik/_service_event'
    server = node_process('ik_service', '--ros-args', '-r', f'__ns:=/{ns}')
    probe = Node('writer_side_probe', context=rclpy_context)
    assert wait_until(lambda: probe.count_publishers(events) == 1, 30.0), server.output()[-2000:]
    client = probe.create_client(ComputeIK, f'/{ns}/compute_ik')
    assert client.wait_for_service(timeout_sec=30.0), server.output()[-2000:]
    assert wait_until(lambda: _named(probe, events), 30.0), server.output()[-2000:]
    executor = SingleThreadedExecutor(context=rclpy_context)
    executor.add_node(probe)
    rec = Recorder(str(tmp_path / 'bag'), topics=[events], robot_name=ns, context=rclpy_context,
                   write_tf=False, ready_timeout=30.0)
    server.signal(signal.SIGSTOP)
    try:
        rec.start(wait=False)
        sub = rec.node.topics.subs.get(events)
        assert wait_until(lambda: sub is not None and sub.get_publisher_count() == 1, 10.0), \
            'the recorder did not see the (stopped) server'
        time.sleep(1.0)   # the stopped server: nothing can happen, nothing to wait for
        assert not rec.node.ready.is_set(), 'ready while the server could not know the recorder'
    finally:
        server.signal(signal.SIGCONT)
    assert rec.wait_ready(20.0), server.output()[-2000:]
    target = PoseStamped()
    target.header.frame_id = f'{ns}/base_link'
    target.header.stamp.sec = 4242
    target.pose.position.x, target.pose.position.z = 0.2, 0.15
    target.pose.orientation.w = 1.0
    future = client.call_async(ComputeIK.Request(target=target))
    executor.spin_until_future_complete(future, timeout_sec=20.0)
    assert future.done(), 'no answer from compute_ik'
    # the events travel apart from the answer: wait for both (a lost one never comes)
    arrived = wait_until(lambda: rec.node.bag.message_count >= 2, 10.0)
    rec.stop()
    executor.shutdown()
    probe.destroy_node()
    with open_bag(str(tmp_path / 'bag')) as bag:
        kinds = sorted(msg.info.event_type for _, msg in bag.iter_decoded([events]))
    assert arrived and kinds == [1, 2], \
        f'events in the bag: {kinds} (1 REQUEST_RECEIVED, 2 RESPONSE_SENT)'


def test_a_ready_recorder_counts_a_call_topic_matched_once_the_server_confirmed(
        rclpy_context, node_process, tmp_path):
    """
    Ready early (ready_timeout 0.5 s, server stopped): the event topic is not 'matched' yet.

    A recorder started with the script gets ready before it knows the servers; clients then
    wait for their call topics in ``topics.matched`` (and on ``recorder/matched``). On the code
    before, a topic counted as matched on the recorder's side alone: in CI a client's first
    goal and IK call were missing from the bag of a recorder started in the script.
    """
    from px100_control.ros.recorder import Recorder
    from rclpy.node import Node
    ns = f'px100_wm_{os.getpid()}'
    events = f'/{ns}/compute_ik/_service_event'
    server = node_process('ik_service', '--ros-args', '-r', f'__ns:=/{ns}')
    probe = Node('writer_side_matched_probe', context=rclpy_context)
    assert wait_until(lambda: _named(probe, events), 30.0), server.output()[-2000:]
    rec = Recorder(str(tmp_path / 'bag'), topics=[events], robot_name=ns, context=rclpy_context,
                   write_tf=False, ready_timeout=0.5)
    server.signal(signal.SIGSTOP)
    try:
        rec.start(wait=False)
        topics = rec.node.topics
        assert rec.wait_ready(10.0), 'not ready after its ready_timeout'
        sub = topics.subs.get(events)
        assert wait_until(lambda: sub is not None and sub.get_publisher_count() == 1, 10.0), \
            'the recorder did not see the (stopped) server'
        time.sleep(1.0)   # the stopped server: nothing can happen, nothing to wait for
        assert events not in topics.matched, 'matched while the server could not know it'
    finally:
        server.signal(signal.SIGCONT)
    try:
        assert wait_until(lambda: events in topics.matched, 20.0), server.output()[-2000:]
    finally:
        rec.stop()
        probe.destroy_node()
