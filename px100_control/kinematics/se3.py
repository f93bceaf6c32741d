"""
SE(3)/SO(3) algebra on plain numpy arrays (Modern Robotics conventions).

Twists and screw axes are 6-vectors ``[omega; v]`` (angular first). Transforms are (4, 4)
homogeneous matrices; lengths in meters, angles in radians.
"""
import numpy as np

_EPS = 1e-12


def skew(w: np.ndarray) -> np.ndarray:
    """
    Return the (3, 3) skew-symmetric matrix [w] such that [w] @ x = w x x.

    Example Input: [1, 2, 3]  Output: [[0, -3, 2], [3, 0, -1], [-2, 1, 0]]
    """
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def transform(R: np.ndarray, p) -> np.ndarray:
    """Return the (4, 4) transform with rotation R (3, 3) and translation p (3,) [m]."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def inv_transform(T: np.ndarray) -> np.ndarray:
    """Return the inverse of a (4, 4) rigid transform without a general matrix inverse."""
    R, p = T[:3, :3], T[:3, 3]
    return transform(R.T, -R.T @ p)


def rot_x(a: float) -> np.ndarray:
    """Return the (3, 3) rotation about x by a [rad]."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a: float) -> np.ndarray:
    """Return the (3, 3) rotation about y by a [rad]."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a: float) -> np.ndarray:
    """Return the (3, 3) rotation about z by a [rad]."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def exp_so3(omega: np.ndarray, theta: float) -> np.ndarray:
    """
    Return exp([omega] theta) for a unit axis omega (Rodrigues' formula).

    Example Input: omega=[0, 0, 1], theta=pi/2  Output: rot_z(pi/2)
    """
    W = skew(omega)
    return np.eye(3) + np.sin(theta) * W + (1.0 - np.cos(theta)) * (W @ W)


def exp_se3(S: np.ndarray, theta: float) -> np.ndarray:
    """
    Return the (4, 4) transform exp([S] theta) of a screw axis S = [omega; v].

    A prismatic axis has omega = 0 and unit v; theta is then a length [m].
    """
    omega, v = S[:3], S[3:]
    T = np.eye(4)
    if omega @ omega < _EPS:
        T[:3, 3] = v * theta
        return T
    W = skew(omega)
    W2 = W @ W
    s, c = np.sin(theta), np.cos(theta)
    T[:3, :3] = np.eye(3) + s * W + (1.0 - c) * W2
    T[:3, 3] = (theta * np.eye(3) + (1.0 - c) * W + (theta - s) * W2) @ v
    return T


def log_so3(R: np.ndarray) -> np.ndarray:
    """
    Return the rotation vector omega*theta (3,) of R, with theta in [0, pi].

    Numerically careful near theta = 0 and theta = pi.
    """
    cos_t = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    theta = np.arccos(cos_t)
    if theta < 1e-9:
        return np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2.0
    if np.pi - theta < 1e-6:
        # R = I + 2 [w]^2 near pi: take the column of R + I with the largest norm.
        B = (R + np.eye(3)) / 2.0
        i = int(np.argmax(np.diag(B)))
        w = B[:, i] / np.sqrt(max(B[i, i], _EPS))
        w /= np.linalg.norm(w)
        # fix the sign with the small antisymmetric part when theta is not exactly pi
        a = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        if a @ w < 0:
            w = -w
        return w * theta
    return theta / (2.0 * np.sin(theta)) * np.array(
        [R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])


def log_se3(T: np.ndarray) -> np.ndarray:
    """Return the twist 6-vector [omega*theta; v*theta] with exp_se3 of it equal to T."""
    R, p = T[:3, :3], T[:3, 3]
    wt = log_so3(R)
    theta = np.linalg.norm(wt)
    if theta < 1e-9:
        return np.concatenate([np.zeros(3), p])
    W = skew(wt / theta)
    G_inv = (np.eye(3) / theta - 0.5 * W
             + (1.0 / theta - 0.5 / np.tan(theta / 2.0)) * (W @ W))
    return np.concatenate([wt, G_inv @ p * theta])


def adjoint(T: np.ndarray) -> np.ndarray:
    """Return the (6, 6) adjoint [Ad_T] mapping twists [omega; v] between frames."""
    R, p = T[:3, :3], T[:3, 3]
    Ad = np.zeros((6, 6))
    Ad[:3, :3] = R
    Ad[3:, 3:] = R
    Ad[3:, :3] = skew(p) @ R
    return Ad


def screw_axis(omega, point) -> np.ndarray:
    """Return the screw axis [omega; -omega x point] of a revolute joint through point [m]."""
    omega = np.asarray(omega, dtype=float)
    return np.concatenate([omega, -np.cross(omega, np.asarray(point, dtype=float))])


def pose_error(T_current: np.ndarray, T_target: np.ndarray):
    """
    Return (position error [m], orientation error [rad]) between two (4, 4) poses.

    The orientation error is the angle of R_current^T R_target.
    """
    dp = float(np.linalg.norm(T_target[:3, 3] - T_current[:3, 3]))
    R = T_current[:3, :3].T @ T_target[:3, :3]
    dr = float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))
    return dp, dr
