"""
A small, fast MCAP writer (chunked, indexed, with summary), for 1 kHz recording in Python.

Implements the MCAP v0 records a rosbag2 bag needs (https://mcap.dev/spec): Header, Schema,
Channel, Message, Chunk, MessageIndex, Metadata, DataEnd, and the summary section (Schema,
Channel, Statistics, ChunkIndex, MetadataIndex, SummaryOffset) with its Footer and CRCs. A
message is appended to the open chunk with one ``struct.pack`` (the ``mcap`` package's writer
spends ~50 Python calls per message); chunks are compressed (zstd or lz4) and written with their
message indexes when full or on :meth:`McapWriter.flush`. Schemas and channels are written
into the chunk of their first use, so a file cut after any complete chunk reads linearly.
Times are integer ns.
"""
import struct
from typing import BinaryIO, Dict, List, Optional, Tuple
import zlib

MAGIC = b'\x89MCAP0\r\n'

OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL = 0x01, 0x02, 0x03, 0x04
OP_MESSAGE, OP_CHUNK, OP_MESSAGE_INDEX, OP_CHUNK_INDEX = 0x05, 0x06, 0x07, 0x08
OP_STATISTICS, OP_METADATA, OP_METADATA_INDEX = 0x0B, 0x0C, 0x0D
OP_SUMMARY_OFFSET, OP_DATA_END = 0x0E, 0x0F

_MESSAGE = struct.Struct('<BQHIQQ')  # opcode, length, channel, sequence, log, publish
_U16, _U32, _U64 = struct.Struct('<H'), struct.Struct('<I'), struct.Struct('<Q')
_RECORD = struct.Struct('<BQ')


def _string(text: str) -> bytes:
    data = text.encode('utf-8')
    return _U32.pack(len(data)) + data


def _bytes32(data: bytes) -> bytes:
    return _U32.pack(len(data)) + data


def _string_map(mapping: Dict[str, str]) -> bytes:
    body = b''.join(_string(k) + _string(v) for k, v in mapping.items())
    return _U32.pack(len(body)) + body


def record(opcode: int, content: bytes) -> bytes:
    """Return one MCAP record: opcode, uint64 length, content."""
    return _RECORD.pack(opcode, len(content)) + content


def _compressor(compression: str):
    if compression == 'zstd':
        import zstandard  # optional: compressed bags only
        return zstandard.ZstdCompressor(level=3).compress
    if compression == 'lz4':
        import lz4.frame  # optional: compressed bags only
        return lz4.frame.compress
    if compression in ('', 'none'):
        return None
    raise ValueError(f"unknown compression '{compression}' (zstd, lz4 or none)")


