"""The IK service's CDR reply writers read back, through rclpy, as the intended messages."""
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from px100_control.ros import cdr
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState


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
