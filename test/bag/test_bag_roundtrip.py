"""BagWriter -> rosbags, mcap (+ mcap_ros2) and BagReader: same counts, bytes and content."""
import os
import shutil

from bag_support import decode, joint_state, mcap_path, string, T0_NS, write_run_bag
from mcap.reader import make_reader
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
import numpy as np
from px100_control.bag import metadata as md
from px100_control.bag.reader import BagReader, read_messages
from px100_control.bag.writer import BagWriter
from px100_control.errors import BagError
import pytest
from rosbags.rosbag2 import Reader
import yaml


@pytest.fixture(scope='module')
def run_bag(tmp_path_factory):
    """Return a synthetic 2 s run and what was written into it."""
    bag_dir = str(tmp_path_factory.mktemp('bags') / 'run')
    written = write_run_bag(bag_dir, seconds=2.0, chunk_size=4096)
    return bag_dir, written


def test_metadata_yaml_is_rosbag2_jazzy(run_bag):
    """metadata.yaml has the v9 fields ros2 bag info reads, with the right counts and times."""
    bag_dir, written = run_bag
    with open(os.path.join(bag_dir, 'metadata.yaml')) as f:
        info = yaml.safe_load(f)['rosbag2_bagfile_information']
    assert info['version'] == 9
    assert info['storage_identifier'] == 'mcap'
    assert info['relative_file_paths'] == ['run_0.mcap']
    total = sum(len(v) for v in written.values())
    assert info['message_count'] == total
    times = [t for v in written.values() for t, _ in v]
    assert info['starting_time']['nanoseconds_since_epoch'] == min(times)
    assert info['duration']['nanoseconds'] == max(times) - min(times)
    assert info['files'][0]['message_count'] == total
    topics = {t['topic_metadata']['name']: t for t in info['topics_with_message_count']}
    assert set(topics) == set(written)
    for name, entry in topics.items():
        meta = entry['topic_metadata']
        assert entry['message_count'] == len(written[name])
        assert meta['serialization_format'] == 'cdr'
        assert meta['type_description_hash'].startswith('RIHS01_')
        assert isinstance(meta['offered_qos_profiles'], list)
    latched = topics['/px100/robot_description']['topic_metadata']['offered_qos_profiles'][0]
    assert latched['durability'] == 'transient_local' and latched['depth'] == 1


def test_rosbags_reads_every_message_strictly(run_bag):
    """Read with the rosbag2 Reader of rosbags: same bytes, and its strict CDR decoder agrees."""
    bag_dir, written = run_bag
    got = {}
    with Reader(bag_dir) as reader:
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
        for conn, t, raw in reader.messages():
            decode(bytes(raw), conn.msgtype)
            got.setdefault(conn.topic, []).append((t, bytes(raw)))
    assert got == written
    assert qos['/px100/robot_description'][0].durability.name == 'TRANSIENT_LOCAL'