class McapWriter:
    """
    Write one MCAP file to a binary stream (the caller opens and closes the stream).

    :param compression: 'zstd', 'lz4' or 'none'
    :param chunk_size: uncompressed bytes that close a chunk
    """

    def __init__(self, stream: BinaryIO, compression: str = 'zstd', chunk_size: int = 1 << 20):
        self._out = stream
        self._compress = _compressor(compression)
        self._compression = '' if self._compress is None else compression
        self._chunk_size = int(chunk_size)
        self._pos = 0
        self._chunk = bytearray()
        self._index: Dict[int, List[Tuple[int, int]]] = {}
        self._chunk_start: Optional[int] = None
        self._chunk_end = 0
        self._schemas: Dict[int, bytes] = {}
        self._channels: Dict[int, bytes] = {}
        self._pending_schemas: List[bytes] = []
        self._pending_channels: List[bytes] = []
        self._chunk_indexes: List[bytes] = []
        self._metadata_indexes: List[bytes] = []
        self._counts: Dict[int, int] = {}
        self.message_count = 0
        self.chunk_count = 0
        self._start: Optional[int] = None
        self._end = 0
        self._finished = False

    def _write(self, data: bytes) -> None:
        self._out.write(data)
        self._pos += len(data)

    def start(self, profile: str, library: str) -> None:
        """Write the magic and the Header record."""
        self._write(MAGIC + record(OP_HEADER, _string(profile) + _string(library)))

    def add_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Register a schema; return its id (written into the next chunk)."""
        schema_id = len(self._schemas) + 1
        content = _U16.pack(schema_id) + _string(name) + _string(encoding) + _bytes32(data)
        rec = record(OP_SCHEMA, content)
        self._schemas[schema_id] = rec
        self._pending_schemas.append(rec)
        return schema_id

    def add_channel(self, topic: str, message_encoding: str, schema_id: int,
                    metadata: Dict[str, str]) -> int:
        """Register a channel; return its id (written into the next chunk)."""
        channel_id = len(self._channels) + 1
        rec = record(OP_CHANNEL, _U16.pack(channel_id) + _U16.pack(schema_id) + _string(topic)
                     + _string(message_encoding) + _string_map(metadata))
        self._channels[channel_id] = rec
        self._pending_channels.append(rec)
        self._counts[channel_id] = 0
        return channel_id

    def add_message(self, channel_id: int, log_time: int, publish_time: int, data: bytes,
                    sequence: int = 0) -> None:
        """Append a message to the open chunk (closing the chunk when it is full)."""
        chunk = self._chunk
        if self._pending_schemas or self._pending_channels:
            for rec in self._pending_schemas + self._pending_channels:
                chunk += rec
            self._pending_schemas.clear()
            self._pending_channels.clear()
        index = self._index.get(channel_id)
        if index is None:
            index = self._index[channel_id] = []
        index.append((log_time, len(chunk)))
        chunk += _MESSAGE.pack(OP_MESSAGE, 22 + len(data), channel_id, sequence & 0xFFFFFFFF,
                               log_time, publish_time)
        chunk += data
        if self._chunk_start is None or log_time < self._chunk_start:
            self._chunk_start = log_time
        if log_time > self._chunk_end:
            self._chunk_end = log_time
        self._counts[channel_id] += 1
        self.message_count += 1
        if len(chunk) >= self._chunk_size:
            self._finish_chunk()

    def _finish_chunk(self) -> None:
        if self._chunk_start is None:
            return
        raw = bytes(self._chunk)
        data = self._compress(raw) if self._compress is not None else raw
        start, end = self._chunk_start, self._chunk_end
        chunk_offset = self._pos
        content = (_U64.pack(start) + _U64.pack(end) + _U64.pack(len(raw))
                   + _U32.pack(zlib.crc32(raw)) + _string(self._compression)
                   + _U64.pack(len(data)) + data)
        chunk_rec = record(OP_CHUNK, content)
        index_offsets = {}
        index_recs = []
        index_pos = chunk_offset + len(chunk_rec)
        for channel_id, entries in self._index.items():
            body = b''.join(_U64.pack(t) + _U64.pack(o) for t, o in entries)
            rec = record(OP_MESSAGE_INDEX, _U16.pack(channel_id) + _U32.pack(len(body)) + body)
            index_offsets[channel_id] = index_pos
            index_pos += len(rec)
            index_recs.append(rec)
        index_bytes = b''.join(index_recs)
        self._write(chunk_rec + index_bytes)
        offsets = b''.join(_U16.pack(c) + _U64.pack(o) for c, o in index_offsets.items())
        self._chunk_indexes.append(record(OP_CHUNK_INDEX, (
            _U64.pack(start) + _U64.pack(end) + _U64.pack(chunk_offset)
            + _U64.pack(len(chunk_rec)) + _U32.pack(len(offsets)) + offsets
            + _U64.pack(len(index_bytes)) + _string(self._compression)
            + _U64.pack(len(data)) + _U64.pack(len(raw)))))
        if self._start is None or start < self._start:
            self._start = start
        self._end = max(self._end, end)
        self.chunk_count += 1
        self._chunk = bytearray()
        self._index = {}
        self._chunk_start = None
        self._chunk_end = 0

    def flush(self) -> None:
        """Write the open chunk (if it has messages) and flush the stream."""
        self._finish_chunk()
        self._out.flush()

    def add_metadata(self, name: str, metadata: Dict[str, str]) -> None:
        """Write a Metadata record (after the open chunk)."""
        self._finish_chunk()
        offset = self._pos
        rec = record(OP_METADATA, _string(name) + _string_map(metadata))
        self._write(rec)
        self._metadata_indexes.append(record(
            OP_METADATA_INDEX, _U64.pack(offset) + _U64.pack(len(rec)) + _string(name)))

    def finish(self) -> None:
        """Write the last chunk, DataEnd, the summary section, the footer and the magic."""
        if self._finished:
            return
        self._finish_chunk()
        # schemas/channels never used by a message still belong in the file
        if self._pending_schemas or self._pending_channels:
            self._write(b''.join(self._pending_schemas + self._pending_channels))
        self._write(record(OP_DATA_END, _U32.pack(0)))
        summary_start = self._pos
        groups = []

        def group(opcode: int, records: List[bytes]) -> bytes:
            data = b''.join(records)
            if records:
                groups.append((opcode, summary_start + sum(len(g) for g in parts), len(data)))
            return data

        parts: List[bytes] = []
        parts.append(group(OP_SCHEMA, list(self._schemas.values())))
        parts.append(group(OP_CHANNEL, list(self._channels.values())))
        counts = b''.join(_U16.pack(c) + _U64.pack(n) for c, n in self._counts.items())
        stats = record(OP_STATISTICS, (
            _U64.pack(self.message_count) + _U16.pack(len(self._schemas))
            + _U32.pack(len(self._channels)) + _U32.pack(0)
            + _U32.pack(len(self._metadata_indexes)) + _U32.pack(self.chunk_count)
            + _U64.pack(self._start or 0) + _U64.pack(self._end)
            + _U32.pack(len(counts)) + counts))
        parts.append(group(OP_STATISTICS, [stats]))
        parts.append(group(OP_CHUNK_INDEX, self._chunk_indexes))
        parts.append(group(OP_METADATA_INDEX, self._metadata_indexes))
        summary = b''.join(parts)
        offset_start = summary_start + len(summary)
        offsets = b''.join(record(OP_SUMMARY_OFFSET, struct.pack('<BQQ', op, start, length))
                           for op, start, length in groups)
        summary += offsets
        footer_head = struct.pack('<BQQQ', OP_FOOTER, 20, summary_start, offset_start)
        crc = zlib.crc32(footer_head, zlib.crc32(summary))
        self._write(summary + footer_head + _U32.pack(crc) + MAGIC)
        self._out.flush()
        self._finished = True
