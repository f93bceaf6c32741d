"""
Bad bags: missing, empty, truncated, corrupt, not MCAP, broken metadata, unknown topics.

Every case must give a BagError naming the file and the problem (and the command-line tools one
error line and exit status 1), never a traceback from inside a library. Truncated files are
recovered by reindex from their complete chunks.
"""
import os
import shutil

from bag_support import mcap_path, write_run_bag
from mcap.reader import make_reader
from px100_control.bag import inspect_cli, reindex
from px100_control.bag.reader import BagReader
from px100_control.errors import BagError
import pytest
from rosbags.rosbag2 import Reader


@pytest.fixture(scope='module')
def good_bag(tmp_path_factory):
    """Return a complete bag with many small chunks (truncation keeps some of them)."""
    bag_dir = str(tmp_path_factory.mktemp('good') / 'run')
    written = write_run_bag(bag_dir, seconds=2.0, chunk_size=2048)
    return bag_dir, sum(len(v) for v in written.values())


def _copy(good_bag, tmp_path, name='bag'):
    dst = str(tmp_path / name)
    shutil.copytree(good_bag[0], dst)
    os.rename(os.path.join(dst, 'run_0.mcap'), os.path.join(dst, f'{name}_0.mcap'))
    with open(os.path.join(dst, 'metadata.yaml')) as f:
        text = f.read().replace('run_0.mcap', f'{name}_0.mcap')
    with open(os.path.join(dst, 'metadata.yaml'), 'w') as f:
        f.write(text)
    return dst


def _truncate(path, keep):
    with open(path, 'r+b') as f:
        f.truncate(keep)


def _error(path, capsys, *extra):
    """Run inspect on path: return its stderr, checking exit status 1 and no traceback."""
    status = inspect_cli.main([str(path), '--no-plots', *extra])
    err = capsys.readouterr().err
    assert status == 1
    assert 'Traceback' not in err
    assert err.startswith('inspect: error: ')
    return err


def test_missing_path(tmp_path, capsys):
    """A path that does not exist."""
    with pytest.raises(BagError, match='no such bag'):
        BagReader(str(tmp_path / 'nope'))
    assert 'nope' in _error(tmp_path / 'nope', capsys)


def test_empty_directory(tmp_path, capsys):
    """A directory without metadata.yaml or .mcap."""
    (tmp_path / 'empty').mkdir()
    with pytest.raises(BagError, match='empty directory'):
        BagReader(str(tmp_path / 'empty'))
    _error(tmp_path / 'empty', capsys)


def test_empty_file(tmp_path, capsys):
    """A zero-byte .mcap (directly and inside a bag dir)."""
    path = tmp_path / 'zero.mcap'
    path.write_bytes(b'')
    with pytest.raises(BagError, match=r'zero\.mcap: empty file'):
        BagReader(str(path))
    assert 'empty file' in _error(path, capsys)
    with pytest.raises(BagError, match='empty file'):
        reindex.reindex(str(path))


def test_not_mcap(tmp_path, capsys):
    """A text file named .mcap."""
    path = tmp_path / 'text.mcap'
    path.write_text('hello, this is not a bag at all\n' * 10)
    with pytest.raises(BagError, match='not an MCAP file'):
        BagReader(str(path))
    assert 'not an MCAP file' in _error(path, capsys)
    with pytest.raises(BagError, match='not an MCAP file'):
        reindex.reindex(str(path))


