"""
Read rosbag2 MCAP bags: summary, raw messages, decoded messages; clear errors on bad files.

A bag is given as its directory (``metadata.yaml`` + ``.mcap`` files), a directory holding
only ``.mcap`` files, or one ``.mcap`` file. Every problem with the input (missing, empty,
truncated, corrupt, not MCAP, unknown topic) raises :class:`~px100_control.errors.BagError`
naming the file and what is wrong; nothing from inside the MCAP library leaks out. Messages are
decoded from the schemas stored in the bag, so no ROS install is needed: ``ros2msg`` ones with
``mcap_ros2``, ``ros2idl`` ones (service events, action types) with rosbags, which reads
rosbag2's concatenated IDL form. Times are integer ns since the epoch.
"""
from dataclasses import dataclass, field
import heapq
import io
import os
from typing import Dict, Iterable, Iterator, List, Optional, Tuple

from mcap.reader import make_reader
from mcap.records import Channel, Schema
from mcap.stream_reader import StreamReader
from px100_control.bag import metadata as md
from px100_control.errors import BagError
from px100_control.wire.private_api import definition_decoders
from rosbags.typesys import get_types_from_idl, get_typestore, Stores

MCAP_MAGIC = b'\x89MCAP0\r\n'
_FOOTER_AND_MAGIC = 1 + 8 + 20 + 8
REINDEX_HINT = 'recover it with `ros2 run px100_control bag_reindex {path}`'


@dataclass
class RawMessage:
    """One serialized message of a bag."""

    topic: str
    type_name: str
    log_time_ns: int
    publish_time_ns: int
    data: bytes
    sequence: int = 0


@dataclass
class TopicSummary:
    """Per-topic statistics of a bag."""

    name: str
    type_name: str
    message_count: int = 0
    first_ns: Optional[int] = None
    last_ns: Optional[int] = None
    offered_qos_profiles: List[dict] = field(default_factory=list)
    type_description_hash: str = ''

    @property
    def rate_hz(self) -> float:
        """Mean message rate [Hz] (0 for fewer than two messages)."""
        if self.message_count < 2 or not self.last_ns or self.last_ns <= self.first_ns:
            return 0.0
        return (self.message_count - 1) / ((self.last_ns - self.first_ns) * 1e-9)


@dataclass
class BagSummary:
    """What a bag holds: files, topics, time span and message count."""

    path: str
    files: List[str]
    topics: Dict[str, TopicSummary]
    start_ns: int
    end_ns: int
    message_count: int
    has_metadata_yaml: bool

    @property
    def duration_s(self) -> float:
        """Time from the first to the last message [s]."""
        return max(0, self.end_ns - self.start_ns) * 1e-9


def check_mcap_file(path: str) -> None:
    """
    Check that a file exists, is not empty, is MCAP and is complete (ends with the magic).

    :raises BagError: naming the file and the problem
    """
    if not os.path.exists(path):
        raise BagError(f'{path}: no such file')
    if not os.path.isfile(path):
        raise BagError(f'{path}: not a regular file')
    size = os.path.getsize(path)
    if size == 0:
        raise BagError(f'{path}: empty file (0 bytes)')
    try:
        with open(path, 'rb') as f:
            head = f.read(len(MCAP_MAGIC))
            if head != MCAP_MAGIC:
                raise BagError(f'{path}: not an MCAP file (bad magic bytes {head[:8]!r})')
            if size < 2 * len(MCAP_MAGIC) + _FOOTER_AND_MAGIC - 8:
                raise BagError(f'{path}: truncated: only {size} bytes, no MCAP footer; '
                               + REINDEX_HINT.format(path=os.path.dirname(path) or path))
            f.seek(-len(MCAP_MAGIC), io.SEEK_END)
            tail = f.read(len(MCAP_MAGIC))
    except OSError as exc:
        raise BagError(f'{path}: cannot read: {exc.strerror}') from None
    if tail != MCAP_MAGIC:
        raise BagError(f'{path}: truncated: the file ends without the MCAP footer after '
                       f'{size} bytes (was the recorder killed?); '
                       + REINDEX_HINT.format(path=os.path.dirname(path) or path))


