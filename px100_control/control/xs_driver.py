"""
The Interbotix X-Series driver (xs_sdk) semantics over the simulated servos, without ROS.

:class:`XsDriver` answers what Interbotix's driver answers (robot info, operating modes,
registers) and turns its commands (group, single, trajectory) into what the simulated servos do,
as the real DYNAMIXELs would; time is always an argument (``now`` [s], the simulator's time).

Configuration: the ``xs_driver`` block of a robot file (config/robots/*.yaml): ``motor_ids``
{joint: id}, ``groups`` {group: [joints]} and ``modes`` as
Interbotix's modes.yaml (``groups`` / ``singles``: operating_mode, profile_type,
profile_velocity, profile_acceleration). Without a block: one group 'arm' of the arm joints,
ids 1..n, position / time profile 2000 ms / 300 ms, gripper pwm. The servo of each joint is the
robot file's ``servos`` section (figures in :data:`px100_control.control.actuator.DYNAMIXEL`;
unlisted: XL430-W250). The group 'all' (every motor)
always exists.

Command units by operating mode (the real driver's): position, ext_position,
current_based_position: rad; linear_position (gripper): finger separation [m]; velocity: rad/s;
current: mA (torque = the servo's torque constant x current); pwm: PWM units (885 = full duty).
Position modes follow the servo's profile: time-based, a trapezoid of Profile_Velocity ms with
Profile_Acceleration ms ramps (:func:`px100_control.control.trajectory.plan_move`); velocity-based,
Profile_Velocity in 0.229 rpm and Profile_Acceleration in 214.577 rev/min^2 units (0: no limit).
A new goal during a move starts from the profile's present state (continuous velocity).

What the real servo cannot do is refused (:class:`XsError`, nothing executed): current modes on
a servo without a current sensor (XL430), unknown groups/joints/modes/registers, a command count
that does not match the group, NaN, values outside the limits, a trajectory while one runs.
"""
from dataclasses import dataclass, field
import math
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

from px100_control.control.actuator import DYNAMIXEL, joint_servos, JointServos
from px100_control.control.gripper import GripperLinkage
from px100_control.control.pid import GAIN_REGISTER_MAX, PWM_FULL_SCALE
from px100_control.control.trajectory import plan_move, scaling_at
from px100_control.errors import Px100Error

#: operating modes of the driver; position-like modes take positions
MODES = ('position', 'ext_position', 'current_based_position', 'linear_position', 'velocity',
         'current', 'pwm')
POSITION_MODES = ('position', 'ext_position', 'current_based_position', 'linear_position')
CURRENT_MODES = ('current', 'current_based_position')
PROFILE_TYPES = ('time', 'velocity')
#: the DYNAMIXEL Operating_Mode register value of each mode
MODE_REGISTER = {'current': 0, 'velocity': 1, 'position': 3, 'ext_position': 4,
                 'current_based_position': 5, 'pwm': 16, 'linear_position': 3}
#: velocity unit of Profile_Velocity / Velocity_Limit / Present_Velocity [rad/s] (0.229 rpm)
VELOCITY_UNIT = 0.229 * 2.0 * math.pi / 60.0
#: acceleration unit of Profile_Acceleration (velocity-based profile) [rad/s^2]
ACCELERATION_UNIT = 214.577 * 2.0 * math.pi / 3600.0
#: position ticks per revolution (Goal_Position, Present_Position; 2048 = 0 rad)
TICKS_PER_REV = 4096


@dataclass(frozen=True)
class ServoCaps:
    """What a DYNAMIXEL model can do: current sensing, stall torque [N*m] and current [A]."""

    current: bool
    stall_torque: float
    stall_current: float
    model: str = 'XL430-W250'

    @property
    def torque_constant(self) -> float:
        """Return the torque per current [N*m/A] (stall torque / stall current)."""
        return self.stall_torque / self.stall_current


#: DYNAMIXEL models without current sensing (no current or current_based_position mode)
NO_CURRENT_SENSING = ('XL430-W250', 'XC430-W150')
DEFAULT_SERVO = 'XL430-W250'


