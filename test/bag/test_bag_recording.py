"""
The recorder's engine without ROS: topic selection, stop conditions, /tf and robot_description.

The clock is an argument and decoding is injected, so each rule is checked here on its own
(test_bag_record.py and test_bag_record_ahead.py check the node over DDS).
"""
import os

from bag_support import decode, joint_state, string, T0_NS
from px100_control.bag import tf_recording
from px100_control.bag.reader import BagReader
from px100_control.bag.recording import (CONTRACT_ACTIONS, CONTRACT_SERVICES, CONTRACT_TOPICS,
                                         default_output_dir, StopConditions, TopicSelection)
from px100_control.bag.tf import TF_TYPE
from px100_control.bag.tf_recording import TF_BACKLOG, TfRecording
from px100_control.bag.world import WorldMarker
from px100_control.bag.writer import BagWriter
from px100_control.errors import BagError
from px100_control.wire.cdr import string_message
import pytest

ARM = ['waist', 'shoulder', 'elbow', 'wrist_angle']


# -- topic selection ----------------------------------------------------------------------------

def test_default_selection_is_the_robot_namespace_diagnostics_and_tf():
    """No topic named: all of the namespace (calls included), /diagnostics, /tf, /tf_static."""
    sel = TopicSelection('/px100')
    assert (sel.all_topics, sel.robot_only) == (True, True)
    for topic in ('/px100/joint_states', '/diagnostics', '/tf', '/tf_static',
                  '/px100/compute_ik/_service_event',
                  '/px100/arm_controller/follow_joint_trajectory/_action/feedback'):
        assert sel.selected(topic), topic
    assert not sel.selected('/other/joint_states')
    assert not sel.selected('/other/compute_ik/_service_event')
    assert not sel.selected('/px100/recorder/ready')
    assert sel.describe().startswith('all topics of /px100/ (their service events')


def test_all_is_topics_services_and_actions_without_hidden_topics():
    """-a: every topic but hidden ones, every service event and every action's topics."""
    sel = TopicSelection('/px100', all_topics=True)
    assert sel.robot_only is False and (sel.all_services, sel.all_actions) == (True, True)
    assert sel.describe() == 'all topics, service events, actions'
    for topic in ('/other/joint_states', '/tf', '/tf_static', '/other/x/_service_event',
                  '/a/_action/send_goal/_service_event', '/a/_action/cancel_goal/_service_event',
                  '/a/_action/get_result/_service_event', '/a/_action/feedback',
                  '/a/_action/status'):
        assert sel.selected(topic), topic
    assert not sel.selected('/px100/_hidden/x')


def test_all_topics_services_actions_and_hidden_one_by_one():
    """--all-topics, --all-services, --all-actions pick one kind; hidden ones on request."""
    event, feedback = '/px100/compute_ik/_service_event', '/a/_action/feedback'
    topics = TopicSelection('/px100', all_topics=True, all_services=False, all_actions=False)
    assert topics.selected('/x') and not topics.selected(event)
    assert not topics.selected(feedback)
    hidden = TopicSelection('/px100', all_topics=True, all_services=False, all_actions=False,
                            include_hidden=True)
    assert hidden.selected('/px100/_hidden/x') and hidden.selected(event)
    services = TopicSelection('/px100', all_services=True)
    assert services.selected(event) and not services.selected('/x')
    assert not services.selected('/a/_action/send_goal/_service_event')
    assert services.robot_only is False
    actions = TopicSelection('/px100', all_actions=True)
    assert actions.selected(feedback) and actions.selected('/a/_action/status')
    assert not actions.selected(event) and not actions.selected('/x')


def test_named_topics_resolve_in_the_namespace_and_are_always_recorded():
    """Relative names go under the namespace; a named topic is recorded even if hidden."""
    sel = TopicSelection('/px100', topics=['joint_states', '/tf', 'x/_service_event'])
    assert sel.all_topics is False
    assert sel.wanted == {'/px100/joint_states', '/tf', '/px100/x/_service_event'}
    assert sel.selected('/tf') and sel.selected('/px100/joint_states')
    assert sel.selected('/px100/x/_service_event')
    assert not sel.selected('/px100/ee_pose') and not sel.selected('/px100/y/_service_event')
    assert sel.describe() == '/px100/joint_states, /px100/x/_service_event, /tf'
    both = TopicSelection('/px100', topics=['/x'], all_topics=True, robot_only=True)
    assert both.selected('/x') and both.selected('/px100/ee_pose')
    assert not both.selected('/y')


