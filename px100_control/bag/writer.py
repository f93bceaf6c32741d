"""
Write rosbag2-compatible MCAP bags from serialized (CDR) message bytes.

A bag is a directory ``<name>/`` holding ``<name>_0.mcap`` and ``metadata.yaml`` (rosbag2 v9,
storage ``mcap``), as ``ros2 bag record -s mcap`` writes it: MCAP profile ``ros2``, one
schema per type (the concatenated definition: ``ros2msg``, or ``ros2idl`` for the service event
and action types, :mod:`px100_control.bag.interface_defs`), one ``cdr`` channel per topic
with ``offered_qos_profiles`` and ``topic_type_hash`` metadata, and a ``rosbag2`` metadata
record. Messages go into compressed chunks; a chunk is written out when it is full or
``flush_period_s`` after its first message, so a killed writer loses at most that much
(``bag_reindex`` recovers the rest). Times are integer ns since the epoch.

Example::

    with BagWriter('/tmp/run1') as bag:
        bag.add_topic('/px100/joint_states', 'sensor_msgs/msg/JointState')
        bag.write('/px100/joint_states', cdr_bytes, log_time_ns)
"""
import os
import threading
import time
from typing import Dict, Iterable, List, Optional

from px100_control.bag import metadata as md
from px100_control.bag.interface_defs import any_type_hash, schema
from px100_control.bag.mcap_io import McapWriter
from px100_control.bag.msgdefs import normalize_type
from px100_control.errors import BagError

PROFILE = 'ros2'
LIBRARY = 'px100_control.bag.writer'
COMPRESSIONS = ('zstd', 'lz4', 'none')


def storage_file_name(bag_dir: str) -> str:
    """Return the file name rosbag2 gives the first storage file of a bag dir."""
    return os.path.basename(os.path.normpath(bag_dir)) + '_0.mcap'


def _mcap_writer(stream, compression: str, chunk_size: int) -> McapWriter:
    if compression not in COMPRESSIONS:
        raise BagError(f"unknown compression '{compression}' (one of {', '.join(COMPRESSIONS)})")
    return McapWriter(stream, compression=compression, chunk_size=chunk_size)


