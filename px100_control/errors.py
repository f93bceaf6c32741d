"""
Exception tree of px100_control.

Bad input raises one of these (they carry data); non-convergence of a solver is a result, not an
exception (see ``IkResult``).
"""


class Px100Error(Exception):
    """Base class for px100_control errors."""


class InvalidInputError(Px100Error, ValueError):
    """Input is malformed: NaN/inf, wrong shape, non-unit quaternion, ..."""


class UnknownJointError(Px100Error, KeyError):
    """A joint name is not part of the robot model."""

    def __init__(self, name: str, known=()):
        self.name = name
        self.known = tuple(known)
        super().__init__(f"unknown joint '{name}' (known: {', '.join(self.known)})")

    def __str__(self) -> str:
        return self.args[0]


class JointLimitError(Px100Error, ValueError):
    """A joint value lies outside its limits."""

    def __init__(self, joint: str, value: float, lower: float, upper: float):
        self.joint, self.value, self.lower, self.upper = joint, value, lower, upper
        super().__init__(
            f"joint '{joint}' = {value:.6g} outside its limits [{lower:.6g}, {upper:.6g}]")


class RobotModelError(Px100Error):
    """A robot description (URDF or YAML table) is missing or inconsistent."""


class UnknownRobotError(RobotModelError):
    """No robot of that name is registered."""


class BagError(Px100Error):
    """A bag file is missing, empty, truncated or corrupt."""
