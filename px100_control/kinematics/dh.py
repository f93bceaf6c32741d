"""
Denavit-Hartenberg tables (standard and modified) to transforms and screw axes.

A row is (a, alpha, d, theta_offset, joint_type). Standard DH (distal):
A_i = Rz(theta) Tz(d) Tx(a) Rx(alpha), joint i moves about/along z_{i-1}.
Modified DH (Craig, proximal): A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta) Tz(d),
joint i moves about/along z_i. theta = q + theta_offset for revolute joints and
d = q + d for prismatic ones. Lengths in m, angles in rad.
"""
from dataclasses import dataclass
from typing import Sequence, Tuple

import numpy as np

from px100_control.kinematics.rotations import euler_sxyz_to_matrix
from px100_control.kinematics.se3 import transform


@dataclass(frozen=True)
class DHRow:
    """One DH row: a [m], alpha [rad], d [m], theta offset [rad], 'revolute'|'prismatic'."""

    a: float
    alpha: float
    d: float
    theta: float = 0.0
    joint_type: str = 'revolute'


def _joint_values(row: DHRow, q: float) -> Tuple[float, float]:
    if row.joint_type == 'prismatic':
        return row.theta, row.d + q
    return row.theta + q, row.d


def dh_transform(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """Return the standard-DH link transform Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct],
                     [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d],
                     [0.0, 0.0, 0.0, 1.0]])


def mdh_transform(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """Return the modified-DH link transform Rx(alpha) Tx(a) Rz(theta) Tz(d)."""
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st, 0.0, a],
                     [st * ca, ct * ca, -sa, -d * sa],
                     [st * sa, ct * sa, ca, d * ca],
                     [0.0, 0.0, 0.0, 1.0]])


def fk_dh(rows: Sequence[DHRow], q, base=None, tool=None, modified: bool = False) -> np.ndarray:
    """Return the (4, 4) end-effector pose of a (modified) DH chain at joint values q."""
    T = np.eye(4) if base is None else np.array(base, dtype=float)
    link = mdh_transform if modified else dh_transform
    for row, qi in zip(rows, q):
        theta, d = _joint_values(row, qi)
        T = T @ link(row.a, row.alpha, d, theta)
    return T if tool is None else T @ tool


def dh_to_screws(rows: Sequence[DHRow], base=None, tool=None, modified: bool = False):
    """
    Return (S_list (6, n), M (4, 4)) of a DH or MDH chain, i.e. its PoE form at q = 0.

    The joint axis is z_{i-1} (standard) or z_i (modified) of the chain at q = 0.
    """
    T = np.eye(4) if base is None else np.array(base, dtype=float)
    link = mdh_transform if modified else dh_transform
    S = np.zeros((6, len(rows)))
    for i, row in enumerate(rows):
        theta, d = _joint_values(row, 0.0)
        if modified:
            T_axis = T @ mdh_transform(row.a, row.alpha, 0.0, 0.0)
            T = T @ link(row.a, row.alpha, d, theta)
            # the axis passes through the frame after Rx(alpha) Tx(a); theta leaves z unchanged
        else:
            T_axis = T
            T = T @ link(row.a, row.alpha, d, theta)
        z, p = T_axis[:3, 2], T_axis[:3, 3]
        if row.joint_type == 'prismatic':
            S[:, i] = np.concatenate([np.zeros(3), z])
        else:
            S[:, i] = np.concatenate([z, -np.cross(z, p)])
    M = T if tool is None else T @ tool
    return S, M


def tool_from_xyz_rpy(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Return the (4, 4) transform of a URDF-style origin (xyz [m], rpy [rad] fixed-axis)."""
    return transform(euler_sxyz_to_matrix(*rpy), xyz)
