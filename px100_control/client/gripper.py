"""
InterbotixGripperXSInterface: the gripper part of the Interbotix-compatible client.

As in ``interbotix_xs_modules.xs_robot.gripper``: the gripper servo runs in PWM mode;
``gripper_pressure`` p in [0, 1] gives ``gripper_value = lower + p (upper - lower)`` PWM
(150..350, 250 by default); ``release()`` drives +value (opens), ``grasp()`` -value (closes);
a 50 Hz timer stops the drive once the left finger passes its limit (an object between the
fingers keeps being squeezed). ROS 1 scripts' ``open()`` / ``close()`` are aliases of
release / grasp.

Units at the edge: sim_driver takes the gripper effort in N*m (SI), so the PWM value is mapped
by :func:`pwm_to_effort`, the XL430-W250's linear PWM-to-torque model: ``effort = pwm / 885 *
1.4`` N*m; 250 PWM -> 0.395 N*m. Finger positions are metres from the fingers link, gripper
angle rad, effort N*m.

Gripper speed per pressure. The DYNAMIXEL XL430-W250-T's published figures (ROBOTIS e-Manual,
XL430-W250 specifications, at 11.1 V): stall torque 1.4 N*m, no-load speed 57 rpm (6.0 rad/s),
PWM_Limit 885 = 100 % duty; the simulated servo (:mod:`px100_control.control.actuator`) uses
them. With the linear torque-speed curve a free horn turns at ``duty * 6.0`` rad/s, so the
fingers need at least ``travel / (pwm / 885 * 6.0)`` to close or open: 0.98 s over the px100's
1.65 rad horn travel at 250 PWM (pressure 0.5), 1.63 s at 150 PWM, 0.70 s at 350 PWM, plus
the spin-up and friction (the simulation measures about 1.4-1.9 s at 250 PWM).
:meth:`InterbotixGripperXSInterface.travel_time` gives the estimate; grasp() still returns
after its ``delay`` as Interbotix's does, and an arm move that starts while the fingers are
still closing on nothing logs a warning saying how long they still need.
"""
from typing import Optional

from px100_control.client.core import effort_to_pwm, InterbotixRobotXSCore, PWM_LIMIT, \
    pwm_to_effort, STALL_TORQUE
from px100_control.client.robot import InterbotixException, robot_shutdown
from px100_control.control.gripper import GripperLinkage
from rclpy.logging import LoggingSeverity

__all__ = ['InterbotixGripperXS', 'InterbotixGripperXSInterface', 'pwm_to_effort',
           'effort_to_pwm', 'PWM_LIMIT', 'STALL_TORQUE']
#: a finger this close to a limit [m] counts as there (the simulated linkage stops at it)
FINGER_TOLERANCE = 2e-4
#: XL430-W250 no-load speed at 11.1 V (57 rpm) [rad/s] (ROBOTIS e-Manual)
NO_LOAD_SPEED = 57.0 * 2.0 * 3.141592653589793 / 60.0
#: below this horn speed [rad/s] closing fingers are taken as stopped (on an object)
STOPPED_SPEED = 0.05


