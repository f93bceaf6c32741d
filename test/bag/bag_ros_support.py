"""rclpy helpers of the bag process tests: a fake robot publisher and a raw listener."""
import threading
import time

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)
ARM = ['waist', 'shoulder', 'elbow', 'wrist_angle']


class FakeRobot(Node):
    """Publishes on the contract topics of /px100 like the real nodes do (QoS included)."""

    def __init__(self, name='fake_robot', **kwargs):
        super().__init__(name, **kwargs)
        from diagnostic_msgs.msg import DiagnosticArray
        from sensor_msgs.msg import JointState
        from std_msgs.msg import String
        self.JointState = JointState
        self.js = self.create_publisher(JointState, '/px100/joint_states', 10)
        self.sp = self.create_publisher(JointState, '/px100/commands/joint_setpoints', 10)
        self.desc = self.create_publisher(String, '/px100/robot_description', LATCHED)
        self.held = self.create_publisher(String, '/px100/world/held_object', LATCHED)
        self.diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.other = self.create_publisher(String, '/elsewhere/chatter', 10)
        self.String = String

    def joint_state(self, seq: int):
        """Return a JointState whose waist position is the sequence number."""
        msg = self.JointState(name=ARM + ['gripper', 'left_finger', 'right_finger'])
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.position = [float(seq), -0.5, 0.4, 0.2, 0.0, 0.03, -0.03]
        msg.velocity = [0.0] * 7
        msg.effort = [0.1] * 7
        return msg

    def wait_for_subscribers(self, pubs, timeout=60.0) -> bool:
        """Wait until every publisher in pubs has a subscriber."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if all(p.get_subscription_count() > 0 for p in pubs):
                return True
            time.sleep(0.05)
        return False


class RawListener(Node):
    """
    Subscribes raw to topics; keeps (publication time [s], bytes) per topic.

    The publication time is the DDS source timestamp (when the publisher sent it), so a slow
    executor in this process does not distort the timing seen.
    """

    def __init__(self, topics, name='raw_listener', qos=None, **kwargs):
        super().__init__(name, **kwargs)
        self.got = {t: [] for t, _ in topics}
        self.lock = threading.Lock()
        for topic, cls in topics:
            self.create_subscription(cls, topic, self._cb(topic), qos or QoSProfile(depth=1000),
                                     raw=True)

    def _cb(self, topic):
        def cb(data, info):
            t = (info.get('source_timestamp') or time.time_ns()) * 1e-9
            with self.lock:
                self.got[topic].append((t, bytes(data)))
        return cb

    def count(self, topic) -> int:
        """Return how many messages arrived on topic."""
        with self.lock:
            return len(self.got[topic])


def wait_until(predicate, timeout: float, period: float = 0.05) -> bool:
    """Poll predicate until it is true or timeout [s] passes."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period)
    return predicate()
