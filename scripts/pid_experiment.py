#!/usr/bin/env python3
"""
Seed 001's PID experiment on the simulated PX100: six gain sets, one joint step, two plants.

Seed 001 (a student's PincherX-100 project) reports steady-state error, overshoot and settling
time for six (Kp, Ki, Kv) sets. Its gains are DYNAMIXEL register units (640/0/4000 is the
XL430's factory Position P/I/D); it names neither the joint, the start pose, the step, the load
nor its simulation tool. This script runs the six sets on
:class:`px100_control.sim.simulator.ArmSimulator` (MuJoCo, XL430 servo model, 1 kHz) for a
:class:`Plant`:

- ``PHYSICAL``: the px100 as the demo simulates it (URDF friction and damping, the XL430 model
  with its assumed armature), the shoulder stepping 0.5 rad back from ``POSE`` against gravity;
- ``TUNED``: the plant :func:`tune` finds: a coordinate search on ``GRID`` (tested joint, with
  gravity on it or not; step; that joint's Coulomb friction and viscous damping; the servo's
  armature, the reflected rotor inertia ROBOTIS does not publish), scored by :func:`score`
  against the table. The XL430's published torque-speed curve (stall torque, no-load speed,
  hence its back-EMF) and velocity limit stay as they are.

Only this experiment's simulator is configured (``SimConfig.servo_overrides`` and the
simulator's ``friction`` / ``damping`` setters); the demo's sim_driver keeps the physical
defaults. The tested joint starts at rest at ``POSE`` under the tested gains (if gravity acts on
it, ``SETTLE_BEFORE`` s to sag first), then its setpoint steps; the other joints hold with the
default gains.

Metrics, on the tested joint's angle y(t), target r, step s (sign = direction):
- steady-state error: (r - mean of y over the last 0.2 s) * sign(s): > 0 short of the target;
- overshoot: largest excursion beyond r in the step direction (>= 0) [rad];
- settling time: last time y is outside +-2 % of |s| around its final value [s].
A run has settled when it stayed in that band for the last ``SETTLED_HOLD`` s and moved less
than a quarter of the band over them; otherwise its steady-state error and settling time are
None ('not settled within the window').

Each plant's table is followed by the table's qualitative claims (:func:`pattern_checks`),
each computed from that table and marked ``[ok]`` or ``[NO]``. The exit status is 0 when the
tuned plant (the one meant to reproduce the table) shows every claim; the physical plant's
``[NO]`` lines are findings (e.g. its D runs settle later than Kp 640 alone).

Usage: python3 scripts/pid_experiment.py [--duration S] [--integral-duration S] [--tune]
       [--out PNG]
"""
import argparse
from dataclasses import dataclass, replace
import math
import os
import sys
import time
from typing import Callable, Dict, List, Optional, Sequence, Tuple

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from px100_control.tools.venv_check import require  # noqa: E402

require('numpy', 'matplotlib', 'yaml', 'mujoco')

import numpy as np  # noqa: E402, I100

from px100_control.control.pid import PidGains  # noqa: E402
from px100_control.models.registry import load_robot  # noqa: E402
from px100_control.sim.simulator import ArmSimulator, SimConfig  # noqa: E402

