"""
What a topic name is: a plain topic, a service's events, or one of an action's five topics.

rosbag2's naming (pure string rules, no rclpy): a service with introspection on publishes its
calls on ``<service>/_service_event`` (type ``<pkg>/srv/<Name>_Event``); an action ``<action>``
has ``<action>/_action/feedback``, ``<action>/_action/status`` and the service events of its
three services ``<action>/_action/{send_goal,cancel_goal,get_result}/_service_event``
(rosbag2 since Kilted records these as the action; Jazzy has no action introspection).
A topic is *hidden* when a part of its name starts with ``_``.
"""
from typing import Optional, Tuple

SERVICE_EVENT_SUFFIX = '/_service_event'
ACTION_INFIX = '/_action/'
#: an action's topics: suffix after the action name -> what it carries
ACTION_TOPICS = {
    '/_action/send_goal/_service_event': 'goal',
    '/_action/cancel_goal/_service_event': 'cancel',
    '/_action/get_result/_service_event': 'result',
    '/_action/feedback': 'feedback',
    '/_action/status': 'status',
}
#: the Interbotix driver's command topics (relative to the robot namespace)
XS_COMMAND_TOPICS = ('commands/joint_group', 'commands/joint_single', 'commands/joint_trajectory')


def is_hidden(topic: str) -> bool:
    """Return True if a part of the name starts with '_' (rclpy's rule, as rosbag2 uses it)."""
    return any(part.startswith('_') for part in topic.split('/'))


def action_topic(topic: str) -> Optional[Tuple[str, str]]:
    """Return (action name, 'goal' | 'cancel' | 'result' | 'feedback' | 'status') or None."""
    for suffix, kind in ACTION_TOPICS.items():
        if topic.endswith(suffix) and len(topic) > len(suffix):
            return topic[:-len(suffix)], kind
    return None


def service_event_topic(topic: str) -> Optional[str]:
    """Return the service whose events a topic carries (None: not a service event topic)."""
    if action_topic(topic) is None and topic.endswith(SERVICE_EVENT_SUFFIX) \
            and len(topic) > len(SERVICE_EVENT_SUFFIX):
        return topic[:-len(SERVICE_EVENT_SUFFIX)]
    return None


def kind_of(topic: str) -> str:
    """Return 'service' (a service's events), 'action' (an action's topic) or 'topic'."""
    if action_topic(topic) is not None:
        return 'action'
    if service_event_topic(topic) is not None:
        return 'service'
    return 'topic'


def is_call_record(topic: str) -> bool:
    """Return True for service event topics, the actions' ones included (calls, not commands)."""
    return topic.endswith(SERVICE_EVENT_SUFFIX)


def is_xs_command(topic: str) -> bool:
    """Return True for an Interbotix driver command topic (``.../commands/joint_group`` etc.)."""
    return any(topic.endswith('/' + t) for t in XS_COMMAND_TOPICS)
