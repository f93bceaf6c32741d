"""
The wire module's CDR checked against rclpy: the nodes use the fast path only when it agrees.

``matches_rclpy`` (JointState and DiagnosticStatus writers), ``clock_matches_rclpy``,
``trajectory_shape_matches_rclpy``, ``pose_stamped_matches_rclpy`` and ``string_matches_rclpy``
(the recorder's std_msgs/String, through ``string_writer``) compare
:mod:`px100_control.wire.cdr` with rclpy's serializer of the running middleware on sample
messages. Not ``tf_message``: rclpy cannot check TFMessage without tf2_msgs (not a dependency),
and its bytes only go into bags; test/bag/test_bag_tf.py checks them against rosbags and
mcap_ros2 instead.
"""
from typing import Callable

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from px100_control.wire.cdr import (clock, diagnostic_status, JointStateWriter,
                                    read_pose_stamped, string_message, trajectory_shape)
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint


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
    values = [('mode', 'pitch'), ('position_error', '1.234e-16'), ('x', '')]
    for level, message in ((b'\x00', 'solved'), (b'\x02', 'invalid request: pose has NaN')):
        msg = DiagnosticStatus(level=level, name='px100/ik_service', message=message,
                               hardware_id='1.000000002',
                               values=[KeyValue(key=k, value=v) for k, v in values])
        raw = diagnostic_status(level, msg.name, message, msg.hardware_id, values)
        if deserialize_message(raw, DiagnosticStatus) != msg:
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


def trajectory_shape_matches_rclpy() -> bool:
    """Return True when :func:`trajectory_shape` reads rclpy's serialization of samples right."""
    for frame, names, counts in (('', [], []), ('px100/base_link', ['waist', 'elbow'],
                                                [(2, 2, 0, 0), (2, 0, 2, 1), (0, 0, 0, 3)]),
                                 ('x', ['a', 'odd_len', ''], [(3, 0, 0, 0)] * 3)):
        msg = JointTrajectory(joint_names=names)
        msg.header.stamp.sec, msg.header.stamp.nanosec = -7, 123
        msg.header.frame_id = frame
        for k, (p, v, a, e) in enumerate(counts):
            msg.points.append(JointTrajectoryPoint(
                positions=[0.5] * p, velocities=[1.0] * v, accelerations=[2.0] * a,
                effort=[3.0] * e))
            msg.points[-1].time_from_start.sec = k
        try:
            got = trajectory_shape(serialize_message(msg))
        except ValueError:
            return False
        if got != ((-7, 123), names, counts):
            return False
    return True


def pose_stamped_matches_rclpy() -> bool:
    """Return True when :func:`read_pose_stamped` reads rclpy's serialization of samples right."""
    for frame in ('', 'px100/base_link', 'odd'):
        msg = PoseStamped()
        msg.header.stamp.sec, msg.header.stamp.nanosec = -3, 77
        msg.header.frame_id = frame
        p, o = msg.pose.position, msg.pose.orientation
        p.x, p.y, p.z, o.x, o.y, o.z, o.w = 0.1, -0.2, 0.3, 0.0, 0.6, 0.0, 0.8
        if read_pose_stamped(serialize_message(msg)) != (-3, 77, frame,
                                                         (0.1, -0.2, 0.3, 0.0, 0.6, 0.0, 0.8)):
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


__all__ = ['matches_rclpy', 'clock_matches_rclpy', 'trajectory_shape_matches_rclpy',
           'pose_stamped_matches_rclpy', 'string_matches_rclpy', 'string_writer',
           'rclpy_string_message', 'clock', 'diagnostic_status', 'JointStateWriter',
           'read_pose_stamped', 'string_message', 'trajectory_shape']