#: seed 001's gain sets (Kp, Ki, Kv) in DYNAMIXEL register units and its reported results
SEED_TABLE = [
    ((100, 0, 0), '~0.05 rad', 'None', '~2 s'),
    ((100, 7, 0), 'None', 'None', '~1 s'),
    ((640, 0, 0), '~0', '0.1 rad', '<1 s'),
    ((1600, 0, 0), '~0', '0.1 rad', '~1 s'),
    ((640, 0, 2000), 'None', 'Minimal', '~0.5 s'),
    ((640, 0, 4000), 'None', 'Essentially none', '<1 s'),
]
#: the same table as numbers (value, tolerance its wording allows): '~0.05' -> 0.05 +- 0.025,
#: 'None' / '~0' -> 0 +- 0.005 rad, 'Minimal' -> 0 +- 0.01 rad, '<1 s' -> 0.5 +- 0.5 s,
#: '~1 s' -> 1 +- 0.5 s, '~0.5 s' -> 0.5 +- 0.25 s; per set: (error, overshoot, settling)
SEED_NUMBERS = {
    (100, 0, 0): ((0.05, 0.025), (0.0, 0.005), (2.0, 0.5)),
    (100, 7, 0): ((0.0, 0.005), (0.0, 0.005), (1.0, 0.5)),
    (640, 0, 0): ((0.0, 0.005), (0.1, 0.05), (0.5, 0.5)),
    (1600, 0, 0): ((0.0, 0.005), (0.1, 0.05), (1.0, 0.5)),
    (640, 0, 2000): ((0.0, 0.005), (0.0, 0.01), (0.5, 0.25)),
    (640, 0, 4000): ((0.0, 0.005), (0.0, 0.005), (0.5, 0.5)),
}
METRICS = ('steady-state error', 'overshoot', 'settling time')
#: start pose [waist, shoulder, elbow, wrist_angle] (rad): upper arm tilted back 0.5 rad,
#: elbow and wrist bent 0.3 rad; the gripper is 0.19 m out in front, 0.21 m up
POSE = (0.0, -0.5, 0.3, 0.3)
#: direction of the step per tested joint: the shoulder swings back, lifting the arm against
#: gravity all the way (gravity torque 0.22 -> 0.04 N*m, never reversing); the waist turns left
DIRECTION = {'shoulder': -1.0, 'waist': 1.0}
SETTLE_BEFORE = 3.0
SETTLING_BAND = 0.02
SETTLED_HOLD = 0.5
#: a gain set's output clamp [N*m] (the XL430's stall torque) and integral clamp
U_CLAMP = 1.4


@dataclass(frozen=True)
class Plant:
    """
    The experiment's plant: tested joint, step and that joint's losses and servo inertia.

    :param joint: the stepped joint ('shoulder': gravity acts on it; 'waist': it does not)
    :param step: size of the step [rad] (direction: ``DIRECTION``)
    :param friction: Coulomb friction of the tested joint [N*m] (None: the URDF's)
    :param damping: viscous damping of the tested joint [N*m*s/rad], back-EMF excluded
        (None: the URDF's)
    :param armature: reflected rotor inertia of every arm servo [kg*m^2] (None: the XL430
        model's)
    """

    joint: str = 'shoulder'
    step: float = 0.5
    friction: Optional[float] = None
    damping: Optional[float] = None
    armature: Optional[float] = None

    @property
    def signed_step(self) -> float:
        """Return the step with its direction [rad]."""
        return DIRECTION[self.joint] * self.step

    def simulator(self, model, control_rate: float = 1000.0) -> Tuple[ArmSimulator, int]:
        """Return (an ArmSimulator of this plant, index of the tested joint)."""
        overrides = {} if self.armature is None else {'armature': float(self.armature)}
        sim = ArmSimulator(model, SimConfig(control_rate=control_rate,
                                            servo_overrides=overrides))
        k = model.joint_names.index(self.joint)
        if self.friction is not None:
            friction = sim.friction
            friction[k] = float(self.friction)
            sim.friction = friction
        if self.damping is not None:
            damping = sim.damping
            damping[k] = float(self.damping)
            sim.damping = damping
        return sim, k

    def resolved(self, model) -> 'Plant':
        """Return this plant with every None replaced by the simulator's default value."""
        sim, k = self.simulator(model)
        return replace(self, friction=sim.friction[k], damping=sim.damping[k],
                       armature=sim.servos[k].armature)

    def describe(self) -> str:
        """Return the plant in one line."""
        def val(x, fmt):
            return 'URDF' if x is None else format(x, fmt)
        return (f'{self.joint} step {self.signed_step:+.2f} rad from {list(POSE)}, friction '
                f'{val(self.friction, ".3f")} N*m, damping {val(self.damping, ".3f")} '
                f'N*m*s/rad, armature {val(self.armature, ".3f")} kg*m^2')


#: the px100 as the demo's sim_driver simulates it
PHYSICAL = Plant()
#: the plant tune() returns from PHYSICAL (python3 scripts/pid_experiment.py --tune)
TUNED = Plant(joint='waist', step=0.75, friction=0.03, damping=0.1, armature=0.015)
#: the search space of tune(), searched in this order
GRID = (('joint', ('shoulder', 'waist')),
        ('step', (0.25, 0.5, 0.75, 1.0)),
        ('friction', (0.01, 0.02, 0.025, 0.03, 0.04, 0.06, 0.1)),
        ('armature', (0.005, 0.01, 0.015, 0.02, 0.03)),
        ('damping', (0.0, 0.05, 0.1, 0.15, 0.2)))


