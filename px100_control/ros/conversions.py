"""
Message <-> numpy conversions shared by every node and the client.

Poses are (4, 4) transforms in meters; ``stamp_id`` is a stamp as text ``'sec.nanosec'`` (how
logs name a request) and ``stamp_key`` as a sortable (sec, nanosec) tuple.
"""
from typing import Iterable, Tuple

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose
import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.kinematics.rotations import matrix_to_quaternion, quaternion_to_matrix


def pose_to_matrix(pose: Pose, *, allow_zero_quaternion: bool = False) -> Tuple[np.ndarray, bool]:
    """
    Return (T (4, 4), orientation_free) of a geometry_msgs/Pose.

    An all-zero quaternion means "orientation free" when allowed (T then has identity rotation).
    A quaternion whose norm is not within 1e-3 of 1 is normalised if its norm is > 0.5 (tools
    round), else refused.
    :raises InvalidInputError: NaN/inf, or a quaternion that is not a rotation
    """
    p = pose.position
    o = pose.orientation
    return pose_values_to_matrix((p.x, p.y, p.z, o.x, o.y, o.z, o.w),
                                 allow_zero_quaternion=allow_zero_quaternion)


def pose_values_to_matrix(values, *, allow_zero_quaternion: bool = False
                          ) -> Tuple[np.ndarray, bool]:
    """
    Return (T (4, 4), orientation_free) of (x, y, z, qx, qy, qz, qw), as pose_to_matrix does.

    For callers that read a pose without building a message (e.g. from serialized CDR).
    :raises InvalidInputError: NaN/inf, or a quaternion that is not a rotation
    """
    vals = np.array(values, dtype=float)
    if not np.all(np.isfinite(vals)):
        raise InvalidInputError(f'pose contains NaN or inf: {vals.tolist()}')
    q = vals[3:]
    norm = float(np.linalg.norm(q))
    T = np.eye(4)
    T[:3, 3] = vals[:3]
    if norm == 0.0:
        if not np.any(q):
            if allow_zero_quaternion:
                return T, True
            raise InvalidInputError('orientation is an all-zero quaternion')
        # non-zero components whose squares underflow: not a rotation, nor "orientation free"
        raise InvalidInputError(f'orientation quaternion {q.tolist()} has norm 0 (underflow), '
                                'not a rotation')
    if abs(norm - 1.0) > 1e-3 and norm < 0.5:
        raise InvalidInputError(f'orientation quaternion has norm {norm:.6g}, not a rotation')
    q = q / norm
    T[:3, :3] = quaternion_to_matrix(*q)
    return T, False


def matrix_to_pose(T: np.ndarray) -> Pose:
    """Return the geometry_msgs/Pose of a (4, 4) transform."""
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = (float(v) for v in T[:3, 3])
    x, y, z, w = matrix_to_quaternion(T[:3, :3])
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = x, y, z, w
    return pose


def stamp_id(stamp: Time) -> str:
    """Return the request/goal id text ``'sec.nanosec'`` of a stamp (nanosec zero-padded)."""
    return f'{stamp.sec}.{stamp.nanosec:09d}'


def stamp_key(stamp: Time) -> Tuple[int, int]:
    """Return (sec, nanosec) of a stamp: a hashable goal/request key."""
    return int(stamp.sec), int(stamp.nanosec)


def time_from_seconds(t: float) -> Time:
    """Return a builtin_interfaces/Time of t [s] (t >= 0)."""
    sec = int(np.floor(t))
    return Time(sec=sec, nanosec=int(round((t - sec) * 1e9)) % 1_000_000_000)


def time_from_ns(ns: int) -> Time:
    """Return a builtin_interfaces/Time of ns [ns] (ns >= 0)."""
    sec, nanosec = divmod(int(ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def seconds(stamp) -> float:
    """Return a Time or Duration message as float seconds."""
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


def joint_values_by_name(names: Iterable[str], values: Iterable[float]) -> dict:
    """Return {name: value}; raise InvalidInputError on mismatched lengths or duplicates."""
    names, values = list(names), list(values)
    if len(names) != len(values):
        raise InvalidInputError(f'{len(names)} joint names but {len(values)} values')
    if len(set(names)) != len(names):
        raise InvalidInputError(f'duplicate joint names: {names}')
    return dict(zip(names, (float(v) for v in values)))
