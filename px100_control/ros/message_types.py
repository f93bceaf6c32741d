"""
Message classes by type name, and the few decoders the recorder needs for /tf.

``message_class`` finds the rclpy class of a ``pkg/msg/Name`` type (None when the package is not
installed here). The decoders turn recorded bytes into what :class:`px100_control.bag.
tf_recording.TfRecording` takes: joint positions [rad or m] by name, world markers (robot base
frame, m), texts; stamps are ns since the epoch.
"""
import importlib
from typing import List, Tuple

from px100_control.bag.world import MARKER_ARRAY_TYPE, markers_from_decoded, WorldMarker
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import String


def message_class(type_name: str):
    """
    Return the rclpy message class of a type, or None when it is not installed.

    ``pkg/msg/Name``, and the types made from services and actions: ``pkg/srv/Name_Event``,
    ``pkg/action/Name_SendGoal_Event``, ``pkg/action/Name_FeedbackMessage``, ...
    """
    parts = type_name.split('/')
    if len(parts) != 3:
        return None
    try:
        module = importlib.import_module(f'{parts[0]}.{parts[1]}')
        if hasattr(module, parts[2]):
            return getattr(module, parts[2])
        action, _, member = parts[2].partition('_')
        return getattr(getattr(module, action).Impl, member) if member == 'FeedbackMessage' \
            else None
    except (ImportError, AttributeError):
        return None


def _stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def joint_positions(data: bytes) -> Tuple[dict, int]:
    """Return ({joint name: position}, header stamp [ns]) of a serialized JointState."""
    msg = deserialize_message(data, JointState)
    return dict(zip(msg.name, msg.position)), _stamp_ns(msg.header.stamp)


def world_markers(data: bytes) -> Tuple[List[WorldMarker], int]:
    """Return (markers, stamp of the first marker [ns], 0 if none) of a MarkerArray."""
    msg = deserialize_message(data, message_class(MARKER_ARRAY_TYPE))
    stamp = _stamp_ns(msg.markers[0].header.stamp) if msg.markers else 0
    return markers_from_decoded(msg), stamp


def string_data(data: bytes) -> str:
    """Return the text of a serialized std_msgs/String."""
    return deserialize_message(data, String).data
