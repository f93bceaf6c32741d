"""
A tiny real rclpy joint-state driver for trajectory_server tests (no physics).

It follows ``commands/joint_setpoints`` exactly (optionally with a first-order lag), publishes
``joint_states`` at ``rate`` Hz, and can be told to freeze a joint (blocked) or to go silent
(dead driver). It records every setpoint it receives.
"""
import threading

from rclpy.node import Node
from sensor_msgs.msg import JointState

ARM = ['waist', 'shoulder', 'elbow', 'wrist_angle']
SLEEP = [0.0, -1.88, 1.5, 0.8]


class FakeDriver(Node):
    """Publish joint_states that track the received setpoints."""

    def __init__(self, rate: float = 100.0, lag: float = 0.0, start=None, **kwargs):
        super().__init__('fake_driver', **kwargs)
        self.q = list(SLEEP if start is None else start)
        self.target = list(self.q)
        self.lag = lag
        self.rate = rate
        self.frozen = set()
        self.offset = {}  # joint -> constant measurement offset [rad] (never settles)
        self.silent = False
        self.lock = threading.Lock()
        self.setpoints = []  # (header stamp ns, names, positions, velocities)
        self.pub = self.create_publisher(JointState, '/px100/joint_states', 10)
        self.create_subscription(JointState, '/px100/commands/joint_setpoints', self._on_sp,
                                 1000)
        self.create_timer(1.0 / rate, self._tick)

    def _on_sp(self, msg):
        with self.lock:
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            self.setpoints.append((stamp, list(msg.name), list(msg.position),
                                   list(msg.velocity)))
            for name, pos in zip(msg.name, msg.position):
                if name in ARM:
                    self.target[ARM.index(name)] = pos

    def _tick(self):
        with self.lock:
            if self.silent:
                return
            alpha = 1.0 if self.lag <= 0 else min(1.0, 1.0 / (self.rate * self.lag))
            for i in range(len(ARM)):
                if ARM[i] not in self.frozen:
                    self.q[i] += alpha * (self.target[i] - self.q[i])
            msg = JointState()
            msg.header.stamp = self.get_clock().now().to_msg()
            msg.name = ARM + ['gripper', 'left_finger', 'right_finger']
            arm = [q + self.offset.get(name, 0.0) for name, q in zip(ARM, self.q)]
            msg.position = arm + [0.0, 0.0195, -0.0195]
            msg.velocity = [0.0] * 7
            msg.effort = [0.0] * 7
        self.pub.publish(msg)

    def reset(self) -> None:
        """Clear faults: no frozen joint, no offset, publishing."""
        with self.lock:
            self.frozen.clear()
            self.offset.clear()
            self.silent = False
            self.target = list(self.q)

    def count(self) -> int:
        """Return how many setpoints arrived."""
        with self.lock:
            return len(self.setpoints)
