"""CDR: the hand-written writers (joint_states, /clock, strings) agree with rclpy."""
from hypothesis import given, settings, strategies as st
from px100_control.ros import cdr
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import String


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


def test_lone_surrogates_are_replaced_not_raised():
    msg = deserialize_message(cdr.string_message('bad \udc80 text'), String)
    assert msg.data == 'bad ? text'
    w = cdr.JointStateWriter(['ok', '\ud800'])
    assert list(deserialize_message(w.write(0, 0, []), JointState).name) == ['ok', '?']


@settings(max_examples=200, deadline=None)
@given(text=st.text(st.characters(codec='utf-8', exclude_characters='\x00'), max_size=40))
def test_string_writer_matches_rclpy(text):
    """The recorder's std_msgs/String bytes read back by rclpy; the fallback writer agrees."""
    assert cdr.string_matches_rclpy() and cdr.string_writer() is cdr.string_message
    assert deserialize_message(cdr.string_message(text), String).data == text
    assert deserialize_message(cdr.rclpy_string_message(text), String).data == text
