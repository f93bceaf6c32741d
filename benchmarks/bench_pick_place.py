"""
The verified pick-and-place demo, N seeded runs with the objects' initial poses jittered.

Each run is ``scripts/pick_and_place_demo.py --jitter 0.005 --seed k`` in a fresh process (its
own in-process nodes, real time): the objects start up to 5 mm (uniform in x and y) away from
the scene file's positions, the demo reads where they are from the world, picks them by contact
and places them; a run succeeds when all 3 objects end within 10 mm of their targets. Reports
the success rate, the per-object error distribution and the run times, and writes
``benchmarks/results/pick_place.json``. Usage: ``python benchmarks/bench_pick_place.py
[--runs 20] [--first-seed 0] [--jitter 0.005] [--bag] [--real-time-factor R]``;
``run(quick)`` for run_all.py (quick: 3 runs).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import bound

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
#: the bound [s] of a run of N demos: BOUND_FIXED_S + N * BOUND_PER_RUN_S (a demo takes ~33 s)
BOUND_FIXED_S, BOUND_PER_RUN_S = 60.0, 150.0
#: the run's bound [s] with --quick (3 demos) and without (20): past it the run fails
BOUND_S = (BOUND_FIXED_S + 3 * BOUND_PER_RUN_S, BOUND_FIXED_S + 20 * BOUND_PER_RUN_S)
DEMO = os.path.join(ROOT, 'scripts', 'pick_and_place_demo.py')


def run_once(seed: int, jitter: float, out_dir: str, bag: bool = False,
             timeout: float = 600.0, extra=()) -> dict:
    """Run the demo once; return its JSON outcome plus 'exit_code' and 'wall_s'."""
    path = os.path.join(out_dir, f'run_{seed}.json')
    args = [sys.executable, DEMO, '--jitter', str(jitter), '--seed', str(seed), '--out',
            out_dir, '--no-plots', '--json', path] + ([] if bag else ['--no-bag']) + list(extra)
    t0 = time.monotonic()
    proc = subprocess.run(args, capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, MPLBACKEND='Agg'))
    wall = time.monotonic() - t0
    try:
        with open(path, encoding='utf-8') as f:
            result = json.load(f)
    except (OSError, ValueError):
        result = {'objects': [], 'error': (proc.stdout + proc.stderr)[-2000:]}
    result.update(exit_code=proc.returncode, wall_s=wall, seed=seed)
    if proc.returncode != 0:
        result['output_head'] = proc.stdout[:3000]
        result['output_tail'] = (proc.stdout + proc.stderr)[-3000:]
    return result


def summarize(results) -> dict:
    """Return the success rate, error statistics [mm] and timings of a list of run results."""
    errors = [o['error'] for r in results for o in r['objects']]
    ok = [r for r in results if r['exit_code'] == 0 and r['objects']
          and all(o['verdict'] == 'placed' for o in r['objects'])]
    verdicts = {}
    for r in results:
        for o in r['objects']:
            verdicts[o['verdict']] = verdicts.get(o['verdict'], 0) + 1
    errors.sort()
    return {
        'runs': len(results), 'successful_runs': len(ok),
        'objects': len(errors), 'verdicts': verdicts,
        'error_mm_median': 1000 * errors[len(errors) // 2] if errors else None,
        'error_mm_max': 1000 * errors[-1] if errors else None,
        'run_s_median': sorted(r['wall_s'] for r in results)[len(results) // 2],
        'failed_seeds': [r['seed'] for r in results if r not in ok],
    }


def run(quick: bool = False, runs: int = 20, first_seed: int = 0, jitter: float = 0.005,
        bag: bool = False, real_time_factor: float = 1.0) -> dict:
    """Run the benchmark; return the summary (with a Markdown table) and per-run results."""
    n = 3 if quick else runs
    results = []
    with tempfile.TemporaryDirectory(prefix='px100_pick_place_') as out_dir:
        for seed in range(first_seed, first_seed + n):
            bound.stage(f'demo run {seed - first_seed + 1} of {n} (seed {seed})')
            r = run_once(seed, jitter, out_dir, bag=bag,
                         extra=['--real-time-factor', str(real_time_factor)])
            results.append(r)
            worst = max((o['error'] for o in r['objects']), default=float('nan'))
            print(f"seed {seed}: exit {r['exit_code']}, "
                  + ', '.join(f"{o['name']} {o['verdict']} {1000 * o['error']:.1f} mm"
                              for o in r['objects'])
                  + f' (worst {1000 * worst:.1f} mm, {r["wall_s"]:.0f} s)', flush=True)
    summary = summarize(results)
    summary['jitter_m'] = jitter
    summary['real_time_factor'] = real_time_factor
    summary['markdown'] = (
        '| runs | 3/3 placed within 10 mm | verdicts | error median / max [mm] | run [s] |\n'
        '| --- | --- | --- | --- | --- |\n'
        f"| {summary['runs']} (jitter +-{1000 * jitter:g} mm, seeds {first_seed}.."
        f"{first_seed + n - 1}) | {summary['successful_runs']}/{summary['runs']} | "
        f"{summary['verdicts']} | {summary['error_mm_median']:.1f} / "
        f"{summary['error_mm_max']:.1f} | {summary['run_s_median']:.0f} |")
    summary['results'] = results
    return summary


def main() -> int:
    """Command line: run, print the summary, write results/pick_place.json."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--runs', type=int, default=20)
    parser.add_argument('--first-seed', type=int, default=0)
    parser.add_argument('--jitter', type=float, default=0.005)
    parser.add_argument('--bag', action='store_true', help='record a bag in every run')
    parser.add_argument('--real-time-factor', type=float, default=1.0,
                        help='simulation speed of the demo (< 1 on a loaded machine)')
    parser.add_argument('--bound', type=float, default=None, metavar='SECONDS',
                        help=f'fail if the run takes longer (default {BOUND_FIXED_S:.0f} s + '
                             f'{BOUND_PER_RUN_S:.0f} s per run)')
    args = parser.parse_args()
    limit = args.bound or BOUND_FIXED_S + BOUND_PER_RUN_S * args.runs
    with bound.bounded('bench_pick_place', limit):
        summary = run(runs=args.runs, first_seed=args.first_seed, jitter=args.jitter,
                      bag=args.bag, real_time_factor=args.real_time_factor)
    print(summary['markdown'])
    os.makedirs(os.path.join(HERE, 'results'), exist_ok=True)
    summary['date'] = time.strftime('%Y-%m-%d %H:%M')
    with open(os.path.join(HERE, 'results', 'pick_place.json'), 'w', encoding='utf-8') as f:
        json.dump(summary, f, indent=1)
    return 0 if summary['successful_runs'] >= 0.95 * summary['runs'] else 1


if __name__ == '__main__':
    sys.exit(main())
