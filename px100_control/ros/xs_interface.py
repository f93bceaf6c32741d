"""
The Interbotix driver interface (xs_sdk's topics and services) of the sim_driver node.

A thin rclpy adapter over :class:`px100_control.control.xs_driver.XsDriver`, created by the
node (docs/ros_interfaces.md, "Interbotix driver interface"). In the robot namespace:

- sub ``commands/joint_group`` (interbotix_xs_msgs/JointGroupCommand, group order),
  ``commands/joint_single`` (JointSingleCommand), ``commands/joint_trajectory``
  (JointTrajectoryCommand), each in the joints' operating mode;
- services ``get_robot_info`` (RobotInfo), ``torque_enable`` (TorqueEnable), ``reboot_motors``
  (Reboot), ``set_operating_modes`` (OperatingModes), ``get_motor_registers`` /
  ``set_motor_registers`` (RegisterValues), ``set_motor_pid_gains`` (MotorGains), each with
  service introspection (``<service>/_service_event``).

Torque, operating modes and PID gains go through the node's parameters
(``torque_enable.<joint>``, ``operating_mode.<joint>``, ``gains.<joint>.p|i|d``), so both
interfaces see one state. Profiled position moves set the simulator's references before every
physics step (the stepper's ``before_step``), as the servo's own profile generator does.
A refused command or request is logged as an error and published on ``/diagnostics``
(``<node>: xs/<topic or service>``); nothing of it is executed.
"""
from interbotix_xs_msgs.msg import JointGroupCommand, JointSingleCommand, JointTrajectoryCommand
from interbotix_xs_msgs.srv import (MotorGains, OperatingModes, Reboot, RegisterValues,
                                    RobotInfo, TorqueEnable)
from px100_control.control.xs_driver import GAIN_REGISTERS, POSITION_MODES, XsDriver
from px100_control.errors import Px100Error
from px100_control.ros.action_events import EVENT_QOS
from px100_control.ros.common import robot_topic
from px100_control.sim.driver_parameters import to_gains
from px100_control.sim.simulator import check_modes, SetpointCommand
from rclpy.parameter import Parameter
from rclpy.service_introspection import ServiceIntrospectionState

#: the sim_driver's operating_mode parameter of each driver mode (arm joints; the gripper's
#: pwm is the parameter's default '', which takes efforts)
SIM_MODE = {'position': 'position', 'ext_position': 'position',
            'current_based_position': 'position', 'linear_position': 'position',
            'velocity': 'velocity', 'current': 'torque', 'pwm': 'duty'}


