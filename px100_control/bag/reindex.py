"""
Recover a bag: rebuild ``metadata.yaml`` and, for a truncated MCAP file, a clean copy.

``ros2 run px100_control bag_reindex BAG`` (BAG: a bag directory or one .mcap file). A complete
MCAP file is only re-read to rebuild metadata.yaml. A truncated or damaged one (recorder killed,
disk full) is scanned record by record: every complete, CRC-valid chunk is copied into a new
file, which replaces the original; the original is kept as ``<name>.mcap.damaged`` (nothing is
deleted). Messages in an incomplete last chunk are lost: the recorder writes a chunk at least
every ``flush_period_s`` (1 s by default), so that bounds the loss.
"""
import argparse
from dataclasses import dataclass, field
import os
import sys
from typing import Dict, List, Optional

from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader
from px100_control.bag import metadata as md
from px100_control.bag.reader import BagReader, check_mcap_file, MCAP_MAGIC
from px100_control.bag.writer import BagWriter
from px100_control.errors import BagError

BACKUP_SUFFIX = '.damaged'


@dataclass
class FileReport:
    """What reindexing did to one storage file."""

    path: str
    message_count: int
    rebuilt: bool
    backup: Optional[str] = None
    lost_bytes: int = 0
    problem: str = ''


@dataclass
class ReindexResult:
    """Result of :func:`reindex`."""

    bag_dir: str
    metadata_path: str
    message_count: int
    files: List[FileReport] = field(default_factory=list)

    @property
    def rebuilt(self) -> bool:
        """Return True if any storage file had to be rebuilt from its readable chunks."""
        return any(f.rebuilt for f in self.files)


def _storage_files(bag_dir: str) -> List[str]:
    names = []
    if os.path.isfile(os.path.join(bag_dir, md.METADATA_FILE)):
        try:
            info = md.read_metadata(bag_dir)
            names = [str(p) for p in info['relative_file_paths']
                     if os.path.isfile(os.path.join(bag_dir, str(p)))]
        except BagError:
            names = []  # a broken metadata.yaml is exactly what we are rebuilding
    if not names:
        names = sorted(f for f in os.listdir(bag_dir) if f.endswith('.mcap'))
    return [os.path.join(bag_dir, n) for n in names]


def _is_complete(path: str) -> bool:
    try:
        check_mcap_file(path)
    except BagError as exc:
        if 'truncated' in str(exc):
            return False
        raise
    try:
        with BagReader(path) as reader:
            for _ in reader.iter_raw():
                pass
    except BagError:
        return False
    return True


def recover_file(path: str) -> FileReport:
    """
    Rewrite a truncated/damaged MCAP file from its complete chunks; keep the original.

    :raises BagError: not an MCAP file at all, or not one complete chunk in it
    """
    size = os.path.getsize(path)
    bag_dir, name = os.path.split(path)
    tmp_name = name + '.recovering'
    if os.path.exists(os.path.join(bag_dir, tmp_name)):
        os.remove(os.path.join(bag_dir, tmp_name))
    schemas: Dict[int, Schema] = {}
    channels: Dict[int, Channel] = {}
    writer = BagWriter(bag_dir, file_name=tmp_name, exist_ok=True, flush_period_s=60.0)
    problem = ''
    good_offset = 0
    with open(path, 'rb') as f:
        reader = StreamReader(f, validate_crcs=True)
        try:
            for record in reader.records:
                good_offset = f.tell()
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Message):
                    channel = channels.get(record.channel_id)
                    if channel is None:
                        continue
                    if not writer.has_topic(channel.topic):
                        schema = schemas.get(channel.schema_id)
                        if schema is None:
                            continue
                        meta = channel.metadata or {}
                        writer.add_topic(channel.topic, schema.name,
                                         md.qos_from_yaml(meta.get('offered_qos_profiles')),
                                         meta.get('topic_type_hash', ''),
                                         msgdef=schema.data.decode('utf-8', 'replace'),
                                         msgdef_encoding=schema.encoding or 'ros2msg')
                    writer.write(channel.topic, record.data, record.log_time,
                                 record.publish_time)
        except Exception as exc:  # the end of the readable part: truncation or damage
            problem = f'{exc.__class__.__name__}: {exc}'.strip().rstrip(':')
    count = writer.message_count
    writer.close(write_metadata_yaml=False)
    tmp_path = os.path.join(bag_dir, tmp_name)
    if count == 0:
        os.remove(tmp_path)
        raise BagError(f'{path}: no complete chunk of messages to recover ({size} bytes; '
                       f'{problem or "no messages"})')
    backup = path + BACKUP_SUFFIX
    n = 1
    while os.path.exists(backup):
        backup = f'{path}{BACKUP_SUFFIX}.{n}'
        n += 1
    os.replace(path, backup)
    os.replace(tmp_path, path)
    return FileReport(path=path, message_count=count, rebuilt=True, backup=backup,
                      lost_bytes=max(0, size - good_offset), problem=problem)


