"""
Reference simulator without MuJoCo: hand-written dynamics (oracle_dynamics.py), PID, servo.

Kept outside the package for benchmarks/bench_physics.py (its exact step, dynamics_divider 1,
is timed side by side with the MuJoCo plant) and for comparisons in tests.

:class:`ArmSimulator` holds the state (q, qd per arm joint, the gripper angle) and advances it by
a fixed control period ``dt = 1 / control_rate`` per :meth:`ArmSimulator.step`; it owns no clock
(time is what you step). Each step, for every joint:

1. PID (:mod:`.pid`) on the held setpoint -> torque command u [N*m]; the gripper may instead be
   in effort mode (u = the commanded effort);
2. servo (:mod:`.actuator`): u -> PWM duty (saturated at the stall torque), drive torque
   ``stall * duty``, back-EMF damping while torque is on; torque off -> no drive, the motor coasts;
3. plant: ``(M(q) + armature) qdd = drive - h(q, qd) - damping qd - Coulomb friction`` with M and
   h from :mod:`.dynamics` (URDF inertials), integrated by semi-implicit Euler with the viscous
   terms (URDF damping + back-EMF) implicit, so stiff servo damping stays stable at 1 kHz;
   Coulomb friction (URDF ``friction``, N*m) is a velocity-level impulse that can stop the joint
   (stiction), joint by joint on the diagonal of the iteration matrix;
4. limits: while torque is on the speed is held within the joint's velocity limit (the servo's
   Velocity_Limit); the joint position stops inelastically at its URDF limits (hard stops).

``dynamics_divider`` k re-evaluates M(q) and h(q, qd) every k-th step; the control law, servo,
friction, limits and integration always run every step. The default 4 (rigid-body terms at
250 Hz, far above the arm's few-Hz mechanical bandwidth) halves the cost of a step; against
k = 1 (exact) it moves a saturated 0.5 rad shoulder step by at most 0.4 mrad and a 2 s move by
less than 0.05 mrad (see test_sim_simulator.py). Set 1 for the exact integration. The gripper is
a separate one-degree-of-freedom plant (:mod:`.gripper`); its links ride on the wrist body of
the arm dynamics, frozen at gripper angle 0.

Setpoints are validated before anything is applied (:func:`parse_setpoints` and
:meth:`ArmSimulator.apply`): unknown or duplicate names, NaN/inf, length mismatches and
out-of-limit positions or velocities raise a :class:`~px100_control.errors.Px100Error` with the
reason, and nothing of that command is used. A velocity feed-forward expires ``ff_timeout``
seconds after its setpoint (a stalled command stream leaves the joint holding, not drifting).
Units: rad, m, s, N*m.
"""
from dataclasses import dataclass, field
import math
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
from oracle_dynamics import ChainDynamics, dynamics_for_model, GRAVITY
from px100_control.control.actuator import servo_for_joint, ServoSpec
from px100_control.control.gripper import GripperLinkage
from px100_control.control.pid import Pid, PidGains
from px100_control.errors import InvalidInputError, JointLimitError, UnknownJointError

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
    :param dynamics_divider: re-evaluate M(q), h(q, qd) every k steps (1 = exact)
    :param default_damping/default_friction: for joints whose URDF has no <dynamics>
    :param servo_overrides: ServoSpec fields to change for every joint (e.g. armature)
    :param object_width: width of an object between the fingers [m] (0 = none)
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
                    known: Sequence[str] = (), gripper: Optional[str] = None) -> SetpointCommand:
    """
    Return the SetpointCommand of a JointState-like setpoint, or raise with the reason.

    ``position`` (with optional ``velocity`` feed-forward) selects position control for the
    named joints; ``effort`` selects effort control and only the gripper has it. Give one of
    position or effort. Each array is empty or has one value per name.
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


def _cholesky(A: List[List[float]]) -> List[List[float]]:
    """Return the lower Cholesky factor L (A = L L^T) of a small SPD matrix, as lists."""
    n = len(A)
    L = [[0.0] * n for _ in range(n)]
    for i in range(n):
        Li = L[i]
        for j in range(i + 1):
            Lj = L[j]
            s = A[i][j]
            for k in range(j):
                s -= Li[k] * Lj[k]
            if i == j:
                if s <= 0.0:
                    raise np.linalg.LinAlgError('mass matrix is not positive definite')
                Li[i] = math.sqrt(s)
            else:
                Li[j] = s / Lj[j]
    return L


def _cholesky_solve(L: List[List[float]], b: List[float]) -> List[float]:
    """Return x with L L^T x = b (forward and back substitution on lists)."""
    n = len(b)
    y = [0.0] * n
    for i in range(n):
        s = b[i]
        Li = L[i]
        for k in range(i):
            s -= Li[k] * y[k]
        y[i] = s / Li[i]
    x = [0.0] * n
    for i in range(n - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, n):
            s -= L[k][i] * x[k]
        x[i] = s / L[i][i]
    return x


def _solve_spd(A: List[List[float]], b: List[float]) -> List[float]:
    """Return x with A x = b for a small symmetric positive definite A (Cholesky, lists)."""
    return _cholesky_solve(_cholesky(A), b)


def _quaternion_xyzw(R) -> Tuple[float, float, float, float]:
    """Return the unit quaternion (x, y, z, w), w >= 0, of a 3x3 rotation given as lists."""
    tr = R[0][0] + R[1][1] + R[2][2]
    if tr > 0.0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = ((R[2][1] - R[1][2]) / s, (R[0][2] - R[2][0]) / s, (R[1][0] - R[0][1]) / s, 0.25 * s)
    elif R[0][0] > R[1][1] and R[0][0] > R[2][2]:
        s = 2.0 * math.sqrt(1.0 + R[0][0] - R[1][1] - R[2][2])
        q = (0.25 * s, (R[0][1] + R[1][0]) / s, (R[0][2] + R[2][0]) / s, (R[2][1] - R[1][2]) / s)
    elif R[1][1] > R[2][2]:
        s = 2.0 * math.sqrt(1.0 + R[1][1] - R[0][0] - R[2][2])
        q = ((R[0][1] + R[1][0]) / s, 0.25 * s, (R[1][2] + R[2][1]) / s, (R[0][2] - R[2][0]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + R[2][2] - R[0][0] - R[1][1])
        q = ((R[0][2] + R[2][0]) / s, (R[1][2] + R[2][1]) / s, 0.25 * s, (R[1][0] - R[0][1]) / s)
    if q[3] < 0.0:
        q = tuple(-x for x in q)
    norm = math.sqrt(sum(x * x for x in q))
    return tuple(x / norm for x in q)


def _urdf_joint_dynamics(urdf_xml: Optional[str]) -> Dict[str, Tuple[float, float]]:
    """Return {joint: (damping, friction)} from a URDF's <dynamics> tags."""
    if not urdf_xml:
        return {}
    from px100_control.models.urdf_chain import load_urdf
    out = {}
    for j in load_urdf(urdf_xml).robot.joints:
        dyn = j.dynamics
        if dyn is not None:
            out[j.name] = (float(dyn.damping or 0.0), float(dyn.friction or 0.0))
    return out