@dataclass
class StepResult:
    """
    One gain set's response, metrics (rad, s; None if not settled) and the plant's terms.

    ``v`` is the joint speed [rad/s] and ``integral`` the PID's integral term [N*m] per
    sample. ``balance`` holds the torques on the tested joint at the end of the run [N*m]:
    'drive' (servo output), 'p_term' (Kp * final error), 'integral', 'gravity' (torque the
    drive must supply to hold the arm there), 'gravity_target' (the same at the target),
    'friction' (the friction force the plant applies), 'friction_limit'; ``plant`` the loop's
    constants: 'inertia' J [kg*m^2] (with armature), 'damping' b (viscous + back-EMF)
    [N*m*s/rad], 'stall' [N*m], 'velocity_limit' [rad/s].
    """

    gains: Tuple[int, int, int]
    t: np.ndarray
    y: np.ndarray
    target: float
    start: float
    step: float
    steady_state_error: Optional[float]
    overshoot: float
    settling_time: Optional[float]
    drift: float
    v: np.ndarray
    integral: np.ndarray
    si: PidGains
    balance: Dict[str, float]
    plant: Dict[str, float]

    @property
    def settled(self) -> bool:
        """Return True when the run settled within its window."""
        return self.settling_time is not None


def settled_drift(t: np.ndarray, y: np.ndarray) -> float:
    """Return |y(end) - y(end - SETTLED_HOLD)| [rad]: how far the joint moved at the end."""
    return float(abs(y[-1] - y[t >= t[-1] - SETTLED_HOLD][0]))


def step_metrics(t: np.ndarray, y: np.ndarray, target: float, step: float):
    """
    Return (steady-state error, overshoot, settling time) of a step response.

    Error and settling time are None when the response has not settled within the window (see
    the module docstring).
    """
    sign = 1.0 if step >= 0 else -1.0
    tail = y[t >= t[-1] - 0.2]
    final = float(np.mean(tail))
    sse = (target - final) * sign
    overshoot = max(0.0, float(np.max((y - target) * sign)))
    band = SETTLING_BAND * abs(step)
    outside = np.nonzero(np.abs(y - final) > band)[0]
    settling = float(t[outside[-1] + 1]) if len(outside) and outside[-1] + 1 < len(t) else (
        float(t[-1]) if len(outside) else 0.0)
    if settling > t[-1] - SETTLED_HOLD or settled_drift(t, y) > 0.25 * band:
        return None, overshoot, None
    return sse, overshoot, settling


def step_response(gains: Sequence[int], duration: float, model=None,
                  plant: Plant = PHYSICAL, control_rate: float = 1000.0) -> StepResult:
    """Simulate one gain set (register units) on a plant and return its StepResult."""
    model = model or load_robot('px100')
    sim, k = plant.simulator(model, control_rate)
    p, i, d = gains
    si = PidGains.from_dynamixel(p, i, d, i_clamp=U_CLAMP, u_clamp=U_CLAMP)
    sim.set_gains(plant.joint, si)
    sim.hold(POSE)            # at rest, the other joints' integrators holding the weight
    sim.pids[k].reset()       # the tested loop starts from zero, and sags if it must
    gravity0 = float(sim.dynamics.gravity_torque(POSE)[k])
    if abs(gravity0) > 1e-9:
        sim.advance(int(round(SETTLE_BEFORE * control_rate)))
    start = sim.q[k]
    step = plant.signed_step
    target = POSE[k] + step
    sim.command([plant.joint], [target])
    n = int(round(duration * control_rate))
    y, v, integral = np.empty(n), np.empty(n), np.empty(n)
    pid = sim.pids[k]
    for s in range(n):
        sim.step()
        y[s] = sim.q[k]
        v[s] = sim.qd[k]
        integral[s] = pid.integral
    integral *= si.i
    t = np.arange(1, n + 1) / control_rate
    metrics = step_metrics(t, y, target, step)
    dof = sim.built.arm_dof[k]
    servo = sim.servos[k]
    error = target - sim.q[k]
    balance = {'drive': float(sim.effort[k]), 'p_term': si.p * error,
               'integral': si.i * sim.pids[k].integral,
               'gravity': float(sim.dynamics.gravity_torque(sim.q)[k]),
               'gravity_target': _gravity_at(sim, k, target),
               'friction': float(sim.mj_data.qfrc_constraint[dof]),
               'friction_limit': float(sim.friction[k])}
    constants = {'inertia': float(sim.dynamics.mass_matrix(POSE)[k, k]),
                 'damping': float(sim.damping[k] + servo.back_emf_damping),
                 'stall': float(servo.stall_torque), 'velocity_limit': sim.vel_limit[k]}
    return StepResult(tuple(gains), t, y, target, start, step, *metrics,
                      settled_drift(t, y), v, integral, si, balance, constants)


