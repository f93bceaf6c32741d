"""
Serialized messages without building them: little-endian CDR (XCDR1) writers and a goal reader.

The IK service answers thousands of requests per second; building a ``sensor_msgs/JointState``
and a ``diagnostic_msgs/DiagnosticStatus`` and letting rclpy convert and serialize them costs
about 45 us per request, writing the bytes here about 5 us (``Publisher.publish`` takes
serialized bytes). Layout: a 4-byte encapsulation header (CDR_LE), then the fields, each
aligned to its size counted from the end of that header; strings are a uint32 length (with the
NUL) and the bytes; sequences a uint32 count and the elements.

``trajectory_shape`` reads a serialized JointTrajectory's stamp, joint names and array lengths
without its values, so the trajectory_server refuses a malformed goal before deserializing it.

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


_I32_U32 = struct.Struct('<iI')


def _read_string(data, off: int) -> Tuple[str, int]:
    """Return (text up to the first NUL, offset after it) of a CDR string at payload ``off``."""
    off += _pad(off, 4)
    (size,) = _U32.unpack_from(data, 4 + off)
    end = off + 4 + size
    if size == 0 or 4 + end > len(data):
        raise ValueError(f'string of {size} bytes at offset {off} runs past the message')
    raw = bytes(data[4 + off + 4:4 + end - 1]).split(b'\x00', 1)[0]
    return raw.decode('utf-8', 'replace'), end


def trajectory_shape(data) -> Tuple[Tuple[int, int], list, list]:
    """
    Read a serialized trajectory_msgs/JointTrajectory without reading its values.

    Returns ((stamp sec, nanosec), joint_names, lengths) where lengths has one
    (positions, velocities, accelerations, effort) count tuple per point: enough to refuse a
    goal with wrong names or wrongly sized arrays before paying for its deserialization.

    :raises ValueError: not little-endian CDR, or the bytes end before the fields do
    """
    if bytes(data[:2]) != ENCAPSULATION[:2]:
        raise ValueError('not little-endian CDR')
    try:
        stamp = _I32_U32.unpack_from(data, 4)
        _, off = _read_string(data, 8)                        # header.frame_id
        off += _pad(off, 4)
        (count,) = _U32.unpack_from(data, 4 + off)
        off += 4
        if count > len(data):                                 # each name takes >= 5 bytes
            raise ValueError(f'{count} joint names in {len(data)} bytes')
        names = []
        for _ in range(count):
            name, off = _read_string(data, off)
            names.append(name)
        off += _pad(off, 4)
        (count,) = _U32.unpack_from(data, 4 + off)
        off += 4
        if count > len(data):
            raise ValueError(f'{count} points in {len(data)} bytes')
        lengths = []
        for _ in range(count):
            sizes = []
            for _field in range(4):   # positions, velocities, accelerations, effort: float64[]
                off += _pad(off, 4)
                (n,) = _U32.unpack_from(data, 4 + off)
                off += 4
                if n:
                    off += _pad(off, 8) + 8 * n
                sizes.append(n)
            off += _pad(off, 4) + 8                           # time_from_start
            lengths.append(tuple(sizes))
    except struct.error as exc:
        raise ValueError(f'message ends early: {exc}') from None
    if 4 + off > len(data):
        raise ValueError(f'message of {len(data)} bytes ends before its last point')
    return stamp, names, lengths


def trajectory_shape_matches_rclpy() -> bool:
    """Return True when :func:`trajectory_shape` reads rclpy's serialization of samples right."""
    from rclpy.serialization import serialize_message
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    for frame, names, counts in (('', [], []), ('px100/base_link', ['waist', 'elbow'],
                                                [(2, 2, 0, 0), (2, 0, 2, 1), (0, 0, 0, 3)]),
                                 ('x', ['a', 'odd_len', ''], [(3, 0, 0, 0)] * 3)):
        msg = JointTrajectory(joint_names=names)
        msg.header.stamp.sec, msg.header.stamp.nanosec = -7, 123
        msg.header.frame_id = frame
        for k, (p, v, a, e) in enumerate(counts):
            msg.points.append(JointTrajectoryPoint(
                positions=[0.5] * p, velocities=[1.0] * v, accelerations=[2.0] * a,
                effort=[3.0] * e))
            msg.points[-1].time_from_start.sec = k
        try:
            got = trajectory_shape(serialize_message(msg))
        except ValueError:
            return False
        if got != ((-7, 123), names, counts):
            return False
    return True
