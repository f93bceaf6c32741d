"""
`record` through real nodes.

What was published is in the bag, byte for byte, readable by rosbags and mcap; SIGINT and
SIGTERM finalise the bag; after SIGKILL the file reads up to its last chunk and bag_reindex
recovers it; the in-process Recorder API and its stop conditions.
"""
import os
import signal
import subprocess
import time

from bag_ros_support import FakeRobot, wait_until
from bag_support import decode, mcap_path
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from px100_control.bag.reader import BagReader
from px100_control.errors import BagError
from px100_control.models.registry import load_robot
from px100_control.models.urdf_prefix import prefix_urdf
from px100_control.tools.processes import executable_path
import pytest
from rosbags.rosbag2 import Reader

pytestmark = pytest.mark.ros
START_TIMEOUT = 90.0  # the 2-core test machine can be slow to import numpy/rclpy
JS = '/px100/joint_states'


def _read_bag(bag_dir, topics=None):
    """Return {topic: [decoded]} and {topic: msgtype} read with rosbags (strict CDR)."""
    out, types, qos = {}, {}, {}
    with Reader(bag_dir) as reader:
        for conn in reader.connections:
            types[conn.topic] = conn.msgtype
            qos[conn.topic] = conn.ext.offered_qos_profiles
        wanted = [c for c in reader.connections if topics is None or c.topic in topics]
        for conn, _, raw in reader.messages(connections=wanted):
            out.setdefault(conn.topic, []).append(decode(bytes(raw), conn.msgtype))
    return out, types, qos


def _start_recording(node_process, fake, bag_dir, *args):
    proc = node_process('record', '-o', bag_dir, *args)
    assert proc.wait_for_output('recording /px100/joint_states', START_TIMEOUT), proc.output()
    assert fake.wait_for_subscribers([fake.js]), 'the recorder never subscribed'
    return proc


def _publish(fake, first, count, period=0.005):
    for seq in range(first, first + count):
        fake.js.publish(fake.joint_state(seq))
        time.sleep(period)


