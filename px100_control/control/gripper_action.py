"""
The gripper_cmd action's engine: a GripperCommand goal's target, reach and stall verdicts.

No ROS here (``ros/trajectory_actions.py`` wires it). Semantics of ros2_control's
``position_controllers/GripperActionController`` for the Interbotix gripper as Interbotix's
ros2_control and MoveIt configurations drive it (their controller's joint is ``left_finger``):

- ``position`` is the left finger's joint position [m]: each finger's distance from the
  gripper's centre line (the gap between the fingers is twice it), within the finger limits
  (PX100: 0.015 .. 0.037 m); the servo is commanded to the horn angle of that finger position
  (:class:`px100_control.control.gripper.GripperLinkage`). A position outside the limits or not
  finite is refused.
- Opening is a position command. Closing is force-limited, as by the effort-interface
  controller and a real servo with a current limit: the servo pushes the fingers closed with
  the horn torque that gives ``max_effort`` [N] of finger force (:func:`closing_torque`; 0 =
  the default grasp torque, 0.395 N*m, Interbotix's default gripper pressure) and is switched to
  a position command at the goal once the fingers are there; fingers stopped by an object keep
  squeezing with that force (an unlimited position loop would push an object out of the
  fingers).
- Reached: |finger position - goal| <= ``goal_tolerance``. Stalled: the fingers slower than
  ``stall_velocity_threshold`` for ``stall_timeout`` short of the goal (closed on an object);
  the command stays (the fingers keep squeezing). ``allow_stalling``: a stall SUCCEEDS, else it
  ABORTS; both report stalled = True, reached_goal = False.

Units: m, m/s, s (ns for clock readings).
"""
from dataclasses import dataclass
import math
from typing import Optional, Tuple

from px100_control.control.gripper import GripperLinkage
from px100_control.errors import InvalidInputError

SUCCEEDED, ABORTED = 'SUCCEEDED', 'ABORTED'


@dataclass
class GripperSettings:
    """The gripper action's parameters (``gripper_*`` of trajectory_server)."""

    goal_tolerance: float             # [m]
    stall_velocity_threshold: float   # [m/s]
    stall_timeout: float              # [s]
    allow_stalling: bool


def gripper_target(linkage: GripperLinkage, position: float, max_effort: float) -> float:
    """
    Return the gripper servo angle [rad] for a finger position goal [m].

    :raises InvalidInputError: position not finite or outside the finger limits, max_effort
        not finite or negative
    Example Input: position=0.015 (PX100)  Output: -0.3776
    """
    lo, hi = linkage.finger_lower, linkage.finger_upper
    if not (math.isfinite(position) and lo <= position <= hi):
        raise InvalidInputError(f'gripper position {position!r} m is outside the finger limits '
                                f'[{lo}, {hi}] m (position = the left finger joint, half the '
                                'gap)')
    if not (math.isfinite(max_effort) and max_effort >= 0.0):
        raise InvalidInputError(f'max_effort must be a finite number >= 0, got {max_effort!r}')
    return linkage.angle_from_finger(position)


#: the closing torque [N*m] of max_effort 0: Interbotix's default gripper pressure (250 PWM)
DEFAULT_GRASP_TORQUE = 0.395
#: the XL430's stall torque [N*m]: no command exceeds it
STALL_TORQUE = 1.4


def closing_torque(linkage: GripperLinkage, max_effort: float, theta: float) -> float:
    """
    Return the horn torque [N*m, > 0] that squeezes with ``max_effort`` [N] of finger force.

    Virtual work over both fingers at the gripper angle theta [rad]: tau = 2 F dd/dtheta;
    max_effort 0 = :data:`DEFAULT_GRASP_TORQUE`; at most :data:`STALL_TORQUE`.
    Example Input: max_effort=10, theta=0 (PX100)  Output: 0.28
    """
    if max_effort <= 0.0:
        return DEFAULT_GRASP_TORQUE
    return min(STALL_TORQUE, 2.0 * max_effort * linkage.finger_rate(theta))


class GripperGoalMonitor:
    """Follow one goal's finger position until it is reached or the fingers stall."""

    def __init__(self, goal_position: float, settings: GripperSettings, now_ns: int):
        """Watch for ``goal_position`` [m] from ``now_ns`` (the fingers count as moving then)."""
        self.goal = goal_position
        self.settings = settings
        self.last_moving_ns = now_ns

    def update(self, position: float, velocity: float,
               now_ns: int) -> Optional[Tuple[str, bool, bool, str]]:
        """
        Take the measured finger position [m] and speed [m/s] at ``now_ns``.

        Return None while the goal runs, else (status, reached_goal, stalled, words).
        """
        s = self.settings
        error = abs(position - self.goal)
        if error <= s.goal_tolerance:
            return SUCCEEDED, True, False, f'reached {position:.4f} m (goal {self.goal:.4f} m)'
        if abs(velocity) > s.stall_velocity_threshold:
            self.last_moving_ns = now_ns
            return None
        if (now_ns - self.last_moving_ns) * 1e-9 <= s.stall_timeout:
            return None
        status = SUCCEEDED if s.allow_stalling else ABORTED
        return status, False, True, (f'stalled at {position:.4f} m, {error:.4f} m from the goal '
                                     f'{self.goal:.4f} m (still squeezing)')
