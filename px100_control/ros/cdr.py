"""
Serialized replies without building messages: little-endian CDR (XCDR1) of the two reply types.

The IK service answers thousands of requests per second; building a ``sensor_msgs/JointState``
and a ``diagnostic_msgs/DiagnosticStatus`` and letting rclpy convert and serialize them costs
about 45 us per request, writing the bytes here about 5 us (``Publisher.publish`` takes
serialized bytes). Layout: a 4-byte encapsulation header (CDR_LE), then the fields, each
aligned to its size counted from the end of that header; strings are a uint32 length (with the
NUL) and the bytes; sequences a uint32 count and the elements.

``matches_rclpy`` checks the bytes against rclpy's own serializer for the running middleware:
callers use the fast path only when it agrees byte for byte.
"""
import struct
from typing import Iterable, Sequence, Tuple

ENCAPSULATION = b'\x00\x01\x00\x00'      # CDR, little endian, no options
_U32 = struct.Struct('<I')


def _pad(n: int, align: int) -> int:
    return -n % align


def cdr_string(text: str, offset: int) -> bytes:
    """Return the CDR bytes of a string written at payload offset ``offset`` (with padding)."""
    data = text.encode('utf-8', 'replace') + b'\x00'   # a lone surrogate becomes '?'
    return b'\x00' * _pad(offset, 4) + _U32.pack(len(data)) + data


class JointStateWriter:
    """
    Serialized sensor_msgs/JointState with fixed joint names and frame_id.

    ``write(sec, nanosec, positions)`` returns the bytes of a message with that stamp, those
    positions (any count, possibly none) and empty velocity and effort.
    """

    def __init__(self, names: Sequence[str], frame_id: str = ''):
        head = cdr_string(frame_id, 8)           # after stamp.sec, stamp.nanosec
        off = 8 + len(head)
        body = [head, b'\x00' * _pad(off, 4), _U32.pack(len(names))]
        off += _pad(off, 4) + 4
        for name in names:
            piece = cdr_string(name, off)
            body.append(piece)
            off += len(piece)
        self._tail = b''.join(body)
        self._count_pad = b'\x00' * _pad(off, 4)
        self._off_after_count = off + _pad(off, 4) + 4
        self._stamp = struct.Struct('<iI')

    def write(self, sec: int, nanosec: int, positions: Sequence[float]) -> bytes:
        """Return the serialized message (stamp, names, positions, empty velocity/effort)."""
        n = len(positions)
        parts = [ENCAPSULATION, self._stamp.pack(sec, nanosec), self._tail, self._count_pad,
                 _U32.pack(n)]
        off = self._off_after_count
        if n:
            pad = _pad(off, 8)
            parts.append(b'\x00' * pad)
            parts.append(struct.pack(f'<{n}d', *positions))
            off += pad + 8 * n
        # velocity and effort: empty sequences (a count, 4-aligned)
        pad = _pad(off, 4)
        parts.append(b'\x00' * pad + b'\x00\x00\x00\x00\x00\x00\x00\x00')
        return b''.join(parts)


def diagnostic_status(level, name: str, message: str, hardware_id: str,
                      values: Iterable[Tuple[str, str]]) -> bytes:
    """Return the serialized diagnostic_msgs/DiagnosticStatus (level: int or 1 byte)."""
    if isinstance(level, (bytes, bytearray)):
        level = level[0]
    parts = [ENCAPSULATION, bytes((level & 0xFF,))]
    off = 1
    for text in (name, message, hardware_id):
        piece = cdr_string(text, off)
        parts.append(piece)
        off += len(piece)
    values = list(values)
    parts.append(b'\x00' * _pad(off, 4) + _U32.pack(len(values)))
    off += _pad(off, 4) + 4
    for key, value in values:
        for text in (key, value):
            piece = cdr_string(text, off)
            parts.append(piece)
            off += len(piece)
    return b''.join(parts)


def matches_rclpy() -> bool:
    """
    Return True when the running middleware reads these bytes as the intended messages.

    rclpy's ``deserialize_message`` (the type support subscribers use) must give back exactly
    the sample messages: odd-length strings, none / one / several positions, two frames.
    (rclpy's own serializer leaves padding bytes uninitialised, so bytes are not compared.)
    """
    from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState
    names = ['waist', 'shoulder', 'elbow', 'wrist_angle']
    for frame in ('', 'px100/base_link'):
        writer = JointStateWriter(names, frame)
        for pos in ([], [0.1, -2.5, 3.0, 1e-300], [1.5]):
            msg = JointState(name=names, position=pos)
            msg.header.stamp.sec, msg.header.stamp.nanosec = -12, 345
            msg.header.frame_id = frame
            if deserialize_message(writer.write(-12, 345, pos), JointState) != msg:
                return False
    values = [('mode', 'pitch'), ('position_error', '1.234e-16'), ('x', '')]
    for level, message in ((b'\x00', 'solved'), (b'\x02', 'invalid request: pose has NaN')):
        msg = DiagnosticStatus(level=level, name='px100/ik_service', message=message,
                               hardware_id='1.000000002',
                               values=[KeyValue(key=k, value=v) for k, v in values])
        raw = diagnostic_status(level, msg.name, message, msg.hardware_id, values)
        if deserialize_message(raw, DiagnosticStatus) != msg:
            return False
    return True