def test_mcap_reader_decodes_with_embedded_schemas(run_bag):
    """Read it with the mcap library and mcap_ros2's decoder (as Foxglove-like tools do)."""
    bag_dir, written = run_bag
    with open(mcap_path(bag_dir), 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        summary = reader.get_summary()
        counts = {}
        last_js = None
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            assert schema.encoding == 'ros2msg' and channel.message_encoding == 'cdr'
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == '/px100/joint_states':
                last_js = decoded
        metadata = list(reader.iter_metadata())
    assert header.profile == 'ros2'
    assert counts == {k: len(v) for k, v in written.items()}
    for channel in summary.channels.values():
        assert 'offered_qos_profiles' in channel.metadata
        assert channel.metadata['topic_type_hash'].startswith('RIHS01_')
    assert [m.name for m in metadata] == ['rosbag2']
    assert 'serialized_metadata' in metadata[0].metadata
    expected = decode(written['/px100/joint_states'][-1][1], 'sensor_msgs/msg/JointState')
    np.testing.assert_array_equal(last_js.position, expected.position)
    assert list(last_js.name) == list(expected.name)


def test_own_reader_summary_and_messages(run_bag):
    """BagReader: counts, rates, time span, and the same bytes in log-time order."""
    bag_dir, written = run_bag
    with BagReader(bag_dir) as reader:
        summary = reader.summary()
        raws = list(reader.iter_raw())
        js = [m for _, m in reader.iter_decoded(['/px100/joint_states'])]
    assert summary.message_count == sum(len(v) for v in written.values())
    assert summary.topics['/px100/joint_states'].rate_hz == pytest.approx(100.0, rel=1e-6)
    sp_rate = summary.topics['/px100/commands/joint_setpoints'].rate_hz
    assert sp_rate == pytest.approx(20.0, rel=1e-3)
    assert summary.has_metadata_yaml
    assert [m.log_time_ns for m in raws] == sorted(m.log_time_ns for m in raws)
    assert sorted((m.topic, m.log_time_ns, m.data) for m in raws) == sorted(
        (k, t, d) for k, v in written.items() for t, d in v)
    assert len(js) == len(written['/px100/joint_states'])
    assert len(list(read_messages(mcap_path(bag_dir)))) == summary.message_count


def test_time_window_and_topic_selection(run_bag):
    """iter_raw honours topics and [start, end) log-time bounds."""
    bag_dir, written = run_bag
    sp = written['/px100/commands/joint_setpoints']
    start, end = sp[3][0], sp[7][0]
    with BagReader(bag_dir) as reader:
        got = list(reader.iter_raw(['/px100/commands/joint_setpoints'], start, end))
    assert [(m.log_time_ns, m.data) for m in got] == sp[3:7]


def test_chunks_reach_the_file_before_close(tmp_path):
    """With a flush period, written chunks are on disk while the bag is still open (SIGKILL)."""
    clock = [0.0]
    bag = BagWriter(str(tmp_path / 'open'), flush_period_s=0.5, clock=lambda: clock[0])
    bag.add_topic('/a', 'std_msgs/msg/String')
    for i in range(10):
        bag.write('/a', string(f'm{i}'), T0_NS + i)
    clock[0] = 0.6
    bag.write('/a', string('m10'), T0_NS + 10)  # the period elapsed: the chunk is written
    bag.write('/a', string('m11'), T0_NS + 11)  # stays in memory
    copy = str(tmp_path / 'killed.mcap')
    shutil.copy(bag.path, copy)
    seen = []
    with open(copy, 'rb') as f:
        try:
            for record in StreamReader(f, validate_crcs=True).records:
                if isinstance(record, Message):
                    seen.append(decode(record.data, 'std_msgs/msg/String').data)
                elif isinstance(record, Channel):
                    assert record.topic == '/a'
        except Exception:  # the file ends after the last chunk, as a killed writer leaves it
            pass
    assert seen == [f'm{i}' for i in range(11)]
    clock[0] = 0.7
    assert not bag.flush_if_due()
    clock[0] = 1.2
    assert bag.flush_if_due()
    bag.close()
    with BagReader(bag.bag_dir) as reader:
        assert reader.summary().message_count == 12


def test_writer_refuses_bad_use(tmp_path):
    """Non-empty output dir, relative topic, type clash, unknown topic, write after close."""
    (tmp_path / 'full').mkdir()
    (tmp_path / 'full' / 'x').write_text('x')
    with pytest.raises(BagError, match='not empty'):
        BagWriter(str(tmp_path / 'full'))
    bag = BagWriter(str(tmp_path / 'ok'))
    with pytest.raises(BagError, match='absolute'):
        bag.add_topic('a', 'std_msgs/msg/String')
    bag.add_topic('/a', 'std_msgs/String')
    assert bag.topics['/a'].type_name == 'std_msgs/msg/String'
    with pytest.raises(BagError, match='already in the bag'):
        bag.add_topic('/a', 'sensor_msgs/msg/JointState')
    with pytest.raises(BagError, match='was not added'):
        bag.write('/b', string('x'), T0_NS)
    with pytest.raises(BagError, match='no message definition'):
        bag.add_topic('/c', 'nosuch_msgs/msg/Thing')
    bag.write('/a', string('x'), T0_NS)
    bag.close()
    with pytest.raises(BagError, match='closed'):
        bag.write('/a', string('y'), T0_NS)
    with pytest.raises(BagError, match='compression'):
        BagWriter(str(tmp_path / 'c'), compression='gzip')


@pytest.mark.parametrize('compression', ['zstd', 'lz4', 'none'])
def test_every_compression_reads_back(tmp_path, compression):
    """zstd, lz4 and uncompressed chunks all read back in rosbags."""
    bag_dir = str(tmp_path / compression)
    with BagWriter(bag_dir, compression=compression, chunk_size=512) as bag:
        bag.add_topic('/js', 'sensor_msgs/msg/JointState', [md.qos_profile()])
        for i in range(50):
            bag.write('/js', joint_state(T0_NS + i, ['a'], [float(i)]), T0_NS + i * 1000)
    with Reader(bag_dir) as reader:
        values = [decode(bytes(raw), c.msgtype).position[0] for c, _, raw in reader.messages()]
    assert values == [float(i) for i in range(50)]
