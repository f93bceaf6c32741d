"""Message definitions: rosbag2's concatenated ros2msg format, shipped texts, RIHS01 hashes."""
import glob
import json
import os

from bag_support import TYPESTORE
from mcap_ros2._dynamic import generate_dynamic
from px100_control.bag import msgdefs
import pytest
from rosbags.typesys import get_types_from_msg


TYPES = ['sensor_msgs/msg/JointState', 'geometry_msgs/msg/PoseStamped', 'std_msgs/msg/String',
         'geometry_msgs/msg/PoseArray', 'trajectory_msgs/msg/JointTrajectory',
         'diagnostic_msgs/msg/DiagnosticStatus', 'diagnostic_msgs/msg/DiagnosticArray',
         'action_msgs/msg/GoalStatusArray', 'tf2_msgs/msg/TFMessage']


def _fields(type_name, text):
    """Return {type: [(field name, field type)]} of a concatenated definition, via rosbags."""
    out = {}
    for name, part in msgdefs.split_definition(text):
        name = msgdefs.normalize_type(name or type_name)
        types = get_types_from_msg(part, name)
        out[name] = [(f[0], repr(f[1])) for f in types[name][1]]
    return out


def test_joint_state_definition_is_rosbag2s_concatenation():
    """Root text first, then each dependency once after 80 '=' and 'MSG: pkg/Name'."""
    text = msgdefs.message_definition('sensor_msgs/msg/JointState')
    parts = text.split('\n' + '=' * 80 + '\n')
    assert parts[0] == msgdefs.msg_text('sensor_msgs/msg/JointState')
    assert [p.splitlines()[0] for p in parts[1:]] == ['MSG: std_msgs/Header',
                                                      'MSG: builtin_interfaces/Time']
    assert text.count('MSG: ') == 2


@pytest.mark.parametrize('type_name', TYPES)
def test_definitions_parse_with_mcap_ros2_and_rosbags(type_name):
    """Every recorded type's schema is understood by both readers, with the same fields."""
    text = msgdefs.message_definition(type_name)
    decoders = generate_dynamic(type_name, text)
    assert type_name in decoders
    ours = _fields(type_name, text)
    full = msgdefs.normalize_type(type_name)
    ref = TYPESTORE.fielddefs[full][1]
    assert [f[0] for f in ours[full]] == [f[0] for f in ref]


def test_tf_message_hash_matches_rosbags():
    """The computed RIHS01 of tf2_msgs/TFMessage (not installed) equals rosbags' value."""
    assert msgdefs.type_hash('tf2_msgs/msg/TFMessage') == \
        TYPESTORE.hash_rihs01('tf2_msgs/msg/TFMessage')


def test_rihs01_recomputes_every_installed_hash():
    """The hash function reproduces the hash stored in every installed type description."""
    share = os.path.dirname(msgdefs._interface_file('std_msgs/msg/String', '.json'))
    files = glob.glob(os.path.join(os.path.dirname(os.path.dirname(share)), '*', 'msg',
                                   '*.json'))
    assert len(files) > 50
    for path in files:
        with open(path) as f:
            desc = json.load(f)
        name = desc['type_description_msg']['type_description']['type_name']
        want = [h['hash_string'] for h in desc['type_hashes'] if h['type_name'] == name][0]
        assert msgdefs.rihs01(desc['type_description_msg']) == want, path


@pytest.mark.parametrize('type_name', sorted(msgdefs.HANDWRITTEN_MSGS))
def test_shipped_texts_match_the_installed_ones(type_name):
    """The hand-written fallback texts declare the same fields as the installed .msg files."""
    if type_name == 'tf2_msgs/msg/TFMessage':
        ref = TYPESTORE.fielddefs[type_name][1]
        got = get_types_from_msg(msgdefs.HANDWRITTEN_MSGS[type_name], type_name)[type_name][1]
        assert [f[0] for f in got] == [f[0] for f in ref]
        return
    installed = get_types_from_msg(msgdefs.msg_text(type_name), type_name)[type_name][1]
    shipped = get_types_from_msg(msgdefs.HANDWRITTEN_MSGS[type_name], type_name)[type_name][1]
    assert [f[0] for f in shipped] == [f[0] for f in installed]


def test_hashes_of_installed_types_match_rosbags():
    """type_hash() of installed types is the hash rosbags computes."""
    for type_name in TYPES:
        assert msgdefs.type_hash(type_name) == TYPESTORE.hash_rihs01(type_name), type_name


@pytest.mark.parametrize('bad', ['JointState', 'a/b/c/d', '', 'sensor_msgs//JointState', '1x/Y'])
def test_malformed_type_names_are_refused(bad):
    """A malformed type name raises MessageTypeError naming it."""
    with pytest.raises(msgdefs.MessageTypeError, match='not a ROS 2 message type name'):
        msgdefs.normalize_type(bad)


def test_unknown_type_is_a_clear_error():
    """A type whose package is not installed (and not shipped) names itself in the error."""
    with pytest.raises(msgdefs.MessageTypeError, match='nosuch_msgs/msg/Thing'):
        msgdefs.message_definition('nosuch_msgs/Thing')
    assert msgdefs.type_hash('nosuch_msgs/msg/Thing') == ''


GENERATED = ['std_srvs/srv/Trigger_Event', 'action_msgs/srv/CancelGoal_Event',
             'px100_control_msgs/srv/ComputeIK_Event', 'interbotix_xs_msgs/srv/RobotInfo_Event',
             'control_msgs/action/FollowJointTrajectory_SendGoal_Event',
             'control_msgs/action/FollowJointTrajectory_GetResult_Event',
             'control_msgs/action/FollowJointTrajectory_FeedbackMessage',
             'control_msgs/action/GripperCommand_SendGoal_Event']


@pytest.mark.parametrize('type_name', GENERATED)
def test_service_and_action_types_get_idl_schemas_rosbags_reads(type_name):
    """ros2idl in rosbag2's IDL concatenation: rosbags parses it and finds the same hash."""
    from px100_control.bag import interface_defs
    from rosbags.typesys import get_typestore, get_types_from_idl, Stores
    encoding, text = interface_defs.schema(type_name)
    assert encoding == 'ros2idl'
    chunks = text.split('=' * 80 + '\n')[1:]
    assert chunks[0].startswith(f'IDL: {type_name}\n') and '#include' not in text
    types = {}
    for chunk in chunks:
        types.update(get_types_from_idl(chunk.split('\n', 1)[1]))
    store = get_typestore(Stores.EMPTY)
    store.register(types)
    assert store.hash_rihs01(type_name) == interface_defs.any_type_hash(type_name)
    assert interface_defs.any_type_hash(type_name).startswith('RIHS01_')


def test_msg_types_keep_their_ros2msg_schema():
    """A .msg type is not generated: its schema is the ros2msg concatenation as before."""
    from px100_control.bag import interface_defs
    assert interface_defs.schema('interbotix_xs_msgs/msg/JointGroupCommand') == (
        'ros2msg', msgdefs.message_definition('interbotix_xs_msgs/msg/JointGroupCommand'))
    with pytest.raises(msgdefs.MessageTypeError, match='nosuch_srvs/srv/X_Event'):
        interface_defs.schema('nosuch_srvs/srv/X_Event')