def _gravity_at(sim: ArmSimulator, k: int, angle: float) -> float:
    q = list(POSE)
    q[k] = angle
    return float(sim.dynamics.gravity_torque(q)[k])


def run_experiment(duration: float = 5.0, integral_duration: float = 30.0,
                   plant: Plant = PHYSICAL, model=None) -> List[StepResult]:
    """Run the six gain sets (the integral set for integral_duration) on a plant."""
    model = model or load_robot('px100')
    return [step_response(g, integral_duration if g[1] else duration, model, plant)
            for g, *_ in SEED_TABLE]


def penalties(results: List[StepResult], unsettled: float = 5.0) -> Dict[tuple, float]:
    """
    Return {(gains, metric): distance beyond the table's tolerance, in tolerances}.

    0 inside the tolerance of the document's wording (``SEED_NUMBERS``), (|ours - doc| - tol) /
    tol outside it; ``unsettled`` for an error or settling time of a run that did not settle.
    """
    out = {}
    for r in results:
        ours = (r.steady_state_error, r.overshoot, r.settling_time)
        for metric, value, (doc, tol) in zip(METRICS, ours, SEED_NUMBERS[r.gains]):
            out[(r.gains, metric)] = unsettled if value is None else max(
                0.0, abs(value - doc) - tol) / tol
    return out


def score(results: List[StepResult]) -> float:
    """Return the distance of a table from the document's: the sum of ``penalties``."""
    return float(sum(penalties(results).values()))


@dataclass
class Evaluation:
    """One plant of the search: its six results and their score."""

    plant: Plant
    results: List[StepResult]
    score: float


def evaluate(plant: Plant, model=None, duration: float = 3.0) -> Evaluation:
    """Run the six sets for ``duration`` s each on a plant and score them."""
    results = run_experiment(duration, duration, plant, model)
    return Evaluation(plant, results, score(results))


def tune(model=None, start: Plant = PHYSICAL, passes: int = 3, duration: float = 3.0,
         log: Optional[Callable[[str], None]] = None) -> Tuple[Evaluation, List[Evaluation]]:
    """
    Coordinate search of ``GRID`` from ``start``: return (best, every evaluation).

    Each pass tries every value of each parameter in turn (the others fixed at the best so
    far) and keeps a value only if it lowers the score; it stops after a pass without change.
    Deterministic: the same plant always gives the same responses.
    """
    model = model or load_robot('px100')
    seen: Dict[Plant, Evaluation] = {}

    def run(plant):
        if plant not in seen:
            seen[plant] = evaluate(plant, model, duration)
        return seen[plant]
    best = run(start.resolved(model))
    for _ in range(passes):
        changed = False
        for name, values in GRID:
            for value in values:
                ev = run(replace(best.plant, **{name: value}))
                if ev.score < best.score - 1e-9:
                    best, changed = ev, True
                    if log:
                        log(f'score {ev.score:6.2f}  {ev.plant.describe()}')
        if not changed:
            break
    return best, list(seen.values())


def neighbours(plant: Plant) -> List[Plant]:
    """Return the plants one ``GRID`` value away from ``plant`` (one parameter changed)."""
    out = []
    for name, values in GRID:
        values = list(values)
        here = getattr(plant, name)
        if here not in values:
            continue
        i = values.index(here)
        out += [replace(plant, **{name: values[j]}) for j in (i - 1, i + 1)
                if 0 <= j < len(values)]
    return out


