"""
Client overhead: how close a blocking move returns to its moving_time, and IK through the client.

Against in-process nodes (``bringup=True``; ``--connect`` uses running ones), with the
Interbotix-compatible client:

- blocking ``set_joint_positions`` with moving_time 0.5 s between two poses: wall time from the
  call to its return (p50 / p95 / max) and the excess over 0.5 s. Interbotix sleeps exactly
  moving_time and never checks arrival; here the call returns when trajectory_server reports
  SUCCEEDED (the arm within its goal tolerance), so the excess is the settling + messaging cost;
- the non-blocking call's return time;
- ``set_ee_pose_matrix(execute=False)`` (IK through ``compute_ik``): latency and success rate on
  FK targets of random in-limit configurations (all reachable; Interbotix solves ~31 %).

Writes ``benchmarks/results/client.json``. Usage: ``python benchmarks/bench_client.py
[--quick] [--connect]``; needs the venv (``source scripts/env.sh``); uses ROS_DOMAIN_ID (a
private one is picked when unset).
"""
import argparse
import json
import os
import sys
import time

import bound
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'client.json')
#: the run's bound [s] with --quick and without: past it the run fails naming its stage
BOUND_S = (180.0, 600.0)
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
os.environ.setdefault('ROS_DOMAIN_ID', str(10 + os.getpid() % 90))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)

MOVING_TIME = 0.5
POSES = ([0.4, -0.3, 0.3, 0.2], [-0.4, 0.2, -0.2, -0.2])


def _stats(values) -> dict:
    a = np.asarray(values, dtype=float)
    return {'n': int(a.size), 'p50': float(np.percentile(a, 50)),
            'p95': float(np.percentile(a, 95)), 'max': float(a.max()), 'mean': float(a.mean())}


def run(quick: bool = False, connect: bool = False, bringup='thread', log=print) -> dict:
    """Measure the client; return the figures (seconds unless named otherwise)."""
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
    n_moves = 6 if quick else 30
    n_ik = 40 if quick else 300
    t0 = time.monotonic()
    bot = InterbotixManipulatorXS('px100', 'arm', 'gripper', moving_time=MOVING_TIME,
                                  accel_time=0.1, connect_timeout=30.0,
                                  bringup=False if connect else (
                                      'process' if bringup == 'process' else True))
    robot_startup()
    construct = time.monotonic() - t0
    try:
        bot.arm.go_to_home_pose(moving_time=2.0)
        bot.arm.set_joint_positions(POSES[1], moving_time=1.5)
        blocking, errors, failures, reasons = [], [], 0, []
        for i in range(n_moves):
            target = POSES[i % 2]
            t = time.monotonic()
            ok = bot.arm.set_joint_positions(target, moving_time=MOVING_TIME)
            blocking.append(time.monotonic() - t)
            if not ok:
                failures += 1
                reasons.append(bot.arm.last_error)
                bot.arm.set_joint_positions(target, moving_time=2.0)  # back on the script
            errors.append(float(np.max(np.abs(np.array(bot.arm.get_joint_positions())
                                              - target))))
        log(f'blocking set_joint_positions({MOVING_TIME} s): p50 {np.median(blocking):.3f} s')
        nonblocking = []
        for i in range(min(n_moves, 10)):
            t = time.monotonic()
            bot.arm.set_joint_positions(POSES[i % 2], moving_time=MOVING_TIME, blocking=False)
            nonblocking.append(time.monotonic() - t)
            bot.arm.wait_for_last_goal()
        model = bot.core.model
        rng = np.random.default_rng(2024)
        Q = model.random_configurations(n_ik, rng, margin=0.02)
        ik_times, ik_ok, ik_err = [], 0, []
        for q in Q:
            T = model.fk(q)
            t = time.monotonic()
            theta, ok = bot.arm.set_ee_pose_matrix(T, execute=False, moving_time=60.0)
            ik_times.append(time.monotonic() - t)
            if ok:
                ik_ok += 1
                ik_err.append(float(np.linalg.norm(model.fk(theta)[:3, 3] - T[:3, 3])))
        log(f'IK through the client: {ik_ok}/{n_ik} solved, p50 {np.median(ik_times) * 1e3:.2f}'
            ' ms')
    finally:
        robot_shutdown()
    rtf = bot.core.real_time_factor
    expected = MOVING_TIME / rtf
    block = _stats(blocking)
    return {
        'setup': 'running nodes' if connect else f'bringup ({bringup})',
        'load_average_1min': os.getloadavg()[0],
        'construct_s': construct,
        'moving_time_s': MOVING_TIME,
        'real_time_factor': rtf,
        'expected_wall_s': expected,
        'blocking_return_s': block,
        'blocking_excess_over_moving_time_s': {k: (v - expected if k != 'n' else v)
                                               for k, v in block.items()},
        'blocking_failures': failures,
        'blocking_failure_reasons': reasons[:3],
        'final_joint_error_rad_max': float(max(errors)),
        'nonblocking_return_s': _stats(nonblocking),
        'ik_execute_false_s': _stats(ik_times),
        'ik_success_rate': ik_ok / n_ik,
        'ik_targets': n_ik,
        'ik_position_error_m_max': float(max(ik_err)) if ik_err else None,
    }


def main(argv=None) -> int:
    """Run the benchmark and write benchmarks/results/client.json."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='fewer samples (smoke run)')
    parser.add_argument('--connect', action='store_true', help='use nodes already running')
    parser.add_argument('--bringup', choices=('thread', 'process'), default='thread',
                        help='nodes as threads of this process (default) or child processes')
    bound.add_argument(parser, *BOUND_S)
    args = parser.parse_args(argv)
    with bound.bounded('bench_client', bound.seconds(args, args.quick)):
        figures = run(quick=args.quick, connect=args.connect, bringup=args.bringup,
                      log=bound.log)
    figures['quick'] = args.quick
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)
    with open(RESULTS, 'w', encoding='utf-8') as f:
        json.dump(figures, f, indent=2)
    print(json.dumps(figures, indent=2))
    print(f'wrote {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
