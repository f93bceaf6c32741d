"""
A spin loop survives subscriptions destroyed in another thread (rclpy's wait-set race).

A Python executor that is building its wait set while another thread destroys a subscription
raises InvalidHandle from the subscription's QoS event handler (ros2/rclpy#1284). That ended
the client's spin thread (and the test probes' ``executor.spin``), so the node received nothing
more: test_camera_node's probe, unsubscribing to leave the camera unwatched, then waited 30 s
for a frame, in CI. Real rclpy nodes over DDS; no mock.
"""
import threading
import time

import pytest

pytestmark = pytest.mark.ros

#: subscriptions the node holds besides the churned one: a longer wait-set build, the race's
#: window (with 100, the loop without the guard died within ~100 cycles here)
EXTRA_SUBSCRIPTIONS = 100
#: how long this thread churns [s]
CHURN_S = 3.0


@pytest.mark.parametrize('kind', ['single', 'multi'])
def test_spin_thread_keeps_spinning_while_another_thread_destroys_subscriptions(kind):
    """Subscriptions created and destroyed from this thread for 3 s; the node still receives."""
    rclpy = pytest.importorskip('rclpy')
    from px100_control.client.robot import SpinThread
    from px100_control.ros.common import make_executor
    from std_msgs.msg import String

    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node('spin_race', context=ctx)
    spin = None
    try:
        pub = node.create_publisher(String, 'spin_race', 10)
        node.create_timer(0.0005, lambda: pub.publish(String(data='tick')))
        for i in range(EXTRA_SUBSCRIPTIONS):
            node.create_subscription(String, f'spin_race_idle_{i}', lambda _m: None, 10)
        executor = make_executor(context=ctx, kind=kind)
        executor.add_node(node)
        spin = SpinThread(executor, 'spin_race').start()
        cycle, end = 0, time.monotonic() + CHURN_S
        while time.monotonic() < end:
            cycle += 1
            sub = node.create_subscription(String, 'spin_race', lambda _m: None, 10)
            time.sleep(0.0002)
            node.destroy_subscription(sub)
            assert spin.is_alive(), f'the spin thread died at cycle {cycle}'
        received = threading.Event()
        node.create_subscription(String, 'spin_race', lambda _m: received.set(), 10)
        assert received.wait(10.0), 'the node receives nothing after the churn'
        assert spin.is_alive()
    finally:
        if spin is not None:
            spin.stop()
        node.destroy_node()
        ctx.try_shutdown()