class XsInterface:
    """
    xs_sdk's ROS interface on a sim_driver node.

    :param node: the SimDriverNode (sim, stepper, physics, lock, parameters, diagnostics)
    :param group: the callback group of the subscriptions and services
    """

    def __init__(self, node, group):
        self.node = node
        self.driver = XsDriver(node.model, (node.model.extra or {}).get('xs_driver'),
                               list(node.sim.joint_state().name))
        for msg, name, callback in (
                (JointGroupCommand, 'commands/joint_group', self._on_group),
                (JointSingleCommand, 'commands/joint_single', self._on_single),
                (JointTrajectoryCommand, 'commands/joint_trajectory', self._on_trajectory)):
            node.create_subscription(msg, robot_topic(node, name), callback, 10,
                                     callback_group=group)
        self.services = []
        for srv, name, callback in (
                (RobotInfo, 'get_robot_info', self._on_info),
                (TorqueEnable, 'torque_enable', self._on_torque),
                (Reboot, 'reboot_motors', self._on_reboot),
                (OperatingModes, 'set_operating_modes', self._on_modes),
                (RegisterValues, 'set_motor_registers', self._on_set_register),
                (RegisterValues, 'get_motor_registers', self._on_get_register),
                (MotorGains, 'set_motor_pid_gains', self._on_gains)):
            service = node.create_service(srv, robot_topic(node, name), callback,
                                          callback_group=group)
            service.configure_introspection(node.get_clock(), EVENT_QOS,
                                            ServiceIntrospectionState.CONTENTS)
            self.services.append(service)
        node.add_post_set_parameters_callback(self._on_parameters)

    # --- helpers -------------------------------------------------------------------------------
    def _refuse(self, what: str, exc: Exception, name: str = '') -> None:
        """Log a refusal as an error and publish it on /diagnostics."""
        self.node.get_logger().error(f'{what}: {exc}')
        self.node._publish_error(f'xs/{what}', str(exc), [('name', str(name)[:64])])

    def _present(self, sim) -> dict:
        """Return {joint: position [rad]} of the arm joints and the gripper (horn angle)."""
        present = dict(zip(sim.names, sim.q))
        if sim.gripper_name:
            present[sim.gripper_name] = sim.g_theta
        return present

    def _servo(self, sim, joint: str):
        return sim.gripper_servo if joint == sim.gripper_name else \
            sim.servos[sim.names.index(joint)]

    def _setpoints(self, sim, outputs: dict) -> SetpointCommand:
        """Return the simulator command of the driver's immediate outputs {joint: (kind, v)}."""
        cmd = SetpointCommand()
        for joint, (kind, value) in outputs.items():
            if kind == 'velocity':
                cmd.velocities[joint] = value
            elif kind == 'duty' and sim.modes.get(joint) != 'duty':   # gripper default: N*m
                cmd.efforts[joint] = value * self._servo(sim, joint).stall_torque
            else:
                cmd.efforts[joint] = value
        return cmd

    def _execute(self, joints, run) -> None:
        """Under the node's lock, at the simulator's now: run(now, present) -> outputs."""
        node = self.node
        with node._lock:
            node.physics.catch_up()
            sim = node.sim
            moving = [j for j in joints if self.driver.state[j].mode in POSITION_MODES]
            check_modes(moving, 'position', sim.gripper_name, sim.modes)
            outputs = run(sim.time, self._present(sim))
            if outputs:
                sim.apply(self._setpoints(sim, outputs))
            if self.driver.active:
                node.stepper.before_step = self._before_step

    def _before_step(self) -> None:
        """Before each physics step: due trajectory points, then the profile references."""
        sim, driver = self.node.sim, self.driver
        if driver.trajectory is not None:
            outputs = driver.due_points(sim.time, self._present(sim))
            if outputs:
                sim.apply(self._setpoints(sim, outputs))
        refs = driver.references(sim.time)
        if refs:
            sim.set_references(refs)
        if not driver.active:
            self.node.stepper.before_step = None

    def _set_parameters(self, values: dict) -> None:
        """Set node parameters {name: value}; raise with the reason of a refusal."""
        results = self.node.set_parameters([Parameter(k, value=v) for k, v in values.items()])
        for result in results:
            if not result.successful:
                raise Px100Error(result.reason)

    def _on_parameters(self, params) -> None:
        """operating_mode.<joint> set from outside (ros2 param, the client): follow it."""
        modes = {p.name[len('operating_mode.'):]: str(p.value) for p in params
                 if p.name.startswith('operating_mode.')}
        if modes:
            with self.node._lock:
                changed = self.driver.follow_sim_modes(modes)
            for joint in changed:
                self.node.get_logger().info(
                    f"'{joint}': operating mode '{self.driver.state[joint].mode}' (parameter)")

    # --- topics --------------------------------------------------------------------------------
    def _on_group(self, msg: JointGroupCommand) -> None:
        try:
            joints = self.driver.groups.get(msg.name, [])
            self._execute(joints, lambda now, present: self.driver.group_command(
                msg.name, list(msg.cmd), now, present))
        except Px100Error as exc:
            self._refuse('commands/joint_group', exc, msg.name)

    def _on_single(self, msg: JointSingleCommand) -> None:
        try:
            joints = [msg.name] if msg.name in self.driver.joints else []
            self._execute(joints, lambda now, present: self.driver.single_command(
                msg.name, msg.cmd, now, present))
        except Px100Error as exc:
            self._refuse('commands/joint_single', exc, msg.name)

    def _on_trajectory(self, msg: JointTrajectoryCommand) -> None:
        try:
            points = msg.traj.points
            kind = 'velocity' if points and points[0].velocities and \
                not points[0].positions else 'position'
            times = [p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in points]
            values = [list(p.velocities if kind == 'velocity' else p.positions) for p in points]
            joints = self.driver.resolve(msg.cmd_type, msg.name, 'executing a trajectory')
            self._execute(joints, lambda now, present: self.driver.trajectory_command(
                msg.cmd_type, msg.name, times, values, kind, now))
        except Px100Error as exc:
            self._refuse('commands/joint_trajectory', exc, msg.name)

    # --- services ------------------------------------------------------------------------------
    def _on_info(self, request, response):
        try:
            info = self.driver.robot_info(request.cmd_type, request.name)
        except Px100Error as exc:
            self._refuse('get_robot_info', exc, request.name)
            return response
        for key, value in vars(info).items():
            setattr(response, key, value)
        return response

    def _on_torque(self, request, response):
        try:
            joints = self.driver.resolve(request.cmd_type, request.name, 'torquing joints')
            self._set_parameters({f'torque_enable.{j}': bool(request.enable) for j in joints})
        except Px100Error as exc:
            self._refuse('torque_enable', exc, request.name)
            return response
        if not request.enable:
            with self.node._lock:
                self.driver.stop(joints)
        kind = 'group' if request.cmd_type == 'group' else 'joint'
        self.node.get_logger().info(
            f"The '{request.name}' {kind} was torqued {'on' if request.enable else 'off'}.")
        return response

    def _on_reboot(self, request, response):
        try:
            joints = self.driver.resolve(request.cmd_type, request.name, 'rebooting motors')
            if request.smart_reboot and request.cmd_type == 'group':
                joints = []        # simulated servos have no hardware error to reboot from
            with self.node._lock:
                self.driver.stop(joints)
            self._set_parameters({f'torque_enable.{j}': bool(request.enable) for j in joints})
        except Px100Error as exc:
            self._refuse('reboot_motors', exc, request.name)
            return response
        for joint in joints:
            self.node.get_logger().info(f"The '{joint}' joint was rebooted.")
        return response

    def _on_modes(self, request, response):
        try:
            self._set_modes(request)
        except Px100Error as exc:
            self._refuse('set_operating_modes', exc, request.name)
        return response

    def _set_modes(self, r) -> None:
        """Check and set the driver's mode and the sim_driver's operating_mode parameters."""
        joints = self.driver.resolve(r.cmd_type, r.name, 'setting operating mode')
        gripper = self.driver.gripper
        values = {f'operating_mode.{j}': ('' if j == gripper and r.mode == 'pwm'
                                          else SIM_MODE.get(r.mode, '')) for j in joints}
        with self.node._lock:
            self.driver.set_operating_modes(r.cmd_type, r.name, r.mode, r.profile_type,
                                            r.profile_velocity, r.profile_acceleration)
        self._set_parameters(values)
        kind = 'group' if r.cmd_type == 'group' else 'joint'
        self.node.get_logger().info(
            f"The operating mode for the '{r.name}' {kind} was changed to '{r.mode}' with "
            f"profile type '{r.profile_type}'.")

    def _on_set_register(self, request, response):
        try:
            self._set_register(request.cmd_type, request.name, request.reg, request.value)
        except Px100Error as exc:
            self._refuse('set_motor_registers', exc, request.name)
        return response

    def _set_register(self, cmd_type: str, name: str, reg: str, value: int) -> None:
        with self.node._lock:
            joints = self.driver.set_register(cmd_type, name, reg, value)
        if reg in GAIN_REGISTERS:
            self._write_gains(joints, {'pid'[GAIN_REGISTERS.index(reg)]: value})
        elif reg == 'Goal_Position':
            self._execute(joints, lambda now, present: self.driver.write_goal(
                joints, value, now, present))

    def _on_get_register(self, request, response):
        try:
            joints = self.driver.resolve(request.cmd_type, request.name,
                                         'getting motor registers')
            with self.node._lock:
                facts = self._facts(joints)
            response.values = self.driver.get_register(request.cmd_type, request.name,
                                                       request.reg, facts)
        except Px100Error as exc:
            self._refuse('get_motor_registers', exc, request.name)
        return response

    def _facts(self, joints) -> dict:
        """Return what the registers read from the simulator, per joint."""
        sim = self.node.sim
        state = sim.joint_state()
        where = {n: k for k, n in enumerate(state.name)}
        torque = sim.torque_states()
        return {j: {'position': state.position[where[j]], 'velocity': state.velocity[where[j]],
                    'torque': torque.get(j, True),
                    'gains': sim.gains(j).to_dynamixel(self._servo(sim, j).stall_torque)}
                for j in joints}

    def _on_gains(self, request, response):
        try:
            r = request
            joints = self.driver.resolve(r.cmd_type, r.name, 'setting PID gains')
            for reg, value in (('Feedforward_1st_Gain', r.k1), ('Feedforward_2nd_Gain', r.k2),
                               ('Velocity_P_Gain', r.kp_vel), ('Velocity_I_Gain', r.ki_vel)):
                self.driver.set_register(r.cmd_type, r.name, reg, value)
            self._write_gains(joints, {'p': r.kp_pos, 'i': r.ki_pos, 'd': r.kd_pos})
        except Px100Error as exc:
            self._refuse('set_motor_pid_gains', exc, request.name)
        return response

    def _write_gains(self, joints, registers: dict) -> None:
        """Set position P/I/D Gain registers {'p'|'i'|'d': value} as the joints' PID gains."""
        sim, units = self.node.sim, self.node.joint_parameters.units
        values = {}
        for joint in joints:
            gains = sim.gains(joint)
            regs = dict(zip('pid', gains.to_dynamixel(self._servo(sim, joint).stall_torque)))
            regs.update({k: float(v) for k, v in registers.items()})
            si = to_gains(sim, joint, dict(regs, i_clamp=gains.i_clamp, u_clamp=gains.u_clamp,
                                           ff_velocity=gains.ff_velocity), 'dynamixel')
            for f in 'pid':
                values[f'gains.{joint}.{f}'] = float(regs[f] if units == 'dynamixel'
                                                     else getattr(si, f))
        self._set_parameters(values)
