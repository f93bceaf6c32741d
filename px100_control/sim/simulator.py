"""
The simulated arm: MuJoCo physics under this project's per-joint PIDs and XL430 servo model.

:class:`ArmSimulator` advances the arm, its gripper and an optional scene of objects by a fixed
control period ``dt = 1 / control_rate`` per :meth:`ArmSimulator.step`; it owns no clock (time
is what you step). Each step, for every arm joint:

1. control law by the joint's mode (:meth:`ArmSimulator.set_mode`): 'position' = PID
   (:mod:`px100_control.control.pid`) on the held setpoint (default), 'velocity' = PI on
   velocity, 'torque' = the commanded joint torque [N*m] (Dynamixel current control), 'duty' =
   the commanded PWM duty;
2. servo (:mod:`px100_control.control.actuator`): torque command -> PWM duty (saturated), drive
   torque ``stall * duty`` plus back-EMF damping while torque is on (torque mode: the commanded
   torque within what the supply voltage allows at that speed); torque off -> the motor coasts;
3. plant: MuJoCo (:mod:`.mjcf`, the model built from the robot's URDF) applies
   the drive torques (``qfrc_applied``) and integrates the rigid-body dynamics, joint damping
   (URDF + back-EMF, implicit), Coulomb friction (URDF ``friction`` -> ``frictionloss``),
   rotor armature, joint limits (stiff hard stops) and contacts with the scene;
4. while torque is on the speed is held within the joint's velocity limit (the servo's
   Velocity_Limit).

The gripper is servo-driven through its linkage (:mod:`px100_control.control.gripper`): the
left finger slide is the MuJoCo degree of freedom (the right one follows through a stiff
equality), the horn angle theta [rad] follows from the finger position; the horn torque u [N*m]
of its PID (or the commanded effort) drives each finger with ``u / (2 d'(theta))`` [N], and the
horn's armature, back-EMF damping and friction are reflected onto the fingers by ``d'(theta)``.
Objects are moved only by contact: the finger pads squeeze them with friction (never attached).

Scene API (see :mod:`px100_control.sim`): :meth:`~ArmSimulator.objects`,
:meth:`~ArmSimulator.object_poses`, :meth:`~ArmSimulator.held_object`,
:meth:`~ArmSimulator.reset` (arm and scene), :meth:`~ArmSimulator.reset_scene`.

Setpoints are validated before anything is applied (:func:`parse_setpoints` and
:meth:`ArmSimulator.apply`): unknown or duplicate names, NaN/inf, length mismatches, values
outside the limits and fields that do not match the joint's mode raise a
:class:`~px100_control.errors.Px100Error` with the reason, and nothing of that command is used.
A velocity feed-forward expires ``ff_timeout`` seconds after its setpoint. Units: rad, m, s, N*m.
"""
from dataclasses import dataclass, field
import math
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import mujoco
import numpy as np
from px100_control.control.actuator import servo_for_joint, ServoSpec
from px100_control.control.gripper import GripperLinkage
from px100_control.control.pid import Pid, PidGains
from px100_control.errors import InvalidInputError, JointLimitError, UnknownJointError
from px100_control.kinematics.kernels import quaternion_xyzw as _quaternion_xyzw
from px100_control.models.urdf_tree import load_urdf_tree
from px100_control.sim.mjcf import build_model, GRAVITY
from px100_control.sim.scene import check_reach

#: control modes of a joint (see the module docstring)
MODES = ('position', 'velocity', 'torque', 'duty')

#: default gains of a revolute arm joint (SI): about 5x the XL430 factory stiffness (P 640 =
#: 5.16 N*m/rad) with integral action, so the arm holds within 1 mrad under gravity and Coulomb
#: friction; velocity feed-forward cancels back-EMF + URDF damping; output clamp = stall.
DEFAULT_REVOLUTE_GAINS = PidGains(p=25.0, i=150.0, d=0.6, i_clamp=1.0, u_clamp=1.4,
                                  ff_velocity=0.333)
#: default gains of a prismatic joint (N/m, N/(m*s), N*s/m, N).
DEFAULT_PRISMATIC_GAINS = PidGains(p=2000.0, i=4000.0, d=150.0, i_clamp=30.0, u_clamp=40.0,
                                   ff_velocity=100.0)
#: default gains of the gripper servo in position mode.
DEFAULT_GRIPPER_GAINS = PidGains(p=5.0, i=20.0, d=0.1, i_clamp=0.5, u_clamp=1.4,
                                 ff_velocity=0.0)
#: default gains of the velocity mode's PI loop (p [N*m*s/rad], i [N*m/rad]; d unused)
DEFAULT_VELOCITY_GAINS = PidGains(p=1.0, i=20.0, d=0.0, i_clamp=1.0, u_clamp=1.4,
                                  ff_velocity=0.333)
#: position tolerance when checking limits [rad or m]
LIMIT_TOLERANCE = 1e-6


def default_gains(joint_type: str, stall_torque: Optional[float] = None) -> PidGains:
    """
    Return the default PidGains of a joint type ('revolute', 'prismatic' or 'gripper').

    :param stall_torque: of the joint's servo; gains and clamps scale with it (the armature
        does too, so the loop dynamics stay those tuned on the XL430)
    """
    if joint_type == 'prismatic':
        base, ref = DEFAULT_PRISMATIC_GAINS, 40.0
    elif joint_type == 'gripper':
        base, ref = DEFAULT_GRIPPER_GAINS, 1.4
    else:
        base, ref = DEFAULT_REVOLUTE_GAINS, 1.4
    if stall_torque is None or stall_torque == ref:
        return base
    k = stall_torque / ref
    return PidGains(p=base.p * k, i=base.i * k, d=base.d * k, i_clamp=base.i_clamp * k,
                    u_clamp=base.u_clamp * k, ff_velocity=base.ff_velocity * k)


