"""
The sim_driver's parameter checks and conversions, on plain values (no ROS).

Each check returns the reason a value is refused (the text the node logs and answers a
``set_parameters`` with), or None. ``sim`` is the node's ArmSimulator; ``current(name)``
returns a parameter's value as set so far. Units: gains in SI (``p`` N*m/rad, ``i``
N*m/(rad*s), ``d`` N*m*s/rad) or, with ``gains_units`` 'dynamixel', p/i/d as the XL430's
Position P/I/D Gain registers; rates [Hz]; ``object_width`` [m]. Ranges and allowed values
are the schema's (:data:`px100_control.parameters.SIM_DRIVER`).
"""
import math
from typing import Callable, Dict, List, Optional, Tuple

from px100_control.control.pid import GAIN_FIELDS, PidGains
from px100_control.errors import Px100Error
from px100_control.parameters import SIM_DRIVER

#: the parameters checked together (one may be valid only with another's value)
CORE_PARAMS = ('publish_rate', 'control_rate', 'real_time_factor', 'publish_clock',
               'clock_rate', 'dynamics_divider', 'object_width', 'gains_units', 'world_rate')
#: the values of ``gains_units``
GAINS_UNITS = SIM_DRIVER['gains_units'].choices
#: the values of ``operating_mode.<joint>`` ('' = the joint's default)
MODE_CHOICES = SIM_DRIVER.group('operating_mode.').spec.choices


def gain_keys(joint: str) -> List[str]:
    """Return the parameter names ``gains.<joint>.<field>`` in GAIN_FIELDS order."""
    return [f'gains.{joint}.{f}' for f in GAIN_FIELDS]


def _servo(sim, joint: str):
    if joint == sim.gripper_name:
        return sim.gripper_servo
    return sim.servos[sim.names.index(joint)]


def gain_defaults(sim, joint: str, units: str) -> Dict[str, float]:
    """Return {field: default} of a joint's gains in ``units`` (scaled to the joint's servo)."""
    base = sim.gains(joint)
    reg = base.to_dynamixel() if units == 'dynamixel' else None
    values = {}
    for k, f in enumerate(GAIN_FIELDS):
        values[f] = float(getattr(base, f))
        if reg is not None and k < 3:
            values[f] = float(round(reg[k]))
    return values


def to_gains(sim, joint: str, values: dict, units: str) -> PidGains:
    """Return the PidGains of {field: value} given in ``units``."""
    values = {k: float(v) for k, v in values.items()}
    if units == 'dynamixel':
        clamps = {k: values[k] for k in ('i_clamp', 'u_clamp', 'ff_velocity')}
        return PidGains.from_dynamixel(values['p'], values['i'], values['d'],
                                       stall_torque=_servo(sim, joint).stall_torque, **clamps)
    return PidGains(**values)


def gains_error(sim, joint: str, values: dict, units: str) -> Optional[str]:
    """Return why {field: value} cannot be the joint's gains (at the simulator's dt), or None."""
    for f, v in values.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            return f'gains.{joint}.{f} must be a number, not {v!r}'
        if math.isinf(v):
            return (f'gains.{joint}.{f} must be finite, not {v!r} (for no clamp give a '
                    'value above the servo torque)')
    try:
        gains = to_gains(sim, joint, values, units)
    except Px100Error as exc:
        return f'gains.{joint}: {exc}'
    return stability_error(sim, joint, gains, sim.dt)


def stability_error(sim, joint: str, gains: PidGains, dt: float) -> Optional[str]:
    """Refuse gains the explicit discrete loop cannot take at step dt [s] (J: the armature)."""
    inertia = max(_servo(sim, joint).armature, 1e-6)
    if gains.d * dt > inertia:
        return (f'gains.{joint}.d = {gains.d:.6g} would make the control loop unstable at '
                f'{1.0 / dt:g} Hz (needs d < J/dt = {inertia / dt:.6g})')
    if gains.p * dt * dt > inertia:
        return (f'gains.{joint}.p = {gains.p:.6g} would make the control loop unstable at '
                f'{1.0 / dt:g} Hz (needs p < J/dt^2 = {inertia / dt / dt:.6g})')
    return None


