"""
The messages the viewer's controls send: a one-point trajectory goal and an IK request.

Built from plain values (:mod:`px100_control.viewer.controls` decides them); the viewer sends
them as a FollowJointTrajectory goal and a compute_ik request. Positions [rad or m], times [s],
poses [m] in ``frame``.
"""
from typing import Optional, Sequence

from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import PoseStamped
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint


def goal_message(stamp: Time, frame: str, names: Sequence[str], target: Sequence[float],
                 seconds: float) -> JointTrajectory:
    """Return a JointTrajectory with one point: target (per name) reached after seconds."""
    msg = JointTrajectory()
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    msg.joint_names = list(names)
    point = JointTrajectoryPoint(positions=[float(v) for v in target])
    ns = int(round(float(seconds) * 1e9))
    point.time_from_start = Duration(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
    msg.points = [point]
    return msg


def ik_request_message(stamp: Time, frame: str, position: Sequence[float],
                       quat_xyzw: Optional[Sequence[float]] = None) -> PoseStamped:
    """Return a PoseStamped IK target at xyz; quat_xyzw None = orientation free (all zero)."""
    msg = PoseStamped()
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    p, q = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = (float(v) for v in position)
    q.x, q.y, q.z, q.w = (float(v) for v in (quat_xyzw or (0.0, 0.0, 0.0, 0.0)))
    return msg