def test_truncated_file_is_named_and_recoverable(good_bag, tmp_path, capsys):
    """A file cut in the middle: a clear 'truncated' error, then reindex recovers its chunks."""
    bag = _copy(good_bag, tmp_path)
    path = mcap_path(bag)
    _truncate(path, os.path.getsize(path) // 2)
    with pytest.raises(BagError, match=r'bag_0\.mcap: truncated.*bag_reindex'):
        BagReader(bag)
    _error(bag, capsys)
    result = reindex.reindex(bag)
    assert result.rebuilt
    report = result.files[0]
    assert 0 < report.message_count < good_bag[1]
    assert os.path.exists(report.backup) and report.backup.endswith('.damaged')
    with Reader(bag) as reader:
        assert sum(1 for _ in reader.messages()) == report.message_count
    with BagReader(bag) as reader:
        assert reader.summary().message_count == report.message_count


def test_header_only_file_has_nothing_to_recover(good_bag, tmp_path):
    """A file killed before its first chunk: reindex says there is nothing to recover."""
    bag = _copy(good_bag, tmp_path)
    path = mcap_path(bag)
    _truncate(path, 40)
    with pytest.raises(BagError, match='no complete chunk'):
        reindex.reindex(bag)
    assert os.path.getsize(path) == 40  # nothing deleted


def test_corrupt_chunk_is_reported_and_skipped_by_reindex(good_bag, tmp_path, capsys):
    """Garbage in the middle of the data: 'corrupt' with the file name; reindex keeps the rest."""
    bag = _copy(good_bag, tmp_path)
    path = mcap_path(bag)
    with open(path, 'rb') as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    target = chunks[len(chunks) // 3]
    with open(path, 'r+b') as f:  # overwrite bytes inside one chunk's compressed data
        f.seek(target.chunk_start_offset + target.chunk_length - 40)
        f.write(bytes(range(7, 39)))
    with pytest.raises(BagError, match=r'bag_0\.mcap: corrupt'):
        with BagReader(bag) as reader:
            reader.summary()
    assert 'corrupt' in _error(bag, capsys)
    result = reindex.reindex(bag)
    assert result.rebuilt and 0 < result.message_count < good_bag[1]
    with Reader(bag) as reader:
        assert sum(1 for _ in reader.messages()) == result.message_count


def test_broken_metadata_yaml(good_bag, tmp_path, capsys):
    """metadata.yaml that is not YAML, not rosbag2, another storage, or naming missing files."""
    bag = _copy(good_bag, tmp_path)
    meta = os.path.join(bag, 'metadata.yaml')
    cases = [(': : [', 'not valid YAML'),
             ('just: text\n', 'not a rosbag2 metadata file'),
             ('rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n'
              '  relative_file_paths: [x.db3]\n', "storage 'sqlite3' is not supported"),
             ('rosbag2_bagfile_information:\n  storage_identifier: mcap\n'
              '  relative_file_paths: [gone_0.mcap]\n', 'do not exist: gone_0.mcap')]
    for text, message in cases:
        with open(meta, 'w') as f:
            f.write(text)
        with pytest.raises(BagError, match=message):
            BagReader(bag)
        assert 'metadata.yaml' in _error(bag, capsys) or 'gone_0' in message
    result = reindex.reindex(bag)  # rebuilds metadata.yaml from the .mcap
    assert not result.rebuilt and result.message_count == good_bag[1]
    with Reader(bag) as reader:
        assert sum(1 for _ in reader.messages()) == good_bag[1]


def test_missing_metadata_yaml_still_reads_and_reindexes(good_bag, tmp_path):
    """A bag dir with only its .mcap reads; reindex writes metadata.yaml for rosbag2 tools."""
    bag = _copy(good_bag, tmp_path)
    os.remove(os.path.join(bag, 'metadata.yaml'))
    with BagReader(bag) as reader:
        summary = reader.summary()
    assert summary.message_count == good_bag[1] and not summary.has_metadata_yaml
    assert reindex.main([bag]) == 0
    with Reader(bag) as reader:
        assert reader.message_count == good_bag[1]


def test_unknown_topic(good_bag, capsys):
    """Asking for a topic the bag does not have names it and lists the bag's topics."""
    with BagReader(good_bag[0]) as reader:
        with pytest.raises(BagError, match=r"no topic '/px100/nope'.*/px100/joint_states"):
            list(reader.iter_raw(['/px100/nope']))
    assert '/px100/nope' in _error(good_bag[0], capsys, '--topics', '/px100/nope')


def test_reindex_command_errors(tmp_path, capsys):
    """bag_reindex on a missing path: exit 1 and one error line."""
    assert reindex.main([str(tmp_path / 'missing')]) == 1
    err = capsys.readouterr().err
    assert err.startswith('bag_reindex: error:') and 'Traceback' not in err


def test_undecodable_type_definition(tmp_path):
    """A topic whose stored definition cannot be parsed: decoding names the type and the bag."""
    from px100_control.bag.writer import BagWriter
    bag_dir = str(tmp_path / 'odd')
    with BagWriter(bag_dir) as bag:
        bag.add_topic('/odd', 'odd_msgs/msg/Thing', msgdef='float64[ broken ] ]] x\n',
                      type_description_hash='')
        bag.write('/odd', b'\x00\x01\x00\x00' + bytes(8), 1)
    with BagReader(bag_dir) as reader:
        assert reader.topics == {'/odd': 'odd_msgs/msg/Thing'}
        assert reader.summary().message_count == 1  # raw access still works
        with pytest.raises(BagError, match=r"definition of 'odd_msgs/msg/Thing' cannot be"):
            list(reader.iter_decoded(['/odd']))


def test_reindex_keeps_the_idl_schema_of_service_events(tmp_path):
    """A truncated bag of service events is rebuilt with its ros2idl schema (rosbags reads it)."""
    from pathlib import Path

    from px100_control.bag.writer import BagWriter
    from rclpy.serialization import serialize_message
    from rosbags.highlevel import AnyReader
    from std_srvs.srv import Trigger
    bag = str(tmp_path / 'calls')
    topic = '/px100/reset/_service_event'
    writer = BagWriter(bag, flush_period_s=0.0)
    writer.add_topic(topic, 'std_srvs/srv/Trigger_Event')
    for seq in range(3):
        event = Trigger.Event()
        event.info.event_type, event.info.sequence_number = 2, seq
        event.response.append(Trigger.Response(success=True, message=f'reset {seq}'))
        writer.write(topic, serialize_message(event), 1_700_000_000_000_000_000 + seq)
    path = writer.path
    complete = os.path.getsize(path)       # every chunk is out (flush period 0)
    writer.close()
    with open(path, 'r+b') as f:
        f.truncate(complete)               # no summary, no footer: as after a SIGKILL
    os.remove(os.path.join(bag, 'metadata.yaml'))
    result = reindex.reindex(bag)
    assert result.rebuilt and result.message_count == 3
    with AnyReader([Path(bag)]) as reader:
        (conn,) = reader.connections
        assert conn.msgdef.format.name == 'IDL'
        got = [reader.deserialize(raw, conn.msgtype).response[0].message
               for _, _, raw in reader.messages()]
    assert got == ['reset 0', 'reset 1', 'reset 2']
    with BagReader(bag) as reader:       # this package's own reader decodes them too
        assert [m.response[0].message for _, m in reader.iter_decoded()] == got
