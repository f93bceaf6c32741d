"""
Physics step cost side by side: the MuJoCo engine with an object held vs the old exact step.

All at 1 kHz on the PX100, in one process, timed in interleaved rounds (A B C A B C ...) so a
busy machine slows every variant alike; the median round is reported:

- ``oracle_exact``: the hand-written plant (test/sim/oracle_simulator.py, imported by path:
  PID + servo + rigid-body dynamics every step, semi-implicit Euler), no objects, the arm moving
  between two poses and the gripper opening and closing;
- ``mujoco_empty``: ArmSimulator (PID + servo + MuJoCo) without a scene, same commands;
- ``mujoco_held``: ArmSimulator with the default scene ``pick_place`` after picking the red
  cube: the waist swings +-45 deg with the cube squeezed between the pads (contacts with the
  pads, the table under the other objects); the cube is checked to be still held at the end.

Per variant: microseconds per step (CPU time of this process) and the real-time factor
unthrottled (simulated seconds per CPU second). Writes ``benchmarks/results/physics.json``.
Usage (venv + install sourced): ``python benchmarks/bench_physics.py [--quick]``.
"""
import argparse
import importlib.util
import json
import math
import os
import statistics
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'physics.json')
ORACLE_DIR = os.path.join(ROOT, 'test', 'sim')
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

POSES = ([0.8, 0.3, -0.4, 0.6], [-0.8, -0.6, 0.5, -0.4])


def _load_oracle():
    """Return the oracle_simulator module of test/sim (by path; it imports oracle_dynamics)."""
    if ORACLE_DIR not in sys.path:
        sys.path.insert(0, ORACLE_DIR)
    spec = importlib.util.spec_from_file_location(
        'oracle_simulator', os.path.join(ORACLE_DIR, 'oracle_simulator.py'))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _moving(sim, model):
    """Return a step function: poses alternate every 1.5 s, the gripper opens and closes."""
    state = {'k': 0}
    names = list(model.joint_names)

    def step():
        k = state['k']
        if k % 1500 == 0:
            sim.command(names, POSES[(k // 1500) % 2])
            sim.command(['gripper'], effort=[0.4 if (k // 1500) % 2 else -0.4])
        sim.step()
        state['k'] = k + 1
    return step


def _held(model):
    """Return (sim, step function) with the red cube picked and the waist swinging."""
    from px100_control.control.simulator import ArmSimulator
    from px100_control.kinematics.rotations import euler_sxyz_to_matrix
    from px100_control.kinematics.solve import solve_ik
    from px100_control.sim.scene import load_scene
    sim = ArmSimulator(model, scene=load_scene('pick_place', model))
    names = list(model.joint_names)

    def ik(p):
        T = np.eye(4)
        T[:3, :3] = euler_sxyz_to_matrix(0.0, math.pi / 2, math.atan2(p[1], p[0]))
        T[:3, 3] = p
        return solve_ik(model, T, mode='pitch', q_seed=sim.positions()).q

    def move(q1, duration):
        q0 = sim.positions()
        for k in range(int(duration / sim.dt) + 200):
            if k % 5 == 0:
                s = min(k * sim.dt / duration, 1.0)
                b = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5
                sim.command(names, list(q0 + b * (q1 - q0)))
            sim.step()

    p0 = np.array(sim.object_poses()['red_cube'][0])
    sim.command(['gripper'], effort=[0.4])
    sim.advance(1500)
    move(ik(p0 + [0.0, 0.0, 0.06]), 1.5)
    move(ik(p0), 1.0)
    sim.command(['gripper'], effort=[-0.4])
    sim.advance(2500)
    move(ik(p0 + [0.0, 0.0, 0.06]), 1.0)
    if sim.held_object() != 'red_cube':
        raise RuntimeError('the benchmark pick failed: nothing held')
    q_mid = sim.positions()
    state = {'k': 0}

    def step():
        k = state['k']
        if k % 5 == 0:      # waist +-45 deg at 0.25 Hz, setpoints at 200 Hz
            q = q_mid.copy()
            q[0] += math.pi / 4 * math.sin(2 * math.pi * 0.25 * k * 1e-3)
            sim.command(names, list(q))
        sim.step()
        state['k'] = k + 1
    return sim, step


def _time(step, steps: int) -> float:
    """Return CPU microseconds per call of step over ``steps`` calls."""
    t0 = time.process_time()
    for _ in range(steps):
        step()
    return (time.process_time() - t0) / steps * 1e6


def run(quick: bool = False) -> dict:
    """Return the benchmark figures (run_all.py interface; quick: 1 s per round, 3 rounds)."""
    return measure(1.0, 3) if quick else measure(3.0, 5)


def measure(seconds: float, rounds: int) -> dict:
    """Return the benchmark figures (see the module docstring)."""
    from px100_control.control.simulator import ArmSimulator
    from px100_control.models.registry import load_robot
    model = load_robot('px100')
    oracle = _load_oracle()
    old = oracle.ArmSimulator(model, oracle.SimConfig(dynamics_divider=1))
    new = ArmSimulator(model)
    held_sim, held_step = _held(model)
    variants = {'oracle_exact': _moving(old, model), 'mujoco_empty': _moving(new, model),
                'mujoco_held': held_step}
    steps = int(seconds * 1000)
    for step in variants.values():            # warm up
        _time(step, 200)
    samples = {name: [] for name in variants}
    for _ in range(rounds):
        for name, step in variants.items():
            samples[name].append(_time(step, steps))
    out = {'load_average': os.getloadavg(), 'steps_per_round': steps, 'rounds': rounds,
           'still_held_at_end': held_sim.held_object()}
    for name, values in samples.items():
        us = statistics.median(values)
        out[name] = {'us_per_step': round(us, 2), 'real_time_factor': round(1e3 / us, 1),
                     'rounds_us': [round(v, 2) for v in values]}
    out['held_vs_oracle'] = round(out['mujoco_held']['us_per_step']
                                  / out['oracle_exact']['us_per_step'], 3)
    return out


def main(argv=None) -> int:
    """Run, print the table and write benchmarks/results/physics.json."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='1 s per round, 3 rounds')
    args = parser.parse_args(argv)
    result = run(args.quick)
    print(f"load average {result['load_average']}")
    print(f"{'variant':<14} {'us/step':>9} {'x real time':>12}")
    for name in ('oracle_exact', 'mujoco_empty', 'mujoco_held'):
        r = result[name]
        print(f"{name:<14} {r['us_per_step']:>9.1f} {r['real_time_factor']:>12.1f}")
    print(f"held / oracle cost: {result['held_vs_oracle']:.2f}; still held at the end: "
          f"{result['still_held_at_end']}")
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)
    with open(RESULTS, 'w', encoding='utf-8') as f:
        json.dump(result, f, indent=2)
    ok = result['still_held_at_end'] == 'red_cube'
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
