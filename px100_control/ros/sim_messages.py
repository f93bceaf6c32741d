"""
The messages the sim_driver publishes: joint states, the end-effector pose, error diagnostics.

Stamps are builtin_interfaces/Time; positions [rad] (fingers [m]), velocities [rad/s] (fingers
[m/s]), efforts [N*m] (fingers [N]); the pose is in ``frame_id`` [m], orientation a unit
quaternion.
"""
from typing import Sequence

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState

#: most joint names a refused setpoint's diagnostics list
SHOWN_NAMES = 20


def set_stamp(stamp, ns: int):
    """Set a builtin_interfaces/Time in place to ``ns`` [ns] (>= 0); return it."""
    stamp.sec, stamp.nanosec = divmod(int(ns), 1_000_000_000)
    return stamp


def fill_joint_state(msg: JointState, stamp_ns: int, sample) -> JointState:
    """
    Return ``msg`` restamped [ns] with a simulator sample's values (its names set once).

    The driver reuses one message per topic: building a JointState costs more than filling it.
    """
    set_stamp(msg.header.stamp, stamp_ns)
    msg.position = sample.position
    msg.velocity = sample.velocity
    msg.effort = sample.effort
    return msg


def pose_stamped(stamp, frame_id: str, position, quaternion_xyzw) -> PoseStamped:
    """Return the PoseStamped of a position (x, y, z) [m] and quaternion (x, y, z, w)."""
    pose = PoseStamped()
    pose.header.stamp = stamp
    pose.header.frame_id = frame_id
    p, o = pose.pose.position, pose.pose.orientation
    p.x, p.y, p.z = position
    o.x, o.y, o.z, o.w = quaternion_xyzw
    return pose


def error_array(stamp, name: str, message: str, hardware_id: str,
                values: Sequence = ()) -> DiagnosticArray:
    """Return a DiagnosticArray of one ERROR status; ``values``: (key, value) pairs."""
    status = DiagnosticStatus(level=DiagnosticStatus.ERROR, name=name, message=message,
                              hardware_id=hardware_id,
                              values=[KeyValue(key=k, value=v) for k, v in values])
    diag = DiagnosticArray(status=[status])
    diag.header.stamp = stamp
    return diag


def shown_names(names) -> str:
    """Return the joint names of a refused message, comma-separated, at most SHOWN_NAMES."""
    names = [str(n) for n in names]
    more = f',... ({len(names)} names)' if len(names) > SHOWN_NAMES else ''
    return ','.join(names[:SHOWN_NAMES]) + more