def _gripper_inertia(urdf_xml: Optional[str], gripper_joint: str, fingers) -> Tuple[float, float]:
    """Return (horn-side inertia about the gripper axis [kg*m^2], one finger's mass [kg])."""
    default = (1.2e-6, 0.016)
    if not urdf_xml:
        return default
    from px100_control.models.urdf_chain import load_urdf
    urdf = load_urdf(urdf_xml)
    joints = {j.name: j for j in urdf.robot.joints}
    links = {link.name: link for link in urdf.robot.links}
    joint = joints.get(gripper_joint)
    if joint is None:
        return default
    J = default[0]
    link = links.get(joint.child)
    if link is not None and link.inertial is not None:
        axis = np.array(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), float)
        axis /= np.linalg.norm(axis)
        To = np.eye(4) if link.inertial.origin is None else np.array(link.inertial.origin)
        I_c = np.zeros((3, 3)) if link.inertial.inertia is None else np.array(
            link.inertial.inertia, float)
        R, c = To[:3, :3], To[:3, 3]
        m = float(link.inertial.mass or 0.0)
        r_perp = c - (c @ axis) * axis
        J = float(axis @ R @ I_c @ R.T @ axis + m * (r_perp @ r_perp))
    finger_mass = default[1]
    finger = joints.get(fingers[0]) if fingers else None
    if finger is not None and links.get(finger.child) is not None:
        inertial = links[finger.child].inertial
        if inertial is not None and inertial.mass:
            finger_mass = float(inertial.mass)
    return J, finger_mass


