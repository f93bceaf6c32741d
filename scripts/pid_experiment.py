#!/usr/bin/env python3
"""
Seed 001's PID experiment on the simulated PX100: six gain sets, one shoulder step under gravity.

Seed 001 tuned a position PID with six (Kp, Ki, Kv) sets, DYNAMIXEL register units, and reported
steady-state error, overshoot and settling time. This script runs the same six sets on
:class:`px100_control.control.simulator.ArmSimulator` (URDF rigid-body dynamics, XL430 servo
model, 1 kHz): the arm starts at ``POSE``, the stepped joint already under the tested gains (so
it has sagged), then the shoulder setpoint steps by ``STEP``; the other joints hold with the
default gains. It prints the table next to the seed's and writes ``out/pid_experiment.png``.

Metrics, on the stepped joint's measured angle y(t), target r, step s (sign = direction):
- steady-state error: (r - mean of y over the last 0.2 s) * sign(s): > 0 short of the target;
- overshoot: largest excursion beyond r in the step direction (>= 0) [rad];
- settling time: last time y is outside +-2 % of |s| around its final value [s].

Usage: python3 scripts/pid_experiment.py [--duration S] [--integral-duration S] [--out PNG]
"""
import argparse
from dataclasses import dataclass
import os
import sys
from typing import List, Sequence, Tuple

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from px100_control.control.pid import PidGains  # noqa: E402
from px100_control.control.simulator import ArmSimulator, SimConfig  # noqa: E402
from px100_control.models.registry import load_robot  # noqa: E402

#: seed 001's gain sets (Kp, Ki, Kv) in DYNAMIXEL register units and its reported results
SEED_TABLE = [
    ((100, 0, 0), '~0.05 rad', 'None', '~2 s'),
    ((100, 7, 0), 'None', 'None', '~1 s'),
    ((640, 0, 0), '~0', '0.1 rad', '<1 s'),
    ((1600, 0, 0), '~0', '0.1 rad', '~1 s'),
    ((640, 0, 2000), 'None', 'Minimal', '~0.5 s'),
    ((640, 0, 4000), 'None', 'Essentially none', '<1 s'),
]
#: start pose [waist, shoulder, elbow, wrist_angle] (rad): upper arm tilted back 0.5 rad,
#: elbow and wrist bent 0.3 rad; the gripper is 0.19 m out in front, 0.21 m up
POSE = (0.0, -0.5, 0.3, 0.3)
#: stepped joint and step [rad]: swing the shoulder 0.5 rad further back, lifting the arm
#: against gravity all the way (shoulder gravity torque 0.22 -> 0.04 N*m, never reversing)
JOINT = 'shoulder'
STEP = -0.5
SETTLE_BEFORE = 3.0
SETTLING_BAND = 0.02


@dataclass
class StepResult:
    """One gain set's response and metrics (rad, s)."""

    gains: Tuple[int, int, int]
    t: np.ndarray
    y: np.ndarray
    target: float
    steady_state_error: float
    overshoot: float
    settling_time: float


def step_metrics(t: np.ndarray, y: np.ndarray, target: float, step: float):
    """Return (steady-state error, overshoot, settling time) of a step response."""
    sign = 1.0 if step >= 0 else -1.0
    tail = y[t >= t[-1] - 0.2]
    final = float(np.mean(tail))
    sse = (target - final) * sign
    overshoot = max(0.0, float(np.max((y - target) * sign)))
    outside = np.nonzero(np.abs(y - final) > SETTLING_BAND * abs(step))[0]
    settling = float(t[outside[-1] + 1]) if len(outside) and outside[-1] + 1 < len(t) else (
        float(t[-1]) if len(outside) else 0.0)
    return sse, overshoot, settling


def step_response(gains: Sequence[int], duration: float, model=None, pose=POSE, joint=JOINT,
                  step=STEP, control_rate: float = 1000.0,
                  dynamics_divider: int = 1) -> StepResult:
    """Simulate one gain set (register units) and return its StepResult (exact dynamics)."""
    model = model or load_robot('px100')
    sim = ArmSimulator(model, SimConfig(control_rate=control_rate,
                                        dynamics_divider=dynamics_divider))
    k = model.joint_names.index(joint)
    p, i, d = gains
    sim.set_gains(joint, PidGains.from_dynamixel(p, i, d, i_clamp=1.4, u_clamp=1.4))
    sim.hold(pose)            # at rest, the other joints' integrators holding the weight
    sim.pids[k].reset()       # the tested loop starts from zero, and sags if it must
    sim.advance(int(round(SETTLE_BEFORE * control_rate)))
    target = pose[k] + step
    sim.command([joint], [target])
    n = int(round(duration * control_rate))
    y = np.empty(n)
    for s in range(n):
        sim.step()
        y[s] = sim.q[k]
    t = np.arange(1, n + 1) / control_rate
    return StepResult(tuple(gains), t, y, target, *step_metrics(t, y, target, step))


