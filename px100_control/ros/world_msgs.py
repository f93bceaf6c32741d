"""
The world's messages: :class:`~px100_control.bag.world.WorldMarker` <-> visualization_msgs.

``marker_array`` builds the ``world/markers`` MarkerArray the sim_driver publishes (one Marker per
body: ``ns`` objects | fixtures | table, ``id`` stable, ``text`` = the body's name, CUBE /
CYLINDER / SPHERE, ``scale`` full extents [m], ``color`` rgba, pose in ``frame_id``, frame-locked
false, lifetime 0 = forever), ``update_marker_array`` restamps it and moves its movable bodies
(the driver builds the messages once per scene); ``markers_of`` reads one back (client,
recorder).
"""
from typing import List, Sequence

from builtin_interfaces.msg import Time
from px100_control.bag.world import MARKER_TYPE, markers_from_decoded, WorldMarker
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
        pose = markers[index].pose
        p, o = pose.position, pose.orientation
        p.x, p.y, p.z = position
        o.x, o.y, o.z, o.w = quaternion


def markers_of(msg: MarkerArray) -> List[WorldMarker]:
    """Return the WorldMarkers of a received MarkerArray (ADD markers only)."""
    return markers_from_decoded(msg)