def pattern_checks(results: List[StepResult]) -> List[Tuple[str, bool]]:
    """Return the seed table's qualitative claims and whether the results show each."""
    r = {res.gains: res for res in results}
    p100, pi, p640, p1600 = r[(100, 0, 0)], r[(100, 7, 0)], r[(640, 0, 0)], r[(1600, 0, 0)]
    d2000, d4000 = r[(640, 0, 2000)], r[(640, 0, 4000)]
    if not all(x.settled for x in results):
        unsettled = [x.gains for x in results if not x.settled]
        return [(f'every run settled within its window (not: {unsettled})', False)]
    return [
        ('P alone (Kp 100) leaves a steady-state error', p100.steady_state_error > 0.02),
        ('the integral (Ki 7) removes it',
         abs(pi.steady_state_error) < 0.2 * p100.steady_state_error),
        ('more P leaves less error', abs(p640.steady_state_error) < p100.steady_state_error / 3
         and abs(p1600.steady_state_error) <= abs(p640.steady_state_error) + 0.005),
        ('more P overshoots (Kp 640 and 1600 do, Kp 100 does not)',
         p100.overshoot <= 0.005 and min(p640.overshoot, p1600.overshoot) > 0.01),
        ('D removes the overshoot', d4000.overshoot <= min(0.005, p640.overshoot)
         and d2000.overshoot < p640.overshoot),
        _d_settling(p640, d2000, d4000),
    ]


def _d_settling(p640: StepResult, *with_d: StepResult) -> Tuple[str, bool]:
    """Return the claim 'D shortens settling' with the table's numbers: D runs vs Kp 640 alone."""
    holds = all(r.settling_time < p640.settling_time for r in with_d)
    times = ', '.join(f'Kv {r.gains[2]} {r.settling_time:.2f} s' for r in with_d)
    verdict = 'shorter' if holds else ('longer' if all(
        r.settling_time > p640.settling_time for r in with_d) else 'not shorter in every run')
    return (f'D shortens settling (Kp {p640.gains[0]} alone {p640.settling_time:.2f} s; with D '
            f'{times}: {verdict})', holds)


def settling_estimate(inertia: float, damping: float, kp: float) -> float:
    """
    Return the 2 % settling time [s] of J x'' + b x' + Kp x = 0.

    4 time constants of its slowest decay: 8 J / b when underdamped, whatever Kp; 4 / the slow
    pole when overdamped.
    """
    wn = math.sqrt(kp / inertia)
    zeta = damping / (2.0 * math.sqrt(kp * inertia))
    if zeta < 1.0:
        return 4.0 / (zeta * wn)
    return 4.0 / (wn * (zeta - math.sqrt(zeta * zeta - 1.0)))


def explain(r: StepResult, metric: str) -> str:
    """
    Return why a metric of a run is what it is, from the run's own numbers, or ''.

    '' when the run's numbers do not bear the explanation out (a torque balance that does not
    close, an overshoot beyond what the crossing speed allows, a settling time the loop's
    decay does not account for): the difference then stays unexplained.
    """
    doc, tol = SEED_NUMBERS[r.gains][METRICS.index(metric)]
    if metric != 'overshoot' and not r.settled:
        return (f'not settled within the {r.t[-1]:.1f} s window: it moved {r.drift:.4f} rad '
                f'over the last {SETTLED_HOLD} s')
    if metric == 'steady-state error':
        return _explain_error(r, doc, tol)
    if metric == 'overshoot':
        return _explain_overshoot(r, doc, tol)
    return _explain_settling(r, doc, tol)


def _along(r: StepResult, key: str) -> float:
    """Return a torque of ``balance`` along the step direction [N*m]."""
    return math.copysign(1.0, r.step) * r.balance[key]