@dataclass(frozen=True)
class SimConfig:
    """
    Simulation settings.

    :param control_rate: physics and control rate [Hz]
    :param dynamics_divider: accepted for compatibility and ignored (MuJoCo evaluates the
        dynamics every step)
    :param default_damping/default_friction: for joints whose URDF has no <dynamics>
    :param servo_overrides: ServoSpec fields to change for every joint (e.g. armature)
    :param object_width: a finger stop at width / 2 [m] (0 = off; no object, see
        :meth:`ArmSimulator.set_object_width`)
    :param ff_timeout: a setpoint's velocity feed-forward expires after this [s]
    """

    control_rate: float = 1000.0
    dynamics_divider: int = 4
    gravity: float = GRAVITY
    default_damping: float = 0.1
    default_friction: float = 0.1
    servo_overrides: Mapping[str, float] = field(default_factory=dict)
    object_width: float = 0.0
    ff_timeout: float = 0.1

    def __post_init__(self):
        if not (math.isfinite(self.control_rate) and 10.0 <= self.control_rate <= 100000.0):
            raise InvalidInputError(f'control_rate must be in 10..100000 Hz, not '
                                    f'{self.control_rate}')
        if int(self.dynamics_divider) != self.dynamics_divider or self.dynamics_divider < 1:
            raise InvalidInputError(f'dynamics_divider must be an integer >= 1, not '
                                    f'{self.dynamics_divider}')


@dataclass(frozen=True)
class JointStateSample:
    """Measured state in Interbotix order (arm, gripper, left_finger, right_finger)."""

    name: Tuple[str, ...]
    position: Tuple[float, ...]
    velocity: Tuple[float, ...]
    effort: Tuple[float, ...]


@dataclass(frozen=True)
class SetpointCommand:
    """A validated-format setpoint: {joint: value} for positions, velocities or efforts."""

    positions: Dict[str, float] = field(default_factory=dict)
    velocities: Dict[str, float] = field(default_factory=dict)
    efforts: Dict[str, float] = field(default_factory=dict)


def _short(name: str, limit: int = 64) -> str:
    """Return a joint name cut to ``limit`` characters for messages."""
    return name if len(name) <= limit else name[:limit] + f'... ({len(name)} chars)'


def _finite(values, what: str) -> List[float]:
    try:
        out = [float(v) for v in values]
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f'{what} is not numeric') from exc
    for i, v in enumerate(out):
        if not math.isfinite(v):
            shown = out if len(out) <= 8 else f'{len(out)} values'
            raise InvalidInputError(f'{what} contains NaN or inf (index {i}: {v}): {shown}')
    return out


def parse_setpoints(names: Sequence[str], position: Sequence[float] = (),
                    velocity: Sequence[float] = (), effort: Sequence[float] = (),
                    known: Sequence[str] = (), gripper: Optional[str] = None,
                    modes: Optional[Mapping[str, str]] = None) -> SetpointCommand:
    """
    Return the SetpointCommand of a JointState-like setpoint, or raise with the reason.

    Without ``modes`` (every joint in position mode): ``position`` (with optional ``velocity``
    feed-forward) for the named joints, or ``effort`` for the gripper only. With ``modes``
    ({joint: mode}, see :data:`MODES`): a command is one kind for all its joints: position
    (+ velocity feed-forward) for 'position' joints, velocity alone for 'velocity' joints,
    effort for 'torque' ([N*m]) and 'duty' ([-1, 1]) joints; the gripper in its default mode
    (absent from ``modes``) takes position or effort. Each array is empty or has one value per
    name.
    :param known: the joints that accept setpoints (arm joints and the gripper)
    :raises InvalidInputError: empty, mismatched lengths, duplicates, NaN/inf, wrong mode
    :raises UnknownJointError: a name that is not in ``known``
    """
    names = [str(n) for n in names]
    if not names:
        raise InvalidInputError('setpoint names no joint')
    if len(set(names)) != len(names):
        seen, dup = set(), set()
        for n in names:  # linear: names.count() per name stalled the node on huge input
            (dup if n in seen else seen).add(n)
        dup = sorted(dup)
        more = f' and {len(dup) - 10} more' if len(dup) > 10 else ''
        raise InvalidInputError(f'duplicate joint names {[_short(d) for d in dup[:10]]}{more}')
    for n in names:
        if n not in known:
            raise UnknownJointError(_short(n), known)
    for what, arr in (('position', position), ('velocity', velocity), ('effort', effort)):
        if len(arr) not in (0, len(names)):
            raise InvalidInputError(f'{len(names)} joint names but {len(arr)} {what} values')
    if modes is not None:
        return _parse_moded(names, position, velocity, effort, gripper, modes)
    if len(velocity) and not len(position):
        raise InvalidInputError('velocity feed-forward needs position values')
    if not len(position) and not len(effort):
        raise InvalidInputError('setpoint has neither position nor effort values')
    if len(position) and len(effort):
        raise InvalidInputError('setpoint has both position and effort values: give position '
                                '(position control) or effort (gripper effort control)')
    if len(effort):
        others = [n for n in names if n != gripper]
        if others:
            raise InvalidInputError(f'effort control exists only for the gripper '
                                    f'({gripper!r}), not for {others}')
        return SetpointCommand(efforts=dict(zip(names, _finite(effort, 'effort'))))
    cmd = SetpointCommand(positions=dict(zip(names, _finite(position, 'position'))))
    if len(velocity):
        cmd.velocities.update(zip(names, _finite(velocity, 'velocity')))
    return cmd


def _mode_of(joint: str, gripper: Optional[str], modes: Mapping[str, str]) -> str:
    mode = modes.get(joint)
    if mode is None:
        return 'gripper-default' if joint == gripper else 'position'
    return mode


#: command kind -> the modes that accept it
_ACCEPTS = {'position': ('position', 'gripper-default'), 'velocity': ('velocity',),
            'effort': ('torque', 'duty', 'gripper-default')}
_EXPECTS = {'position': 'position values (velocity only as feed-forward)',
            'velocity': 'velocity values only', 'torque': 'effort values (torque, N*m)',
            'duty': 'effort values (PWM duty in [-1, 1])',
            'gripper-default': 'position or effort values'}


def _parse_moded(names, position, velocity, effort, gripper, modes) -> SetpointCommand:
    if len(position) and len(effort):
        raise InvalidInputError('setpoint has both position and effort values')
    if len(position):
        kind = 'position'
    elif len(effort):
        kind = 'effort'
        if len(velocity):
            raise InvalidInputError('setpoint has both velocity and effort values')
    elif len(velocity):
        kind = 'velocity'
    else:
        raise InvalidInputError('setpoint has neither position, velocity nor effort values')
    check_modes(names, kind, gripper, modes)
    if kind == 'effort':
        return SetpointCommand(efforts=dict(zip(names, _finite(effort, 'effort'))))
    if kind == 'velocity':
        return SetpointCommand(velocities=dict(zip(names, _finite(velocity, 'velocity'))))
    cmd = SetpointCommand(positions=dict(zip(names, _finite(position, 'position'))))
    if len(velocity):
        cmd.velocities.update(zip(names, _finite(velocity, 'velocity')))
    return cmd


