"""
Euler angles and quaternions.

Euler angles follow the ``tf_transformations`` static 'sxyz' convention that Interbotix uses:
R = Rz(yaw) Ry(pitch) Rx(roll). Quaternions are ROS-ordered (x, y, z, w).
"""
import numpy as np

from px100_control.kinematics.kernels import euler_sxyz, quaternion_xyzw, rpy_rows


def euler_sxyz_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Return the (3, 3) rotation Rz(yaw) Ry(pitch) Rx(roll); angles [rad]."""
    return np.array(rpy_rows(float(roll), float(pitch), float(yaw)))


def matrix_to_euler_sxyz(R: np.ndarray):
    """
    Return (roll, pitch, yaw) [rad] of R (3, 3) in the static 'sxyz' convention.

    At pitch = +-pi/2 (gimbal lock) roll is set to 0 and yaw absorbs the rest.
    """
    return euler_sxyz(np.asarray(R, dtype=float)[:3, :3].tolist())


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