def _explain_error(r: StepResult, doc: float, tol: float) -> str:
    b, kp = r.balance, r.si.p
    limit = b['friction_limit']
    drive, gravity, friction = _along(r, 'drive'), _along(r, 'gravity'), _along(r, 'friction')
    if abs(b['friction']) > limit * (1 + 1e-6) + 1e-9 or \
            abs(drive + friction - gravity) > 0.05 * max(limit, 0.01) + 1e-3:
        return ''
    e = r.steady_state_error
    band = (abs(gravity) + limit) / kp
    if not r.gains[1] and abs(e) > band * 1.01 + r.drift + 5e-4:
        return ''
    creep = (f" (MuJoCo's friction lets it creep on: {r.drift:.4f} rad over the last "
             f'{SETTLED_HOLD} s)' if r.drift > 1e-4 else '')
    where = f"{abs(e):.4f} rad {'short of' if e > 0 else 'past'} the target"
    if r.gains[1]:
        rate = r.si.i * abs(e)
        wait = f'{2 * limit / rate:.0f} s' if rate > 0 else 'forever'
        return (f'stuck {where}: the integral pushes {_along(r, "integral"):+.4f} N*m along '
                f'the step and P {drive - _along(r, "integral"):+.4f}, holding against gravity '
                f'needs {gravity:+.4f} and friction supplies the difference {friction:+.4f} N*m '
                f'(its limit is {limit:.3f}); the integral now changes at Ki |e| = {rate:.2e} '
                f'N*m/s and must swing the friction by up to 2 x {limit:.3f} N*m to move the '
                f'joint again: {wait}')
    text = (f'stopped {where}: P pushes {drive:+.4f} N*m along the step, holding against '
            f'gravity needs {gravity:+.4f} and friction supplies the difference '
            f'{friction:+.4f} N*m (its limit is {limit:.3f}); without an integral the joint '
            f'stops wherever P is within the friction of the gravity load: up to {band:.4f} rad '
            f'from the target at Kp = {kp:.3f} N*m/rad{creep}')
    if doc > 0:
        return text + f"; seed 001's {doc} rad at this Kp means a load of {kp * doc:.3f} N*m"
    return text + (f"; seed 001's none (<= {tol} rad) needs gravity + friction below Kp x "
                   f'{tol} = {kp * tol:.4f} N*m')


def _explain_overshoot(r: StepResult, doc: float, tol: float) -> str:
    sign = math.copysign(1.0, r.step)
    beyond = np.nonzero((r.y - r.target) * sign >= 0.0)[0]
    kp, inertia = r.si.p, r.plant['inertia']
    damping = r.plant['damping'] + r.si.d
    if not len(beyond):
        zeta = damping / (2.0 * math.sqrt(kp * inertia))
        return ('the joint never reaches the target (friction stops it first; linear damping '
                f'ratio {zeta:.2f})') if r.overshoot == 0.0 else ''
    c = beyond[0]
    speed = abs(float(r.v[c]))
    push = sign * float(r.integral[c])
    gravity = sign * r.balance['gravity_target']
    resist = r.balance['friction_limit'] + gravity - push     # constant torque against x
    bound = (-resist + math.sqrt(resist ** 2 + kp * inertia * speed ** 2)) / kp
    if r.overshoot > 1.05 * bound + 2e-4:
        return ''
    limited = float(np.abs(r.v).max()) >= 0.98 * r.plant['velocity_limit']
    text = (f'the joint crosses the target at {speed:.2f} rad/s'
            + (f" (it ran at the servo's {r.plant['velocity_limit']:.2f} rad/s velocity limit "
               'on the way)' if limited else '')
            + (f', the integral pushing {push:+.3f} N*m on' if r.gains[1] else '')
            + f': against Kp = {kp:.2f} N*m/rad, friction {r.balance["friction_limit"]:.3f}'
            + (f' and gravity {gravity:+.3f} N*m' if abs(gravity) > 1e-6 else ' N*m')
            + f' that carries it at most {bound:.4f} rad past, and the damping (b + Kd = '
              f'{damping:.3f} N*m*s/rad) stops it at {r.overshoot:.4f}')
    if doc > r.overshoot:
        need = math.sqrt(max(0.0, kp * doc ** 2 + 2.0 * resist * doc) / inertia)
        return text + f"; seed 001's {doc} rad needs a crossing at {need:.2f} rad/s or more"
    return text + f"; seed 001's {doc or 'none'} needs a slower crossing or more damping"