def servo_caps(servos: JointServos) -> ServoCaps:
    """Return what the servo(s) of one joint can do (a shadowed joint has twice the torque)."""
    fig = servos.figures
    return ServoCaps(current=fig.model not in NO_CURRENT_SENSING,
                     stall_torque=servos.count * fig.stall_torque, stall_current=fig.stall_current,
                     model=('2x ' if servos.count == 2 else '') + fig.model)


#: registers this driver reads and writes; others are refused naming them
WRITABLE = ('Profile_Velocity', 'Profile_Acceleration', 'Position_P_Gain', 'Position_I_Gain',
            'Position_D_Gain', 'Velocity_P_Gain', 'Velocity_I_Gain', 'Feedforward_1st_Gain',
            'Feedforward_2nd_Gain', 'Goal_Position')
READ_ONLY = ('Present_Position', 'Present_Velocity', 'Torque_Enable', 'Operating_Mode', 'ID',
             'PWM_Limit', 'Velocity_Limit')
GAIN_REGISTERS = ('Position_P_Gain', 'Position_I_Gain', 'Position_D_Gain')


class XsError(Px100Error):
    """A driver request or command is refused; the message says why (xs_sdk's words if any)."""


def no_such(name: str) -> XsError:
    """Return xs_sdk's error for an unknown joint or group."""
    return XsError(f"The '{name}' joint/group does not exist. Was it added to the motor config "
                   'file?')


@dataclass
class JointState:
    """Driver state of one motor: mode, profile and registers it keeps."""

    mode: str = 'position'
    profile_type: str = 'velocity'
    profile_velocity: int = 0
    profile_acceleration: int = 0
    registers: Dict[str, int] = field(default_factory=dict)


class Motion:
    """
    A profiled move of one joint from ``t0`` [s]: a segment of plan_move, sampled in floats.

    The segment's own scaling (:func:`~px100_control.control.trajectory.scaling_at`) and start
    velocity blend, on plain floats: this runs before every physics step.
    """

    def __init__(self, t0: float, segment):
        self.t0 = float(t0)
        self.segment = segment
        self.q0, self.q1 = float(segment.q0[0]), float(segment.q1[0])
        self.v0 = float(segment.v0[0]) if segment.v0 is not None else 0.0

    def sample(self, now: float) -> Tuple[float, float, bool]:
        """Return (position [rad], velocity [rad/s], done) at ``now`` [s]."""
        seg = self.segment
        tl = now - self.t0
        if tl >= seg.T:
            return self.q1, 0.0, True
        tl = max(tl, 0.0)
        s, sd, _ = scaling_at(seg.profile, tl, seg.T, seg.accel_time)
        d = self.q1 - self.q0
        q, qd = self.q0 + s * d, sd * d
        if self.v0:
            tau = tl / seg.T
            q += seg.T * tau * (1.0 - tau) ** 2 * self.v0
            qd += (1.0 - tau) * (1.0 - 3.0 * tau) * self.v0
        return q, qd, False


@dataclass
class RobotInfo:
    """The fields of interbotix_xs_msgs/srv/RobotInfo's response."""

    mode: str
    profile_type: str
    joint_names: List[str]
    joint_ids: List[int]
    joint_lower_limits: List[float]
    joint_upper_limits: List[float]
    joint_velocity_limits: List[float]
    joint_sleep_positions: List[float]
    joint_state_indices: List[int]
    num_joints: int
    name: List[str]


def _finite(cmd: Sequence[float], what: str) -> List[float]:
    values = [float(v) for v in cmd]
    for i, v in enumerate(values):
        if not math.isfinite(v):
            raise XsError(f'{what} contains NaN or inf (index {i}): nothing executed')
    return values


