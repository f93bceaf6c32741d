"""
Little-endian CDR (XCDR1) without ROS: writers and readers of the few messages that go fast.

One module for every hand-written serialization of the package (no rclpy: ``bag/`` uses it
too). Layout: a 4-byte encapsulation header (CDR_LE), then the fields, each aligned to its size
counted from the end of that header; strings are a uint32 length (with the NUL) and the bytes;
sequences a uint32 count and the elements.

- ``JointStateWriter``: the sim_driver's joint_states (building the message and letting rclpy
  serialize it costs about 45 us, writing the bytes about 5 us); ``clock``: its /clock;
- ``PatchedTemplate`` / ``unique_offset``: a message serialized once whose stamps and poses are
  rewritten in place (the sim_driver's world/markers).
- ``tf_message``: tf2_msgs/TFMessage bytes for bags (no tf2_msgs needed).
- ``string_message``: std_msgs/String bytes (the robot_description a recorder adds to a bag).

``ros/cdr.py`` checks the writers against rclpy's serializer of the running
middleware at start; the nodes use them only when they agree. ``tf_message`` is the exception:
rclpy has no TFMessage type without tf2_msgs, which is not a dependency; its bytes go only into
bags, and test/bag/test_bag_tf.py checks them against rosbags' and mcap_ros2's serializers.
"""
import struct
from typing import Optional, Sequence

ENCAPSULATION = b'\x00\x01\x00\x00'      # CDR, little endian, no options
_POSE = struct.Struct('<7d')           # position x y z, orientation x y z w
_U32 = struct.Struct('<I')
_I32_U32 = struct.Struct('<iI')


def _pad(n: int, align: int) -> int:
    return -n % align


def cdr_string(text: str, offset: int) -> bytes:
    """Return the CDR bytes of a string written at payload offset ``offset`` (with padding)."""
    data = text.encode('utf-8', 'replace') + b'\x00'   # a lone surrogate becomes '?'
    return b'\x00' * _pad(offset, 4) + _U32.pack(len(data)) + data


def string_message(text: str) -> bytes:
    """Return the CDR bytes of a std_msgs/String (encapsulation header, length, text, NUL)."""
    return ENCAPSULATION + cdr_string(text, 0)


class JointStateWriter:
    """
    Serialized sensor_msgs/JointState with fixed joint names and frame_id.

    ``write(sec, nanosec, positions, velocities=(), efforts=())`` returns the bytes of a message
    with that stamp and those arrays (any counts, possibly none).
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
        self._off_names_end = off
        self._stamp = struct.Struct('<iI')

    def write(self, sec: int, nanosec: int, positions: Sequence[float],
              velocities: Sequence[float] = (), efforts: Sequence[float] = ()) -> bytes:
        """Return the serialized message (stamp, names, the three float64 arrays)."""
        parts = [ENCAPSULATION, self._stamp.pack(sec, nanosec), self._tail]
        off = self._off_names_end
        for values in (positions, velocities, efforts):
            n = len(values)
            pad = _pad(off, 4)
            parts.append(b'\x00' * pad + _U32.pack(n))
            off += pad + 4
            if n:
                pad = _pad(off, 8)
                parts.append(b'\x00' * pad + struct.pack(f'<{n}d', *values))
                off += pad + 8 * n
        return b''.join(parts)


def clock(sec: int, nanosec: int) -> bytes:
    """Return the serialized rosgraph_msgs/Clock of a time (sec, nanosec)."""
    return ENCAPSULATION + _I32_U32.pack(sec, nanosec)


class PatchedTemplate:
    """
    A serialized message whose stamps and poses change and nothing else (a fixed layout).

    :param template: the message's bytes (little-endian CDR)
    :param stamps: payload-independent byte offsets (from the start of ``template``) of
        builtin_interfaces/Time fields to set at each write
    :param poses: byte offsets of geometry_msgs/Pose fields (7 float64: position, orientation)
    """

    _POSE = struct.Struct('<7d')

    def __init__(self, template: bytes, stamps: Sequence[int], poses: Sequence[int]):
        self._template = bytes(template)
        self._stamps = list(stamps)
        self._poses = list(poses)

    def write(self, sec: int, nanosec: int, poses: Sequence[Sequence[float]]) -> bytes:
        """Return the bytes with every stamp set and pose k set to ``poses[k]`` (7 values)."""
        buf = bytearray(self._template)
        for off in self._stamps:
            _I32_U32.pack_into(buf, off, sec, nanosec)
        for off, pose in zip(self._poses, poses):
            self._POSE.pack_into(buf, off, *pose)
        return bytes(buf)


def unique_offset(data: bytes, pattern: bytes) -> Optional[int]:
    """Return the offset of ``pattern`` in ``data`` if it occurs exactly once, else None."""
    first = data.find(pattern)
    if first < 0 or data.find(pattern, first + 1) >= 0:
        return None
    return first


def tf_message(entries, sec: int, nanosec: int) -> bytes:
    """
    Return the serialized tf2_msgs/TFMessage of [(parent, child, (x, y, z), (qx, qy, qz, qw))].

    Every transform carries the stamp (sec, nanosec); translations [m], unit quaternions.
    """
    parts = [ENCAPSULATION, _U32.pack(len(entries))]
    off = 4
    stamp = _I32_U32.pack(sec, nanosec)
    for parent, child, t, q in entries:
        parts.append(b'\x00' * _pad(off, 4) + stamp)
        off += _pad(off, 4) + 8
        for text in (parent, child):
            piece = cdr_string(text, off)
            parts.append(piece)
            off += len(piece)
        pose = _POSE.pack(t[0], t[1], t[2], q[0], q[1], q[2], q[3])
        parts.append(b'\x00' * _pad(off, 8) + pose)
        off += _pad(off, 8) + 56
    return b''.join(parts)