class ArmSimulator:
    """
    Simulated arm + gripper with per-joint PID servos (see the module docstring).

    :param model: a RobotModel (joint_names, limits, sleep, urdf_xml, gripper)
    :param config: SimConfig; gains: {joint: PidGains} (defaults per joint type)
    """

    def __init__(self, model, config: SimConfig = SimConfig(),
                 gains: Optional[Mapping[str, PidGains]] = None):
        self.model = model
        self.config = config
        self.names: Tuple[str, ...] = tuple(model.joint_names)
        self.n = len(self.names)
        self.dt = 1.0 / config.control_rate
        overrides = dict(model.extra.get('dynamics', {}) or {}) if model.extra else {}
        overrides = {k: float(v) for k, v in overrides.items() if k in ServoSpec.__annotations__
                     and k != 'model'}
        overrides.update(config.servo_overrides)
        self.servos = [servo_for_joint(t, float(e), overrides)
                       for t, e in zip(model.joint_types, model.effort_limits)]
        gripper_spec = model.gripper
        fixed = {}
        if gripper_spec is not None:
            self.linkage = GripperLinkage(gripper_spec.horn_radius, gripper_spec.arm_length,
                                          gripper_spec.finger_lower, gripper_spec.finger_upper)
            d0 = self.linkage.finger_position(0.0)
            fixed = {gripper_spec.joint: 0.0, gripper_spec.fingers[0]: d0}
        else:
            self.linkage = None
        self.dynamics: ChainDynamics = dynamics_for_model(
            model, [s.armature for s in self.servos], fixed_values=fixed)
        jd = _urdf_joint_dynamics(model.urdf_xml)
        self._damping = [jd.get(nm, (config.default_damping, 0.0))[0] for nm in self.names]
        self._friction = [jd.get(nm, (0.0, config.default_friction))[1] for nm in self.names]
        self.lower = [float(x) for x in model.lower]
        self.upper = [float(x) for x in model.upper]
        self.vel_limit = [min(float(v), s.velocity_limit) if math.isfinite(v) and v > 0
                          else s.velocity_limit
                          for v, s in zip(model.velocity_limits, self.servos)]
        gains = dict(gains or {})
        self.pids = [Pid(gains.get(nm, default_gains(t, s.stall_torque)))
                     for nm, t, s in zip(self.names, model.joint_types, self.servos)]
        # gripper
        self.gripper_name = gripper_spec.joint if gripper_spec is not None else None
        self.finger_names = tuple(gripper_spec.fingers) if gripper_spec is not None else ()
        if gripper_spec is not None:
            self.gripper_servo = servo_for_joint('revolute', None, overrides)
            g_d, g_f = jd.get(self.gripper_name, (config.default_damping,
                                                  config.default_friction))
            self.gripper_damping, self.gripper_friction = g_d, g_f
            self.gripper_inertia, self.finger_mass = _gripper_inertia(
                model.urdf_xml, self.gripper_name, self.finger_names)
            self.gripper_pid = Pid(gains.get(self.gripper_name, default_gains('gripper')))
            self.gripper_lower = self.linkage.angle_lower
            self.gripper_upper = self.linkage.angle_upper
        M = np.asarray(model.M, dtype=float)
        self._ee_home = (M[:3, :3].tolist(), M[:3, 3].tolist())
        self.object_width = 0.0
        self.set_object_width(config.object_width)
        self.time = 0.0
        self.torque_enabled = True
        self.reset()

    # --- joint losses (URDF <dynamics>) ---------------------------------------------------------
    @property
    def damping(self) -> List[float]:
        """Return the viscous damping per arm joint [N*m*s/rad]."""
        return list(self._damping)

    @damping.setter
    def damping(self, values) -> None:
        self._damping = [float(v) for v in values]
        self._factor = None

    @property
    def friction(self) -> List[float]:
        """Return the Coulomb friction per arm joint [N*m]."""
        return list(self._friction)

    @friction.setter
    def friction(self, values) -> None:
        self._friction = [float(v) for v in values]
        self._factor = None

    # --- commands ------------------------------------------------------------------------------
    @property
    def command_joints(self) -> Tuple[str, ...]:
        """Return the joints that accept setpoints: the arm joints, then the gripper."""
        return self.names + ((self.gripper_name,) if self.gripper_name else ())

    def reset(self) -> None:
        """
        Go back to the sleep pose at rest, torque on, setpoints = sleep.

        The integrators start holding the arm's weight there (as if the servos had been holding
        the pose, or the arm rests in its cradle as the real PX100 does at sleep), so the arm
        starts in equilibrium instead of sagging; P-only gains have no integrator to preload.
        """
        self.hold(self.model.sleep)
        self._step_count = 0
        self.torque_enabled = True
        if self.gripper_name:
            self.g_theta = 0.0
            self.g_omega = 0.0
            self.g_effort = 0.0
            self.g_mode = 'effort'
            self.g_command = 0.0
            self.g_ref = 0.0
            self.g_ref_vel = 0.0
            self.gripper_pid.reset()
            self._object_engaged = False
            self._update_object_engagement()

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
        gravity = self.dynamics.evaluate_lists(self.q, self.qd)[1]
        for pid, g in zip(self.pids, gravity):
            pid.reset()
            pid.preload(g)
        self.effort = [float(g) if pid.gains.i > 0 else 0.0
                       for pid, g in zip(self.pids, gravity)]
        self._M = None
        self._h = None
        self._factor = None

    def set_torque_enabled(self, enabled: bool) -> None:
        """
        Switch all servos' torque on or off.

        Torque on (as the DYNAMIXEL does) makes each joint hold where it is now: setpoints =
        present positions, integrators cleared; the gripper effort is zeroed.
        """
        enabled = bool(enabled)
        if enabled and not self.torque_enabled:
            self.q_ref = list(self.q)
            self.qd_ref = [0.0] * self.n
            for pid in self.pids:
                pid.reset()
            if self.gripper_name:
                self.g_ref, self.g_ref_vel, self.g_command = self.g_theta, 0.0, 0.0
                self.gripper_pid.reset()
        self.torque_enabled = enabled

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
        """Put an object of this width [m] between the fingers (0 removes it)."""
        if self.linkage is None:
            if width:
                raise InvalidInputError('this robot has no gripper to hold an object')
            return
        self.object_width = self.linkage.check_object_width(float(width))
        self._object_angle = None
        half = 0.5 * self.object_width
        if self.object_width > 0.0 and half > self.linkage.finger_lower:
            self._object_angle = self.linkage.angle_from_finger(half)
        if hasattr(self, 'g_theta'):
            self._update_object_engagement()

    def _update_object_engagement(self) -> None:
        # the object blocks the fingers only once they are outside it
        self._object_engaged = (self._object_angle is not None
                                and self.g_theta >= self._object_angle - 1e-9)

    def check(self, cmd: SetpointCommand) -> None:
        """
        Raise if a parsed command violates limits (position, velocity, gripper effort).

        :raises JointLimitError: position outside the URDF limits (gripper: finger limits)
        :raises InvalidInputError: velocity above the joint's limit; effort above stall
        """
        tol = LIMIT_TOLERANCE
        for name, value in cmd.positions.items():
            if name == self.gripper_name:
                lo, hi = self.gripper_lower, self.gripper_upper
            else:
                i = self.names.index(name)
                lo, hi = self.lower[i], self.upper[i]
            if value < lo - tol or value > hi + tol:
                raise JointLimitError(name, value, lo, hi)
        for name, value in cmd.velocities.items():
            limit = (self.gripper_servo.velocity_limit if name == self.gripper_name
                     else self.vel_limit[self.names.index(name)])
            if abs(value) > limit * (1.0 + 1e-9) + 1e-12:
                raise InvalidInputError(f"velocity feed-forward of '{name}' = {value:.6g} "
                                        f'exceeds its limit {limit:.6g}')
        for name, value in cmd.efforts.items():
            limit = self.gripper_servo.max_torque
            if abs(value) > limit + 1e-12:
                raise InvalidInputError(f"effort of '{name}' = {value:.6g} N*m exceeds the "
                                        f'servo maximum {limit:.6g} N*m')

    def apply(self, cmd: SetpointCommand) -> None:
        """Check a command against the limits and, only if all of it is valid, hold it."""
        self.check(cmd)
        for name, value in cmd.positions.items():
            lo_hi_clip = value
            if name == self.gripper_name:
                self.g_mode = 'position'
                self.g_ref = min(max(lo_hi_clip, self.gripper_lower), self.gripper_upper)
                self.g_ref_vel = cmd.velocities.get(name, 0.0)
                continue
            i = self.names.index(name)
            self.q_ref[i] = min(max(lo_hi_clip, self.lower[i]), self.upper[i])
            self.qd_ref[i] = cmd.velocities.get(name, 0.0)
            self.ff_until[i] = self.time + self.config.ff_timeout
        for name, value in cmd.efforts.items():
            self.g_mode = 'effort'
            self.g_command = value

    def command(self, names, position=(), velocity=(), effort=()) -> SetpointCommand:
        """Parse, check and apply a JointState-like setpoint; return it (raises on bad input)."""
        cmd = parse_setpoints(names, position, velocity, effort, self.command_joints,
                              self.gripper_name)
        self.apply(cmd)
        return cmd

    # --- physics -------------------------------------------------------------------------------
    def step(self) -> None:
        """Advance the simulation by one control period dt."""
        dt = self.dt
        n = self.n
        q, qd = self.q, self.qd
        on = self.torque_enabled
        if self._step_count % self.config.dynamics_divider == 0 or self._M is None:
            self._M, self._h = self.dynamics.evaluate_lists(q, qd)
            self._factor = None
        self._step_count += 1
        factor = self._factor
        if factor is None or factor[0] != on or factor[1] != dt:
            # iteration matrix M + dt B (B: URDF damping + back-EMF while torque is on),
            # factored once per dynamics refresh
            damp = [self._damping[i] + (self.servos[i].back_emf_damping if on else 0.0)
                    for i in range(n)]
            A = [row[:] for row in self._M]
            for i in range(n):
                A[i][i] += dt * damp[i]
            fric = [dt * self._friction[i] / A[i][i] for i in range(n)]
            factor = self._factor = (on, dt, damp, _cholesky(A), fric)
        damp, L, fric = factor[2], factor[3], factor[4]
        h = self._h
        t = self.time
        drive = [0.0] * n
        rhs = [0.0] * n
        if on:
            pids, q_ref, qd_ref, ff_until = self.pids, self.q_ref, self.qd_ref, self.ff_until
            for i in range(n):
                v_ref = qd_ref[i] if t < ff_until[i] else 0.0
                u = pids[i].step(q_ref[i] - q[i], dt, v_ref - qd[i], v_ref)
                servo = self.servos[i]
                stall, lim = servo.stall_torque, servo.pwm_limit
                duty = u / stall
                duty = lim if duty > lim else (-lim if duty < -lim else duty)
                drive[i] = d = stall * duty
                rhs[i] = d - h[i] - damp[i] * qd[i]
        else:
            for i in range(n):
                rhs[i] = -h[i] - damp[i] * qd[i]
        acc = _cholesky_solve(L, rhs)
        new_q = [0.0] * n
        effort = self.effort
        lower, upper, vel_limit, viscous = self.lower, self.upper, self.vel_limit, self._damping
        for i in range(n):
            v = qd[i] + dt * acc[i]
            # Coulomb friction: an impulse up to dt * friction, which may stop the joint
            dv = fric[i]
            v = v - dv if v > dv else (v + dv if v < -dv else 0.0)
            if on:
                vl = vel_limit[i]
                v = vl if v > vl else (-vl if v < -vl else v)
            x = q[i] + dt * v
            if x < lower[i]:
                x, v = lower[i], max(v, 0.0)
            elif x > upper[i]:
                x, v = upper[i], min(v, 0.0)
            new_q[i] = x
            qd[i] = v
            effort[i] = drive[i] - (damp[i] - viscous[i]) * v if on else 0.0
        self.q = new_q
        if self.gripper_name:
            self._step_gripper(dt, on)
        self.time = t + dt

    def _step_gripper(self, dt: float, on: bool) -> None:
        servo = self.gripper_servo
        link = self.linkage
        theta, omega = self.g_theta, self.g_omega
        rate = link.finger_rate(theta)
        J = servo.armature + self.gripper_inertia + 2.0 * self.finger_mass * rate * rate
        b = self.gripper_damping
        drive = 0.0
        if on:
            if self.g_mode == 'effort':
                u = self.g_command
            else:
                u = self.gripper_pid.step(self.g_ref - theta, dt, self.g_ref_vel - omega,
                                          self.g_ref_vel)
            drive = servo.stall_torque * servo.duty(u)
            b += servo.back_emf_damping
        Jb = J + dt * b
        v = omega + dt * (drive - b * omega) / Jb
        dv = dt * self.gripper_friction / Jb
        v = v - dv if v > dv else (v + dv if v < -dv else 0.0)
        if on:
            vl = servo.velocity_limit
            v = vl if v > vl else (-vl if v < -vl else v)
        x = theta + dt * v
        lo = self._object_angle if self._object_engaged else self.gripper_lower
        if x < lo:
            x, v = lo, max(v, 0.0)
        elif x > self.gripper_upper:
            x, v = self.gripper_upper, min(v, 0.0)
        self.g_theta, self.g_omega = x, v
        self.g_effort = drive - servo.back_emf_damping * v if on else 0.0
        if not self._object_engaged:
            self._update_object_engagement()

    def advance(self, steps: int) -> None:
        """Run ``steps`` control periods."""
        for _ in range(int(steps)):
            self.step()

    # --- outputs -------------------------------------------------------------------------------
    def joint_state(self) -> JointStateSample:
        """Return the measured state in Interbotix order (arm, gripper, left, right finger)."""
        names = self.names
        pos, vel, eff = list(self.q), list(self.qd), list(self.effort)
        if self.gripper_name:
            d = self.linkage.finger_position(self.g_theta)
            rate = self.linkage.finger_rate(self.g_theta)
            force = self.g_effort / (2.0 * rate) if rate > 1e-9 else 0.0
            ds = rate * self.g_omega
            names = names + (self.gripper_name,) + self.finger_names
            pos += [self.g_theta, d, -d]
            vel += [self.g_omega, ds, -ds]
            eff += [self.g_effort, force, -force]
        return JointStateSample(names, tuple(pos), tuple(vel), tuple(eff))

    @property
    def finger_position(self) -> float:
        """Return the left finger position [m] (nan without a gripper)."""
        return self.linkage.finger_position(self.g_theta) if self.linkage else math.nan

    def ee_pose(self) -> np.ndarray:
        """Return the (4, 4) end-effector pose of the measured arm joints in the base frame."""
        return self.model.fk(self.q)

    def ee_pose_quaternion(self) -> Tuple[Tuple[float, ...], Tuple[float, ...]]:
        """
        Return the end-effector pose as (position (x, y, z) [m], quaternion (x, y, z, w)).

        Same pose as :meth:`ee_pose` (base frame), in plain floats for publishing at rate.
        """
        R, p = self.dynamics.displacement_lists(self.q)
        M = self._ee_home
        Rm, pm = M[0], M[1]
        Rt = [[sum(R[i][k] * Rm[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
        pos = tuple(sum(R[i][k] * pm[k] for k in range(3)) + p[i] for i in range(3))
        return pos, _quaternion_xyzw(Rt)

    def positions(self) -> np.ndarray:
        """Return the measured arm joint values as an (n,) array [rad or m]."""
        return np.array(self.q)

    def velocities(self) -> np.ndarray:
        """Return the measured arm joint speeds as an (n,) array [rad/s or m/s]."""
        return np.array(self.qd)

    def energy(self) -> float:
        """Return the arm's kinetic + potential energy [J] (gripper excluded)."""
        return (self.dynamics.kinetic_energy(self.q, self.qd)
                + self.dynamics.potential_energy(self.q))