class XsDriver:
    """
    The xs_sdk driver state and command semantics of one robot.

    :param model: the RobotModel (joints, limits, sleep pose, gripper)
    :param config: the robot file's ``xs_driver`` block (None: the defaults above)
    :param joint_state_names: the names of the driver's joint_states, in order
    """

    def __init__(self, model, config: Optional[Mapping] = None,
                 joint_state_names: Sequence[str] = ()):
        config = dict(config or {})
        self.model = model
        gripper = model.gripper
        self.gripper = gripper.joint if gripper is not None else None
        self.left_finger = gripper.fingers[0] if gripper is not None else None
        self.linkage = (GripperLinkage(gripper.horn_radius, gripper.arm_length,
                                       gripper.finger_lower, gripper.finger_upper)
                        if gripper is not None else None)
        self.joints = list(model.joint_names) + ([self.gripper] if self.gripper else [])
        self.ids = {j: int(config.get('motor_ids', {}).get(j, k + 1))
                    for k, j in enumerate(self.joints)}
        # the robot file's servos section (control.actuator: the e-Manual figures); joints it
        # does not list have the px100's XL430-W250
        listed = joint_servos((getattr(model, 'extra', None) or {}).get('servos'), self.joints)
        self._caps = {j: servo_caps(listed.get(j, JointServos(DYNAMIXEL[DEFAULT_SERVO])))
                      for j in self.joints}
        self.servos = {j: c.model for j, c in self._caps.items()}
        groups = dict(config.get('groups') or {'arm': list(model.joint_names)})
        groups['all'] = list(self.joints)
        for group, members in groups.items():
            for joint in members:
                if joint not in self.joints:
                    raise XsError(f"group '{group}': {no_such(joint)}")
        self.groups = {g: list(m) for g, m in groups.items()}
        self.js_names = list(joint_state_names)
        self.state = {j: JointState() for j in self.joints}
        self.group_modes = {g: ('position', 'velocity') for g in self.groups}
        self.motions: Dict[str, Motion] = {}
        self.ref: Dict[str, Tuple[float, float]] = {}   # last profile reference (q, qd)
        self.trajectory: Optional[dict] = None
        modes = dict(config.get('modes') or {
            'groups': {'arm': {'operating_mode': 'position', 'profile_type': 'time',
                               'profile_velocity': 2000, 'profile_acceleration': 300}},
            'singles': {self.gripper: {'operating_mode': 'pwm'}} if self.gripper else {}})
        for kind, cmd_type in (('groups', 'group'), ('singles', 'single')):
            for name, m in (modes.get(kind) or {}).items():
                self.set_operating_modes(
                    cmd_type, name, m.get('operating_mode', 'position'),
                    m.get('profile_type', 'velocity'), int(m.get('profile_velocity', 0)),
                    int(m.get('profile_acceleration', 0)))

    # --- names -------------------------------------------------------------------------------
    def resolve(self, cmd_type: str, name: str, action: str) -> List[str]:
        """Return the joints of ('group' | 'single', name); raise xs_sdk's error otherwise."""
        if cmd_type == 'group':
            if name not in self.groups:
                raise no_such(name)
            return list(self.groups[name])
        if cmd_type == 'single':
            if name not in self.joints:
                raise no_such(name)
            return [name]
        raise XsError(f"Invalid command for argument 'cmd_type' while {action}.")

    def caps(self, joint: str) -> ServoCaps:
        """Return the capabilities of a joint's servo."""
        return self._caps[joint]

    # --- services ----------------------------------------------------------------------------
    def robot_info(self, cmd_type: str, name: str) -> RobotInfo:
        """Return get_robot_info's answer (the gripper is reported as its left finger)."""
        joints = self.resolve(cmd_type, name, 'getting robot info')
        if cmd_type == 'group':
            mode, profile = self.group_modes[name]
        else:
            mode, profile = self.state[name].mode, self.state[name].profile_type
        info = RobotInfo(mode, profile, [], [], [], [], [], [], [], len(joints),
                         sorted(self.groups) if name == 'all' else [name])
        m = self.model
        for joint in joints:
            info.joint_ids.append(self.ids[joint])
            if joint == self.gripper:
                g = m.gripper
                info.joint_sleep_positions.append(self.linkage.finger_position(0.0))
                info.joint_names.append(self.left_finger)
                lower, upper, velocity = g.finger_lower, g.finger_upper, 1.0
                finger = self.left_finger
            else:
                k = m.joint_names.index(joint)
                info.joint_names.append(joint)
                info.joint_sleep_positions.append(float(m.sleep[k]))
                lower, upper, velocity = (float(m.lower[k]), float(m.upper[k]),
                                          float(m.velocity_limits[k]))
                finger = joint
            info.joint_lower_limits.append(lower)
            info.joint_upper_limits.append(upper)
            info.joint_velocity_limits.append(velocity)
            info.joint_state_indices.append(
                self.js_names.index(finger) if finger in self.js_names else -1)
        return info

    def set_operating_modes(self, cmd_type: str, name: str, mode: str, profile_type: str,
                            profile_velocity: int, profile_acceleration: int) -> List[str]:
        """Set the mode and profile of a group or joint; return the joints changed."""
        joints = self.resolve(cmd_type, name, 'setting operating mode')
        if mode not in MODES:
            raise XsError(f"Invalid command for argument 'mode' while setting the operating "
                          f"mode for the {name} motor (modes: {', '.join(MODES)}).")
        for joint in joints:
            if mode in CURRENT_MODES and not self.caps(joint).current:
                raise XsError(f"'{joint}' ({self.servos[joint]}) has no current sensing: "
                              f'the {mode} mode does not exist on it')
            if mode == 'linear_position' and joint != self.gripper:
                raise XsError(f"linear_position is the gripper's mode, not '{joint}''s")
        profile_type = profile_type or 'velocity'     # xs_sdk: anything but 'time' is velocity
        if profile_type not in PROFILE_TYPES:
            raise XsError(f"profile_type must be 'time' or 'velocity', not {profile_type!r}")
        for value, what in ((profile_velocity, 'profile_velocity'),
                            (profile_acceleration, 'profile_acceleration')):
            if not 0 <= int(value) <= 32767:
                raise XsError(f'{what} must be in 0..32767, not {value}')
        for joint in joints:
            s = self.state[joint]
            s.mode, s.profile_type = mode, profile_type
            s.profile_velocity, s.profile_acceleration = int(profile_velocity), \
                int(profile_acceleration)
            self.motions.pop(joint, None)
            self.ref.pop(joint, None)
        if cmd_type == 'group':
            self.group_modes[name] = (mode, profile_type)
        return joints

    def set_register(self, cmd_type: str, name: str, reg: str, value: int) -> List[str]:
        """Write a register of a group or joint; return the joints (gains: see gain_targets)."""
        joints = self.resolve(cmd_type, name, 'setting motor registers')
        if reg in READ_ONLY:
            raise XsError(f"register '{reg}' is read-only")
        if reg not in WRITABLE:
            raise XsError(f"register '{reg}' is not supported by this driver (writable: "
                          f"{', '.join(WRITABLE)})")
        value = int(value)
        if reg in GAIN_REGISTERS and not 0 <= value <= GAIN_REGISTER_MAX:
            raise XsError(f'{reg} must be in 0..{GAIN_REGISTER_MAX}, not {value}')
        if reg in ('Profile_Velocity', 'Profile_Acceleration') and not 0 <= value <= 32767:
            raise XsError(f'{reg} must be in 0..32767, not {value}')
        for joint in joints:
            s = self.state[joint]
            if reg == 'Profile_Velocity':
                s.profile_velocity = value
            elif reg == 'Profile_Acceleration':
                s.profile_acceleration = value
            elif reg not in GAIN_REGISTERS and reg != 'Goal_Position':
                s.registers[reg] = value
        return joints

    def get_register(self, cmd_type: str, name: str, reg: str,
                     facts: Mapping[str, Mapping]) -> List[int]:
        """
        Return a register's value per joint.

        :param facts: {joint: {'position' [rad], 'velocity' [rad/s], 'torque' (bool),
            'gains' (P, I, D registers)}} from the simulator
        """
        joints = self.resolve(cmd_type, name, 'getting motor registers')
        if reg not in WRITABLE + READ_ONLY:
            raise XsError(f"register '{reg}' is not supported by this driver (readable: "
                          f"{', '.join(WRITABLE + READ_ONLY)})")
        out = []
        for joint in joints:
            s, f = self.state[joint], facts[joint]
            value = {
                'Profile_Velocity': s.profile_velocity,
                'Profile_Acceleration': s.profile_acceleration,
                'Present_Position': rad_to_ticks(f['position']),
                'Goal_Position': rad_to_ticks(self.goal(joint, f['position'])),
                'Present_Velocity': int(round(f['velocity'] / VELOCITY_UNIT)),
                'Torque_Enable': int(bool(f['torque'])),
                'Operating_Mode': MODE_REGISTER[s.mode],
                'ID': self.ids[joint],
                'PWM_Limit': int(PWM_FULL_SCALE),
                'Velocity_Limit': 131,
            }.get(reg)
            if value is None and reg in GAIN_REGISTERS:
                value = int(round(f['gains'][GAIN_REGISTERS.index(reg)]))
            if value is None:
                value = s.registers.get(reg, {'Velocity_P_Gain': 100, 'Velocity_I_Gain': 1000}
                                        .get(reg, 0))
            out.append(int(value))
        return out

    def write_goal(self, joints: Sequence[str], ticks: int, now: float,
                   present: Mapping[str, float]) -> None:
        """Write Goal_Position [ticks] to ``joints`` (position modes): profiled moves."""
        for joint in joints:
            if self.state[joint].mode not in POSITION_MODES:
                raise XsError(f"Goal_Position: joint '{joint}' is in "
                              f'{self.state[joint].mode} mode')
        self._command(joints, [ticks_to_rad(ticks)] * len(joints), now, present)

    def goal(self, joint: str, present: float) -> float:
        """Return the joint's goal position [rad] (its move's end, else ``present``)."""
        motion = self.motions.get(joint)
        return motion.q1 if motion is not None else present

    # --- commands ----------------------------------------------------------------------------
    def group_command(self, name: str, cmd: Sequence[float], now: float,
                      present: Mapping[str, float]) -> Dict[str, Tuple[str, float]]:
        """
        Execute a JointGroupCommand; return the immediate setpoints {joint: (kind, value)}.

        kind: 'velocity' [rad/s], 'duty' [-1, 1] or 'torque' [N*m]; position-like modes start
        profiled moves instead (:meth:`references`).
        """
        if name not in self.groups:
            raise no_such(name)
        joints = self.groups[name]
        if len(cmd) != len(joints):
            raise XsError(f'Number of commands ({len(cmd)}) does not match the number of joints '
                          f"in group '{name}' ({len(joints)}). Will not execute.")
        mode = self.group_modes[name][0]
        for joint in joints:
            if self.state[joint].mode != mode:
                raise XsError(f"joint '{joint}' is in {self.state[joint].mode} mode but group "
                              f"'{name}' in {mode} mode: set the group's operating mode")
        return self._command(joints, _finite(cmd, 'command'), now, present)

    def single_command(self, name: str, cmd: float, now: float,
                       present: Mapping[str, float]) -> Dict[str, Tuple[str, float]]:
        """Execute a JointSingleCommand (see :meth:`group_command`)."""
        if name not in self.joints:
            raise no_such(name)
        return self._command([name], _finite([cmd], 'command'), now, present)

    def _command(self, joints, values, now, present) -> Dict[str, Tuple[str, float]]:
        targets = [self._target(j, v) for j, v in zip(joints, values)]   # all checked first
        out = {}
        for joint, (kind, value) in zip(joints, targets):
            if kind == 'position':
                self._start_move(joint, value, now, present[joint])
            else:
                self.motions.pop(joint, None)
                self.ref.pop(joint, None)
                out[joint] = (kind, value)
        return out

    def _target(self, joint: str, value: float) -> Tuple[str, float]:
        """Return (kind, SI value) of a command in the joint's mode; raise if out of limits."""
        mode = self.state[joint].mode
        if mode in POSITION_MODES:
            if mode == 'linear_position':
                g = self.model.gripper
                if not 2 * g.finger_lower - 1e-9 <= value <= 2 * g.finger_upper + 1e-9:
                    raise XsError(f"'{joint}' linear_position {value:.6g} m outside "
                                  f'[{2 * g.finger_lower:g}, {2 * g.finger_upper:g}] m')
                value = self.linkage.angle_from_finger(0.5 * value)
            lower, upper = self.position_limits(joint)
            if not lower - 1e-6 <= value <= upper + 1e-6:
                raise XsError(f"'{joint}' position {value:.6g} rad outside its limits "
                              f'[{lower:.6g}, {upper:.6g}]: nothing executed')
            return 'position', value
        if mode == 'velocity':
            limit = self.velocity_limit(joint)
            if abs(value) > limit + 1e-9:
                raise XsError(f"'{joint}' velocity {value:.6g} rad/s above its limit "
                              f'{limit:.6g}: nothing executed')
            return 'velocity', value
        if mode == 'pwm':
            if abs(value) > PWM_FULL_SCALE:
                raise XsError(f"'{joint}' pwm {value:.6g} outside +-{PWM_FULL_SCALE:g}: "
                              'nothing executed')
            return 'duty', value / PWM_FULL_SCALE
        caps = self.caps(joint)
        if abs(value) > caps.stall_current * 1000.0:
            raise XsError(f"'{joint}' current {value:.6g} mA above the {self.servos[joint]}'s "
                          f'{caps.stall_current * 1000:g} mA: nothing executed')
        return 'torque', value / 1000.0 * caps.torque_constant

    def position_limits(self, joint: str) -> Tuple[float, float]:
        """Return a joint's position limits [rad] (the gripper: its horn angle range)."""
        if joint == self.gripper:
            return self.linkage.angle_lower, self.linkage.angle_upper
        k = self.model.joint_names.index(joint)
        return float(self.model.lower[k]), float(self.model.upper[k])

    def velocity_limit(self, joint: str) -> float:
        """Return a joint's velocity limit [rad/s] (URDF, within the servo's Velocity_Limit)."""
        servo = 131 * VELOCITY_UNIT
        if joint == self.gripper:
            return servo
        v = float(self.model.velocity_limits[self.model.joint_names.index(joint)])
        return min(v, servo) if math.isfinite(v) and v > 0 else servo

    def _start_move(self, joint: str, goal: float, now: float, present: float) -> None:
        """Start the servo's profile from its present reference (or position) to ``goal``."""
        q0, v0 = self.ref.get(joint, (present, 0.0))
        if joint not in self.motions:
            q0, v0 = present, 0.0
        s = self.state[joint]
        T, ta = profile_times(s.profile_type, s.profile_velocity, s.profile_acceleration,
                              abs(goal - q0))
        if T <= 0.0:
            self.motions[joint] = Motion(now, plan_move([goal], [goal], 1e-9, accel_time=0.0)
                                         .segments[0])
        else:
            self.motions[joint] = Motion(now, plan_move(
                [q0], [goal], T, accel_time=ta, v_start=[v0] if v0 else None).segments[0])

    def trajectory_command(self, cmd_type: str, name: str, times: Sequence[float],
                           points: Sequence[Sequence[float]], kind: str, now: float) -> None:
        """
        Accept a JointTrajectoryCommand (checked whole, nothing executed if refused).

        Each point after the first is written at its time as a command in the joints' mode
        (:meth:`due_points`), as xs_sdk's timers do.

        :param kind: 'position' or 'velocity' (which field the points carry)
        """
        joints = self.resolve(cmd_type, name, 'executing a trajectory')
        if self.trajectory is not None:
            raise XsError('Trajectory rejected since joints are still moving.')
        if len(points) < 2:
            raise XsError('Trajectory has fewer than 2 points. Aborting...')
        for joint in joints:
            mode = self.state[joint].mode
            ok = mode == 'velocity' if kind == 'velocity' else mode in POSITION_MODES
            if not ok:
                raise XsError(f"joint '{joint}' is in {mode} mode: a {kind} trajectory is "
                              'refused')
        previous = -math.inf
        checked = []
        for t, values in zip(_finite(times, 'time_from_start'), points):
            if t <= previous:
                raise XsError('trajectory times must increase')
            previous = t
            if len(values) != len(joints):
                raise XsError(f'a trajectory point has {len(values)} values for '
                              f'{len(joints)} joints')
            checked.append((t, [self._target(j, v)[1] for j, v in
                                zip(joints, _finite(values, 'trajectory point'))]))
        self.trajectory = {'joints': joints, 'start': now, 'points': checked[1:], 'kind': kind}

    def due_points(self, now: float, present: Mapping[str, float]
                   ) -> Dict[str, Tuple[str, float]]:
        """Write the trajectory points due at ``now``; return immediate setpoints."""
        traj = self.trajectory
        out = {}
        while traj is not None and traj['points'] and \
                traj['start'] + traj['points'][0][0] <= now:
            _, values = traj['points'].pop(0)
            for joint, value in zip(traj['joints'], values):
                if traj['kind'] == 'position':
                    self._start_move(joint, value, now, present[joint])
                else:
                    out[joint] = ('velocity', value)
        if traj is not None and not traj['points']:
            self.trajectory = None
        return out

    def references(self, now: float) -> Dict[str, Tuple[float, float]]:
        """Return the profile references {joint: (q [rad], qd [rad/s])} at ``now``."""
        out = {}
        if self.trajectory is not None and now < self.trajectory['start']:
            self.trajectory = None          # the clock went back (a new scene): drop it
        for joint, motion in list(self.motions.items()):
            if now < motion.t0:             # the clock went back (a reset): drop the move
                del self.motions[joint]
                continue
            q, qd, done = motion.sample(now)
            out[joint] = (q, qd)
            self.ref[joint] = (q, qd)
            if done:
                del self.motions[joint]
        return out

    def follow_sim_modes(self, modes: Mapping[str, str]) -> List[str]:
        """
        Take the simulator's control modes set from outside; return the joints changed.

        ``modes``: the ``operating_mode.<joint>`` parameters {joint: '' | position | velocity |
        torque | duty}; a joint whose driver mode changes drops its move. '' and position keep
        a position-like mode (the gripper's '' also keeps pwm); velocity, torque and duty become
        velocity, current and pwm. A group whose joints then share one mode reports it.
        """
        changed = []
        for joint, sim_mode in modes.items():
            s = self.state.get(joint)
            if s is None:
                continue
            keeps = POSITION_MODES + (('pwm',) if joint == self.gripper and not sim_mode else ())
            if sim_mode in ('', 'position'):
                mode = s.mode if s.mode in keeps else 'position'
            else:
                mode = {'velocity': 'velocity', 'torque': 'current', 'duty': 'pwm'}.get(
                    sim_mode, s.mode)
            if mode != s.mode:
                s.mode = mode
                self.stop([joint])
                changed.append(joint)
        for group, members in self.groups.items():
            shared = {self.state[j].mode for j in members}
            if changed and len(shared) == 1:
                self.group_modes[group] = (shared.pop(), self.group_modes[group][1])
        return changed

    @property
    def active(self) -> bool:
        """Return True while a profiled move or a trajectory runs."""
        return bool(self.motions) or self.trajectory is not None

    def stop(self, joints: Sequence[str]) -> None:
        """Forget the moves (and a trajectory) of ``joints``: torque off, reboot, reset."""
        for joint in joints:
            self.motions.pop(joint, None)
            self.ref.pop(joint, None)
        if self.trajectory is not None and set(self.trajectory['joints']) & set(joints):
            self.trajectory = None