def _number_error(p: dict, name: str) -> Optional[str]:
    """Return why p[name] is out of its schema range [low, high] (+inf where allowed), or None."""
    v, spec = p[name], SIM_DRIVER[name]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v):
        return f'{name} must be a number, not {v!r}'
    if spec.kind == 'integer' and (not isinstance(v, int) or v < spec.low):
        return f'{name} must be an integer >= {spec.low:g}, not {v!r}'
    if math.isinf(v) and spec.allow_inf:
        return None
    if not spec.low <= v <= spec.high:
        return f'{name} = {v} is outside [{spec.low}, {spec.high}]'
    return None


def core_error(p: dict, sim=None) -> Optional[str]:
    """Return why the CORE_PARAMS values ``p`` are refused, or None (``sim``: object_width)."""
    for name in ('control_rate', 'publish_rate', 'real_time_factor', 'clock_rate',
                 'object_width', 'world_rate', 'dynamics_divider'):
        err = _number_error(p, name)
        if err:
            return err
    if p['publish_rate'] > p['control_rate']:
        return (f"publish_rate {p['publish_rate']} Hz is above control_rate "
                f"{p['control_rate']} Hz")
    if sim is not None and sim.linkage is not None:
        try:
            sim.linkage.check_object_width(float(p['object_width']))
        except Px100Error as exc:
            return str(exc)
    elif sim is not None and p['object_width']:
        return 'this robot has no gripper to hold an object'
    return None


def mode_error(name: str, value) -> Optional[str]:
    """Return why ``value`` is not a control mode of parameter ``name``, or None."""
    if value not in MODE_CHOICES:
        modes = ', '.join(m for m in MODE_CHOICES if m)
        return (f"{name} must be '' (default) or one of {modes}, not {value!r} "
                '(Interbotix modes map to these: current -> torque, pwm -> duty)')
    return None


def changed_gains(changed: dict, current: Callable, joints) -> Dict[str, dict]:
    """Return {joint: {field: value}} of the joints whose gains ``changed`` touches."""
    out = {}
    for joint in joints:
        keys = gain_keys(joint)
        if any(k in changed for k in keys):
            out[joint] = {f: changed.get(k, current(k)) for f, k in zip(GAIN_FIELDS, keys)}
    return out


def joint_change_error(changed: dict, current: Callable, sim, units: str) -> Optional[str]:
    """Return why the operating_mode.* / gains.* values in ``changed`` are refused, or None."""
    for name, value in changed.items():
        if name.startswith('operating_mode.'):
            error = mode_error(name, value)
            if error:
                return error
    for joint, values in changed_gains(changed, current, sim.command_joints).items():
        error = gains_error(sim, joint, values, units)
        if error:
            return error
    return None


def core_change_error(changed: dict, current: Callable, sim, stepper) -> Optional[str]:
    """
    Return why the CORE_PARAMS values in ``changed`` are refused, or None.

    ``stepper`` (:class:`px100_control.sim.stepper.Stepper`): the clock mode (the real-time
    factor changes only on an own clock) and the measured step cost (control_rate).
    """
    if not any(n in CORE_PARAMS for n in changed):
        return None
    error = core_error({n: changed.get(n, current(n)) for n in CORE_PARAMS}, sim)
    if error:
        return error
    if 'real_time_factor' in changed and not stepper.master \
            and float(changed['real_time_factor']) != 1.0:
        return ('this driver follows the node clock; start it with real_time_factor != 1 '
                'or publish_clock:=true to run on its own clock')
    if 'control_rate' not in changed:
        return None
    rate = float(changed['control_rate'])
    error = stepper.load_error(rate)
    if error:
        return error
    for joint in sim.command_joints:
        error = stability_error(sim, joint, sim.gains(joint), 1.0 / rate)
        if error:
            return f"control_rate {changed['control_rate']} Hz: {error}"
    return None


def joint_switches(changed: dict) -> Tuple[Dict[str, bool], Dict[str, str]]:
    """Return ({joint: torque on} of torque_enable.*, {joint: mode} of operating_mode.*)."""
    torque = {n[len('torque_enable.'):]: bool(v) for n, v in changed.items()
              if n.startswith('torque_enable.')}
    modes = {n[len('operating_mode.'):]: str(v) for n, v in changed.items()
             if n.startswith('operating_mode.')}
    return torque, modes