def check_modes(names, kind: str, gripper: Optional[str], modes: Mapping[str, str]) -> None:
    """
    Raise InvalidInputError if a command kind does not match the mode of one of its joints.

    :param kind: 'position', 'velocity' or 'effort'; a mismatched command is refused, never
        executed as something else
    """
    for n in names:
        mode = _mode_of(n, gripper, modes)
        if mode not in _ACCEPTS[kind]:
            raise InvalidInputError(f"joint '{_short(n)}' is in {mode} mode and takes "
                                    f'{_EXPECTS[mode]}, not {kind} values (set_mode changes '
                                    f'the mode)')


def _urdf_joint_dynamics(urdf_xml: Optional[str]) -> Dict[str, Tuple[float, float]]:
    """Return {joint: (damping, friction)} from a URDF's <dynamics> tags."""
    if not urdf_xml:
        return {}
    out = {}
    for j in load_urdf_tree(urdf_xml).robot.joints:
        dyn = j.dynamics
        if dyn is not None:
            out[j.name] = (float(dyn.damping or 0.0), float(dyn.friction or 0.0))
    return out


@dataclass(frozen=True)
class ObjectInfo:
    """
    A body of the scene.

    kind 'object' | 'fixture' | 'table'; shape 'box' | 'cylinder' | 'sphere'; size (box: full
    x, y, z extents; cylinder: radius, height; sphere: radius) [m]; rgba (4 floats 0..1);
    mass [kg] (0 for static bodies).
    """

    name: str
    kind: str
    shape: str
    size: Tuple[float, ...]
    rgba: Tuple[float, float, float, float]
    mass: float


class PlantDynamics:
    """
    Rigid-body quantities of the arm from the simulator's MuJoCo model (arm joints only).

    M(q) includes the rotor armature, h(q, qd) = C(q, qd) qd + g(q) [N*m]; the gripper and the
    objects stay where they are. ``notes`` say how the URDF inertials were interpreted.
    """

    def __init__(self, sim: 'ArmSimulator'):
        self._sim = sim
        self.notes = sim.built.notes
        self.gravity = GRAVITY

    def _at(self, q, qd):
        sim = self._sim
        m, d = sim.mj_model, mujoco.MjData(sim.mj_model)
        d.qpos[:] = sim.mj_data.qpos
        d.qpos[list(sim.built.arm_qpos)] = np.asarray(q, float)
        d.qvel[list(sim.built.arm_dof)] = np.asarray(qd, float)
        mujoco.mj_forward(m, d)
        return m, d

    def evaluate(self, q, qd) -> Tuple[np.ndarray, np.ndarray]:
        """Return (M (n, n) with armature, h (n,)) at joint positions q and velocities qd."""
        m, d = self._at(q, qd)
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, full)
        idx = list(self._sim.built.arm_dof)
        return full[np.ix_(idx, idx)], d.qfrc_bias[idx].copy()

    def mass_matrix(self, q) -> np.ndarray:
        """Return M(q) + diag(armature) (n, n) [kg*m^2]."""
        return self.evaluate(q, np.zeros(len(q)))[0]

    def gravity_torque(self, q) -> np.ndarray:
        """Return g(q) (n,): the joint torques [N*m] that hold the arm still at q."""
        return self.evaluate(q, np.zeros(len(q)))[1]

    def bias_forces(self, q, qd) -> np.ndarray:
        """Return h(q, qd) (n,) [N*m]."""
        return self.evaluate(q, qd)[1]