def profile_times(profile_type: str, velocity: int, acceleration: int,
                  distance: float) -> Tuple[float, float]:
    """
    Return (moving time, ramp time) [s] of the servo's profile over ``distance`` [rad].

    time: Profile_Velocity / Profile_Acceleration in ms; velocity: in 0.229 rpm and
    214.577 rev/min^2 units. 0 velocity: a step (moving time 0).
    """
    if profile_type == 'time':
        T = velocity / 1000.0
        return T, min(acceleration / 1000.0, T / 2.0)
    if velocity <= 0 or distance <= 0.0:
        return 0.0, 0.0
    v = velocity * VELOCITY_UNIT
    if acceleration <= 0:
        return distance / v, 0.0
    a = acceleration * ACCELERATION_UNIT
    if distance < v * v / a:                # triangle: never reaches v
        T = 2.0 * math.sqrt(distance / a)
        return T, T / 2.0
    return distance / v + v / a, v / a


def rad_to_ticks(rad: float) -> int:
    """Return the DYNAMIXEL position value of an angle [rad] (2048 = 0 rad)."""
    return int(round(2048 + rad * TICKS_PER_REV / (2.0 * math.pi)))


def ticks_to_rad(ticks: int) -> float:
    """Return the angle [rad] of a DYNAMIXEL position value."""
    return (int(ticks) - 2048) * 2.0 * math.pi / TICKS_PER_REV
