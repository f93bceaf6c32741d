"""
Servo model: a PWM-driven DC motor behind a gearbox (DYNAMIXEL XL430-W250 by default).

The servo's controller outputs a PWM duty ``duty`` in [-pwm_limit, pwm_limit] (the XL430 PWM_Limit
register, 885 = 100 %). A voltage-driven DC motor then gives the output-shaft torque [N*m]::

    tau = stall_torque * duty - (stall_torque / no_load_speed) * omega

i.e. the linear torque-speed curve: ``stall_torque`` at zero speed and full duty, zero torque at
``no_load_speed``. The second term is the back-EMF, a viscous damping ``back_emf_damping`` that
exists whenever the bridge drives the motor (torque on); with torque off the motor coasts.
``velocity_limit`` is the servo's Velocity_Limit register (131 x 0.229 rpm = pi rad/s on the
PX100): while torque is on the joint speed is held within it. ``armature`` is the rotor inertia
reflected through the gearbox [kg*m^2]; ROBOTIS does not publish it: 0.002 kg*m^2 (about 3e-8
kg*m^2 at the rotor times 258.5^2) gives an 8.6 ms mechanical time constant, typical of small
cored DC motors, and dominates the inertia of the light PX100 wrist as on the real arm.

XL430-W250 at 11.1 V (ROBOTIS e-Manual): stall torque 1.4 N*m, no-load speed 57 rpm (6.0 rad/s),
gear ratio 258.5:1, 4096 ticks/rev. Units: N*m, rad/s (N and m/s for a linear actuator).
"""
from dataclasses import dataclass, replace
import math

from px100_control.errors import InvalidInputError


@dataclass(frozen=True)
class ServoSpec:
    """
    Electromechanical data of one servo.

    :param stall_torque: [N*m] (N for linear) at full duty and zero speed
    :param no_load_speed: [rad/s] (m/s) at full duty and zero load
    :param velocity_limit: [rad/s] (m/s) speed held while torque is on
    :param armature: reflected rotor inertia [kg*m^2] (kg)
    :param pwm_limit: largest |duty| (PWM_Limit / 885)
    """

    model: str = 'XL430-W250'
    stall_torque: float = 1.4
    no_load_speed: float = 6.0
    velocity_limit: float = math.pi
    armature: float = 0.01
    pwm_limit: float = 1.0
    pwm_max_register: int = 885

    def __post_init__(self):
        for name in ('stall_torque', 'no_load_speed', 'velocity_limit', 'pwm_limit'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f'servo {name} must be a positive number, not {value!r}')
        if not (math.isfinite(self.armature) and self.armature >= 0.0):
            raise InvalidInputError(f'servo armature must be >= 0, not {self.armature!r}')
        if self.pwm_limit > 1.0:
            raise InvalidInputError(f'servo pwm_limit is a fraction <= 1, not {self.pwm_limit}')

    @property
    def back_emf_damping(self) -> float:
        """Return the back-EMF damping stall_torque / no_load_speed [N*m*s/rad]."""
        return self.stall_torque / self.no_load_speed

    @property
    def max_torque(self) -> float:
        """Return the largest drive torque, stall_torque * pwm_limit [N*m]."""
        return self.stall_torque * self.pwm_limit

    def duty(self, command: float) -> float:
        """Return the PWM duty in [-pwm_limit, pwm_limit] for a torque command [N*m]."""
        d = command / self.stall_torque
        lim = self.pwm_limit
        return lim if d > lim else (-lim if d < -lim else d)

    def torque(self, command: float, velocity: float, enabled: bool = True) -> float:
        """
        Return the output torque [N*m] for a torque command at a joint velocity [rad/s].

        Example Input: command=2.0, velocity=0.0  Output: 1.4 (saturated at stall)
        Example Input: command=1.4, velocity=6.0  Output: 0.0 (no-load speed)
        """
        if not enabled:
            return 0.0
        return self.stall_torque * self.duty(command) - self.back_emf_damping * velocity

    def with_changes(self, **changes) -> 'ServoSpec':
        """Return a copy with some fields changed (validated)."""
        return replace(self, **changes)


#: DYNAMIXEL XL430-W250-T at 11.1 V, the five PX100 servos.
XL430_W250 = ServoSpec()

#: A generic linear actuator for prismatic joints of robots without data (N, m/s, kg).
GENERIC_LINEAR = ServoSpec(model='generic-linear', stall_torque=40.0, no_load_speed=0.4,
                           velocity_limit=0.2, armature=0.5)

#: joints whose URDF effort limit is at most this [N*m] get the XL430 (the PX100 URDF lists
#: 1-2 N*m for its XL430 joints); stronger joints get a servo scaled to their effort limit.
XL430_CLASS_EFFORT = 2.0