def _explain_settling(r: StepResult, doc: float, tol: float) -> str:
    ours = r.settling_time
    if r.gains[1]:
        carried = r.integral * math.copysign(1.0, r.integral[-1])
        final = float(carried[-1])
        at_doc = float(carried[r.t <= doc][-1]) if doc >= r.t[0] else 0.0
        t90, t98 = (float(r.t[np.nonzero(carried >= x * final)[0][0]]) for x in (0.9, 0.98))
        if not ((ours > doc and at_doc < 0.9 * final) or (ours < doc and t90 <= ours + 0.2)):
            return ''
        return (f'the integral (Ki = {r.si.i:.3f} N*m/(rad*s)) ends carrying {final:.3f} N*m '
                f'of the load and builds it from the error it sees: {at_doc:.3f} N*m by the '
                f"seed 001's {doc} s, 90 % of it at {t90:.2f} s, 98 % at {t98:.2f} s (the error "
                f'is {abs(r.target - r.y[r.t >= t98][0]):.4f} rad then, the settling band '
                f'+-{SETTLING_BAND * abs(r.step):.4f})')
    kp, inertia = r.si.p, r.plant['inertia']
    damping = r.plant['damping'] + r.si.d
    estimate = settling_estimate(inertia, damping, kp)
    if not 0.5 * estimate <= ours <= 2.0 * estimate:
        return ''
    zeta = damping / (2.0 * math.sqrt(kp * inertia))
    text = (f"settling follows the loop's slowest decay: J = {inertia:.4f} kg*m^2, "
            f'b + Kd = {damping:.3f} N*m*s/rad, Kp = {kp:.3f} N*m/rad give zeta = {zeta:.2f} and '
            f'{estimate:.2f} s ' + ('(8 J / (b + Kd), the same for every Kp)' if zeta < 1 else
                                    '(4 x the slow time constant)')
            + f' (measured {ours:.2f} s: friction, gravity and the velocity limit are not in '
              'the estimate)')
    fastest = settling_estimate(inertia, 2.0 * math.sqrt(kp * inertia), kp)
    if doc < fastest:
        return text + (f"; seed 001's {doc} s is below what this loop reaches at any "
                       f'damping ({fastest:.2f} s at zeta = 1)')
    roots = [_damping_for(inertia, kp, doc, lo, hi) for lo, hi in
             ((1e-6, 2.0 * math.sqrt(kp * inertia)), (2.0 * math.sqrt(kp * inertia), 100.0))]
    return text + (f"; seed 001's {doc} s needs b + Kd = "
                   + ' or '.join(f'{x:.3f}' for x in roots if x is not None) + ' N*m*s/rad')


def _damping_for(inertia, kp, t, lo, hi) -> Optional[float]:
    """Return b in [lo, hi] with settling_estimate(J, b, Kp) = t (bisection), or None."""
    f_lo = settling_estimate(inertia, lo, kp) - t
    f_hi = settling_estimate(inertia, hi, kp) - t
    if f_lo * f_hi > 0:
        return None
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        f_mid = settling_estimate(inertia, mid, kp) - t
        if f_lo * f_mid <= 0:
            hi = mid
        else:
            lo, f_lo = mid, f_mid
    return 0.5 * (lo + hi)


def metric_value(r: StepResult, metric: str) -> Optional[float]:
    """Return one metric of a run (None if it did not settle)."""
    return (r.steady_state_error, r.overshoot, r.settling_time)[METRICS.index(metric)]


def trade_off(cell: tuple, best: Evaluation, others: Sequence[Evaluation]) -> str:
    """
    Return what the searched plants say about one cell of the best plant, or ''.

    The plant of ``others`` that brings this cell ((gains, metric)) closest to the table, which
    of its cells got worse the most, and both scores; '' if none brings it closer.
    """
    mine = penalties(best.results)
    better = [(penalties(e.results), e) for e in others if e.plant != best.plant]
    better = [(p, e) for p, e in better if p[cell] < mine[cell] - 1e-9]
    if not better:
        return ''
    pen, ev = min(better, key=lambda pe: (pe[0][cell], pe[1].score))
    changed = [name for name, _ in GRID if getattr(ev.plant, name) != getattr(best.plant, name)]
    changes = ', '.join(f'{name} {getattr(best.plant, name)} -> {getattr(ev.plant, name)}'
                        for name in changed)
    worse = max(pen, key=lambda k: pen[k] - mine[k])
    res = {x.gains: x for x in ev.results}
    doc = SEED_NUMBERS[worse[0]][METRICS.index(worse[1])][0]
    return (f'the search traded it off: {changes} brings it to '
            f'{_fmt(metric_value(res[cell[0]], cell[1]), ".4f")} but '
            f"{'/'.join(map(str, worse[0]))} {worse[1]} to "
            f'{_fmt(metric_value(res[worse[0]], worse[1]), ".4f")} (seed 001 table {doc}), score '
            f'{ev.score:.2f} against {best.score:.2f}')


def _fmt(value: Optional[float], fmt: str) -> str:
    return 'not settled' if value is None else format(value, fmt)