def test_contract_topics_in_a_namespace_and_at_the_root():
    """Contract names go under the namespace; /diagnostics, /tf stay absolute; calls too."""
    topics = {t: (ty, latched) for t, ty, latched in TopicSelection('/arm1').contract_topics()}
    assert len(topics) == len(CONTRACT_TOPICS) + len(CONTRACT_SERVICES) + 5 * len(
        CONTRACT_ACTIONS)
    assert topics['/arm1/robot_description'] == ('std_msgs/msg/String', True)
    assert topics['/diagnostics'] == ('diagnostic_msgs/msg/DiagnosticArray', False)
    assert topics['/tf_static'] == ('tf2_msgs/msg/TFMessage', True)
    assert topics['/arm1/commands/joint_group'] == (
        'interbotix_xs_msgs/msg/JointGroupCommand', False)
    assert topics['/arm1/compute_ik/_service_event'] == (
        'px100_control_msgs/srv/ComputeIK_Event', False)
    action = '/arm1/arm_controller/follow_joint_trajectory/_action/'
    assert topics[action + 'send_goal/_service_event'] == (
        'control_msgs/action/FollowJointTrajectory_SendGoal_Event', False)
    assert topics[action + 'cancel_goal/_service_event'] == (
        'action_msgs/srv/CancelGoal_Event', False)
    assert topics[action + 'status'] == ('action_msgs/msg/GoalStatusArray', True)
    assert topics['/arm1/gripper_controller/gripper_cmd/_action/feedback'] == (
        'control_msgs/action/GripperCommand_FeedbackMessage', False)
    root = TopicSelection('/')
    assert '/joint_states' in {t for t, _, _ in root.contract_topics()}
    assert root.ready_topic == '/recorder/ready'


def test_default_output_dir_is_named_like_ros2_bag():
    """rosbag2_YYYY_MM_DD-HH_MM_SS in the current directory."""
    path = default_output_dir()
    assert os.path.dirname(path) == os.getcwd()
    name = os.path.basename(path)
    assert name.startswith('rosbag2_') and len(name) == len('rosbag2_2026_01_02-03_04_05')


# -- stop conditions ----------------------------------------------------------------------------

def test_stop_conditions_with_the_clock_as_argument():
    """Duration from the start; idle only after a first message; max messages exactly."""
    stop = StopConditions(duration=2.0, max_messages=3, idle_timeout=0.5)
    assert stop.time_reason(101.9, 100.0, None) == ''
    assert stop.time_reason(102.0, 100.0, None) == 'duration 2 s reached'
    assert stop.time_reason(101.0, 100.0, 100.6) == ''
    assert stop.time_reason(101.1, 100.0, 100.6) == 'no message for 0.5 s'
    assert stop.count_reason(2) == '' and stop.count_reason(3) == '3 messages recorded'
    never = StopConditions()
    assert never.time_reason(1e9, 0.0, 0.0) == '' and never.count_reason(10**9) == ''


@pytest.mark.parametrize('kwargs, message', [
    ({'duration': 0}, 'duration must be a number > 0, got 0'),
    ({'idle_timeout': float('inf')}, 'idle_timeout must be a number > 0'),
    ({'idle_timeout': float('nan')}, 'idle_timeout must be a number > 0'),
    ({'max_messages': 0}, 'max_messages must be > 0, got 0'),
])
def test_bad_stop_conditions_are_refused(kwargs, message):
    """Each bad value is named in a BagError."""
    with pytest.raises(BagError, match=message):
        StopConditions(**kwargs)


# -- /tf from joint states and markers ----------------------------------------------------------

def _positions(data):
    msg = decode(data, 'sensor_msgs/msg/JointState')
    stamp = msg.header.stamp
    return dict(zip(msg.name, msg.position)), stamp.sec * 1_000_000_000 + stamp.nanosec


