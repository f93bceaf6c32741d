"""
Euler angles and quaternions.

Euler angles follow the ``tf_transformations`` static 'sxyz' convention that Interbotix uses:
R = Rz(yaw) Ry(pitch) Rx(roll). Quaternions are ROS-ordered (x, y, z, w).
"""
import numpy as np

from px100_control.kinematics.kernels import quaternion_xyzw
from px100_control.kinematics.se3 import rot_x, rot_y, rot_z


def euler_sxyz_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Return the (3, 3) rotation Rz(yaw) Ry(pitch) Rx(roll); angles [rad]."""
    return rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)


def matrix_to_euler_sxyz(R: np.ndarray):
    """
    Return (roll, pitch, yaw) [rad] of R in the static 'sxyz' convention.

    At pitch = +-pi/2 (gimbal lock) roll is set to 0 and yaw absorbs the rest.
    """
    cy = np.hypot(R[0, 0], R[1, 0])
    if cy > 1e-9:
        roll = np.arctan2(R[2, 1], R[2, 2])
        pitch = np.arctan2(-R[2, 0], cy)
        yaw = np.arctan2(R[1, 0], R[0, 0])
    else:
        roll = 0.0
        pitch = np.arctan2(-R[2, 0], cy)
        yaw = np.arctan2(-R[0, 1], R[1, 1])
    return float(roll), float(pitch), float(yaw)


def quaternion_to_rows(x: float, y: float, z: float, w: float, norm2: float = 1.0):
    """
    Return the rotation of quaternion (x, y, z, w) as 3 rows of 3 plain floats.

    norm2: the quaternion's squared norm (the result is then the rotation of the normalised
    quaternion, without a square root); 1 for a unit quaternion.
    """
    k = 2.0 / norm2
    return [[1.0 - k * (y * y + z * z), k * (x * y - z * w), k * (x * z + y * w)],
            [k * (x * y + z * w), 1.0 - k * (x * x + z * z), k * (y * z - x * w)],
            [k * (x * z - y * w), k * (y * z + x * w), 1.0 - k * (x * x + y * y)]]


def quaternion_to_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """Return the (3, 3) rotation of a unit quaternion (x, y, z, w)."""
    return np.array(quaternion_to_rows(x, y, z, w))


def matrix_to_quaternion(R: np.ndarray):
    """Return the unit quaternion (x, y, z, w) of a (3, 3) rotation, with w >= 0."""
    return quaternion_xyzw(np.asarray(R, dtype=float).tolist())