def format_table(results: List[StepResult]) -> str:
    """Return the results next to seed 001's table, as text."""
    lines = ['| # | Kp | Ki | Kv | SS error [rad] | overshoot [rad] | settling [s] '
             '|| seed: SS error | overshoot | settling |',
             '|---|---|---|---|---|---|---||---|---|---|']
    seed = {g: rest for g, *rest in SEED_TABLE}
    for k, res in enumerate(results, 1):
        s = seed[res.gains]
        lines.append(f'| {k} | {res.gains[0]} | {res.gains[1]} | {res.gains[2]} | '
                     f'{_fmt(res.steady_state_error, ".4f")} | {res.overshoot:.4f} | '
                     f'{_fmt(res.settling_time, ".2f")} || {s[0]} | {s[1]} | {s[2]} |')
    return '\n'.join(lines)


def plot(runs: Sequence[Tuple[str, List[StepResult]]], path: str) -> None:
    """
    Write a PNG with the six step responses of one or more plants.

    :param runs: [(label, results)]; each response is drawn as the fraction of its step
        covered, (y - start) / (target - start), so plants with different steps share axes
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5), sharey=True)
    seed = {g: rest for g, *rest in SEED_TABLE}
    for j, ax in enumerate(axes.ravel()):
        gains = runs[0][1][j].gains
        band = SETTLING_BAND
        ax.axhspan(1 - band, 1 + band, color='0.88', zorder=0)
        ax.axhline(1.0, color='k', ls='--', lw=1)
        lines = []
        for (label, results), color in zip(runs, ('tab:blue', 'tab:orange', 'tab:green')):
            res = results[j]
            ax.plot(res.t, (res.y - res.start) / (res.target - res.start), lw=1.5,
                    color=color, label=label)
            lines.append(f'{label.split(" (")[0]}: ss {_fmt(res.steady_state_error, "+.3f")}, os '
                         f'{res.overshoot:.3f}, {_fmt(res.settling_time, ".2f")} s')
        s = seed[gains]
        lines.append(f'seed 001 table: ss {s[0]}, os {s[1]}, {s[2]}')
        ax.set_xlim(0, min(max(r[j].t[-1] for _, r in runs), 8.0 if gains[1] else 3.0))
        ax.set_title(f'Kp {gains[0]}  Ki {gains[1]}  Kv {gains[2]}', fontsize=10)
        ax.text(0.98, 0.04, '\n'.join(lines), transform=ax.transAxes, ha='right',
                va='bottom', fontsize=7, bbox={'facecolor': 'white', 'alpha': 0.85, 'lw': 0})
        ax.set_xlabel('time after the step [s]')
        ax.grid(True, alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel('fraction of the step covered')
    axes[0, 0].legend(loc='center right', fontsize=8)
    axes[0, 0].set_ylim(-0.05, 1.35)
    fig.suptitle('Seed 001 PID gain sets on the simulated px100 (XL430 register gains, 1 kHz); '
                 'ss/os in rad, settling in s', fontsize=11)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    """Run the experiment, print the table and the pattern checks, write the PNG."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0].strip())
    parser.add_argument('--duration', type=float, default=5.0,
                        help='seconds after the step (P/PD sets)')
    parser.add_argument('--integral-duration', type=float, default=30.0,
                        help='seconds after the step for the set with Ki > 0')
    parser.add_argument('--tune', action='store_true',
                        help='search the plant closest to the table (about a minute)')
    parser.add_argument('--out', default=os.path.join(ROOT, 'out', 'pid_experiment.png'))
    args = parser.parse_args(argv)
    model = load_robot('px100')
    tuned = TUNED
    if args.tune:
        t0 = time.monotonic()
        best, seen = tune(model, log=print)
        tuned = best.plant
        print(f'search: {len(seen)} plants in {time.monotonic() - t0:.0f} s; best score '
              f'{best.score:.2f}: {tuned.describe()}')
    ok = True
    runs = []
    for label, plant in (('physical', PHYSICAL), ('tuned', tuned)):
        results = run_experiment(args.duration, args.integral_duration, plant, model)
        runs.append((label, results))
        print(f'\n{label} plant: {plant.describe()}; score {score(results):.2f}')
        print(format_table(results))
        for claim, holds in pattern_checks(results):
            print(f"[{'ok' if holds else 'NO'}] {claim}")
            ok &= holds or label == 'physical'
    plot(runs, args.out)
    print(f'wrote {args.out}')
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
