"""CDR: the IK service's reply writers and the trajectory_server's goal reader agree with rclpy."""
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from hypothesis import given, settings, strategies as st
from px100_control.ros import cdr
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint


def test_writers_match_the_middleware():
    assert cdr.matches_rclpy()


def test_joint_state_writer_round_trip():
    names = ['a', 'bb', 'ccc', 'dddd', 'eeeee']
    for frame in ('', 'x', 'px100/base_link'):
        w = cdr.JointStateWriter(names, frame)
        for pos in ([], [1.0], [0.5, -0.25, 3.0, 1e-310, -0.0]):
            msg = deserialize_message(w.write(7, 999_999_999, pos), JointState)
            assert list(msg.name) == names and list(msg.position) == pos
            assert msg.header.frame_id == frame and msg.header.stamp.sec == 7
            assert msg.header.stamp.nanosec == 999_999_999
            assert len(msg.velocity) == 0 and len(msg.effort) == 0


def test_diagnostic_status_round_trip_with_unicode_and_empty_values():
    values = [('k', ''), ('', 'v'), ('ünïcode', 'ßé→')]
    raw = cdr.diagnostic_status(DiagnosticStatus.ERROR, 'n', 'message with ümlaut', '1.000000001',
                                values)
    msg = deserialize_message(raw, DiagnosticStatus)
    assert msg.level == DiagnosticStatus.ERROR and msg.message == 'message with ümlaut'
    assert [(kv.key, kv.value) for kv in msg.values] == values
    assert msg == DiagnosticStatus(level=DiagnosticStatus.ERROR, name='n',
                                   message='message with ümlaut', hardware_id='1.000000001',
                                   values=[KeyValue(key=k, value=v) for k, v in values])
    empty = deserialize_message(cdr.diagnostic_status(0, '', '', '', []), DiagnosticStatus)
    assert empty == DiagnosticStatus()


def test_lone_surrogates_are_replaced_not_raised():
    raw = cdr.diagnostic_status(0, 'n', 'bad \udc80 text', '1.0', [('k', '\ud800')])
    msg = deserialize_message(raw, DiagnosticStatus)
    assert msg.message == 'bad ? text' and msg.values[0].value == '?'


def test_trajectory_shape_reader_matches_the_middleware():
    assert cdr.trajectory_shape_matches_rclpy()


_text = st.text(st.characters(codec='utf-8', exclude_characters='\x00'), max_size=12)
_counts = st.tuples(*[st.integers(0, 5)] * 4)


@settings(max_examples=300, deadline=None)
@given(frame=_text, names=st.lists(_text, max_size=6), counts=st.lists(_counts, max_size=6),
       sec=st.integers(-2 ** 31, 2 ** 31 - 1), nanosec=st.integers(0, 2 ** 32 - 1))
def test_trajectory_shape_reads_what_rclpy_wrote(frame, names, counts, sec, nanosec):
    """Stamp, names and per-point array lengths of any goal, read without deserializing it."""
    msg = JointTrajectory(joint_names=names)
    msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id = sec, nanosec, frame
    for p, v, a, e in counts:
        msg.points.append(JointTrajectoryPoint(positions=[0.5] * p, velocities=[-1.0] * v,
                                               accelerations=[2.0] * a, effort=[3.0] * e))
    data = serialize_message(msg)
    assert cdr.trajectory_shape(data) == ((sec, nanosec), names, [tuple(c) for c in counts])


def test_trajectory_shape_refuses_truncated_or_foreign_bytes():
    """Bytes that end early or are not little-endian CDR raise ValueError (never IndexError)."""
    msg = JointTrajectory(joint_names=['waist', 'elbow'])
    msg.points = [JointTrajectoryPoint(positions=[0.1, 0.2], velocities=[0.0, 0.0])] * 3
    data = serialize_message(msg)
    for end in range(len(data) - 1):
        if end >= 4:   # a cut inside the last point's padding may still parse to its end
            try:
                shape = cdr.trajectory_shape(data[:end])
            except ValueError:
                continue
            assert shape == cdr.trajectory_shape(data), end
    with pytest.raises(ValueError):
        cdr.trajectory_shape(b'\x00\x00\x00\x00' + data[4:])    # big-endian CDR header
    with pytest.raises(ValueError):
        cdr.trajectory_shape(data[:4] + b'\x00' * 8 + b'\xff\xff\xff\x7f')   # 2 G names


def test_pose_stamped_reader_matches_rclpy():
    """wire.cdr.read_pose_stamped reads rclpy's bytes; what it cannot read it declines (None)."""
    from geometry_msgs.msg import PoseStamped
    from px100_control.wire.cdr import read_pose_stamped
    from rclpy.serialization import serialize_message
    assert cdr.pose_stamped_matches_rclpy()
    msg = PoseStamped()
    msg.header.frame_id = 'px100/base_link'
    msg.pose.position.x = 0.25
    raw = serialize_message(msg)
    assert read_pose_stamped(raw)[:3] == (0, 0, 'px100/base_link')
    assert read_pose_stamped(b'\x00\x00' + raw[2:]) is None        # big-endian header
    assert read_pose_stamped(raw[:40]) is None                       # truncated


@settings(max_examples=200, deadline=None)
@given(text=st.text(st.characters(codec='utf-8', exclude_characters='\x00'), max_size=40))
def test_string_writer_matches_rclpy(text):
    """The recorder's std_msgs/String bytes read back by rclpy; the fallback writer agrees."""
    assert cdr.string_matches_rclpy() and cdr.string_writer() is cdr.string_message
    assert deserialize_message(cdr.string_message(text), String).data == text
    assert deserialize_message(cdr.rclpy_string_message(text), String).data == text