class ArmSimulator:
    """
    Simulated arm + gripper (+ scene) with per-joint PID servos on MuJoCo (module docstring).

    :param model: a RobotModel (joint_names, limits, sleep, urdf_xml, gripper)
    :param config: SimConfig; gains: {joint: PidGains} (defaults per joint type)
    :param scene: a :class:`px100_control.sim.scene.Scene` of objects, or None (no objects)
    """

    def __init__(self, model, config: SimConfig = SimConfig(),
                 gains: Optional[Mapping[str, PidGains]] = None, scene=None):
        self.model = model
        self.config = config
        self.scene = scene
        self.names: Tuple[str, ...] = tuple(model.joint_names)
        self.n = len(self.names)
        overrides = dict(model.extra.get('dynamics', {}) or {}) if model.extra else {}
        overrides = {k: float(v) for k, v in overrides.items() if k in ServoSpec.__annotations__
                     and k != 'model'}
        overrides.update(config.servo_overrides)
        self.servos = [servo_for_joint(t, float(e), overrides)
                       for t, e in zip(model.joint_types, model.effort_limits)]
        if scene is not None:
            check_reach(scene, model)
        self.built = build_model(model, scene, 1.0 / config.control_rate)
        self.mj_model = m = self.built.model
        self._dt = float(m.opt.timestep)
        m.opt.gravity[2] = -float(config.gravity)
        m.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
        self.mj_data = mujoco.MjData(m)
        self.dynamics = PlantDynamics(self)
        b = self.built
        self._arm_dof = list(b.arm_dof)
        self._arm_qpos = list(b.arm_qpos)
        n = self.n
        # the arm joints come first in MuJoCo's tree order: plain slices are the fast path
        self._contiguous = (self._arm_qpos == list(range(n)) and self._arm_dof == list(range(n)))
        jd = _urdf_joint_dynamics(model.urdf_xml)
        self._damping = [jd.get(nm, (config.default_damping, 0.0))[0] for nm in self.names]
        self._friction = [jd.get(nm, (0.0, config.default_friction))[1] for nm in self.names]
        m.dof_armature[self._arm_dof] = [s.armature for s in self.servos]
        m.dof_frictionloss[self._arm_dof] = self._friction
        self.lower = [float(x) for x in model.lower]
        self.upper = [float(x) for x in model.upper]
        self.vel_limit = [min(float(v), s.velocity_limit) if math.isfinite(v) and v > 0
                          else s.velocity_limit
                          for v, s in zip(model.velocity_limits, self.servos)]
        self._vlim_list = list(self.vel_limit)
        gains = dict(gains or {})
        self.pids = [Pid(gains.get(nm, default_gains(t, s.stall_torque)))
                     for nm, t, s in zip(self.names, model.joint_types, self.servos)]
        self.velocity_pids = [Pid(_scaled(DEFAULT_VELOCITY_GAINS, s.stall_torque / 1.4))
                              for s in self.servos]
        self.modes: Dict[str, str] = {}
        self._mode_list = ['position'] * self.n
        self._all_position = True           # every arm joint in position mode (step's fast path)
        self._servo_consts = [(s.stall_torque, s.pwm_limit, s.back_emf_damping, s.max_torque)
                              for s in self.servos]
        # gripper
        gripper_spec = model.gripper
        self.gripper_name = gripper_spec.joint if gripper_spec is not None else None
        self.finger_names = tuple(gripper_spec.fingers) if gripper_spec is not None else ()
        self.linkage = None
        if gripper_spec is not None:
            self.linkage = GripperLinkage(gripper_spec.horn_radius, gripper_spec.arm_length,
                                          gripper_spec.finger_lower, gripper_spec.finger_upper)
            self.gripper_servo = servo_for_joint('revolute', None, overrides)
            g_d, g_f = jd.get(self.gripper_name, (config.default_damping,
                                                  config.default_friction))
            self.gripper_damping, self.gripper_friction = g_d, g_f
            self.gripper_inertia = _horn_inertia(model.urdf_xml, self.gripper_name)
            self.gripper_pid = Pid(gains.get(self.gripper_name, default_gains('gripper')))
            self.gripper_velocity_pid = Pid(DEFAULT_VELOCITY_GAINS)
            self.gripper_lower = self.linkage.angle_lower
            self.gripper_upper = self.linkage.angle_upper
            self._fq, self._fd = b.finger_qpos, b.finger_dof
            self._finger_range = (m.jnt_range[m.dof_jntid[self._fd[0]]].copy(),
                                  m.jnt_range[m.dof_jntid[self._fd[1]]].copy())
            # step constants: stall [N*m], PWM limit, back-EMF damping [N*m*s/rad]
            servo = self.gripper_servo
            self._g_servo = (servo.stall_torque, servo.pwm_limit, servo.back_emf_damping)
            self._g_velocity_limit = servo.velocity_limit
            self._finger_max = self.linkage.horn_radius + self.linkage.arm_length - 1e-9
            self._finger_views = (m.dof_armature, m.dof_damping, m.dof_frictionloss)
            self._g_reflected = None     # the finger slides' armature, damping, friction
        self._qpos, self._qvel = self.mj_data.qpos, self.mj_data.qvel
        self._qfrc = self.mj_data.qfrc_applied
        self._q_view, self._qd_view = self._qpos[:n], self._qvel[:n]   # (contiguous arm)
        if gripper_spec is not None:
            d0 = self.linkage.finger_position(0.0)
            self._qpos[self._fq[0]], self._qpos[self._fq[1]] = d0, -d0
            self._gripper_force(self.dt, False)          # the fingers' reflected armature
        # constraint regularisation (invweight0) computed with the armatures in place
        mujoco.mj_setConst(m, self.mj_data)
        self._object_adr = [(name, b.object_qpos[name], b.object_dof[name])
                            for name in b.object_qpos]
        self._initial = {o.name: (list(o.position), _wxyz(o.quaternion_xyzw))
                         for o in (scene.objects if scene is not None else ())}
        self._pads = set(b.pad_geoms)
        self._static_poses = {body.name: (tuple(body.position), tuple(body.quaternion_xyzw))
                              for body in (scene.statics if scene is not None else ())}
        self._geom_object = {}
        self._static_geoms = set()
        for name, bid in b.bodies.items():
            first = int(m.body_geomadr[bid])
            for g in range(first, first + int(m.body_geomnum[bid])):
                if scene.body(name).kind == 'object':
                    self._geom_object[g] = name
                else:
                    self._static_geoms.add(g)
        self.object_width = 0.0
        self._object_half = None
        self.time = 0.0
        self.torque_enabled = True
        #: torque per arm joint (False: that servo coasts) and of the gripper
        self.joint_torque = [True] * self.n
        self.gripper_torque = True
        self.set_object_width(config.object_width)
        self.reset()

    # --- time step -------------------------------------------------------------------------------
    @property
    def dt(self) -> float:
        """Return the control and physics period [s]."""
        return float(self.mj_model.opt.timestep)

    @dt.setter
    def dt(self, value: float) -> None:
        self.mj_model.opt.timestep = float(value)
        self._dt = float(self.mj_model.opt.timestep)

    # --- state -----------------------------------------------------------------------------------
    @property
    def q(self) -> List[float]:
        """Return the measured arm joint positions [rad or m] (a new list)."""
        if self._contiguous:
            return self._qpos[:self.n].tolist()
        return self._qpos[self._arm_qpos].tolist()

    @q.setter
    def q(self, values) -> None:
        self._qpos[self._arm_qpos] = [float(v) for v in values]

    @property
    def qd(self) -> List[float]:
        """Return the measured arm joint speeds [rad/s or m/s] (a new list)."""
        if self._contiguous:
            return self._qvel[:self.n].tolist()
        return self._qvel[self._arm_dof].tolist()

    @qd.setter
    def qd(self, values) -> None:
        self._qvel[self._arm_dof] = [float(v) for v in values]

    @property
    def g_theta(self) -> float:
        """Return the gripper (horn) angle [rad] from the finger position."""
        return self.linkage.angle_from_finger(float(self._qpos[self._fq[0]]))

    @property
    def g_omega(self) -> float:
        """Return the gripper horn speed [rad/s]."""
        theta = self.g_theta
        return float(self._qvel[self._fd[0]]) / self.linkage.finger_rate(theta)

    # --- joint losses (URDF <dynamics>) ---------------------------------------------------------
    @property
    def damping(self) -> List[float]:
        """Return the viscous damping per arm joint [N*m*s/rad] (back-EMF excluded)."""
        return list(self._damping)

    @damping.setter
    def damping(self, values) -> None:
        self._damping = [float(v) for v in values]
        self._update_damping()

    @property
    def friction(self) -> List[float]:
        """Return the Coulomb friction per arm joint [N*m]."""
        return list(self._friction)

    @friction.setter
    def friction(self, values) -> None:
        self._friction = [float(v) for v in values]
        self.mj_model.dof_frictionloss[self._arm_dof] = self._friction

    def _update_damping(self) -> None:
        on = getattr(self, 'joint_torque', None) or [self.torque_enabled] * self.n
        self._back_emf = [s.back_emf_damping if t and self.modes.get(nm) != 'torque' else 0.0
                          for nm, s, t in zip(self.names, self.servos, on)]
        self.mj_model.dof_damping[self._arm_dof] = [d + b for d, b in
                                                    zip(self._damping, self._back_emf)]

    # --- commands ------------------------------------------------------------------------------
    @property
    def command_joints(self) -> Tuple[str, ...]:
        """Return the joints that accept setpoints: the arm joints, then the gripper."""
        return self.names + ((self.gripper_name,) if self.gripper_name else ())

    def mode(self, joint: str) -> str:
        """Return the control mode of a joint (the gripper's default 'position' takes effort)."""
        if joint not in self.command_joints:
            raise UnknownJointError(joint, self.command_joints)
        return self.modes.get(joint, 'position')

    def set_mode(self, joint: str, mode: str) -> None:
        """
        Put one joint (arm joint or gripper) in a control mode (see :data:`MODES`).

        The joint then holds: position mode at its present position, velocity mode at 0 rad/s,
        torque and duty modes with 0 output (a joint under gravity then falls, as a Dynamixel
        does at goal current or PWM 0). Commands of another kind are refused from then on.
        :raises UnknownJointError: no such joint; InvalidInputError: unknown mode
        """
        if joint not in self.command_joints:
            raise UnknownJointError(joint, self.command_joints)
        if mode not in MODES:
            raise InvalidInputError(f"unknown control mode {mode!r} for '{joint}' (modes: "
                                    f"{', '.join(MODES)})")
        self.modes[joint] = mode
        if joint == self.gripper_name:
            theta = self.g_theta
            self.g_mode = 'effort' if mode in ('torque', 'duty') else mode
            self.g_ref, self.g_ref_vel, self.g_command = theta, 0.0, 0.0
            self.gripper_pid.reset()
            self.gripper_velocity_pid.reset()
            return
        i = self.names.index(joint)
        self._mode_list[i] = mode
        self._all_position = all(m == 'position' for m in self._mode_list)
        self.q_ref[i] = self.q[i]
        self.qd_ref[i] = 0.0
        self.ff_until[i] = -math.inf
        self.u_cmd[i] = 0.0
        self.pids[i].reset()
        self.velocity_pids[i].reset()
        self._update_damping()

    def parse(self, names, position=(), velocity=(), effort=()) -> SetpointCommand:
        """Return the SetpointCommand of a JointState-like setpoint under the joints' modes."""
        return parse_setpoints(names, position, velocity, effort, self.command_joints,
                               self.gripper_name, self.modes)

    def reset(self) -> None:
        """
        Go back to the sleep pose at rest, torque on, setpoints = sleep; objects to their start.

        The scene objects return to their initial poses at rest; control modes are kept.

        The integrators start holding the arm's weight there (as if the servos had been holding
        the pose, or the arm rests in its cradle as the real PX100 does at sleep), so the arm
        starts in equilibrium instead of sagging; P-only gains have no integrator to preload.
        """
        mujoco.mj_resetData(self.mj_model, self.mj_data)
        self.torque_enabled = True
        self.joint_torque = [True] * self.n
        self.gripper_torque = True
        if self.gripper_name:
            d0 = self.linkage.finger_position(0.0)
            self._qpos[self._fq[0]], self._qpos[self._fq[1]] = d0, -d0
            self.g_effort = 0.0
            self.g_mode = 'effort'
            self.g_command = 0.0
            self.g_ref = 0.0
            self.g_ref_vel = 0.0
            self.gripper_pid.reset()
            self.gripper_velocity_pid.reset()
            self._object_engaged = False
            self._set_finger_stop(None)
        self._put_objects()
        self.hold(self.model.sleep)
        self._update_damping()

    def reset_scene(self) -> None:
        """Put every scene object back at its initial pose, at rest (the arm is untouched)."""
        self._put_objects()
        mujoco.mj_forward(self.mj_model, self.mj_data)

    def _put_objects(self) -> None:
        for name, qadr, dadr in self._object_adr:
            pos, quat = self._initial[name]
            self._qpos[qadr:qadr + 7] = pos + quat
            self._qvel[dadr:dadr + 6] = 0.0

    def hold(self, q) -> None:
        """
        Put the arm at rest at q (arm joints), holding it there: setpoints = q.

        Integrators are preloaded with the gravity torque at q (see :meth:`reset`).
        :raises JointLimitError: q outside the limits; InvalidInputError: wrong size, NaN
        """
        q = [float(x) for x in self.model.check_limits(q, LIMIT_TOLERANCE)]
        self.q = q
        self.qd = [0.0] * self.n
        self.q_ref = list(q)
        self.qd_ref = [0.0] * self.n
        self.ff_until = [-math.inf] * self.n
        self.u_cmd = [0.0] * self.n
        self._qfrc[:] = 0.0
        mujoco.mj_forward(self.mj_model, self.mj_data)
        gravity = self.mj_data.qfrc_bias[self._arm_dof].tolist()
        for pid, vpid, g in zip(self.pids, self.velocity_pids, gravity):
            pid.reset()
            pid.preload(g)
            vpid.reset()
            vpid.preload(g)
        self.effort = [float(g) if pid.gains.i > 0 else 0.0
                       for pid, g in zip(self.pids, gravity)]

    def set_torque_enabled(self, enabled: bool, joints: Optional[Sequence[str]] = None) -> None:
        """
        Switch servos' torque on or off: all of them, or only ``joints`` (arm joints, gripper).

        Torque on (as the DYNAMIXEL does) makes a joint hold where it is now: setpoint =
        present position, integrators cleared; the gripper effort is zeroed.
        :raises UnknownJointError: a name that is not an arm joint or the gripper
        """
        enabled = bool(enabled)
        names = list(self.command_joints) if joints is None else [str(j) for j in joints]
        for name in names:
            if name not in self.command_joints:
                raise UnknownJointError(name, self.command_joints)
        q = self.q
        for name in names:
            if name == self.gripper_name:
                if enabled and not self.gripper_torque:
                    self.g_ref, self.g_ref_vel, self.g_command = self.g_theta, 0.0, 0.0
                    self.gripper_pid.reset()
                self.gripper_torque = enabled
                continue
            i = self.names.index(name)
            if enabled and not self.joint_torque[i]:
                self.q_ref[i] = q[i]
                self.qd_ref[i] = 0.0
                self.pids[i].reset()
                self.velocity_pids[i].reset()
            self.joint_torque[i] = enabled
        self.torque_enabled = all(self.joint_torque) and (
            self.gripper_torque or not self.gripper_name)
        self._update_damping()

    def torque_states(self) -> Dict[str, bool]:
        """Return {joint: torque on} for the arm joints and the gripper."""
        out = dict(zip(self.names, self.joint_torque))
        if self.gripper_name:
            out[self.gripper_name] = self.gripper_torque
        return out

    def set_gains(self, joint: str, gains: PidGains) -> None:
        """Use new PID gains on one joint (arm joint or gripper)."""
        if joint == self.gripper_name:
            self.gripper_pid.set_gains(gains)
            return
        if joint not in self.names:
            raise UnknownJointError(joint, self.command_joints)
        self.pids[self.names.index(joint)].set_gains(gains)

    def gains(self, joint: str) -> PidGains:
        """Return a joint's PID gains."""
        if joint == self.gripper_name:
            return self.gripper_pid.gains
        if joint not in self.names:
            raise UnknownJointError(joint, self.command_joints)
        return self.pids[self.names.index(joint)].gains

    def set_object_width(self, width: float) -> None:
        """
        Stop the closing fingers at ``width / 2`` [m] wherever the arm is (0 removes the stop).

        The driver's ``object_width`` parameter (docs/ros_interfaces.md): a way to check the
        gripper's blocked behaviour (the servo keeps squeezing) without a scene. It is not an
        object: nothing is carried and :meth:`held_object` does not report it; scene objects
        are grasped by contact only.
        """
        if self.linkage is None:
            if width:
                raise InvalidInputError('this robot has no gripper to hold an object')
            return
        self.object_width = self.linkage.check_object_width(float(width))
        half = 0.5 * self.object_width
        self._object_half = half if self.object_width > 0.0 and \
            half > self.linkage.finger_lower else None
        self._object_engaged = False
        self._set_finger_stop(None)

    def _set_finger_stop(self, half: Optional[float]) -> None:
        m = self.mj_model
        left, right = self._finger_range
        jl, jr = m.dof_jntid[self._fd[0]], m.dof_jntid[self._fd[1]]
        m.jnt_range[jl] = left if half is None else (half, left[1])
        m.jnt_range[jr] = right if half is None else (right[0], -half)

    def check(self, cmd: SetpointCommand) -> None:
        """
        Raise if a parsed command violates the joints' modes or limits.

        :raises JointLimitError: position outside the URDF limits (gripper: finger limits)
        :raises InvalidInputError: a field that does not match the joint's mode; velocity above
            the joint's limit; torque above stall; duty outside [-pwm_limit, pwm_limit]
        """
        tol = LIMIT_TOLERANCE
        gripper = self.gripper_name
        if cmd.positions:
            check_modes(cmd.positions, 'position', gripper, self.modes)
        elif cmd.velocities:
            check_modes(cmd.velocities, 'velocity', gripper, self.modes)
        if cmd.efforts:
            check_modes(cmd.efforts, 'effort', gripper, self.modes)
        for name, value in cmd.positions.items():
            if name == gripper:
                lo, hi = self.gripper_lower, self.gripper_upper
            else:
                i = self.names.index(name)
                lo, hi = self.lower[i], self.upper[i]
            if value < lo - tol or value > hi + tol:
                raise JointLimitError(name, value, lo, hi)
        for name, value in cmd.velocities.items():
            limit = (self.gripper_servo.velocity_limit if name == gripper
                     else self.vel_limit[self.names.index(name)])
            if abs(value) > limit * (1.0 + 1e-9) + 1e-12:
                raise InvalidInputError(f"velocity of '{name}' = {value:.6g} exceeds its "
                                        f'limit {limit:.6g}')
        for name, value in cmd.efforts.items():
            servo = self.gripper_servo if name == gripper else \
                self.servos[self.names.index(name)]
            if self.modes.get(name) == 'duty':
                if abs(value) > servo.pwm_limit + 1e-12:
                    raise InvalidInputError(f"duty of '{name}' = {value:.6g} is outside "
                                            f'[-{servo.pwm_limit:g}, {servo.pwm_limit:g}]')
            elif abs(value) > servo.max_torque + 1e-12:
                raise InvalidInputError(f"effort of '{name}' = {value:.6g} N*m exceeds the "
                                        f'servo maximum {servo.max_torque:.6g} N*m')

    def apply(self, cmd: SetpointCommand) -> None:
        """Check a command against the modes and limits; only if all of it is valid, hold it."""
        self.check(cmd)
        for name, value in cmd.positions.items():
            if name == self.gripper_name:
                self.g_mode = 'position'
                self.g_ref = min(max(value, self.gripper_lower), self.gripper_upper)
                self.g_ref_vel = cmd.velocities.get(name, 0.0)
                continue
            i = self.names.index(name)
            self.q_ref[i] = min(max(value, self.lower[i]), self.upper[i])
            self.qd_ref[i] = cmd.velocities.get(name, 0.0)
            self.ff_until[i] = self.time + self.config.ff_timeout
        if not cmd.positions:
            for name, value in cmd.velocities.items():
                if name == self.gripper_name:
                    self.g_ref_vel = value
                else:
                    self.qd_ref[self.names.index(name)] = value
        for name, value in cmd.efforts.items():
            if name == self.gripper_name:
                self.g_mode = 'effort'
                self.g_command = value
            else:
                self.u_cmd[self.names.index(name)] = value

    def set_references(self, refs: Mapping[str, Tuple[float, float]]) -> None:
        """
        Hold position references {joint: (q, qd)} [rad, rad/s], qd as feed-forward.

        Clamped to the limits and unchecked otherwise: the per-step path of a profile whose
        command was checked when it was given (joints in position mode; the gripper goes to
        position).
        """
        for name, (q, qd) in refs.items():
            if name == self.gripper_name:
                self.g_mode = 'position'
                self.g_ref = min(max(q, self.gripper_lower), self.gripper_upper)
                self.g_ref_vel = qd
                continue
            i = self.names.index(name)
            self.q_ref[i] = min(max(q, self.lower[i]), self.upper[i])
            self.qd_ref[i] = qd
            self.ff_until[i] = self.time + self.config.ff_timeout

    def command(self, names, position=(), velocity=(), effort=()) -> SetpointCommand:
        """Parse, check and apply a JointState-like setpoint; return it (raises on bad input)."""
        cmd = self.parse(names, position, velocity, effort)
        self.apply(cmd)
        return cmd

    # --- physics -------------------------------------------------------------------------------
    def step(self) -> None:
        """
        Advance the simulation by one control period dt.

        The hot loop of the simulator (the driver runs it 1,000 times per simulated second):
        plain floats and lists, model arrays reached through views cached at construction, and
        numpy only where MuJoCo needs it. test/sim/test_sim_step_identity.py checks it
        bit for bit against the plain formulation (test/sim/reference_step.py).
        """
        dt = self._dt
        n = self.n
        torque = self.joint_torque
        on = any(torque)
        qvel = self._qvel
        if self._contiguous:
            q = self._q_view.tolist()
            qd = self._qd_view.tolist()
        else:
            q, qd = self.q, self.qd
        t = self.time
        # the usual case, every arm servo on in position mode: one loop without mode checks
        every = on and self._all_position and all(torque)
        if every:
            drive = []
            for pid, qr, qdr, fu, qi, qdi, c in zip(self.pids, self.q_ref, self.qd_ref,
                                                    self.ff_until, q, qd, self._servo_consts):
                v_ref = qdr if t < fu else 0.0
                stall, lim = c[0], c[1]
                duty = pid.step(qr - qi, dt, v_ref - qdi, v_ref) / stall
                drive.append(stall * (lim if duty > lim else (-lim if duty < -lim else duty)))
        elif on:
            drive = [0.0] * n
            pids, q_ref, qd_ref, ff_until = self.pids, self.q_ref, self.qd_ref, self.ff_until
            consts = self._servo_consts
            for i, mode in enumerate(self._mode_list):
                if not torque[i]:
                    continue  # this servo coasts
                stall, lim, back, top = consts[i]
                if mode == 'position':
                    v_ref = qd_ref[i] if t < ff_until[i] else 0.0
                    u = pids[i].step(q_ref[i] - q[i], dt, v_ref - qd[i], v_ref)
                elif mode == 'velocity':
                    u = self.velocity_pids[i].step(qd_ref[i] - qd[i], dt, 0.0, qd_ref[i])
                elif mode == 'torque':
                    # current control: the commanded torque within the supply's reach
                    b = back * qd[i]
                    u = self.u_cmd[i]
                    drive[i] = min(max(u, -top - b), top - b)
                    continue
                else:
                    u = self.u_cmd[i] * stall
                duty = u / stall
                duty = lim if duty > lim else (-lim if duty < -lim else duty)
                drive[i] = stall * duty
        else:
            drive = [0.0] * n
        qfrc = self._qfrc
        for dof, x in zip(self._arm_dof, drive):    # (faster than a slice from a list)
            qfrc[dof] = x
        if self.gripper_name:
            self._gripper_force(dt, self.gripper_torque)
        mujoco.mj_step(self.mj_model, self.mj_data)
        if every:
            # speeds held within the servos' Velocity_Limit; effort = drive - back-EMF torque
            vel = self._qd_view.tolist() if self._contiguous else self.qd
            effort = []
            for dof, x, lim, d, b in zip(self._arm_dof, vel, self._vlim_list, drive,
                                         self._back_emf):
                if x > lim:
                    x = qvel[dof] = lim
                elif x < -lim:
                    x = qvel[dof] = -lim
                effort.append(d - b * x)
            self.effort = effort
        elif on:
            # speeds held within the servos' Velocity_Limit (while torque is on)
            vel = self._qd_view.tolist() if self._contiguous else self.qd
            vlim, dofs = self._vlim_list, self._arm_dof
            for i in range(n):
                if torque[i]:
                    x, lim = vel[i], vlim[i]
                    if x > lim:
                        vel[i] = qvel[dofs[i]] = lim
                    elif x < -lim:
                        vel[i] = qvel[dofs[i]] = -lim
            self.effort = [x - b * v if tq else 0.0
                           for x, b, v, tq in zip(drive, self._back_emf, vel, torque)]
        else:
            self.effort = [0.0] * n
        if self.gripper_name:
            self._after_gripper_step(self.gripper_torque)
        self.time = t + dt

    def _gripper_force(self, dt: float, on: bool) -> None:
        link = self.linkage
        fq, fd = self._fq, self._fd
        finger = float(self._qpos[fq[0]])
        theta = link.angle_from_finger(min(max(finger, 1e-6), self._finger_max))
        rate = link.finger_rate(theta)
        omega = float(self._qvel[fd[0]]) / rate
        drive = 0.0
        b = self.gripper_damping
        if on:
            stall, lim, back = self._g_servo
            if self.g_mode == 'effort':
                duty_mode = self.modes.get(self.gripper_name) == 'duty'
                u = self.g_command * stall if duty_mode else self.g_command
            elif self.g_mode == 'velocity':
                u = self.gripper_velocity_pid.step(self.g_ref_vel - omega, dt, 0.0,
                                                   self.g_ref_vel)
            else:
                u = self.gripper_pid.step(self.g_ref - theta, dt, self.g_ref_vel - omega,
                                          self.g_ref_vel)
            duty = u / stall
            drive = stall * (lim if duty > lim else (-lim if duty < -lim else duty))
            b += back
        # horn torque, inertia, damping and friction reflected onto each finger slide
        k = 0.5 / rate
        force = drive * k
        qfrc = self._qfrc
        qfrc[fd[0]] = force
        qfrc[fd[1]] = -force
        reflected = ((self.gripper_servo.armature + self.gripper_inertia) * k / rate,
                     b * k / rate, self.gripper_friction * k)
        if reflected != self._g_reflected:     # unchanged while the fingers stand still
            self._g_reflected = reflected
            arm, damp, fric = reflected
            armature, damping, friction = self._finger_views
            for dof in fd:
                armature[dof] = arm
                damping[dof] = damp
                friction[dof] = fric
        self.g_effort = drive
        self._g_rate = rate

    def _after_gripper_step(self, on: bool) -> None:
        fd = self._fd
        rate = self._g_rate
        if on:
            qvel = self._qvel
            vl = self._g_velocity_limit * rate
            for dof in fd:
                v = float(qvel[dof])
                if v > vl:
                    qvel[dof] = vl
                elif v < -vl:
                    qvel[dof] = -vl
            self.g_effort -= self._g_servo[2] * float(qvel[fd[0]]) / rate
        else:
            self.g_effort = 0.0
        if self._object_half is not None and not self._object_engaged and \
                float(self._qpos[self._fq[0]]) >= self._object_half - 1e-9:
            self._object_engaged = True
            self._set_finger_stop(self._object_half)

    def advance(self, steps: int) -> None:
        """Run ``steps`` control periods."""
        for _ in range(int(steps)):
            self.step()

    # --- outputs -------------------------------------------------------------------------------
    def joint_state(self) -> JointStateSample:
        """Return the measured state in Interbotix order (arm, gripper, left, right finger)."""
        names = self.names
        pos, vel, eff = self.q, self.qd, list(self.effort)
        if self.gripper_name:
            d = float(self._qpos[self._fq[0]])
            theta = self.linkage.angle_from_finger(d)
            rate = self.linkage.finger_rate(theta)
            ds = float(self._qvel[self._fd[0]])
            force = self.g_effort / (2.0 * rate) if rate > 1e-9 else 0.0
            names = names + (self.gripper_name,) + self.finger_names
            pos += [theta, d, -d]
            vel += [ds / rate, ds, -ds]
            eff += [self.g_effort, force, -force]
        return JointStateSample(names, tuple(pos), tuple(vel), tuple(eff))

    @property
    def finger_position(self) -> float:
        """Return the left finger position [m] (nan without a gripper)."""
        return float(self._qpos[self._fq[0]]) if self.linkage else math.nan

    def ee_pose(self) -> np.ndarray:
        """Return the (4, 4) end-effector pose of the measured arm joints in the base frame."""
        return self.model.fk(self.q)

    def ee_pose_quaternion(self) -> Tuple[Tuple[float, ...], Tuple[float, ...]]:
        """
        Return the end-effector pose as (position (x, y, z) [m], quaternion (x, y, z, w)).

        Same pose as :meth:`ee_pose` (base frame), in plain floats for publishing at rate.
        """
        T = self.ee_pose()
        return tuple(T[:3, 3].tolist()), _quaternion_xyzw(T[:3, :3].tolist())

    def positions(self) -> np.ndarray:
        """Return the measured arm joint values as an (n,) array [rad or m]."""
        return np.array(self.q)

    def velocities(self) -> np.ndarray:
        """Return the measured arm joint speeds as an (n,) array [rad/s or m/s]."""
        return np.array(self.qd)

    def energy(self) -> float:
        """Return the kinetic + potential energy of the whole MuJoCo model [J] (z = 0 datum)."""
        mujoco.mj_forward(self.mj_model, self.mj_data)
        return float(self.mj_data.energy[0] + self.mj_data.energy[1])

    # --- scene -----------------------------------------------------------------------------------
    def objects(self) -> List[ObjectInfo]:
        """Return the bodies of the scene (table, fixtures, objects) in file order."""
        if self.scene is None:
            return []
        return [ObjectInfo(b.name, b.kind, b.shape, tuple(b.size), tuple(b.rgba), b.mass)
                for b in self.scene.bodies]

    def object_poses(self) -> Dict[str, Tuple[Tuple[float, float, float],
                                              Tuple[float, float, float, float]]]:
        """Return {body: (position xyz [m], quaternion xyzw)} in the robot base frame."""
        out = {}
        qpos = self._qpos
        for name, qadr, _ in self._object_adr:
            x, y, z, w, a, b, c = qpos[qadr:qadr + 7].tolist()
            norm = math.sqrt(w * w + a * a + b * b + c * c)
            out[name] = ((x, y, z), (a / norm, b / norm, c / norm, w / norm))
        out.update(self._static_poses)
        return out

    def contacts(self) -> Dict[str, set]:
        """
        Return {object: names of what touches it ('left_pad', 'right_pad', bodies)}.

        The contacts MuJoCo found last (at the start of the last step, or by
        :meth:`held_object`).
        """
        ncon = int(self.mj_data.ncon)
        if not ncon:
            return {}
        out: Dict[str, set] = {}
        pads = self.built.pad_geoms
        labels = {pads[0]: 'left_pad', pads[1]: 'right_pad'} if len(pads) == 2 else {}
        geom_object, statics = self._geom_object, self._static_geoms
        for g1, g2 in self.mj_data.contact.geom[:ncon].tolist():
            for a, b in ((g1, g2), (g2, g1)):
                obj = geom_object.get(a)
                if obj is None:
                    continue
                if b in labels:
                    other = labels[b]
                elif b in geom_object:
                    other = geom_object[b]
                elif b in statics:
                    other = 'static'
                else:
                    other = 'robot'
                out.setdefault(obj, set()).add(other)
        return out

    def held_object(self) -> Optional[str]:
        """
        Return the object touched by both finger pads and off its support, or None.

        Contacts at the present state: kinematics and collision detection only (what the
        next step computes first; the trajectory does not depend on this query).
        """
        return next((name for name, lifted in self.gripped_objects().items() if lifted), None)

    def gripped_objects(self) -> Dict[str, bool]:
        """
        Return {object: off its support} for every object both finger pads touch, by name.

        ``False``: it also touches a static body (squeezed on the table, or set down and not
        yet released). Contacts at the present state, as :meth:`held_object`.
        """
        if not self._geom_object:
            return {}
        mujoco.mj_kinematics(self.mj_model, self.mj_data)
        mujoco.mj_collision(self.mj_model, self.mj_data)
        return {name: 'static' not in touching
                for name, touching in sorted(self.contacts().items())
                if {'left_pad', 'right_pad'} <= touching}