def run_experiment(duration: float = 5.0, integral_duration: float = 30.0) -> List[StepResult]:
    """Run the six gain sets (the integral set for integral_duration) and return the results."""
    model = load_robot('px100')
    return [step_response(g, integral_duration if g[1] else duration, model)
            for g, *_ in SEED_TABLE]


def pattern_checks(results: List[StepResult]) -> List[Tuple[str, bool]]:
    """Return the seed table's qualitative claims and whether the results show each."""
    r = {res.gains: res for res in results}
    p100, pi, p640, p1600 = r[(100, 0, 0)], r[(100, 7, 0)], r[(640, 0, 0)], r[(1600, 0, 0)]
    d2000, d4000 = r[(640, 0, 2000)], r[(640, 0, 4000)]
    return [
        ('P alone (Kp 100) leaves a steady-state error', p100.steady_state_error > 0.05),
        ('the integral (Ki 7) removes it',
         abs(pi.steady_state_error) < 0.1 * p100.steady_state_error),
        ('more P leaves less error', abs(p640.steady_state_error) < p100.steady_state_error / 3
         and abs(p1600.steady_state_error) <= abs(p640.steady_state_error) + 0.005),
        ('more P overshoots', p1600.overshoot > max(0.01, 2.0 * p640.overshoot)
         and p640.overshoot >= p100.overshoot),
        ('D removes the overshoot', max(d2000.overshoot, d4000.overshoot)
         <= min(0.002, p640.overshoot)),
        ('D shortens settling', d2000.settling_time < p1600.settling_time),
    ]


def format_table(results: List[StepResult]) -> str:
    """Return the results next to seed 001's table, as text."""
    lines = ['| # | Kp | Ki | Kv | SS error [rad] | overshoot [rad] | settling [s] '
             '|| seed: SS error | overshoot | settling |',
             '|---|---|---|---|---|---|---||---|---|---|']
    seed = {g: rest for g, *rest in SEED_TABLE}
    for k, res in enumerate(results, 1):
        s = seed[res.gains]
        lines.append(f'| {k} | {res.gains[0]} | {res.gains[1]} | {res.gains[2]} | '
                     f'{res.steady_state_error:.4f} | {res.overshoot:.4f} | '
                     f'{res.settling_time:.2f} || {s[0]} | {s[1]} | {s[2]} |')
    return '\n'.join(lines)


def plot(results: List[StepResult], path: str) -> None:
    """Write a PNG with the six step responses."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 3, figsize=(13, 7), sharey=True)
    for ax, res in zip(axes.ravel(), results):
        ax.plot(res.t, res.y, lw=1.5, label='shoulder')
        ax.axhline(res.target, color='k', ls='--', lw=1, label='setpoint')
        band = SETTLING_BAND * abs(STEP)
        ax.axhspan(res.target - band, res.target + band, color='0.85', zorder=0)
        ax.set_xlim(0, min(res.t[-1], 5.0) if res.gains[1] == 0 else res.t[-1])
        ax.set_title(f'Kp {res.gains[0]}  Ki {res.gains[1]}  Kv {res.gains[2]}\n'
                     f'ss {res.steady_state_error:+.3f} rad, overshoot {res.overshoot:.3f} '
                     f'rad, settle {res.settling_time:.2f} s', fontsize=9)
        ax.set_xlabel('time after the step [s]')
        ax.grid(True, alpha=0.3)
    axes[0, 0].set_ylabel('shoulder angle [rad]')
    axes[1, 0].set_ylabel('shoulder angle [rad]')
    axes[0, 0].legend(loc='best', fontsize=8)
    fig.suptitle(f'PX100 shoulder step {STEP:+.1f} rad from {list(POSE)} under gravity, '
                 'XL430 register gains (simulated, 1 kHz)')
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
    parser.add_argument('--out', default=os.path.join(ROOT, 'out', 'pid_experiment.png'))
    args = parser.parse_args(argv)
    results = run_experiment(args.duration, args.integral_duration)
    print(format_table(results))
    ok = True
    for claim, holds in pattern_checks(results):
        print(f"[{'ok' if holds else 'NO'}] {claim}")
        ok &= holds
    plot(results, args.out)
    print(f'wrote {args.out}')
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