def resolve_bag(path: str) -> Tuple[str, List[str], Optional[dict]]:
    """
    Return (bag directory, absolute .mcap paths, metadata info or None) of a bag path.

    :raises BagError: missing path, empty directory, metadata naming missing files
    """
    if path is None or str(path).strip() == '':
        raise BagError('no bag path given')
    path = os.path.abspath(os.path.expanduser(str(path)))
    if not os.path.exists(path):
        raise BagError(f'{path}: no such bag (file or directory does not exist)')
    if os.path.isfile(path):
        if os.path.basename(path) == md.METADATA_FILE:
            return resolve_bag(os.path.dirname(path))
        return os.path.dirname(path), [path], None
    info = None
    if os.path.isfile(os.path.join(path, md.METADATA_FILE)):
        info = md.read_metadata(path)
        files = [os.path.join(path, str(p)) for p in info['relative_file_paths']]
        # rosbag2 before v6 stored paths relative to the parent directory
        fixed = []
        for f in files:
            if not os.path.exists(f):
                alt = os.path.join(os.path.dirname(path), os.path.relpath(f, path))
                f = alt if os.path.exists(alt) else f
            fixed.append(f)
        missing = [f for f in fixed if not os.path.exists(f)]
        if missing:
            raise BagError(f'{path}: metadata.yaml lists storage file(s) that do not exist: '
                           f"{', '.join(os.path.basename(m) for m in missing)}")
        return path, fixed, info
    files = sorted(os.path.join(path, f) for f in os.listdir(path) if f.endswith('.mcap'))
    if not files:
        if not os.listdir(path):
            raise BagError(f'{path}: empty directory, not a bag (no metadata.yaml, no .mcap)')
        raise BagError(f'{path}: not a bag (no metadata.yaml and no .mcap file)')
    return path, files, None


class _File:
    """One open MCAP file with its summary."""

    def __init__(self, path: str):
        check_mcap_file(path)
        self.path = path
        self.stream = open(path, 'rb')
        try:
            self.reader = make_reader(self.stream, validate_crcs=True)
            self.header = self.reader.get_header()
            self.summary = self.reader.get_summary()
        except BagError:
            self.stream.close()
            raise
        except Exception as exc:  # the mcap library raises many types on damaged files
            self.stream.close()
            raise BagError(f'{path}: corrupt MCAP file: cannot read its header/summary '
                           f'({_reason(exc)}); '
                           + REINDEX_HINT.format(path=os.path.dirname(path))) from None
        self.channels = dict(self.summary.channels) if self.summary else {}
        self.schemas = dict(self.summary.schemas) if self.summary else {}
        if self.summary is None:
            self._scan_channels()

    def _scan_channels(self) -> None:
        self.stream.seek(0)
        try:
            for record in StreamReader(self.stream, validate_crcs=True).records:
                if isinstance(record, Channel):
                    self.channels[record.id] = record
                elif isinstance(record, Schema):
                    self.schemas[record.id] = record
        except Exception as exc:
            raise BagError(f'{self.path}: corrupt MCAP file ({_reason(exc)})') from None

    def close(self) -> None:
        self.stream.close()


def _reason(exc: BaseException) -> str:
    text = str(exc).strip()
    name = exc.__class__.__name__
    return f'{name}: {text}' if text else name