def _engine(bag, markers=None, model='px100', period_ns=10_000_000):
    log = []
    tf = TfRecording(bag, 'px100', model, period_ns, _positions,
                     lambda data: markers[data], lambda data: decode(
                         data, 'std_msgs/msg/String').data,
                     lambda level, text: log.append((level, text)), '/px100/')
    return tf, log


def _tf_messages(bag_dir):
    with BagReader(bag_dir) as reader:
        return [(m.log_time_ns, decode(m.data, TF_TYPE)) for m in reader.iter_raw(['/tf'])]


def test_joint_states_wait_for_the_model_then_get_tf_at_the_rate(tmp_path):
    """Before the URDF is parsed joint states wait; then every one at most each period_ns."""
    bag_dir = str(tmp_path / 'bag')
    with BagWriter(bag_dir) as bag:
        tf, log = _engine(bag)
        q = [0.1, -0.2, 0.3, 0.0]
        first = joint_state(T0_NS, ARM, q)
        tf.take('/px100/joint_states', first, T0_NS, now=5.0)
        assert tf.backlog == [(first, T0_NS)] and tf.first_js_at == 5.0
        assert not bag.has_topic('/tf')
        tf.load_model()
        assert tf.model_ready.is_set() and log == []
        for i in range(1, 6):   # 5 ms apart: every other one is written
            t = T0_NS + i * 5_000_000
            tf.take('/px100/joint_states', joint_state(t, ARM, q), t, now=5.0 + i)
        tf.take('/px100/joint_states', b'\x00\x01\x00\x00broken', T0_NS + 40_000_000, 9.0)
    written = _tf_messages(bag_dir)
    assert [t - T0_NS for t, _ in written] == [0, 10_000_000, 20_000_000]
    frames = {tr.child_frame_id for tr in written[0][1].transforms}
    assert 'px100/ee_gripper_link' in frames and 'px100/upper_arm_link' in frames
    assert written[0][1].transforms[0].header.stamp.sec == T0_NS // 10**9


def test_backlog_is_bounded_and_written_at_close(tmp_path, monkeypatch):
    """At most TF_BACKLOG joint states wait; flush_backlog writes them once the model is in."""
    assert TF_BACKLOG >= 10_000      # 20 s of joint states at 500 Hz while the URDF is parsed
    monkeypatch.setattr(tf_recording, 'TF_BACKLOG', 50)
    bag_dir = str(tmp_path / 'bag')
    with BagWriter(bag_dir) as bag:
        tf, _ = _engine(bag, period_ns=1)
        data = joint_state(T0_NS, ARM, [0.0] * 4)
        for i in range(55):
            tf.joint_states(data, T0_NS + i, now=0.0)
        assert len(tf.backlog) == 50
        tf.start_loading()
        tf.flush_backlog(timeout_s=60.0)
        assert tf.backlog == []
        assert bag.topics['/tf'].type_name == TF_TYPE
    assert len(_tf_messages(bag_dir)) == 50


def test_no_urdf_turns_tf_off_with_a_warning(tmp_path):
    """A model without a URDF: a warning, no /tf, the joint states are recorded as they are."""
    with BagWriter(str(tmp_path / 'bag')) as bag:
        tf, log = _engine(bag, model='no_such_robot')
        tf.load_model()
        assert log and log[0][0] == 'warning' and 'no_such_robot' in log[0][1]
        tf.take('/px100/joint_states', joint_state(T0_NS, ARM, [0.0] * 4), T0_NS, 0.0)
        assert tf.enabled is False and not bag.has_topic('/tf')


def test_a_live_tf_publisher_stops_the_computed_tf_for_good(tmp_path):
    """Asked before each computed /tf: once the graph has a /tf publisher, none is computed."""
    live = []
    bag_dir = str(tmp_path / 'bag')
    with BagWriter(bag_dir) as bag:
        log = []
        tf = TfRecording(bag, 'px100', 'px100', 1, _positions, None, None,
                         lambda level, text: log.append(text), '/px100/',
                         live=lambda: bool(live))
        tf.load_model()
        data = joint_state(T0_NS, ARM, [0.0] * 4)
        tf.take('/px100/joint_states', data, T0_NS, now=0.0)
        live.append(True)          # robot_state_publisher appears
        tf.take('/px100/joint_states', data, T0_NS + 1000, now=0.001)
        assert tf.live_seen and tf.enabled is False and tf.backlog == []
        live.clear()               # gone again: the recorder does not go back (one source)
        tf.take('/px100/joint_states', data, T0_NS + 2000, now=1.0)
        assert [text for text in log if 'live publisher' in text]
    assert [t - T0_NS for t, _ in _tf_messages(bag_dir)] == [0]