class InterbotixGripperXSInterface:
    """
    The gripper of an X-Series arm (PWM-driven, fingers reported in metres).

    :param core: the robot's InterbotixRobotXSCore
    :param gripper_name: the gripper motor ('gripper')
    :param gripper_pressure: fraction 0..1 of the PWM range used to grasp
    :param gripper_pressure_lower_limit: PWM at pressure 0 (enough to overcome friction)
    :param gripper_pressure_upper_limit: PWM at pressure 1 (below servo overload)
    """

    def __init__(self, core: InterbotixRobotXSCore, gripper_name: str = 'gripper',
                 gripper_pressure: float = 0.5, gripper_pressure_lower_limit: int = 150,
                 gripper_pressure_upper_limit: int = 350) -> None:
        self.core = core
        spec = core.model.gripper
        if spec is None or spec.joint != gripper_name:
            raise InterbotixException(
                f"Robot model '{core.robot_model}' has no gripper named '{gripper_name}'"
                + (f" (its gripper is '{spec.joint}')." if spec is not None else '.'))
        self.gripper_name = gripper_name
        self.spec = spec
        self.gripper_pressure_lower_limit = gripper_pressure_lower_limit
        self.gripper_pressure_upper_limit = gripper_pressure_upper_limit
        self.gripper_value = 0.0
        self.set_pressure(gripper_pressure)
        self.gripper_moving = False
        self.gripper_command = 0.0
        self.gripper_info = core.robot_get_robot_info('single', gripper_name)
        if self.gripper_info.mode not in ('current', 'pwm'):
            core.get_node().logwarn(
                f"Motor '{gripper_name}' operating mode not set to 'pwm' or 'current'.")
        self.left_finger_index = core.js_index_map.get(spec.fingers[0])
        if self.left_finger_index is None:
            raise InterbotixException(
                f"sim_driver publishes no '{spec.fingers[0]}' in its joint states "
                f'({list(core.js_index_map)}): cannot drive the gripper.')
        self.left_finger_lower_limit = float(self.gripper_info.joint_lower_limits[0])
        self.left_finger_upper_limit = float(self.gripper_info.joint_upper_limits[0])
        linkage = GripperLinkage(spec.horn_radius, spec.arm_length, spec.finger_lower,
                                 spec.finger_upper)
        #: horn angle [rad] between fully open and fully closed
        self.horn_travel = float(linkage.angle_upper - linkage.angle_lower)
        self._linkage = linkage
        self.tmr_gripper_state = core.get_node().create_timer(
            0.02, self.gripper_state, callback_group=core._cbg)
        core._before_arm_move.append(self.closing_warning)
        core.get_node().loginfo(f'\n\tGripper Name: {self.gripper_name}\n\tGripper Pressure: '
                                f'{self.gripper_pressure * 100:.1f}%')
        core.get_node().loginfo('Initialized InterbotixGripperXSInterface!')

    def gripper_state(self, event=None) -> None:
        """
        Stop the PWM drive once the fingers reach the limit they were driven to (50 Hz).

        :param event: unused (ROS 1 timer callbacks take the timer event)
        """
        if not self.gripper_moving or self.core._torn_down:
            return
        try:
            pos = self.get_finger_position()
        except InterbotixException:
            return
        if (self.gripper_command > 0 and
                pos >= self.left_finger_upper_limit - FINGER_TOLERANCE) or \
                (self.gripper_command < 0 and
                 pos <= self.left_finger_lower_limit + FINGER_TOLERANCE):
            self.core.robot_write_joint_command(self.gripper_name, 0.0)
            self.gripper_command = 0.0
            self.gripper_moving = False

    def gripper_controller(self, effort: float, delay: float) -> None:
        """
        Drive the gripper with a signed PWM ``effort`` (> 0 opens), then wait ``delay`` [s].

        Nothing is sent when the fingers already are at that side's limit.
        """
        mode = self.core.mode_of(self.gripper_name)
        if mode not in ('pwm', 'current'):
            self.core.get_node().logerror(
                f"Gripper '{self.gripper_name}' is in {mode} mode: its effort {effort:g} is not "
                "sent (robot_set_operating_modes('single', 'gripper', 'pwm') first).")
            return
        pos = self.get_finger_position()
        if (effort > 0 and pos < self.left_finger_upper_limit - FINGER_TOLERANCE) or \
                (effort < 0 and pos > self.left_finger_lower_limit + FINGER_TOLERANCE):
            self.gripper_command = float(effort)
            self.core.robot_write_joint_command(self.gripper_name, float(effort))
            self.gripper_moving = True
            self.core.sleep(delay)

    def travel_time(self, pwm: Optional[float] = None, fraction: float = 1.0) -> float:
        """
        Return the least time [s] the fingers need to close or open at ``pwm`` (no load).

        From the XL430-W250 figures (module docstring): ``fraction * horn_travel / (|pwm| /
        885 * no-load speed)``. :param pwm: default the current gripper_value
        """
        duty = abs(self.gripper_value if pwm is None else float(pwm)) / PWM_LIMIT
        if duty <= 0.0:
            return float('inf')
        return fraction * self.horn_travel / (min(duty, 1.0) * NO_LOAD_SPEED)

    def closing_warning(self) -> Optional[str]:
        """Return a warning when the fingers are still closing on nothing (else None)."""
        if not self.gripper_moving or self.gripper_command >= 0 or self.core._torn_down:
            return None
        try:
            finger = self.get_finger_position()
            speed = abs(self.get_gripper_velocity())
        except InterbotixException:
            return None
        if finger <= self.left_finger_lower_limit + FINGER_TOLERANCE or speed < STOPPED_SPEED:
            return None  # closed, or squeezing an object
        angle = self._linkage.angle_from_finger(finger)
        left = max(0.0, angle - self._linkage.angle_lower) / max(self.horn_travel, 1e-9)
        return (f'The arm starts moving while the gripper is still closing on nothing (finger '
                f'at {finger * 1000:.1f} mm of {self.left_finger_lower_limit * 1000:.1f} mm, '
                f'horn at {speed:.2f} rad/s): at {abs(self.gripper_command):.0f} PWM the XL430 '
                f'needs at least {self.travel_time(self.gripper_command, left):.2f} s more '
                f'({self.travel_time(self.gripper_command):.2f} s open to closed); give '
                'grasp() a longer delay.')

    def set_pressure(self, pressure: float) -> None:
        """Set the grasp pressure (0..1, clipped) used by the next release()/grasp()."""
        p = float(pressure)
        if not 0.0 <= p <= 1.0:
            self.core.get_node().logwarn(f'gripper_pressure {p} outside [0, 1]; clipped.')
            p = min(1.0, max(0.0, p))
        self.gripper_pressure = p
        self.gripper_value = self.gripper_pressure_lower_limit + p * (
            self.gripper_pressure_upper_limit - self.gripper_pressure_lower_limit)

    def release(self, delay: float = 1.0) -> None:
        """Open the gripper (PWM +gripper_value), then wait ``delay`` [s]."""
        self.gripper_controller(self.gripper_value, delay)

    def grasp(self, delay: float = 1.0) -> None:
        """Close the gripper (PWM -gripper_value), then wait ``delay`` [s]."""
        self.gripper_controller(-self.gripper_value, delay)

    def open(self, delay: float = 1.0) -> None:  # noqa: A003 - ROS 1 API name
        """ROS 1 name of :meth:`release`."""
        self.release(delay)

    def close(self, delay: float = 1.0) -> None:
        """ROS 1 name of :meth:`grasp`."""
        self.grasp(delay)

    def get_gripper_position(self) -> float:
        """Return the gripper servo angle [rad]."""
        return float(self.core.joint_positions([self.gripper_name])[0])

    def get_gripper_velocity(self) -> float:
        """Return the gripper servo velocity [rad/s]."""
        return float(self.core._joint_field([self.gripper_name], 'velocity')[0])

    def get_gripper_effort(self) -> float:
        """Return the gripper servo effort [N*m] (Interbotix: mA or load)."""
        return float(self.core._joint_field([self.gripper_name], 'effort')[0])

    def get_finger_position(self) -> float:
        """Return the left finger position [m] from the fingers link."""
        return float(self.core.joint_positions([self.spec.fingers[0]])[0])

    def get_finger_width(self) -> Optional[float]:
        """Return the distance between the fingers [m] (px100_control extension)."""
        left, right = self.core.joint_positions(list(self.spec.fingers[:2]))
        return float(left - right)


