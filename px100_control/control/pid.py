"""
One PID loop per joint, gains in SI, with the DYNAMIXEL register-unit conversion.

Control law at each control period dt [s] (position error e = q_ref - q [rad], error rate
ed = qd_ref - qd [rad/s], setpoint velocity qd_ref)::

    integral += e * dt, clamped so that |i * integral| <= i_clamp        (anti-windup)
    u = p * e + i * integral + d * ed + ff_velocity * qd_ref, clamped to |u| <= u_clamp

``u`` is a torque command [N*m] handed to the servo model (:mod:`.actuator`), which turns it into
a PWM duty. Gains: p [N*m/rad], i [N*m/(rad*s)], d [N*m*s/rad], ff_velocity [N*m*s/rad],
i_clamp and u_clamp [N*m] (``inf`` = no clamp). For a prismatic joint read N and m.

DYNAMIXEL register units (X-series control table, Position P/I/D Gain 84/82/80): the servo
computes a PWM output from the position error in encoder ticks with KPP = P/128, KPI = I/65536,
KPD = D/16 per control cycle. With 4096 ticks/rev, a full-scale PWM of 885 giving the stall
torque, and the servo's control cycle T_s (not published by ROBOTIS; taken as 1 ms)::

    k_unit = (4096 / 2 pi) [tick/rad] * stall_torque / 885 [N*m per PWM unit]
           = 1.0313 N*m/rad for the XL430 at 11.1 V (1.4 N*m stall)
    p_SI = P / 128 * k_unit                      P = 640  -> 5.156 N*m/rad
    i_SI = I / 65536 * k_unit / T_s              I = 7    -> 0.110 N*m/(rad*s)
    d_SI = D / 16 * k_unit * T_s                 D = 4000 -> 0.258 N*m*s/rad

The XL430 factory values 640/0/4000 are what the PX100 runs (P only with D: it sags under
gravity, as the real arm does).
"""
from dataclasses import asdict, dataclass, replace
import math
from typing import Tuple

from px100_control.errors import InvalidInputError

#: encoder ticks per revolution of the X-series servos
TICKS_PER_REV = 4096
#: register divisors of the X-series Position P, I and D gains
P_DIVISOR, I_DIVISOR, D_DIVISOR = 128.0, 65536.0, 16.0
#: largest register value of a position gain
GAIN_REGISTER_MAX = 16383
#: assumed control cycle of the servo's position loop [s]
SERVO_PERIOD = 1e-3
#: full-scale PWM (the XL430 PWM_Limit default)
PWM_FULL_SCALE = 885.0
#: names of the gain fields, in parameter order
GAIN_FIELDS = ('p', 'i', 'd', 'i_clamp', 'u_clamp', 'ff_velocity')


def register_unit_torque(stall_torque: float = 1.4) -> float:
    """
    Return k_unit [N*m/rad]: the torque per (PWM unit per tick) of a servo's position loop.

    Example Input: stall_torque=1.4  Output: 1.03128...
    """
    return TICKS_PER_REV / (2.0 * math.pi) * stall_torque / PWM_FULL_SCALE