def _wxyz(xyzw) -> List[float]:
    x, y, z, w = xyzw
    return [w, x, y, z]


def _scaled(gains: PidGains, k: float) -> PidGains:
    if k == 1.0:
        return gains
    return PidGains(p=gains.p * k, i=gains.i * k, d=gains.d * k, i_clamp=gains.i_clamp * k,
                    u_clamp=gains.u_clamp * k, ff_velocity=gains.ff_velocity * k)


def _horn_inertia(urdf_xml: Optional[str], gripper_joint: str) -> float:
    """Return the inertia of the gripper horn link about the gripper axis [kg*m^2]."""
    default = 1.2e-6
    if not urdf_xml:
        return default
    urdf = load_urdf_tree(urdf_xml)
    joints = {j.name: j for j in urdf.robot.joints}
    links = {link.name: link for link in urdf.robot.links}
    joint = joints.get(gripper_joint)
    if joint is None or links.get(joint.child) is None or links[joint.child].inertial is None:
        return default
    inertial = links[joint.child].inertial
    axis = np.array(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), float)
    axis /= np.linalg.norm(axis)
    To = np.eye(4) if inertial.origin is None else np.array(inertial.origin)
    I_c = np.zeros((3, 3)) if inertial.inertia is None else np.array(inertial.inertia, float)
    R, c = To[:3, :3], To[:3, 3]
    mass = float(inertial.mass or 0.0)
    r_perp = c - (c @ axis) * axis
    return float(axis @ R @ I_c @ R.T @ axis + mass * (r_perp @ r_perp))
