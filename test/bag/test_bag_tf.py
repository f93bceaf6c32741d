"""/tf from joint states through the URDF: agrees with the robot model, strict CDR bytes."""
from bag_support import decode, TYPESTORE
from hypothesis import given, settings, strategies as st
from mcap_ros2._dynamic import serialize_dynamic
import numpy as np
from px100_control.bag.msgdefs import message_definition
from px100_control.bag.tf import encode_tf_message, TF_TYPE, TfTree
from px100_control.models.registry import load_robot
from px100_control.models.urdf_prefix import prefix_urdf
from px100_control.wire.cdr import tf_message
import pytest


@pytest.fixture(scope='module')
def px100():
    """Return the px100 model and its tree from the prefixed URDF (as sim_driver has it)."""
    model = load_robot('px100')
    return model, TfTree(prefix_urdf(model.urdf_xml, 'px100'))


def _quat_to_matrix(x, y, z, w):
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def test_chain_matches_the_model_fk(px100):
    """The end-effector link pose through the tree equals RobotModel.fk at random q."""
    model, tree = px100
    assert tree.root == 'px100/base_link'
    for q in model.random_configurations(50, rng=3):
        pose = tree.link_poses(dict(zip(model.joint_names, q)))['px100/ee_gripper_link']
        np.testing.assert_allclose(pose, model.fk(q), atol=1e-12)


def test_tf_message_composes_to_the_same_poses(px100):
    """Chaining the decoded TFMessage transforms gives the same link poses (mimic included)."""
    model, tree = px100
    q = dict(zip(model.joint_names, [0.4, -0.6, 0.5, 0.3]), gripper=0.7, left_finger=0.027)
    msg = decode(encode_tf_message(tree.tf_entries(q), 1_700_000_000_123_456_789), TF_TYPE)
    assert len(msg.transforms) == len(tree.joints)
    poses = {'px100/base_link': np.eye(4)}
    for tr in msg.transforms:
        assert (tr.header.stamp.sec, tr.header.stamp.nanosec) == (1_700_000_000, 123_456_789)
        T = np.eye(4)
        r, t = tr.transform.rotation, tr.transform.translation
        T[:3, :3] = _quat_to_matrix(r.x, r.y, r.z, r.w)
        T[:3, 3] = [t.x, t.y, t.z]
        poses[tr.child_frame_id] = poses[tr.header.frame_id] @ T
    ref = tree.link_poses(q)
    for link, pose in ref.items():
        np.testing.assert_allclose(poses[link], pose, atol=1e-12)
    # the right finger mimics the left one (multiplier -1)
    fingers = {tr.child_frame_id: tr.transform.translation for tr in msg.transforms}
    left, right = fingers['px100/left_finger_link'], fingers['px100/right_finger_link']
    assert abs(left.y - right.y) > 0.04


def test_encoding_is_byte_identical_to_rosbags_and_mcap_ros2(px100):
    """Our TFMessage CDR equals rosbags' serializer and mcap_ros2's (from the .msg text)."""
    model, tree = px100
    data = encode_tf_message(tree.joint_transforms({'waist': 1.0, 'elbow': -0.3}), 42)
    msg = decode(data, TF_TYPE)
    assert bytes(TYPESTORE.serialize_cdr(msg, TF_TYPE)) == data
    enc = serialize_dynamic(TF_TYPE, message_definition(TF_TYPE))[TF_TYPE]

    def as_dict(tr):
        t, r = tr.transform.translation, tr.transform.rotation
        return {'header': {'stamp': {'sec': tr.header.stamp.sec,
                                     'nanosec': tr.header.stamp.nanosec},
                           'frame_id': tr.header.frame_id},
                'child_frame_id': tr.child_frame_id,
                'transform': {'translation': {'x': t.x, 'y': t.y, 'z': t.z},
                              'rotation': {'x': r.x, 'y': r.y, 'z': r.z, 'w': r.w}}}
    assert enc({'transforms': [as_dict(tr) for tr in msg.transforms]}) == data


def test_prefix_and_missing_joints():
    """An unprefixed URDF gets the frame prefix; joints absent from the state sit at 0."""
    model = load_robot('px100')
    tree = TfTree(model.urdf_xml, 'px100/')
    entries = tree.tf_entries({})
    assert entries[0][0] == 'px100/base_link'
    np.testing.assert_allclose(tree.link_poses({'px100/waist': 0.0})['ee_gripper_link'],
                               model.fk(np.zeros(4)), atol=1e-12)
    values = tree.joint_values({'waist': float('nan')})
    assert values['waist'] == 0.0


_frame = st.text(st.characters(codec='utf-8', exclude_characters='\x00'), max_size=9)
_num = st.floats(allow_nan=False, allow_infinity=False, width=64)
_entry = st.tuples(_frame, _frame, st.tuples(_num, _num, _num), st.tuples(_num, _num, _num, _num))


@settings(max_examples=200, deadline=None)
@given(entries=st.lists(_entry, max_size=5),
       sec=st.integers(-2 ** 31, 2 ** 31 - 1), nanosec=st.integers(0, 10 ** 9 - 1))
def test_tf_message_bytes_equal_rosbags_for_any_frames(entries, sec, nanosec):
    """wire.cdr.tf_message (no rclpy check: tf2_msgs is not installed) equals rosbags' bytes."""
    data = tf_message(entries, sec, nanosec)
    msg = decode(data, TF_TYPE)
    assert bytes(TYPESTORE.serialize_cdr(msg, TF_TYPE)) == data
    assert [(t.header.frame_id, t.child_frame_id) for t in msg.transforms] == \
        [(p, c) for p, c, _, _ in entries]
