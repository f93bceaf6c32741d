"""
Product-of-exponentials forward kinematics and geometric Jacobians.

``S_list`` is (6, n): column i is joint i's screw axis [omega; v] in the space (base) frame at
q = 0. ``M`` is the (4, 4) end-effector pose at q = 0. Revolute joints in rad, prismatic in m.
"""
import numpy as np

from px100_control.kinematics.se3 import adjoint, exp_se3, inv_transform


def fk_space(S_list: np.ndarray, M: np.ndarray, theta) -> np.ndarray:
    """
    Return the (4, 4) end-effector pose T_sb(theta) = e^[S1]th1 ... e^[Sn]thn M.

    Example Input: S_list of px100, M of px100, theta = 0  Output: M
    """
    T = np.eye(4)
    for i in range(S_list.shape[1]):
        T = T @ exp_se3(S_list[:, i], theta[i])
    return T @ M


def joint_frames_space(S_list: np.ndarray, theta):
    """Return the list of cumulative products T_i = e^[S1]th1 ... e^[Si]thi, i = 0..n."""
    T = np.eye(4)
    frames = [T]
    for i in range(S_list.shape[1]):
        T = T @ exp_se3(S_list[:, i], theta[i])
        frames.append(T)
    return frames


def jacobian_space(S_list: np.ndarray, theta) -> np.ndarray:
    """Return the (6, n) space Jacobian J_s(theta); rows [omega; v] in the base frame."""
    n = S_list.shape[1]
    J = np.zeros((6, n))
    T = np.eye(4)
    for i in range(n):
        J[:, i] = S_list[:, i] if i == 0 else adjoint(T) @ S_list[:, i]
        T = T @ exp_se3(S_list[:, i], theta[i])
    return J


def jacobian_body(S_list: np.ndarray, M: np.ndarray, theta) -> np.ndarray:
    """Return the (6, n) body Jacobian J_b(theta) = [Ad_{T_sb^-1}] J_s(theta)."""
    return adjoint(inv_transform(fk_space(S_list, M, theta))) @ jacobian_space(S_list, theta)


def jacobian_geometric(S_list: np.ndarray, M: np.ndarray, theta) -> np.ndarray:
    """
    Return the (6, n) geometric Jacobian [v_ee; omega] in the base frame.

    Rows 0-2 are the end-effector origin's linear velocity [m/s], rows 3-5 the angular
    velocity [rad/s] (the classic robotics-textbook ordering).
    """
    J_s = jacobian_space(S_list, theta)
    p = fk_space(S_list, M, theta)[:3, 3]
    omega, v_s = J_s[:3], J_s[3:]
    return np.vstack([v_s + np.cross(omega.T, p).T, omega])