class BagWriter:
    """
    A rosbag2 MCAP bag being written (thread safe; a context manager that closes it).

    :param bag_dir: bag directory; created, must not exist or be empty (unless exist_ok)
    :param compression: chunk compression, 'zstd' (default), 'lz4' or 'none'
    :param chunk_size: uncompressed chunk size [bytes] that triggers writing a chunk
    :param flush_period_s: longest time [s] a message waits in memory before its chunk is
        written to the file (what a SIGKILL can lose); <= 0 writes a chunk per message
    :param file_name: storage file name (default ``<dir name>_0.mcap``)
    :param exist_ok: allow an existing non-empty directory (the storage file must not exist)
    :raises BagError: the directory exists and is not empty, or cannot be created
    """

    def __init__(self, bag_dir: str, *, compression: str = 'zstd', chunk_size: int = 1 << 20,
                 flush_period_s: float = 1.0, file_name: Optional[str] = None,
                 exist_ok: bool = False, custom_data: Optional[Dict[str, str]] = None,
                 clock=time.monotonic):
        self.bag_dir = os.path.abspath(bag_dir)
        if os.path.exists(self.bag_dir) and not os.path.isdir(self.bag_dir):
            raise BagError(f'{self.bag_dir}: exists and is not a directory')
        if os.path.isdir(self.bag_dir) and os.listdir(self.bag_dir) and not exist_ok:
            raise BagError(f'{self.bag_dir}: bag directory exists and is not empty '
                           '(choose another output directory)')
        try:
            os.makedirs(self.bag_dir, exist_ok=True)
        except OSError as exc:
            raise BagError(f'{self.bag_dir}: cannot create the bag directory: '
                           f'{exc.strerror}') from None
        self.file_name = file_name or storage_file_name(self.bag_dir)
        self.path = os.path.join(self.bag_dir, self.file_name)
        if os.path.exists(self.path):
            raise BagError(f'{self.path}: exists already')
        if compression not in COMPRESSIONS:
            raise BagError(f"unknown compression '{compression}' "
                           f"(one of {', '.join(COMPRESSIONS)})")
        self.compression = compression
        self.flush_period_s = float(flush_period_s)
        self.custom_data = dict(custom_data or {})
        self._clock = clock
        self._lock = threading.Lock()
        self._stream = open(self.path, 'wb')
        self._writer = _mcap_writer(self._stream, compression, int(chunk_size))
        self._writer.start(PROFILE, LIBRARY)
        self._stream.flush()
        self._schemas: Dict[str, int] = {}
        self._channels: Dict[str, int] = {}
        self._sequence: Dict[str, int] = {}
        self.topics: Dict[str, md.TopicRecord] = {}
        self.message_count = 0
        self.start_ns: Optional[int] = None
        self.end_ns: Optional[int] = None
        self._pending = 0
        self._first_pending_at: Optional[float] = None
        self.closed = False

    # -- topics -----------------------------------------------------------------------------
    def has_topic(self, topic: str) -> bool:
        """Return True once the topic has a channel in this bag."""
        return topic in self._channels

    def add_topic(self, topic: str, type_name: str, offered_qos_profiles: Iterable[dict] = (),
                  type_description_hash: Optional[str] = None,
                  msgdef: Optional[str] = None,
                  msgdef_encoding: str = 'ros2msg') -> md.TopicRecord:
        """
        Add a topic (a schema for its type if new, and a channel); return its record.

        :param offered_qos_profiles: QoS profile dicts of its publishers (see bag.metadata)
        :param msgdef: the concatenated definition; looked up when not given
        :param msgdef_encoding: its schema encoding, 'ros2msg' or 'ros2idl'
        :raises BagError: malformed type, unknown definition, topic added with another type
        """
        full = normalize_type(type_name)
        if not topic or not topic.startswith('/'):
            raise BagError(f"topic name '{topic}' must be absolute (start with '/')")
        with self._lock:
            self._check_open()
            if topic in self.topics:
                if self.topics[topic].type_name != full:
                    raise BagError(f"topic '{topic}' is already in the bag as "
                                   f"'{self.topics[topic].type_name}', not '{full}'")
                return self.topics[topic]
            if full not in self._schemas:
                encoding, text = ((msgdef_encoding, msgdef) if msgdef is not None
                                  else schema(full))
                self._schemas[full] = self._writer.add_schema(full, encoding,
                                                              text.encode('utf-8'))
            profiles = [dict(p) for p in offered_qos_profiles]
            digest = (any_type_hash(full) if type_description_hash is None
                      else type_description_hash)
            self._channels[topic] = self._writer.add_channel(
                topic, 'cdr', self._schemas[full],
                {'offered_qos_profiles': md.qos_to_yaml(profiles), 'topic_type_hash': digest})
            self._sequence[topic] = 0
            record = md.TopicRecord(name=topic, type_name=full, offered_qos_profiles=profiles,
                                    type_description_hash=digest)
            self.topics[topic] = record
            return record

    # -- messages ---------------------------------------------------------------------------
    def write(self, topic: str, data: bytes, log_time_ns: int,
              publish_time_ns: Optional[int] = None) -> None:
        """
        Append one serialized message (CDR bytes with encapsulation header) to a topic.

        :raises BagError: unknown topic (call add_topic first) or the bag is closed
        """
        with self._lock:
            self._check_open()
            channel = self._channels.get(topic)
            if channel is None:
                raise BagError(f"topic '{topic}' was not added to the bag")
            log_time_ns = int(log_time_ns)
            seq = self._sequence[topic] + 1
            self._sequence[topic] = seq
            self._writer.add_message(
                channel, log_time_ns,
                log_time_ns if publish_time_ns is None else int(publish_time_ns), data, seq)
            self.topics[topic].message_count += 1
            self.message_count += 1
            if self.start_ns is None or log_time_ns < self.start_ns:
                self.start_ns = log_time_ns
            if self.end_ns is None or log_time_ns > self.end_ns:
                self.end_ns = log_time_ns
            self._pending += 1
            now = self._clock()
            if self._first_pending_at is None:
                self._first_pending_at = now
            if now - self._first_pending_at >= self.flush_period_s:
                self._flush_locked()

    def flush(self) -> None:
        """Write the open chunk (if any) to the file now."""
        with self._lock:
            if not self.closed:
                self._flush_locked()

    def flush_if_due(self) -> bool:
        """Write the open chunk if its first message waited flush_period_s; return True if so."""
        with self._lock:
            if self.closed or self._first_pending_at is None:
                return False
            if self._clock() - self._first_pending_at < self.flush_period_s:
                return False
            self._flush_locked()
            return True

    def _flush_locked(self) -> None:
        self._writer.flush()
        self._pending = 0
        self._first_pending_at = None

    def _check_open(self) -> None:
        if self.closed:
            raise BagError(f'{self.path}: the bag is closed')

    # -- closing ----------------------------------------------------------------------------
    def topic_records(self) -> List[md.TopicRecord]:
        """Return the topic records in the order they were added."""
        return list(self.topics.values())

    def metadata(self) -> dict:
        """Return the rosbag2 metadata document of what was written so far."""
        start = self.start_ns or 0
        files = [md.FileRecord(path=self.file_name, starting_time_ns=start,
                               duration_ns=(self.end_ns or start) - start,
                               message_count=self.message_count)]
        return md.build_metadata(self.topic_records(), files, self.custom_data)

    def close(self, write_metadata_yaml: bool = True) -> str:
        """Finish the MCAP file (summary, index, footer), write metadata.yaml; return its path."""
        with self._lock:
            if self.closed:
                return os.path.join(self.bag_dir, md.METADATA_FILE)
            doc = self.metadata()
            info = doc['rosbag2_bagfile_information']
            self._writer.add_metadata('rosbag2', {
                'serialized_metadata': md.dump_metadata(info), 'ros_distro': md.ROS_DISTRO})
            self._writer.finish()
            self._stream.flush()
            os.fsync(self._stream.fileno())
            self._stream.close()
            self.closed = True
        if not write_metadata_yaml:
            return ''
        return md.write_metadata(self.bag_dir, doc)

    def __enter__(self):
        """Context manager support."""
        return self

    def __exit__(self, *exc):
        """Close the bag on exit (also after an exception: what was written is kept)."""
        self.close()
