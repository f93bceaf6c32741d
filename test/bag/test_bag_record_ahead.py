"""
The recorder subscribes to the contract topics before their publishers exist, and adapts.

In-process Recorder on a test context: a publisher whose QoS (best effort) or type differs from
the contract's is still matched (the recorder re-subscribes to fit it) before the recorder
reports ready, and its messages are in the bag.
"""
import time

from px100_control.bag.reader import open_bag
import pytest

pytestmark = pytest.mark.ros


def test_mismatched_publishers_are_matched_before_ready(rclpy_context, spin_node, tmp_path):
    """Best-effort joint_states and a String on ee_pose: matched, ready, recorded."""
    import rclpy
    from px100_control.ros.recorder import Recorder
    from rclpy.node import Node
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String
    # the publishers in a participant of their own (as another process would be)
    other = rclpy.Context()
    rclpy.init(context=other)
    node = Node('odd_publishers', context=other)
    js = node.create_publisher(JointState, '/px100_ahead/joint_states', QoSProfile(
        depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
    odd = node.create_publisher(String, '/px100_ahead/ee_pose', 10)
    time.sleep(0.5)
    bag = str(tmp_path / 'bag')
    # ready when matched, or after ready_timeout regardless: 30 s, not the default 5 s, which
    # a loaded CI machine used up re-subscribing (ready with both topics unmatched)
    with Recorder(bag, robot_name='px100_ahead', context=rclpy_context, write_tf=False,
                  ready_timeout=30.0) as rec:
        assert rec.node.ready.is_set()
        assert rec.node.topics.unmatched() == []
        end = time.monotonic() + 10.0  # and the publishers' side of the match (best effort)
        while (js.get_subscription_count() < 1 or odd.get_subscription_count() < 1) and \
                time.monotonic() < end:
            time.sleep(0.01)
        for i in range(20):
            js.publish(JointState(name=['waist'], position=[float(i)]))
            odd.publish(String(data=f'odd {i}'))
            time.sleep(0.01)
        time.sleep(0.5)
    node.destroy_node()
    other.try_shutdown()
    with open_bag(bag) as reader:
        counts = {t: s.message_count for t, s in reader.summary().topics.items()}
        types = dict(reader.topics)
    assert counts['/px100_ahead/joint_states'] >= 18  # best effort: (almost) all
    assert counts['/px100_ahead/ee_pose'] == 20
    assert types['/px100_ahead/ee_pose'] == 'std_msgs/msg/String'