class InterbotixGripperXS:
    """
    Standalone gripper (``interbotix_xs_modules.xs_robot.gripper.InterbotixGripperXS``).

    Accepts the ROS 2 signature (``joint_state_topic``, ``logging_level``, ``node_name``) and
    the ROS 1 one (``init_node``, 7th positional); ``.core`` (ROS 2) and ``.dxl`` (ROS 1) are the
    core, ``.gripper`` the interface, ``shutdown()`` ends the API. ``grasp()`` closes and
    ``release()`` opens, as in the manipulator's interface (the stale ROS 2 standalone class
    has them swapped). px100_control keywords as for InterbotixManipulatorXS (``bringup``, ...).
    """

    def __init__(self, robot_model: str, gripper_name: str, robot_name: Optional[str] = None,
                 gripper_pressure: float = 0.5, gripper_pressure_lower_limit: int = 150,
                 gripper_pressure_upper_limit: int = 350,
                 joint_state_topic: str = 'joint_states', logging_level=None,
                 node_name: str = 'robot_manipulation', *, init_node: bool = True, **kwargs):
        if isinstance(joint_state_topic, bool):  # ROS 1: the 7th positional is init_node
            init_node, joint_state_topic = joint_state_topic, 'joint_states'
        self.init_node = init_node  # ROS 1: unused (the client's node always exists)
        self.core = InterbotixRobotXSCore(
            robot_model, robot_name, topic_joint_states=joint_state_topic,
            logging_level=LoggingSeverity.INFO if logging_level is None else logging_level,
            node_name=node_name, **kwargs)
        self.gripper = InterbotixGripperXSInterface(
            self.core, gripper_name, gripper_pressure, gripper_pressure_lower_limit,
            gripper_pressure_upper_limit)

    @property
    def dxl(self) -> InterbotixRobotXSCore:
        """ROS 1 name of :attr:`core`."""
        return self.core

    def shutdown(self) -> None:
        """Shut the API down (robot_shutdown)."""
        robot_shutdown()
