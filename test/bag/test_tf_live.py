"""LiveTf (the live robot_state_publisher's logic, no ROS): static/moving, rate, bad input."""
import math

from px100_control.bag.tf_live import LiveTf
from px100_control.bag.world import WorldMarker
from px100_control.errors import InvalidInputError
from px100_control.models.registry import load_robot
from px100_control.models.urdf_prefix import prefix_urdf
import pytest

MODEL = load_robot('px100')
ARM = list(MODEL.joint_names)


@pytest.fixture
def live():
    """Return a LiveTf of the px100 (prefixed URDF, as sim_driver publishes it), 20 Hz."""
    tf = LiveTf('px100', 50_000_000)
    static = tf.set_description(prefix_urdf(MODEL.urdf_xml, 'px100'))
    assert {e[1] for e in static} >= {'px100/ee_arm_link', 'px100/ee_gripper_link'}
    return tf


def test_static_and_moving_split(live):
    """Fixed joints only on /tf_static; the movable joints present in the state on /tf."""
    fixed = {live.tree.frame(j.child) for j in live.tree.joints if j.kind == 'fixed'}
    assert {e[1] for e in live.tree.static_entries()} == fixed
    entries = live.joint_state(ARM, [0.1, 0.2, 0.3, 0.4], 10**9)
    assert [e[1] for e in entries] == ['px100/shoulder_link', 'px100/upper_arm_link',
                                       'px100/forearm_link', 'px100/gripper_link']
    assert not {e[1] for e in entries} & fixed


def test_rate_limit_follows_the_stamps(live):
    """At most one /tf per 50 ms of stamps; a stamp going back is published at once."""
    stamps = [10**9 + k * 10_000_000 for k in range(11)]
    published = [s for s in stamps if live.joint_state(['waist'], [0.1], s)]
    assert published == [stamps[0], stamps[5], stamps[10]]
    assert live.joint_state(['waist'], [0.1], 5 * 10**8)        # the clock restarted
    live.min_period_ns = 0
    assert all(live.joint_state(['waist'], [0.1], 5 * 10**8 + k) for k in range(1, 5))


def test_bad_states_and_unknown_joints(live):
    """Lengths that differ are refused; NaN and unknown joints give no transform."""
    with pytest.raises(InvalidInputError, match='2 names but 1 positions'):
        live.joint_state(['waist', 'elbow'], [0.1], 10**9)
    assert live.joint_state(['waist'], [math.nan], 2 * 10**9) == []
    assert live.joint_state(['nobody'], [0.3], 3 * 10**9) == []
    fingers = live.joint_state(['left_finger'], [0.03], 4 * 10**9)
    assert sorted(e[1] for e in fingers) == ['px100/left_finger_link', 'px100/right_finger_link']


def test_bad_description_keeps_the_previous_tree(live):
    """A malformed URDF raises with a one-line reason; the tree stays."""
    tree = live.tree
    for urdf, words in (('<robot', 'not valid XML'), ('<a/>', 'not <robot>'),
                        ('<robot name="x"><link name="a"/></robot>', 'no movable joint')):
        with pytest.raises(InvalidInputError, match=words) as info:
            live.set_description(urdf)
        assert '\n' not in str(info.value)
        assert live.tree is tree
    assert LiveTf('').joint_state(ARM, [0.0] * 4, 1) == []       # no description yet


def test_unprefixed_description_and_objects():
    """An unprefixed URDF gets <robot_name>/; objects become <robot_name>/objects/<name>."""
    tf = LiveTf('arm2')
    tf.set_description(MODEL.urdf_xml)
    assert tf.tree.frame(tf.tree.root) == 'arm2/base_link'
    marker = WorldMarker('objects', 0, 'cube', 'box', (0.02,) * 3, (1, 0, 0, 1), (0.2, 0, 0.01),
                         (0, 0, 0, 1), 'arm2/base_link')
    table = WorldMarker('table', 1, 'table', 'box', (1, 1, 0.01), (1, 1, 1, 1), (0, 0, 0),
                        (0, 0, 0, 1), 'arm2/base_link')
    assert tf.objects([marker, table]) == [('arm2/base_link', 'arm2/objects/cube',
                                            (0.2, 0, 0.01), (0, 0, 0, 1))]
