"""
The robot model: one immutable record that every solver, node and client reads.

Kinematics are held in product-of-exponentials form (``S_list`` (6, n) space screw axes at q = 0
and ``M`` the (4, 4) end-effector pose at q = 0), whatever the source (URDF, DH, MDH or PoE
table). Units: m, rad, s.
"""
from dataclasses import dataclass, field
from typing import Optional, Tuple

import numpy as np

from px100_control.errors import InvalidInputError, JointLimitError, UnknownJointError
from px100_control.kinematics.poe import fk_space, jacobian_body, jacobian_space


@dataclass(frozen=True)
class GripperSpec:
    """
    Gripper of an Interbotix-style arm.

    ``joint`` is the servo (continuous, rad); ``fingers`` the prismatic finger joints (m from the
    fingers link, right = -left); the horn/arm lengths [m] give the linkage angle -> finger map.
    """

    joint: str = 'gripper'
    fingers: Tuple[str, ...] = ('left_finger', 'right_finger')
    horn_radius: float = 0.014
    arm_length: float = 0.024
    finger_lower: float = 0.015
    finger_upper: float = 0.037


@dataclass(frozen=True, eq=False)
class RobotModel:
    """
    A serial arm: joint names in group order, PoE kinematics, limits and named poses.

    :param S_list: (6, n) space screw axes [omega; v] at q = 0
    :param M: (4, 4) end-effector pose at q = 0 in ``base_frame``
    :param lower/upper: (n,) position limits [rad or m]
    :param velocity_limits: (n,) [rad/s or m/s]; effort_limits (n,) [N*m or N]
    """

    name: str
    joint_names: Tuple[str, ...]
    joint_types: Tuple[str, ...]
    S_list: np.ndarray
    M: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    velocity_limits: np.ndarray
    effort_limits: np.ndarray
    home: np.ndarray
    sleep: np.ndarray
    base_frame: str = 'base_link'
    ee_frame: str = 'ee_gripper_link'
    urdf_xml: Optional[str] = None
    gripper: Optional[GripperSpec] = None
    analytic_ik: Optional[str] = None
    description: str = ''
    extra: dict = field(default_factory=dict)

    @property
    def dof(self) -> int:
        """Return the number of arm joints."""
        return len(self.joint_names)

    def fk(self, q) -> np.ndarray:
        """Return the (4, 4) end-effector pose in the base frame at joint values q."""
        return fk_space(self.S_list, self.M, self.check_vector(q))

    def jacobian_space(self, q) -> np.ndarray:
        """Return the (6, n) space Jacobian at q."""
        return jacobian_space(self.S_list, self.check_vector(q))

    def jacobian_body(self, q) -> np.ndarray:
        """Return the (6, n) body Jacobian at q."""
        return jacobian_body(self.S_list, self.M, self.check_vector(q))

    def joint_index(self, name: str) -> int:
        """Return the group index of a joint; raise UnknownJointError otherwise."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise UnknownJointError(name, self.joint_names) from None

    def check_vector(self, q, what: str = 'joint vector') -> np.ndarray:
        """Return q as a float (n,) array; raise InvalidInputError on wrong size or NaN/inf."""
        try:
            arr = np.asarray(q, dtype=float).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f'{what} is not numeric: {q!r}') from exc
        if arr.size != self.dof:
            raise InvalidInputError(f'{what} has {arr.size} values, {self.name} has {self.dof} '
                                    f'joints {list(self.joint_names)}')
        if not np.all(np.isfinite(arr)):
            raise InvalidInputError(f'{what} contains NaN or inf: {arr.tolist()}')
        return arr

    def limit_violations(self, q, tol: float = 1e-9):
        """Return [(joint, value, lower, upper)] of every joint outside its limits."""
        arr = self.check_vector(q)
        bad = np.nonzero((arr < self.lower - tol) | (arr > self.upper + tol))[0]
        return [(self.joint_names[i], float(arr[i]), float(self.lower[i]), float(self.upper[i]))
                for i in bad]

    def within_limits(self, q, tol: float = 1e-9) -> bool:
        """Return True if every joint of q lies within its position limits (+- tol)."""
        return not self.limit_violations(q, tol)

    def check_limits(self, q, tol: float = 1e-9) -> np.ndarray:
        """Return q as an array; raise JointLimitError for the first joint out of limits."""
        for name, value, lo, hi in self.limit_violations(q, tol):
            raise JointLimitError(name, value, lo, hi)
        return self.check_vector(q)

    def random_configurations(self, count: int, rng=None, margin: float = 0.0) -> np.ndarray:
        """Return (count, n) uniformly random in-limit configurations (margin inside limits)."""
        rng = np.random.default_rng(rng)
        return rng.uniform(self.lower + margin, self.upper - margin, size=(count, self.dof))
