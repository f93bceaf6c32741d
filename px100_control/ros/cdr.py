"""
The wire module's CDR checked against rclpy: the nodes use the fast path only when it agrees.

``matches_rclpy`` (the JointState writer), ``clock_matches_rclpy`` and ``string_matches_rclpy``
(the recorder's std_msgs/String, through ``string_writer``) compare
:mod:`px100_control.wire.cdr` with rclpy's serializer of the running middleware on sample
messages. Not ``tf_message``: rclpy cannot check TFMessage without tf2_msgs (not a dependency),
and its bytes only go into bags; test/bag/test_bag_tf.py checks them against rosbags and
mcap_ros2 instead.
"""
from typing import Callable

from px100_control.wire.cdr import clock, JointStateWriter, string_message
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import String


def matches_rclpy() -> bool:
    """
    Return True when the running middleware reads these bytes as the intended messages.

    rclpy's ``deserialize_message`` (the type support subscribers use) must give back exactly
    the sample messages: odd-length strings, none / one / several positions, two frames.
    (rclpy's own serializer leaves padding bytes uninitialised, so bytes are not compared.)
    """
    names = ['waist', 'shoulder', 'elbow', 'wrist_angle']
    for frame in ('', 'px100/base_link'):
        writer = JointStateWriter(names, frame)
        for pos, vel, eff in (([], [], []), ([0.1, -2.5, 3.0, 1e-300], [], []), ([1.5], [], []),
                              ([0.1, 0.2, 0.3, 0.4], [-1.0, 0.0, 2.0, 3.5], [0.5, 0.6, -0.7, 8.0]),
                              ([], [1.0], [])):
            msg = JointState(name=names, position=pos, velocity=vel, effort=eff)
            msg.header.stamp.sec, msg.header.stamp.nanosec = -12, 345
            msg.header.frame_id = frame
            if deserialize_message(writer.write(-12, 345, pos, vel, eff), JointState) != msg:
                return False
    return True


def clock_matches_rclpy() -> bool:
    """Return True when the running middleware reads :func:`clock` bytes as the sample times."""
    for sec, nanosec in ((0, 0), (12, 999_999_999), (2 ** 31 - 1, 4)):
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = sec, nanosec
        if deserialize_message(clock(sec, nanosec), Clock) != msg:
            return False
    return True


def string_matches_rclpy() -> bool:
    """Return True when rclpy reads :func:`string_message` bytes back as the same String."""
    for text in ('', 'x', 'odd', '<robot name="px100"/>\n', 'ünïcode →'):
        if deserialize_message(string_message(text), String) != String(data=text):
            return False
    return True


def rclpy_string_message(text: str) -> bytes:
    """Return rclpy's serialization of a std_msgs/String (the writer when the check fails)."""
    return serialize_message(String(data=text))


def string_writer() -> Callable[[str], bytes]:
    """Return :func:`string_message` when it agrees with rclpy, else rclpy's serializer."""
    return string_message if string_matches_rclpy() else rclpy_string_message


__all__ = ['matches_rclpy', 'clock_matches_rclpy', 'string_matches_rclpy', 'string_writer',
           'rclpy_string_message', 'clock', 'JointStateWriter', 'string_message']