def servo_for_joint(joint_type: str, effort_limit: float = None,
                    overrides: dict = None) -> ServoSpec:
    """
    Return the servo model of a joint.

    Revolute joints with an effort limit <= 2 N*m (or none) get the XL430-W250. A stronger
    revolute joint (other robots' shoulders: 10-20 N*m) gets a generic servo whose stall torque
    is its effort limit and whose armature scales with it (same time constants as the XL430).
    Prismatic joints get a generic linear actuator (stall force = effort limit if given).
    :param overrides: ServoSpec fields to force (e.g. a robot file's ``dynamics`` section)
    """
    if joint_type == 'prismatic':
        base = GENERIC_LINEAR
        if effort_limit and math.isfinite(effort_limit) and effort_limit > 0:
            scale = effort_limit / base.stall_torque
            base = base.with_changes(stall_torque=float(effort_limit),
                                     armature=base.armature * scale)
    else:
        base = XL430_W250
        if effort_limit and math.isfinite(effort_limit) and effort_limit > XL430_CLASS_EFFORT:
            scale = effort_limit / base.stall_torque
            base = base.with_changes(model=f'generic-{effort_limit:g}Nm',
                                     stall_torque=float(effort_limit),
                                     armature=base.armature * scale)
    return base.with_changes(**overrides) if overrides else base


# -- DYNAMIXEL figures per servo model -----------------------------------------------------------
@dataclass(frozen=True)
class DynamixelFigures:
    """
    A DYNAMIXEL's published stall figures at one supply voltage (ROBOTIS e-Manual).

    :param stall_torque: [N*m] at ``voltage`` and full duty, zero speed
    :param stall_current: [A] drawn at stall
    :param no_load_speed: [rad/s] at ``voltage``, no load
    :param source: where the figures are published
    """

    model: str
    voltage: float
    stall_torque: float
    stall_current: float
    no_load_speed: float
    source: str

    @property
    def torque_per_amp(self) -> float:
        """Return stall_torque / stall_current [N*m/A] (the e-Manual's torque constant)."""
        return self.stall_torque / self.stall_current


def _rpm(value: float) -> float:
    return value * 2.0 * math.pi / 60.0


_EMANUAL = 'ROBOTIS e-Manual, https://emanual.robotis.com/docs/en/dxl/x/{}/ (Specifications)'
#: the servos of the Interbotix X-Series arms: stall torque, stall current and no-load speed at
#: the voltage given (XL430 at 11.1 V as this project's servo model; the XM and XC at their
#: recommended 12.0 V)
DYNAMIXEL = {f.model: f for f in (
    DynamixelFigures('XL430-W250', 11.1, 1.4, 1.3, _rpm(57.0), _EMANUAL.format('xl430-w250')),
    DynamixelFigures('XM430-W350', 12.0, 4.1, 2.3, _rpm(46.0), _EMANUAL.format('xm430-w350')),
    DynamixelFigures('XM540-W270', 12.0, 10.6, 4.4, _rpm(30.0), _EMANUAL.format('xm540-w270')),
    DynamixelFigures('XC430-W150', 12.0, 1.6, 1.4, _rpm(106.0), _EMANUAL.format('xc430-w150')),
)}


@dataclass(frozen=True)
class JointServos:
    """The DYNAMIXEL(s) driving one joint: ``count`` of ``figures`` (2 for a shadowed joint)."""

    figures: DynamixelFigures
    count: int = 1

    @property
    def torque_per_amp(self) -> float:
        """Return the joint torque [N*m] per ampere commanded to each of its servos."""
        return self.count * self.figures.torque_per_amp


def joint_servos(spec, joints=None) -> dict:
    """
    Return {joint: JointServos} of a robot file's ``servos`` section.

    ``spec`` maps joint -> 'XM430-W350' or '2x XM430-W350' (a joint with a shadow servo).
    :param joints: the robot's joint names (unknown names are refused)
    :raises InvalidInputError: naming every entry that is not a known DYNAMIXEL or joint
    """
    out, bad = {}, []
    for joint, text in dict(spec or {}).items():
        count, _, name = str(text).strip().rpartition('x ')
        try:
            n = int(count) if count else 1
        except ValueError:
            n = 0
        if name not in DYNAMIXEL or n < 1 or (joints is not None and joint not in joints):
            bad.append(f'{joint}: {text!r}')
            continue
        out[str(joint)] = JointServos(DYNAMIXEL[name], n)
    if bad:
        raise InvalidInputError(
            f"servos: {'; '.join(bad)} (expected a joint of the robot and one of "
            f"{', '.join(sorted(DYNAMIXEL))}, optionally '2x <model>')")
    return out