def reindex(bag: str) -> ReindexResult:
    """
    Rebuild a bag's metadata.yaml (and its truncated/damaged storage files); return a report.

    :param bag: bag directory or .mcap file
    :raises BagError: no such bag, no MCAP file, or nothing recoverable
    """
    bag = os.path.abspath(os.path.expanduser(str(bag)))
    if not os.path.exists(bag):
        raise BagError(f'{bag}: no such bag (file or directory does not exist)')
    if os.path.isfile(bag):
        if bag.endswith(md.METADATA_FILE):
            bag = os.path.dirname(bag)
            paths = _storage_files(bag)
        else:
            paths = [bag]
            bag = os.path.dirname(bag)
    else:
        paths = _storage_files(bag)
    if not paths:
        raise BagError(f'{bag}: no .mcap storage file to reindex')
    reports = []
    for path in paths:
        if os.path.getsize(path) == 0:
            raise BagError(f'{path}: empty file (0 bytes): nothing to recover')
        with open(path, 'rb') as f:
            if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                raise BagError(f'{path}: not an MCAP file (bad magic bytes): cannot recover')
        if _is_complete(path):
            reports.append(FileReport(path=path, message_count=-1, rebuilt=False))
        else:
            reports.append(recover_file(path))
    topics: Dict[str, md.TopicRecord] = {}
    files = []
    total = 0
    for report in reports:
        with BagReader(report.path) as reader:
            summary = reader.summary()
        report.message_count = summary.message_count
        total += summary.message_count
        files.append(md.FileRecord(path=os.path.basename(report.path),
                                   starting_time_ns=summary.start_ns,
                                   duration_ns=summary.end_ns - summary.start_ns,
                                   message_count=summary.message_count))
        for t in summary.topics.values():
            rec = topics.setdefault(t.name, md.TopicRecord(
                name=t.name, type_name=t.type_name, offered_qos_profiles=t.offered_qos_profiles,
                type_description_hash=t.type_description_hash))
            rec.message_count += t.message_count
    doc = md.build_metadata(list(topics.values()), files)
    meta_path = md.write_metadata(bag, doc)
    return ReindexResult(bag_dir=bag, metadata_path=meta_path, message_count=total,
                         files=reports)


def main(args=None) -> int:
    """Command line: ``bag_reindex BAG``; exit 0 on success, 1 with a clear message if not."""
    parser = argparse.ArgumentParser(
        prog='bag_reindex',
        description='Rebuild metadata.yaml of a rosbag2 MCAP bag; recover the complete chunks '
                    'of a truncated .mcap file (the original is kept as *.mcap.damaged).')
    parser.add_argument('bag', help='bag directory or .mcap file')
    options = parser.parse_args(sys.argv[1:] if args is None else args)
    try:
        result = reindex(options.bag)
    except BagError as exc:
        print(f'bag_reindex: error: {exc}', file=sys.stderr)
        return 1
    for f in result.files:
        if f.rebuilt:
            print(f'{f.path}: rebuilt from its complete chunks: {f.message_count} messages '
                  f'recovered, {f.lost_bytes} bytes at the end dropped ({f.problem}); '
                  f'original kept as {f.backup}')
        else:
            print(f'{f.path}: complete, {f.message_count} messages')
    print(f'wrote {result.metadata_path} ({result.message_count} messages)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
