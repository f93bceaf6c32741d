"""
The world's messages: :class:`~px100_control.bag.world.WorldMarker` <-> visualization_msgs.

``marker_array`` builds the ``world/markers`` MarkerArray the sim_driver publishes (one Marker per
body: ``ns`` objects | fixtures | table, ``id`` stable, ``text`` = the body's name, CUBE /
CYLINDER / SPHERE, ``scale`` full extents [m], ``color`` rgba, pose in ``frame_id``, frame-locked
false, lifetime 0 = forever), ``update_marker_array`` restamps it and moves its movable bodies
(the driver builds the messages once per scene), ``raw_marker_writer`` does the same on its
serialized bytes; ``markers_of`` reads one back (client, recorder).
"""
import struct
from typing import List, Optional, Sequence

from builtin_interfaces.msg import Time
from px100_control.bag.world import MARKER_TYPE, markers_from_decoded, WorldMarker
from px100_control.wire.cdr import PatchedTemplate, unique_offset
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker, MarkerArray


def marker_msg(m: WorldMarker, stamp: Time, frame_id: str = '') -> Marker:
    """Return the visualization_msgs/Marker of one body."""
    msg = Marker()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id or m.frame_id
    msg.ns = m.ns
    msg.id = int(m.id)
    msg.type = MARKER_TYPE[m.shape]
    msg.action = Marker.ADD
    msg.text = m.name
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = (float(v) for v in m.position)
    o.x, o.y, o.z, o.w = (float(v) for v in m.orientation)
    msg.scale.x, msg.scale.y, msg.scale.z = (float(v) for v in m.scale)
    msg.color.r, msg.color.g, msg.color.b, msg.color.a = (float(v) for v in m.rgba)
    return msg


def marker_array(markers: Sequence[WorldMarker], stamp: Time, frame_id: str = '') -> MarkerArray:
    """Return the MarkerArray of the world's bodies (stamp and frame on every marker)."""
    return MarkerArray(markers=[marker_msg(m, stamp, frame_id) for m in markers])


def update_marker_array(msg: MarkerArray, stamp: Time, poses) -> None:
    """
    Restamp a MarkerArray of :func:`marker_array` in place and move some of its markers.

    :param poses: (marker index, (position xyz [m], quaternion xyzw)) pairs
    """
    markers = msg.markers
    for marker in markers:
        marker.header.stamp = stamp
    for index, (position, quaternion) in poses:
        _set_pose(markers[index], position, quaternion)


def _set_pose(marker: Marker, position, quaternion) -> None:
    p, o = marker.pose.position, marker.pose.orientation
    p.x, p.y, p.z = position
    o.x, o.y, o.z, o.w = quaternion


def raw_marker_writer(msg: MarkerArray, movable: Sequence[int]) -> Optional[PatchedTemplate]:
    """
    Return a writer of ``msg``'s bytes with new stamps and new poses of some markers, or None.

    ``msg`` is serialized once with a distinct sentinel in every stamp and in every pose of the
    ``movable`` markers, to find where they are; the writer then rewrites only those bytes.
    None when a sentinel is not found exactly once or when the running middleware does not read
    the written bytes back as the message (the caller publishes messages then).

    :param movable: indices of the markers whose poses change
    """
    probe = deserialize_message(serialize_message(msg), MarkerArray)
    for k, marker in enumerate(probe.markers):
        marker.header.stamp.sec, marker.header.stamp.nanosec = 0x5EC0_0000 + k, 0x1F00_0000 + k
    sentinels = [[0.123456789e-3 * (1000 + 8 * j + i) for i in range(7)]
                 for j in range(len(movable))]
    for index, values in zip(movable, sentinels):
        _set_pose(probe.markers[index], values[:3], values[3:])
    data = serialize_message(probe)
    if data[:2] != b'\x00\x01':                      # little-endian CDR only
        return None
    stamps = [unique_offset(data, struct.pack('<iI', 0x5EC0_0000 + k, 0x1F00_0000 + k))
              for k in range(len(probe.markers))]
    poses = [unique_offset(data, struct.pack('<7d', *values)) for values in sentinels]
    if None in stamps or None in poses:
        return None
    writer = PatchedTemplate(serialize_message(msg), stamps, poses)
    check = [[0.5 + j, -0.25, 0.125, 0.0, 0.6, 0.0, 0.8] for j in range(len(movable))]
    expected = deserialize_message(serialize_message(msg), MarkerArray)
    update_marker_array(expected, Time(sec=7, nanosec=11), [
        (index, (pose[:3], pose[3:])) for index, pose in zip(movable, check)])
    if deserialize_message(writer.write(7, 11, check), MarkerArray) != expected:
        return None
    return writer


def markers_of(msg: MarkerArray) -> List[WorldMarker]:
    """Return the WorldMarkers of a received MarkerArray (ADD markers only)."""
    return markers_from_decoded(msg)
