"""
What a recorder records and when it stops: topic selection, stop conditions, option checks.

Pure (no rclpy, no clock read here): the ``record`` node asks :class:`TopicSelection` whether a
topic of the graph goes into the bag and :class:`StopConditions` whether to close it, passing
the monotonic time [s] it reads. Topic names are absolute ROS names (``/px100/joint_states``);
durations are seconds.
"""
from dataclasses import dataclass
import os
import time
from typing import Optional, Sequence

from px100_control.bag import metadata as md
from px100_control.bag.replay import resolve_topic
from px100_control.errors import BagError

TF_TOPIC = '/tf'
#: QoS a tf2 broadcaster offers (recorded with the /tf the recorder writes)
TF_QOS = md.qos_profile('reliable', 'volatile', 'keep_last', 100)
DESCRIPTION_QOS = md.qos_profile('reliable', 'transient_local', 'keep_last', 1)
#: the contract's topics (docs/ros_interfaces.md), subscribed before any publisher appears:
#: name (relative to /<robot_name>/ unless absolute) -> (type, latched)
CONTRACT_TOPICS = {
    'joint_states': ('sensor_msgs/msg/JointState', False),
    'ee_pose': ('geometry_msgs/msg/PoseStamped', False),
    'robot_description': ('std_msgs/msg/String', True),
    'commands/joint_setpoints': ('sensor_msgs/msg/JointState', False),
    'ik/request': ('geometry_msgs/msg/PoseStamped', False),
    'ik/solution': ('sensor_msgs/msg/JointState', False),
    'ik/status': ('diagnostic_msgs/msg/DiagnosticStatus', False),
    'ik/path_request': ('geometry_msgs/msg/PoseArray', False),
    'ik/path_solution': ('trajectory_msgs/msg/JointTrajectory', False),
    'trajectory/goal': ('trajectory_msgs/msg/JointTrajectory', False),
    'trajectory/status': ('action_msgs/msg/GoalStatusArray', True),
    'trajectory/feedback': ('sensor_msgs/msg/JointState', False),
    'world/markers': ('visualization_msgs/msg/MarkerArray', True),
    'world/held_object': ('std_msgs/msg/String', True),
    '/diagnostics': ('diagnostic_msgs/msg/DiagnosticArray', False),
}
#: where a recorder announces that it is ready (relative to /<robot_name>/): the bag directory
READY_TOPIC = 'recorder/ready'


def default_output_dir() -> str:
    """Return ``rosbag2_YYYY_MM_DD-HH_MM_SS`` (what ros2 bag record uses) in the cwd."""
    return os.path.abspath(time.strftime('rosbag2_%Y_%m_%d-%H_%M_%S'))


def check_positive(**values) -> None:
    """
    Refuse option values that are not finite numbers > 0 (None means 'not set' and passes).

    :raises BagError: naming the first bad option and its value
    """
    for what, value in values.items():
        if value is not None and not (float(value) > 0 and float(value) < float('inf')):
            raise BagError(f'{what} must be a number > 0, got {value!r}')


class TopicSelection:
    """
    Which topics of the graph a recorder records.

    :param namespace: the recorder's (robot's) namespace, e.g. ``/px100`` (``/`` for none);
        relative topic names resolve in it
    :param topics: topics asked for by name (always recorded)
    :param all_topics: every topic of the graph (also when no topic is named), hidden
        ``_x`` topics excepted
    :param robot_only: with all_topics, only the namespace's topics plus ``/diagnostics``
        (None: True unless all_topics was asked for)
    """

    def __init__(self, namespace: str, topics: Optional[Sequence[str]] = None,
                 all_topics: Optional[bool] = None, robot_only: Optional[bool] = None):
        self.namespace = namespace
        explicit = [resolve_topic(t, namespace) for t in (topics or ())]
        self.robot_only = (not all_topics) if robot_only is None else bool(robot_only)
        self.all_topics = bool(all_topics) or not explicit
        self.wanted = set(explicit)
        #: topics below the namespace start with this
        self.prefix = namespace.rstrip('/') + '/'
        self.ready_topic = self.prefix + READY_TOPIC

    def selected(self, topic: str, write_tf: bool) -> bool:
        """Return True if ``topic`` is recorded (``write_tf``: the recorder writes /tf itself)."""
        if topic == self.ready_topic:
            return False
        if topic in self.wanted:
            return True
        if not self.all_topics:
            return False
        if write_tf and topic in (TF_TOPIC, '/tf_static'):
            return False
        if self.robot_only:
            return topic.startswith(self.prefix) or topic == '/diagnostics'
        return not any(part.startswith('_') for part in topic.split('/'))

    def contract_topics(self):
        """Yield (absolute topic, type, latched) of the contract's topics in this namespace."""
        for name, (type_name, latched) in CONTRACT_TOPICS.items():
            yield (name if name.startswith('/') else self.prefix + name), type_name, latched

    def describe(self) -> str:
        """Return what is recorded, in words (for the start-up log line)."""
        if not self.all_topics:
            return ', '.join(sorted(self.wanted))
        if self.robot_only:
            return 'all topics of ' + self.prefix + ' and /diagnostics'
        return 'all topics'


@dataclass
class StopConditions:
    """
    When a recording ends by itself.

    :param duration: after this long [s] from the start (None: never)
    :param max_messages: once the bag holds this many messages (None: no limit)
    :param idle_timeout: when nothing arrived for this long [s] after the first message
    :raises BagError: a value that is not > 0
    """

    duration: Optional[float] = None
    max_messages: Optional[int] = None
    idle_timeout: Optional[float] = None

    def __post_init__(self):
        check_positive(duration=self.duration, idle_timeout=self.idle_timeout)
        if self.max_messages is not None and int(self.max_messages) <= 0:
            raise BagError(f'max_messages must be > 0, got {self.max_messages!r}')
        self.max_messages = None if self.max_messages is None else int(self.max_messages)

    def count_reason(self, message_count: int) -> str:
        """Return why to stop after ``message_count`` messages ('' to go on)."""
        if self.max_messages is not None and message_count >= self.max_messages:
            return f'{self.max_messages} messages recorded'
        return ''

    def time_reason(self, now: float, started_at: float,
                    last_message_at: Optional[float]) -> str:
        """Return why to stop at monotonic time ``now`` [s] ('' to go on)."""
        if self.duration is not None and now - started_at >= self.duration:
            return f'duration {self.duration:g} s reached'
        if (self.idle_timeout is not None and last_message_at is not None
                and now - last_message_at >= self.idle_timeout):
            return f'no message for {self.idle_timeout:g} s'
        return ''