class BagReader:
    """
    An open bag (context manager). ``topics`` maps topic name -> type.

    :param path: bag directory, or one .mcap file
    :raises BagError: missing, empty, truncated, corrupt or not a bag
    """

    def __init__(self, path: str):
        self.bag_dir, self.paths, self.info = resolve_bag(path)
        self.path = os.path.abspath(str(path))
        self._files: List[_File] = []
        try:
            for p in self.paths:
                self._files.append(_File(p))
        except BagError:
            self.close()
            raise
        self.topics: Dict[str, str] = {}
        self.qos: Dict[str, List[dict]] = {}
        self.type_hashes: Dict[str, str] = {}
        self.schema_texts: Dict[str, str] = {}
        #: type name -> schema encoding ('ros2msg', or 'ros2idl' for service/action types)
        self.schema_encodings: Dict[str, str] = {}
        for f in self._files:
            for channel in f.channels.values():
                schema = f.schemas.get(channel.schema_id)
                type_name = schema.name if schema is not None else ''
                self.topics.setdefault(channel.topic, type_name)
                meta = channel.metadata or {}
                try:
                    self.qos.setdefault(channel.topic,
                                        md.qos_from_yaml(meta.get('offered_qos_profiles')))
                except BagError as exc:
                    raise BagError(f"{f.path}: topic '{channel.topic}': {exc}") from None
                self.type_hashes.setdefault(channel.topic, meta.get('topic_type_hash', ''))
                if schema is not None:
                    text = schema.data.decode('utf-8', 'replace')
                    self.schema_texts.setdefault(type_name, text)
                    self.schema_encodings.setdefault(type_name, schema.encoding)
        self._decoders: Dict[str, object] = {}

    def close(self) -> None:
        """Close the files."""
        for f in self._files:
            f.close()

    def __enter__(self):
        """Context manager support."""
        return self

    def __exit__(self, *exc):
        """Close on exit."""
        self.close()

    # -- selection --------------------------------------------------------------------------
    def check_topics(self, topics: Optional[Iterable[str]]) -> Optional[List[str]]:
        """
        Return the topic list (None = all) after checking that every topic is in the bag.

        :raises BagError: a topic that the bag does not have
        """
        if topics is None:
            return None
        topics = list(topics)
        unknown = [t for t in topics if t not in self.topics]
        if unknown:
            raise BagError(f"{self.path}: no topic {', '.join(repr(t) for t in unknown)} in the "
                           f"bag (it has: {', '.join(sorted(self.topics)) or 'no topics'})")
        return topics

    # -- iteration --------------------------------------------------------------------------
    def _iter_file(self, f: _File, topics, start_ns, end_ns) -> Iterator[RawMessage]:
        try:
            it = f.reader.iter_messages(topics=topics, log_time_order=True,
                                        starting_at=start_ns, ending_before=end_ns)
            for schema, channel, message in it:
                yield RawMessage(channel.topic, schema.name if schema is not None else '',
                                 message.log_time, message.publish_time, message.data,
                                 message.sequence)
        except BagError:
            raise
        except Exception as exc:  # damaged chunk, CRC mismatch, bad record...
            raise BagError(f'{f.path}: corrupt data ({_reason(exc)}); '
                           + REINDEX_HINT.format(path=self.bag_dir)) from None

    def iter_raw(self, topics: Optional[Iterable[str]] = None, start_ns: Optional[int] = None,
                 end_ns: Optional[int] = None) -> Iterator[RawMessage]:
        """
        Yield the raw messages of the selected topics in log-time order.

        :param start_ns: first log time included; end_ns: first log time excluded
        :raises BagError: unknown topic, or damaged data met while reading
        """
        topics = self.check_topics(topics)
        iters = [self._iter_file(f, topics, start_ns, end_ns) for f in self._files]
        if len(iters) == 1:
            yield from iters[0]
        else:
            yield from heapq.merge(*iters, key=lambda m: m.log_time_ns)

    def decoder(self, type_name: str):
        """
        Return a function bytes -> decoded message (attribute access) for a type in the bag.

        :raises BagError: the bag has no usable definition for that type
        """
        if type_name in self._decoders:
            return self._decoders[type_name]
        text = self.schema_texts.get(type_name)
        if not text:
            raise BagError(f"{self.path}: no message definition stored for type '{type_name}'")
        try:
            if self.schema_encodings.get(type_name) == 'ros2idl':
                decoders = _idl_decoders(type_name, text)
            else:
                decoders = definition_decoders(type_name, text)
        except Exception as exc:
            raise BagError(f"{self.path}: the stored definition of '{type_name}' cannot be "
                           f'parsed ({_reason(exc)})') from None
        if type_name not in decoders:
            raise BagError(f"{self.path}: the stored definition of '{type_name}' is incomplete")
        self._decoders[type_name] = decoders[type_name]
        return decoders[type_name]

    def decode(self, message: RawMessage):
        """
        Return the decoded message of a RawMessage.

        :raises BagError: the bytes do not match the type's definition
        """
        fn = self.decoder(message.type_name)
        try:
            return fn(message.data)
        except Exception as exc:
            raise BagError(f"{self.path}: message on '{message.topic}' at "
                           f'{message.log_time_ns} ns cannot be decoded as {message.type_name} '
                           f'({_reason(exc)})') from None

    def iter_decoded(self, topics: Optional[Iterable[str]] = None,
                     start_ns: Optional[int] = None,
                     end_ns: Optional[int] = None) -> Iterator[Tuple[RawMessage, object]]:
        """Yield (raw message, decoded message) of the selected topics in log-time order."""
        for raw in self.iter_raw(topics, start_ns, end_ns):
            yield raw, self.decode(raw)

    # -- summary ----------------------------------------------------------------------------
    def summary(self) -> BagSummary:
        """
        Return topics, counts, first/last times and rates (reads every message once).

        :raises BagError: damaged data met while reading
        """
        topics = {name: TopicSummary(name, type_name, offered_qos_profiles=self.qos.get(name, []),
                                     type_description_hash=self.type_hashes.get(name, ''))
                  for name, type_name in self.topics.items()}
        start = end = None
        count = 0
        for m in self.iter_raw():
            t = topics[m.topic]
            t.message_count += 1
            if t.first_ns is None:
                t.first_ns = m.log_time_ns
            t.last_ns = m.log_time_ns
            start = m.log_time_ns if start is None else min(start, m.log_time_ns)
            end = m.log_time_ns if end is None else max(end, m.log_time_ns)
            count += 1
        return BagSummary(path=self.bag_dir if self.info is not None else self.path,
                          files=list(self.paths), topics=topics, start_ns=start or 0,
                          end_ns=end or 0, message_count=count,
                          has_metadata_yaml=self.info is not None)


