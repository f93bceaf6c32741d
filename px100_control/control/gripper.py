"""
The Interbotix gripper: a servo horn driving two fingers through a linkage.

Geometry (interbotix_xs_sdk ``xs_sdk_sim``): the horn of radius ``r`` turns by the gripper angle
theta [rad]; a link of length ``L`` joins the horn tip to the finger, which slides along the
fingers' axis. Each finger's distance from the centre [m] is::

    d(theta) = r sin(theta) + sqrt(L^2 - (r cos(theta))^2)

and the inverse is ``theta = asin((r^2 + d^2 - L^2) / (2 r d))``. The PX100 has r = 0.014 m,
L = 0.024 m and the fingers stop at d in [0.015, 0.037] m (theta about -0.378 .. 1.268 rad);
theta = 0 gives d = 0.01949 m. ``left_finger = d``, ``right_finger = -d``; the gap between the
fingers is 2 d.

Effort control (the real PX100 gripper runs in PWM mode): a gripper effort is a torque command
[N*m] at the horn. Interbotix's client speaks PWM (``gripper_pressure`` -> 150..350 PWM); the
mapping at that edge is ``effort = pwm / 885 * stall_torque`` (885 = full-scale PWM, 1.4 N*m the
XL430 stall torque): 250 PWM -> 0.395 N*m. Positive effort opens the gripper (Interbotix
``release``), negative closes it (``grasp``). With the URDF's 0.1 N*m joint friction an effort
below about 0.1 N*m (63 PWM) does not move the fingers: the PWM dead band users see on the real
gripper (interbotix_ros_toolboxes#37).

A grasped object of width w [m] stops the closing fingers at d = w / 2 (``w`` between 2 x the
lower and 2 x the upper finger limit). The horn torque [N*m] and the finger force F [N] relate by
virtual work over both fingers: ``tau = 2 F d'(theta)``.
"""
from dataclasses import dataclass
import math

from px100_control.errors import InvalidInputError


@dataclass(frozen=True)
class GripperLinkage:
    """
    Horn-and-link gripper geometry with finger limits.

    :param horn_radius: r [m]; arm_length: L [m] (L > r)
    :param finger_lower/finger_upper: finger travel limits d [m]
    """

    horn_radius: float = 0.014
    arm_length: float = 0.024
    finger_lower: float = 0.015
    finger_upper: float = 0.037

    def __post_init__(self):
        r, L = self.horn_radius, self.arm_length
        if not (r > 0.0 and L > r):
            raise InvalidInputError(f'gripper linkage needs 0 < horn_radius < arm_length, '
                                    f'got r={r}, L={L}')
        lo, hi = self.finger_lower, self.finger_upper
        if not (0.0 < lo < hi):
            raise InvalidInputError(f'finger limits must satisfy 0 < lower < upper, got '
                                    f'[{lo}, {hi}]')
        dmin, dmax = math.sqrt(L * L - r * r) - r, L + r
        if lo < dmin - 1e-12 or hi > dmax + 1e-12:
            raise InvalidInputError(f'finger limits [{lo}, {hi}] m are outside what the linkage '
                                    f'reaches for |theta| < pi/2')

    def finger_position(self, theta: float) -> float:
        """
        Return the finger distance d [m] at gripper angle theta [rad].

        Example Input: theta=0  Output: 0.019494 (PX100)
        """
        r, L = self.horn_radius, self.arm_length
        rc = r * math.cos(theta)
        return r * math.sin(theta) + math.sqrt(L * L - rc * rc)

    def finger_rate(self, theta: float) -> float:
        """Return dd/dtheta [m/rad] at gripper angle theta."""
        r, L = self.horn_radius, self.arm_length
        c, s = math.cos(theta), math.sin(theta)
        return r * c + r * r * s * c / math.sqrt(L * L - r * r * c * c)

    def angle_from_finger(self, d: float) -> float:
        """
        Return the gripper angle theta [rad] that puts the fingers at distance d [m].

        :raises InvalidInputError: d not reachable by the linkage
        Example Input: d=0.015  Output: -0.3776 (PX100)
        """
        r, L = self.horn_radius, self.arm_length
        if not (d > 0.0):
            raise InvalidInputError(f'finger distance must be positive, not {d}')
        x = (r * r + d * d - L * L) / (2.0 * r * d)
        if not -1.0 <= x <= 1.0:
            raise InvalidInputError(f'finger distance {d} m is not reachable by the linkage')
        return math.asin(x)

    @property
    def angle_lower(self) -> float:
        """Return the gripper angle at the closed finger limit [rad]."""
        return self.angle_from_finger(self.finger_lower)

    @property
    def angle_upper(self) -> float:
        """Return the gripper angle at the open finger limit [rad]."""
        return self.angle_from_finger(self.finger_upper)

    def check_object_width(self, width: float) -> float:
        """
        Return a valid object width [m] (0 = no object).

        :raises InvalidInputError: NaN, negative, or wider than the open gripper
        """
        if not math.isfinite(width) or width < 0.0:
            raise InvalidInputError(f'object width must be a finite number >= 0, not {width}')
        if width > 2.0 * self.finger_upper:
            raise InvalidInputError(f'object width {width} m is wider than the open gripper '
                                    f'({2.0 * self.finger_upper} m)')
        return float(width)


def pwm_to_effort(pwm: float, stall_torque: float = 1.4, pwm_full_scale: float = 885.0) -> float:
    """
    Return the gripper effort [N*m] of an Interbotix PWM command.

    Example Input: pwm=250  Output: 0.3955
    """
    return pwm / pwm_full_scale * stall_torque


def effort_to_pwm(effort: float, stall_torque: float = 1.4,
                  pwm_full_scale: float = 885.0) -> float:
    """Return the Interbotix PWM command of a gripper effort [N*m] (inverse of pwm_to_effort)."""
    return effort / stall_torque * pwm_full_scale