@dataclass(frozen=True)
class PidGains:
    """
    PID gains of one joint in SI units (see the module docstring).

    :param p: [N*m/rad]; i: [N*m/(rad*s)]; d: [N*m*s/rad]; ff_velocity: [N*m*s/rad]
    :param i_clamp: bound on the integral term |i * integral| [N*m]
    :param u_clamp: bound on the output |u| [N*m]
    """

    p: float = 0.0
    i: float = 0.0
    d: float = 0.0
    i_clamp: float = math.inf
    u_clamp: float = math.inf
    ff_velocity: float = 0.0

    def __post_init__(self):
        for name in GAIN_FIELDS:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InvalidInputError(f'gain {name} must be a number, not {value!r}')
            if math.isnan(value):
                raise InvalidInputError(f'gain {name} is NaN')
            if value < 0.0:
                raise InvalidInputError(f'gain {name} = {value} is negative')
            if name in ('p', 'i', 'd', 'ff_velocity') and math.isinf(value):
                raise InvalidInputError(f'gain {name} must be finite')

    @classmethod
    def from_dynamixel(cls, p: float, i: float = 0.0, d: float = 0.0,
                       stall_torque: float = 1.4, period: float = SERVO_PERIOD,
                       **clamps) -> 'PidGains':
        """
        Return SI gains from DYNAMIXEL Position P/I/D Gain register values.

        :param stall_torque: of the servo [N*m]; period: its control cycle T_s [s]
        :param clamps: i_clamp, u_clamp, ff_velocity in SI
        :raises InvalidInputError: a register value outside 0..16383
        Example Input: p=640, i=0, d=4000  Output: PidGains(p=5.156, i=0, d=0.2578)
        """
        for name, value in (('P', p), ('I', i), ('D', d)):
            if not (0 <= value <= GAIN_REGISTER_MAX):
                raise InvalidInputError(f'DYNAMIXEL {name} gain register must be in '
                                        f'0..{GAIN_REGISTER_MAX}, not {value}')
        k = register_unit_torque(stall_torque)
        return cls(p=p / P_DIVISOR * k, i=i / I_DIVISOR * k / period,
                   d=d / D_DIVISOR * k * period, **clamps)

    def to_dynamixel(self, stall_torque: float = 1.4,
                     period: float = SERVO_PERIOD) -> Tuple[float, float, float]:
        """Return the (P, I, D) register values (unrounded) of these SI gains."""
        k = register_unit_torque(stall_torque)
        return (self.p * P_DIVISOR / k, self.i * I_DIVISOR * period / k,
                self.d * D_DIVISOR / (k * period))

    def with_changes(self, **changes) -> 'PidGains':
        """Return a validated copy with some gains changed."""
        return replace(self, **changes)

    def as_dict(self) -> dict:
        """Return the gains as {field: value}."""
        return asdict(self)


class Pid:
    """
    One joint's PID loop with integral and output clamps; time is passed in.

    >>> pid = Pid(PidGains(p=2.0, i=1.0, i_clamp=0.5))
    >>> pid.step(0.1, 0.01)
    0.201
    """

    __slots__ = ('gains', 'integral', '_p', '_i', '_d', '_ff', '_ilim', '_ulim')

    def __init__(self, gains: PidGains = PidGains()):
        self.integral = 0.0
        self.set_gains(gains)

    def set_gains(self, gains: PidGains) -> None:
        """Use new gains; the integral is kept but re-clamped to the new i_clamp."""
        self.gains = gains
        self._p, self._i, self._d = float(gains.p), float(gains.i), float(gains.d)
        self._ff = float(gains.ff_velocity)
        self._ilim = (gains.i_clamp / gains.i) if gains.i > 0.0 else 0.0
        self._ulim = float(gains.u_clamp)
        if self._i <= 0.0:
            self.integral = 0.0
        elif abs(self.integral) > self._ilim:
            self.integral = math.copysign(self._ilim, self.integral)

    def reset(self) -> None:
        """Clear the integral."""
        self.integral = 0.0

    def preload(self, term: float) -> None:
        """Set the integral so that the integral term equals ``term`` [N*m] (within i_clamp)."""
        if self._i <= 0.0:
            self.integral = 0.0
            return
        integral = term / self._i
        lim = self._ilim
        self.integral = lim if integral > lim else (-lim if integral < -lim else integral)

    def step(self, error: float, dt: float, error_rate: float = 0.0,
             velocity_ref: float = 0.0) -> float:
        """
        Advance the loop by dt [s] and return the command u [N*m].

        :param error: q_ref - q [rad]; error_rate: qd_ref - qd [rad/s]
        :param velocity_ref: setpoint velocity for the feed-forward [rad/s]
        """
        if self._i > 0.0:
            integral = self.integral + error * dt
            lim = self._ilim
            self.integral = lim if integral > lim else (-lim if integral < -lim else integral)
        u = (self._p * error + self._i * self.integral + self._d * error_rate
             + self._ff * velocity_ref)
        lim = self._ulim
        return lim if u > lim else (-lim if u < -lim else u)
