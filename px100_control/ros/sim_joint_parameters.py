"""
The sim_driver's per-joint parameters, for every arm joint and the gripper.

- ``gains.<joint>.p|i|d|i_clamp|u_clamp|ff_velocity``: the joint's PID gains, in SI or, with
  ``gains_units`` 'dynamixel', p/i/d as XL430 Position P/I/D Gain registers;
- ``torque_enable.<joint>`` (bool): the servo's torque (false: it coasts);
- ``operating_mode.<joint>`` (string): '' (default), 'position', 'velocity', 'torque' [N*m] or
  'duty' [-1, 1].

Types, ranges and descriptions are the groups of :data:`px100_control.parameters.SIM_DRIVER`;
the checks and conversions are :mod:`px100_control.sim.driver_parameters` (no ROS); this
module declares the parameters on the node and applies them to its ArmSimulator.
"""
from px100_control.control.pid import GAIN_FIELDS
from px100_control.errors import Px100Error
from px100_control.parameters import SIM_DRIVER
from px100_control.ros.parameter_schema import parameter_descriptor
from px100_control.sim.driver_parameters import (changed_gains, gain_defaults, gain_keys,
                                                 gains_error, joint_change_error,
                                                 joint_switches, mode_error, to_gains)


class JointParameters:
    """
    Declare and apply a sim_driver node's per-joint parameters.

    :param node: the node (parameters, logger)
    :param units: ``gains_units``, 'si' or 'dynamixel'
    :param joints: the joints with gains, torque and mode (the simulator's command joints)
    """

    def __init__(self, node, units: str, joints):
        self._node = node
        self.units = units
        self.joints = list(joints)

    def _value(self, name: str):
        return self._node.get_parameter(name).value

    def _declare(self, name: str, default=None):
        """Declare a per-joint parameter with its group's descriptor (default: the group's)."""
        spec = SIM_DRIVER.get(name)
        value = spec.default if default is None else default
        return self._node.declare_parameter(name, value, parameter_descriptor(spec))

    def declare(self, sim) -> None:
        """
        Declare the parameters and apply their values to ``sim``.

        :raises Px100Error: a value from the command line or a params file is refused
        """
        declare = self._declare
        for joint in self.joints:
            defaults = gain_defaults(sim, joint, self.units)  # scaled to the joint's servo
            values = {f: declare(k, defaults[f]).value
                      for f, k in zip(GAIN_FIELDS, gain_keys(joint))}
            error = gains_error(sim, joint, values, self.units)
            if error:
                raise Px100Error(error)
            sim.set_gains(joint, to_gains(sim, joint, values, self.units))
        for joint in self.joints:
            declare(f'torque_enable.{joint}')
            mode = declare(f'operating_mode.{joint}')
            if mode.value:
                error = mode_error(mode.name, mode.value)
                if error:
                    raise Px100Error(error)
                self.set_mode(sim, joint, mode.value)

    def error(self, sim, changed: dict):
        """Return why the per-joint values in ``changed`` {name: value} are refused, or None."""
        return joint_change_error(changed, self._value, sim, self.units)

    def set_mode(self, sim, joint: str, mode: str) -> None:
        """Put a joint in a control mode ('' = its default); the joint then holds."""
        sim.set_mode(joint, mode or 'position')
        if not mode:
            sim.modes.pop(joint, None)  # the default (the gripper: position or effort)
        self._node.get_logger().info(f"{joint}: {mode or 'default'} mode")

    def apply(self, sim, changed: dict, catch_up) -> None:
        """
        Apply the accepted per-joint values of ``changed`` {name: value} to ``sim``.

        ``catch_up()`` integrates the physics up to now before a mode or torque switch.
        """
        for joint, values in changed_gains(changed, self._value, self.joints).items():
            sim.set_gains(joint, to_gains(sim, joint, values, self.units))
            self._node.get_logger().info(f'gains of {joint}: {sim.gains(joint)}')
        torque, modes = joint_switches(changed)
        if modes:
            catch_up()
            for joint, mode in modes.items():
                self.set_mode(sim, joint, mode)
        if torque:
            catch_up()
            for joint, on in torque.items():
                sim.set_torque_enabled(on, [joint])
            if len(torque) < len(self.joints):
                self._node.get_logger().info('torque ' + ', '.join(
                    f"{j} {'on' if on else 'off'}" for j, on in torque.items()))

    def carry_over(self, sim) -> None:
        """Give a new simulator the joints' modes and torque switches as set."""
        for joint in self.joints:
            mode = str(self._value(f'operating_mode.{joint}'))
            if mode:
                self.set_mode(sim, joint, mode)
            if not self._value(f'torque_enable.{joint}'):
                sim.set_torque_enabled(False, [joint])
