"""
Physics speed side by side, in one run: the 1 kHz step and the unthrottled ``sim_driver``.

1. Step cost, all at 1 kHz on the PX100 in this process, timed in interleaved rounds
   (A B C A B C ...) so a busy machine slows every variant alike; the median round is reported:

   - ``oracle_exact``: the former hand-written plant (test/sim/oracle_simulator.py, imported by
     path: PID + servo + rigid-body dynamics every step, semi-implicit Euler), no objects, the
     arm moving between two poses and the gripper opening and closing;
   - ``mujoco_empty``: ArmSimulator (PID + servo + MuJoCo) without a scene, same commands;
   - ``mujoco_held``: ArmSimulator with the default scene ``pick_place`` after picking the red
     cube: the waist swings +-45 deg with the cube squeezed between the pads (contacts with the
     pads, the table under the other objects); the cube is checked to be still held at the end;
   - ``mujoco_scene_idle``: ArmSimulator with ``pick_place``, the arm holding its sleep pose and
     the objects resting on the table: the driver's work below (part 2) without ROS, so the
     driver's figure can be read against it.

   Per variant: microseconds per step (CPU time of this process) and simulated seconds per CPU
   second.
2. ``sim_driver``: the installed executable at ``real_time_factor`` 0 (as fast as possible;
   joint_states at 100 Hz and /clock at 250 Hz of simulated time, world/markers at 30 Hz; the
   arm holding its sleep pose, the objects resting on the table), with the default scene
   ``pick_place`` and with ``scene:=''``, in alternating windows: simulated seconds per wall
   second (read from /clock by a subscriber in this process, best effort with depth 1 as every
   use_sim_time node reads it) and per CPU second of the driver
   process (all its threads, from /proc), the median window of each. On a shared machine the
   wall figure follows what else runs; the CPU figure is the fairer one.

The load average and the busy share of the machine's CPUs (/proc/stat) are stored with the
figures, the driver's rate against bare stepping of its scene (paired in time), and whether the
issue's goals are met: the held step costs no more than the former exact step, and the driver
with the default scene runs at least 20x real time. CPU seconds are fairer than wall seconds on
a shared machine but not load-free: with both cores busy a CPU second does less work. Writes
``benchmarks/results/physics.json`` (also when run by run_all.py).
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

import bound
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'physics.json')
#: the run's bound [s] with --quick and without: past it the run fails naming its stage
BOUND_S = (180.0, 600.0)
ORACLE_DIR = os.path.join(ROOT, 'test', 'sim')
for path in (ROOT, os.path.join(ROOT, 'benchmarks')):
    if path not in sys.path:
        sys.path.insert(0, path)

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
    from px100_control.sim.simulator import ArmSimulator
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
    """
    Return the figures and their table, and write them to physics.json.

    The run_all.py interface (quick: shorter rounds and windows).
    """
    result = measure(1.0, 3, 3.0, 1) if quick else measure(2.0, 5, 5.0, 3)
    result['quick'] = quick
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)
    with open(RESULTS, 'w', encoding='utf-8') as f:
        json.dump(result, f, indent=2)
    result['markdown'] = _table(result)
    return result


def _steps(seconds: float, rounds: int) -> dict:
    """Return the step-cost figures (see the module docstring, part 1)."""
    from px100_control.sim.simulator import ArmSimulator
    from px100_control.models.registry import load_robot
    from px100_control.sim.scene import load_scene
    model = load_robot('px100')
    oracle = _load_oracle()
    old = oracle.ArmSimulator(model, oracle.SimConfig(dynamics_divider=1))
    new = ArmSimulator(model)
    held_sim, held_step = _held(model)
    idle = ArmSimulator(model, scene=load_scene('pick_place', model))
    variants = {'oracle_exact': _moving(old, model), 'mujoco_empty': _moving(new, model),
                'mujoco_held': held_step, 'mujoco_scene_idle': idle.step}
    steps = int(seconds * 1000)
    for step in variants.values():            # warm up
        _time(step, 200)
    samples = {name: [] for name in variants}
    for _ in range(rounds):
        for name, step in variants.items():
            samples[name].append(_time(step, steps))
    out = {'steps_per_round': steps, 'rounds': rounds,
           'still_held_at_end': held_sim.held_object()}
    for name, values in samples.items():
        us = statistics.median(values)
        out[name] = {'us_per_step': round(us, 2), 'sim_s_per_cpu_s': round(1e3 / us, 1),
                     'rounds_us': [round(v, 2) for v in values]}
    out['held_vs_oracle'] = round(out['mujoco_held']['us_per_step']
                                  / out['oracle_exact']['us_per_step'], 3)
    return out


def _driver(window: float, alternations: int) -> dict:
    """
    Return the unthrottled sim_driver figures, default scene and none (part 2).

    Before each window with the default scene, the same scene is stepped bare here (arm at
    sleep, no ROS) for a second: ``vs_bare_step`` is the driver's rate over that one, paired in
    time, the median of the pairs (the driver's overhead on the machine as it is then).
    """
    from bench_sim_driver import bench_unthrottled
    from px100_control.sim.simulator import ArmSimulator
    from px100_control.models.registry import load_robot
    from px100_control.sim.scene import load_scene
    model = load_robot('px100')
    bare = ArmSimulator(model, scene=load_scene('pick_place', model))
    runs, pairs = {'pick_place': [], 'none': []}, []
    for _ in range(alternations):
        for name in runs:
            if name == 'pick_place':
                bare_rate = 1.0 / (_time(bare.step, 1000) * 1e-3)   # sim s per CPU s
            runs[name].append(bench_unthrottled(window, name if name != 'none' else ''))
            if name == 'pick_place' and 'error' not in runs[name][-1]:
                pairs.append(runs[name][-1]['sim_s_per_driver_cpu_s'] / bare_rate)
    out = {}
    for name, windows in runs.items():
        good = [w for w in windows if 'error' not in w]
        if not good:
            out[name] = windows[-1]
            continue
        out[name] = {key: statistics.median(w[key] for w in good)
                     for key in ('sim_s_per_wall_s', 'sim_s_per_driver_cpu_s',
                                 'driver_cpu_share', 'machine_busy')}
        out[name]['windows'] = good
    if pairs:
        out['pick_place']['vs_bare_step'] = round(statistics.median(pairs), 2)
    return out


def measure(seconds: float, rounds: int, window: float, alternations: int) -> dict:
    """
    Return the figures (see the module docstring).

    :param seconds: simulated seconds per variant and round of the step costs
    :param rounds: step-cost rounds
    :param window: wall seconds of one sim_driver window
    :param alternations: sim_driver windows per scene
    """
    from bench_sim_driver import busy_share, machine_busy
    load0, busy0 = os.getloadavg(), machine_busy()
    out = {'steps': _steps(seconds, rounds),
           'sim_driver_unthrottled': _driver(window, alternations)}
    out['load_average'] = {'start': [round(v, 2) for v in load0],
                           'end': [round(v, 2) for v in os.getloadavg()]}
    out['machine_busy'] = busy_share(busy0, machine_busy())
    scene = out['sim_driver_unthrottled'].get('pick_place', {})
    out['cpu_count'] = os.cpu_count()
    out['goals'] = {
        'held_step_at_most_former_exact_step': out['steps']['held_vs_oracle'] <= 1.0,
        'sim_driver_default_scene_20x_per_cpu_s':
            scene.get('sim_s_per_driver_cpu_s', 0.0) >= 20.0,
        'sim_driver_default_scene_20x_per_wall_s': scene.get('sim_s_per_wall_s', 0.0) >= 20.0}
    return out


def _table(result: dict) -> str:
    """Return the figures as a Markdown table."""
    st, dr = result['steps'], result['sim_driver_unthrottled']
    rows = ['| physics speed, one run | value |', '| --- | --- |']
    for name in ('oracle_exact', 'mujoco_empty', 'mujoco_held', 'mujoco_scene_idle'):
        fig = st[name]
        rows.append(f'| 1 kHz step, {name}: µs (CPU) / simulated s per CPU s | '
                    f"{fig['us_per_step']} / {fig['sim_s_per_cpu_s']} |")
    rows.append(f"| held step / former exact step | {st['held_vs_oracle']} "
                f"(held at the end: {st['still_held_at_end']}) |")
    for name, label in (('pick_place', 'default scene pick_place'), ('none', 'no scene')):
        d = dr.get(name, {})
        rows.append(f'| sim_driver at real_time_factor 0, {label}: simulated s per driver '
                    f"CPU s / per wall s (driver's CPU share; machine busy) | "
                    f"{d.get('sim_s_per_driver_cpu_s')} / {d.get('sim_s_per_wall_s')} "
                    f"({d.get('driver_cpu_share')}; {d.get('machine_busy')}) |")
    ratio = dr.get('pick_place', {}).get('vs_bare_step')
    rows.append('| sim_driver (default scene) per CPU s / bare stepping of that scene per '
                f'CPU s just before each window | {ratio} |')
    load = result['load_average']
    rows.append(f"| load average 1/5/15 min at start, end ({result['cpu_count']} cores); "
                f"machine busy | {load['start']}, {load['end']}; {result['machine_busy']} |")
    rows.append(f"| goals met | {result['goals']} |")
    return '\n'.join(rows)


def main(argv=None) -> int:
    """Run, print the table and write benchmarks/results/physics.json."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='short rounds and windows')
    bound.add_argument(parser, *BOUND_S)
    args = parser.parse_args(argv)
    with bound.bounded('bench_physics', bound.seconds(args, args.quick)):
        result = run(args.quick)
    print(result['markdown'])
    print(f'wrote {RESULTS}')
    return 0 if result['steps']['still_held_at_end'] == 'red_cube' else 1


if __name__ == '__main__':
    sys.exit(main())
