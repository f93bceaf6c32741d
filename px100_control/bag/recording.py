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
from px100_control.bag.ros_names import is_hidden, kind_of, SERVICE_EVENT_SUFFIX
from px100_control.errors import BagError

TF_TOPIC = '/tf'
TF_STATIC_TOPIC = '/tf_static'
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
    'trajectory/feedback': ('sensor_msgs/msg/JointState', False),
    'world/markers': ('visualization_msgs/msg/MarkerArray', True),
    'world/held_object': ('std_msgs/msg/String', True),
    '/diagnostics': ('diagnostic_msgs/msg/DiagnosticArray', False),
    'commands/joint_group': ('interbotix_xs_msgs/msg/JointGroupCommand', False),
    'commands/joint_single': ('interbotix_xs_msgs/msg/JointSingleCommand', False),
    'commands/joint_trajectory': ('interbotix_xs_msgs/msg/JointTrajectoryCommand', False),
    TF_TOPIC: ('tf2_msgs/msg/TFMessage', False),
    TF_STATIC_TOPIC: ('tf2_msgs/msg/TFMessage', True),
}
#: the contract's services (relative to /<robot_name>/) -> type; their introspection events
#: ``<service>/_service_event`` (``<type>_Event``) are subscribed ahead too
CONTRACT_SERVICES = {
    'get_robot_info': 'interbotix_xs_msgs/srv/RobotInfo',
    'torque_enable': 'interbotix_xs_msgs/srv/TorqueEnable',
    'reboot_motors': 'interbotix_xs_msgs/srv/Reboot',
    'set_operating_modes': 'interbotix_xs_msgs/srv/OperatingModes',
    'get_motor_registers': 'interbotix_xs_msgs/srv/RegisterValues',
    'set_motor_registers': 'interbotix_xs_msgs/srv/RegisterValues',
    'set_motor_pid_gains': 'interbotix_xs_msgs/srv/MotorGains',
    'compute_ik': 'px100_control_msgs/srv/ComputeIK',
    'compute_cartesian_path': 'px100_control_msgs/srv/ComputeCartesianPath',
}
#: the contract's actions (relative to /<robot_name>/) -> type
CONTRACT_ACTIONS = {
    'arm_controller/follow_joint_trajectory': 'control_msgs/action/FollowJointTrajectory',
    'gripper_controller/gripper_cmd': 'control_msgs/action/GripperCommand',
}
#: the types on an action's topics (``{type}``: the action type, ``pkg/action/Name``)
ACTION_TOPIC_TYPES = {
    '/_action/send_goal/_service_event': '{type}_SendGoal_Event',
    '/_action/cancel_goal/_service_event': 'action_msgs/srv/CancelGoal_Event',
    '/_action/get_result/_service_event': '{type}_GetResult_Event',
    '/_action/feedback': '{type}_FeedbackMessage',
    '/_action/status': 'action_msgs/msg/GoalStatusArray',
}
#: where a recorder announces that it is ready (relative to /<robot_name>/): the bag directory
READY_TOPIC = 'recorder/ready'
#: latched std_msgs/String: the subscribed-ahead topics matched with a publisher, one per line
MATCHED_TOPIC = 'recorder/matched'


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
    Which topics of the graph a recorder records (``ros2 bag record``'s rules, Jazzy).

    :param namespace: the recorder's (robot's) namespace, e.g. ``/px100`` (``/`` for none);
        relative topic names resolve in it
    :param topics: topics asked for by name (always recorded)
    :param all_topics: every topic of the graph, hidden ``_x`` topics excepted (``-a``,
        ``--all-topics``); also when nothing else is asked for
    :param robot_only: only the namespace's topics plus ``/diagnostics``, ``/tf`` and
        ``/tf_static``; with all_topics, all of them: hidden ones, service events and action
        topics included (None: True when nothing else was asked for)
    :param all_services: every service's events ``<service>/_service_event`` (``-a``,
        ``--all-services``; None: as all_topics when it was asked for)
    :param all_actions: every action's five topics (``-a``, ``--all-actions``, as rosbag2
        since Kilted; None: as all_topics when it was asked for)
    :param include_hidden: with all_topics, hidden topics too (``--include-hidden-topics``)
    """

    def __init__(self, namespace: str, topics: Optional[Sequence[str]] = None,
                 all_topics: Optional[bool] = None, robot_only: Optional[bool] = None,
                 all_services: Optional[bool] = None, all_actions: Optional[bool] = None,
                 include_hidden: bool = False):
        self.namespace = namespace
        explicit = [resolve_topic(t, namespace) for t in (topics or ())]
        asked = bool(all_topics) or bool(all_services) or bool(all_actions)
        self.robot_only = (not (asked or explicit)) if robot_only is None else bool(robot_only)
        self.all_topics = bool(all_topics) or not (explicit or asked)
        self.all_services = bool(all_topics) if all_services is None else bool(all_services)
        self.all_actions = bool(all_topics) if all_actions is None else bool(all_actions)
        self.include_hidden = bool(include_hidden)
        self.wanted = set(explicit)
        #: topics below the namespace start with this
        self.prefix = namespace.rstrip('/') + '/'
        self.ready_topic = self.prefix + READY_TOPIC
        self.matched_topic = self.prefix + MATCHED_TOPIC

    @property
    def default_set(self) -> bool:
        """Return True for the robot's view: all of the namespace, /diagnostics and tf."""
        return self.robot_only and self.all_topics

    def in_robot_scope(self, topic: str) -> bool:
        """Return True for the namespace's topics, /diagnostics, /tf and /tf_static."""
        return topic.startswith(self.prefix) or topic in ('/diagnostics', TF_TOPIC,
                                                          TF_STATIC_TOPIC)

    def selected(self, topic: str) -> bool:
        """Return True if ``topic`` is recorded."""
        if topic in (self.ready_topic, self.matched_topic):
            return False
        if topic in self.wanted:
            return True
        if self.robot_only and not self.in_robot_scope(topic):
            return False
        if self.default_set:
            return True
        kind = kind_of(topic)
        if kind == 'action':
            return self.all_actions or (self.all_topics and self.include_hidden)
        if kind == 'service':
            return self.all_services or (self.all_topics and self.include_hidden)
        return self.all_topics and (self.include_hidden or not is_hidden(topic))

    def contract_topics(self):
        """Yield (absolute topic, type, latched) of the contract's topics in this namespace."""
        for name, (type_name, latched) in CONTRACT_TOPICS.items():
            yield (name if name.startswith('/') else self.prefix + name), type_name, latched
        for name, type_name in CONTRACT_SERVICES.items():
            yield self.prefix + name + SERVICE_EVENT_SUFFIX, type_name + '_Event', False
        for name, type_name in CONTRACT_ACTIONS.items():
            for suffix, kind in ACTION_TOPIC_TYPES.items():
                yield self.prefix + name + suffix, kind.format(type=type_name), \
                    suffix.endswith('status')

    def describe(self) -> str:
        """Return what is recorded, in words (for the start-up log line)."""
        if self.default_set:
            return ('all topics of ' + self.prefix + ' (their service events and actions '
                    'included), /diagnostics, /tf and /tf_static')
        kinds = (('topics', self.all_topics), ('service events', self.all_services),
                 ('actions', self.all_actions))
        what = [w for w, on in kinds if on]
        text = ', '.join(sorted(self.wanted))
        if what:
            text = (text + ' and ' if text else '') + 'all ' + ', '.join(what) + (
                ' of ' + self.prefix + ' (and /diagnostics, /tf, /tf_static)'
                if self.robot_only else '') + (' (hidden ones included)'
                                               if self.include_hidden else '')
        return text


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