def test_record_robot_topics_then_sigint(rclpy_context, spin_node, node_process, tmp_path):
    """--robot-only records every /px100 topic and /diagnostics (not others), content, /tf."""
    fake = spin_node(FakeRobot(context=rclpy_context))
    urdf = prefix_urdf(load_robot('px100').urdf_xml, 'px100')
    fake.desc.publish(fake.String(data=urdf))
    fake.held.publish(fake.String(data='red_cube'))
    bag_dir = str(tmp_path / 'all')
    proc = _start_recording(node_process, fake, bag_dir, '--robot-only', '--tf-rate', '1000')
    assert fake.wait_for_subscribers([fake.sp, fake.diag])
    _publish(fake, 0, 300)
    sp = fake.joint_state(7)
    sp.name, sp.position = ['elbow'], [0.25]
    fake.sp.publish(sp)
    fake.diag.publish(DiagnosticArray(status=[DiagnosticStatus(name='x', message='hello')]))
    fake.other.publish(fake.String(data='not recorded'))
    time.sleep(1.0)
    assert proc.stop(30.0) == 0, proc.output()
    msgs, types, qos = _read_bag(bag_dir)
    assert [m.position[0] for m in msgs['/px100/joint_states']] == list(range(300))
    assert msgs['/px100/robot_description'][0].data == urdf
    assert [m.data for m in msgs['/px100/world/held_object']] == ['red_cube']
    assert msgs['/px100/commands/joint_setpoints'][0].position.tolist() == [0.25]
    assert msgs['/diagnostics'][0].status[0].message == 'hello'
    assert '/elsewhere/chatter' not in types
    assert types['/tf'] == 'tf2_msgs/msg/TFMessage'
    assert 0 < len(msgs['/tf']) <= 300
    frames = {tr.child_frame_id for tr in msgs['/tf'][-1].transforms}
    assert 'px100/ee_gripper_link' in frames
    assert qos['/px100/robot_description'][0].durability.name == 'TRANSIENT_LOCAL'
    assert qos['/px100/joint_states'][0].durability.name == 'VOLATILE'
    # the mcap library (with mcap_ros2's decoder) reads the same messages; BagReader agrees
    by_topic = {}
    with open(mcap_path(bag_dir), 'rb') as f:
        for _, channel, _, decoded in make_reader(
                f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            by_topic.setdefault(channel.topic, []).append(decoded)
    assert {k: len(v) for k, v in by_topic.items()} == {k: len(v) for k, v in msgs.items()}
    assert [m.position[0] for m in by_topic[JS]] == list(range(300))
    assert by_topic['/px100/robot_description'][0].data == urdf
    with BagReader(bag_dir) as reader:
        summary = reader.summary()
    assert summary.topics['/px100/joint_states'].message_count == 300
    assert summary.message_count == sum(len(v) for v in msgs.values())


def test_record_a_records_every_topic(rclpy_context, spin_node, node_process, tmp_path):
    """-a records every topic of the graph, as ros2 bag record -a: other namespaces too."""
    fake = spin_node(FakeRobot(context=rclpy_context))
    bag_dir = str(tmp_path / 'everything')
    proc = _start_recording(node_process, fake, bag_dir, '-a', '--no-tf')
    assert fake.wait_for_subscribers([fake.other, fake.diag])
    _publish(fake, 0, 20)
    fake.other.publish(fake.String(data='recorded too'))
    time.sleep(1.0)
    assert proc.stop(30.0) == 0, proc.output()
    # other processes of the test's DDS domain may be in the bag too: decode only ours
    msgs, types, _ = _read_bag(bag_dir, ['/elsewhere/chatter', JS])
    assert [m.data for m in msgs['/elsewhere/chatter']] == ['recorded too']
    assert [m.position[0] for m in msgs[JS]] == list(range(20))


def test_sigterm_finalises_selected_topics(rclpy_context, spin_node, node_process, tmp_path):
    """SIGTERM closes the bag (metadata.yaml, summary); only the named topics are recorded."""
    fake = spin_node(FakeRobot(context=rclpy_context))
    bag_dir = str(tmp_path / 'term')
    proc = _start_recording(node_process, fake, bag_dir, 'joint_states', '--no-tf')
    _publish(fake, 0, 120)
    fake.diag.publish(DiagnosticArray())
    time.sleep(0.8)
    proc.signal(signal.SIGTERM)
    assert proc.proc.wait(30) == 0, proc.output()
    assert os.path.isfile(os.path.join(bag_dir, 'metadata.yaml'))
    msgs, types, _ = _read_bag(bag_dir)
    assert set(types) == {'/px100/joint_states'}
    assert [m.position[0] for m in msgs['/px100/joint_states']] == list(range(120))


def test_sigkill_leaves_a_readable_bag_that_reindex_recovers(
        rclpy_context, spin_node, node_process, tmp_path):
    """After SIGKILL the file reads up to its last chunk (a flush period lost); reindex it."""
    fake = spin_node(FakeRobot(context=rclpy_context))
    bag_dir = str(tmp_path / 'kill')
    proc = _start_recording(node_process, fake, bag_dir, 'joint_states', '--flush-period',
                            '0.5')
    _publish(fake, 0, 300, period=0.01)  # about 3 s at 100 Hz
    time.sleep(0.2)
    proc.signal(signal.SIGKILL)
    proc.proc.wait(10)
    path = mcap_path(bag_dir)
    assert not os.path.exists(os.path.join(bag_dir, 'metadata.yaml'))
    with pytest.raises(BagError, match='truncated'):
        BagReader(bag_dir)
    streamed, topics = [], {}
    with open(path, 'rb') as f:
        try:
            for record in StreamReader(f, validate_crcs=True).records:
                if isinstance(record, Channel):
                    topics[record.id] = record.topic
                elif isinstance(record, Message) and topics[record.channel_id] == JS:
                    streamed.append(decode(record.data, 'sensor_msgs/msg/JointState'))
        except EndOfFile:  # the end of a killed file
            pass
    seqs = [m.position[0] for m in streamed]
    assert seqs == list(range(len(seqs)))
    # at 100 Hz a 0.5 s flush period loses at most ~50 messages (plus scheduling slack)
    assert len(seqs) >= 300 - 150, len(seqs)
    result = subprocess.run([executable_path('bag_reindex'), bag_dir], capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert 'recovered' in result.stdout
    msgs, _, _ = _read_bag(bag_dir)
    assert [m.position[0] for m in msgs['/px100/joint_states']] == seqs


def test_in_process_recorder_api(rclpy_context, spin_node, tmp_path):
    """Recorder(...) as a context manager on a given context; max_messages stops it exactly."""
    from px100_control.ros.recorder import Recorder
    fake = spin_node(FakeRobot(context=rclpy_context))
    bag_dir = str(tmp_path / 'inproc')
    rec = Recorder(bag_dir, topics=['joint_states'], context=rclpy_context, max_messages=50,
                   write_tf=False).start()
    try:
        assert fake.wait_for_subscribers([fake.js])
        _publish(fake, 0, 80)
        assert rec.wait(30.0), 'max_messages did not stop the recorder'
        assert rec.node.stop_reason == '50 messages recorded'
    finally:
        meta = rec.stop()
    assert meta.endswith('metadata.yaml') and os.path.isfile(meta)
    msgs, _, _ = _read_bag(bag_dir)
    assert [m.position[0] for m in msgs['/px100/joint_states']] == list(range(50))
    assert rclpy_context.ok()  # the caller's context is left alone

    bag2 = str(tmp_path / 'ctx')
    with Recorder(bag2, duration=30.0, context=rclpy_context, write_tf=False) as rec2:
        assert wait_until(lambda: '/px100/joint_states' in rec2.node.topics_recorded, 30)
        assert fake.wait_for_subscribers([fake.js])
        _publish(fake, 1000, 20)
        time.sleep(0.5)
    msgs, types, _ = _read_bag(bag2)
    assert [m.position[0] for m in msgs['/px100/joint_states']] == list(range(1000, 1020))


def test_record_cli_errors(node_process, tmp_path):
    """A non-empty output directory and a bad option value: one error line, exit 1."""
    (tmp_path / 'full').mkdir()
    (tmp_path / 'full' / 'x').write_text('x')
    proc = node_process('record', '-o', str(tmp_path / 'full'))
    assert proc.proc.wait(START_TIMEOUT) == 1
    assert 'record: error:' in proc.output() and 'not empty' in proc.output()
    assert 'Traceback' not in proc.output()
    proc = node_process('record', '-o', str(tmp_path / 'd'), '--duration', '-1')
    assert proc.proc.wait(START_TIMEOUT) == 1
    assert 'duration must be a number > 0' in proc.output()
    assert 'Traceback' not in proc.output()


def test_recorder_announces_the_topics_it_matched(rclpy_context, spin_node, node_process,
                                                  tmp_path):
    """recorder/matched (latched) lists a topic once the recorder matched its publisher."""
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import String
    fake = spin_node(FakeRobot(context=rclpy_context))
    listener = spin_node(Node('matched_listener', context=rclpy_context))
    heard = []
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    proc = _start_recording(node_process, fake, str(tmp_path / 'matched'), '-a', '--no-tf')
    listener.create_subscription(String, '/px100/recorder/matched',
                                 lambda msg: heard.append(msg.data.splitlines()), latched)
    assert wait_until(lambda: heard and JS in heard[-1], 30.0), (heard, proc.output())
    assert not {'/px100/recorder/ready', '/px100/recorder/matched'} & set(heard[-1]), heard[-1]
    assert proc.stop(30.0) == 0, proc.output()