def _idl_decoders(type_name: str, text: str) -> dict:
    """
    Return {type_name: decode(bytes) -> message} from a ``ros2idl`` schema.

    rosbag2's form: each struct after a line of 80 ``=`` and ``IDL: pkg/ns/Name``; a plain IDL
    text is read as one. Decoded messages are rosbags dataclasses (arrays of numbers as numpy).
    Bytes after the last field are ignored (rosbags' ``deserialize_cdr`` refuses more than 3):
    rclpy's ``serialize_message`` left 4 to 12 after a service event's last field.
    """
    separator = '=' * 80 + '\n'
    parts = text.split(separator)[1:] if text.startswith(separator + 'IDL: ') else [text]
    types = {}
    for part in parts:
        types.update(get_types_from_idl(part.split('\n', 1)[1] if part.startswith('IDL: ')
                                        else part))
    store = get_typestore(Stores.EMPTY)
    store.register(types)
    if type_name not in store.fielddefs:
        return {}
    msgdef = store.get_msgdef(type_name)

    def decode(data: bytes):
        if len(data) < 4 or bytes(data[:2]) not in (b'\x00\x00', b'\x00\x01'):
            raise ValueError('not CDR (bad encapsulation header)')
        read = msgdef.deserialize_cdr_le if data[1] else msgdef.deserialize_cdr_be
        return read(memoryview(data)[4:], 0, msgdef.cls, store)[0]
    return {type_name: decode}


def open_bag(path: str) -> BagReader:
    """Open a bag for reading (see :class:`BagReader`)."""
    return BagReader(path)


def read_messages(path: str, topics: Optional[Iterable[str]] = None) -> Iterator[RawMessage]:
    """
    Yield the raw messages of a bag in log-time order (opens and closes the bag).

    :raises BagError: bad bag or unknown topic
    """
    with BagReader(path) as reader:
        yield from reader.iter_raw(topics)