def test_object_frames_from_markers(tmp_path):
    """Object markers become <robot>/objects/<name> frames; tables and fixtures do not."""
    cube = WorldMarker(ns='objects', id=0, name='red_cube', shape='box', scale=(0.02,) * 3,
                       rgba=(1.0, 0.0, 0.0, 1.0), position=(0.2, 0.1, 0.01),
                       orientation=(0.0, 0.0, 0.0, 1.0), frame_id='px100/base_link')
    table = WorldMarker(ns='table', id=0, name='table', shape='box', scale=(0.6, 0.8, 0.02),
                        rgba=(0.5, 0.5, 0.5, 1.0), position=(0.2, 0.0, -0.01),
                        orientation=(0.0, 0.0, 0.0, 1.0), frame_id='px100/base_link')
    bag_dir = str(tmp_path / 'bag')
    with BagWriter(bag_dir) as bag:
        tf, _ = _engine(bag, markers={b'a': ([cube, table], 0), b'b': ([table], T0_NS)})
        tf.take('/px100/world/markers', b'a', T0_NS, 0.0)
        tf.take('/px100/world/markers', b'b', T0_NS + 50_000_000, 0.0)   # no object: nothing
        tf.take('/px100/world/markers', b'?', T0_NS + 90_000_000, 0.0)   # malformed: nothing
    (t, msg), = _tf_messages(bag_dir)
    assert t == T0_NS
    assert [(x.header.frame_id, x.child_frame_id) for x in msg.transforms] == [
        ('px100/base_link', 'px100/objects/red_cube')]
    assert msg.transforms[0].header.stamp.sec == T0_NS // 10**9  # stamp 0: the log time


def test_model_description_when_none_is_published(tmp_path):
    """1.5 s after the first joint states, with no robot_description: the prefixed model URDF."""
    bag_dir = str(tmp_path / 'bag')
    with BagWriter(bag_dir) as bag:
        tf, log = _engine(bag)
        tf.load_model()
        assert not tf.description_due(100.0)                     # no joint states yet
        tf.take('/px100/joint_states', joint_state(T0_NS, ARM, [0.0] * 4), T0_NS, 100.0)
        assert not tf.description_due(101.5) and tf.description_due(101.6)
        tf.write_model_description()
        assert not tf.description_due(200.0)
        assert log[-1] == ('info', 'no robot_description published: wrote the px100 model '
                                   'URDF to /px100/robot_description')
    with BagReader(bag_dir) as reader:
        (msg,) = list(reader.iter_raw(['/px100/robot_description']))
        assert reader.qos['/px100/robot_description'][0]['durability'] == 'transient_local'
    urdf = decode(msg.data, 'std_msgs/msg/String').data
    assert 'px100/base_link' in urdf and 'px100/ee_gripper_link' in urdf


def test_a_published_description_is_used_unless_tf_is_off(tmp_path):
    """A recorded robot_description counts as seen; with /tf on, its URDF builds the tree."""
    with BagWriter(str(tmp_path / 'bag')) as bag:
        tf, log = _engine(bag)
        tf.load_model()
        tf.use_description(tf.model_urdf)            # unprefixed: prefixed with the robot name
        assert tf.tree.frame(tf.tree.root) == 'px100/base_link'
        tf.use_description('<robot name="x"><link name="a"/></robot>')
        assert log[-1][0] == 'warning' and 'not a usable URDF' in log[-1][1]
        tf.enabled = False
        tf.take('/px100/robot_description', b'not a string', T0_NS, 0.0)
        assert tf.description_seen and not tf.description_due(1e9)


def test_string_message_is_the_cdr_of_std_msgs_string():
    """Byte-identical to rosbags' serializer."""
    for text in ('', 'x', '<robot name="px100"/>' * 3):
        assert string_message(text) == string(text)
