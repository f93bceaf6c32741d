"""
IK per robot model: success rate and solve time, closed form vs iterative, on reachable targets.

For every registered robot: N random in-limit configurations give N full-pose targets (so every
target is reachable within the limits). Each is solved by ``solve_ik`` with
method='analytic' (the robot's closed-form plug-in, FK-verified, limits filtered), and on a
subset with the iterative methods 'dls' and 'newton' (seed 003's Newton-Raphson), all to
1e-9 m / 1e-9 rad. The plug-in's ``candidates()`` alone is timed too. Figures: success rate,
median and 95th percentile wall time per solve [us]. Writes ``benchmarks/results/robots.json``.
Usage: ``python benchmarks/bench_robots.py [--quick] [--robots px100,rrrp]``.
"""
import argparse
import json
import os
import platform
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'robots.json')


def _stats(times_s, ok) -> dict:
    t = np.asarray(times_s) * 1e6
    return {'n': int(len(t)), 'success_rate': float(np.mean(ok)) if len(ok) else float('nan'),
            'median_us': float(np.median(t)) if len(t) else float('nan'),
            'p95_us': float(np.percentile(t, 95)) if len(t) else float('nan')}


def _bench_robot(name: str, n_analytic: int, n_iterative: int, seed: int) -> dict:
    from px100_control.kinematics.analytic import get_solver
    from px100_control.kinematics.solve import solve_ik
    from px100_control.models.registry import load_robot
    m = load_robot(name)
    rng = np.random.default_rng(seed)
    Q = m.random_configurations(n_analytic, rng=rng)
    targets = [m.fk(q) for q in Q]
    out = {'dof': m.dof, 'analytic_module': m.analytic_ik}
    module = get_solver(m.analytic_ik)
    times, counts = [], []
    for T in targets:
        t0 = time.perf_counter()
        C = module.candidates(m, T, 'full')
        times.append(time.perf_counter() - t0)
        counts.append(len(C))
    out['candidates'] = _stats(times, [c > 0 for c in counts])
    out['candidates']['mean_count'] = float(np.mean(counts))
    for method, n in (('analytic', n_analytic), ('dls', n_iterative), ('newton', n_iterative)):
        times, ok, iters = [], [], []
        for T in targets[:n]:
            t0 = time.perf_counter()
            res = solve_ik(m, T, mode='full', method=method)
            times.append(time.perf_counter() - t0)
            ok.append(res.success)
            iters.append(res.iterations)
        out[method] = _stats(times, ok)
        if method != 'analytic':
            out[method]['median_iterations'] = float(np.median(iters))
    return out


def _markdown(results: dict) -> str:
    rows = ['| robot | DOF | closed form | candidates() median us | solve_ik success | '
            'median us | p95 us | DLS success | median us | p95 us | Newton success | '
            'median us | p95 us |',
            '| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |']
    for name, r in results.items():
        a, d, n = r['analytic'], r['dls'], r['newton']
        rows.append(f"| {name} | {r['dof']} | {r['analytic_module']} | "
                    f"{r['candidates']['median_us']:.0f} | "
                    f"{100 * a['success_rate']:.1f} % | {a['median_us']:.0f} | "
                    f"{a['p95_us']:.0f} | {100 * d['success_rate']:.1f} % | "
                    f"{d['median_us']:.0f} | {d['p95_us']:.0f} | "
                    f"{100 * n['success_rate']:.1f} % | {n['median_us']:.0f} | "
                    f"{n['p95_us']:.0f} |")
    return '\n'.join(rows)


def run(quick: bool = False, robots=None, log=print) -> dict:
    """
    Benchmark every robot (or ``robots``) and write benchmarks/results/robots.json.

    :param quick: 100 analytic / 20 iterative targets per robot instead of 1,000 / 200
    :return: {'robots': {name: figures}, 'markdown': table, sizes}
    """
    from px100_control.models.registry import available_robots
    n_analytic, n_iterative = (100, 20) if quick else (1000, 200)
    names = robots or available_robots()
    results = {}
    for i, name in enumerate(names):
        t0 = time.monotonic()
        results[name] = _bench_robot(name, n_analytic, n_iterative, seed=1000 + i)
        r = results[name]
        log(f"{name}: analytic {100 * r['analytic']['success_rate']:.1f} % "
            f"{r['analytic']['median_us']:.0f} us, dls {100 * r['dls']['success_rate']:.1f} % "
            f"{r['dls']['median_us']:.0f} us, newton {100 * r['newton']['success_rate']:.1f} % "
            f"{r['newton']['median_us']:.0f} us ({time.monotonic() - t0:.1f} s)")
    figures = {'targets_analytic': n_analytic, 'targets_iterative': n_iterative,
               'tolerance': '1e-9 m, 1e-9 rad', 'robots': results,
               'markdown': _markdown(results)}
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)
    with open(RESULTS, 'w') as f:
        machine = (f'{platform.processor() or platform.machine()}, {os.cpu_count()} cores, '
                   f'Python {platform.python_version()}')
        json.dump(dict(figures, load_average=os.getloadavg(), machine=machine, quick=quick),
                  f, indent=2)
    return figures


def main(argv=None) -> int:
    """Run the benchmark, print the table and write benchmarks/results/robots.json."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='reduced sizes')
    parser.add_argument('--robots', default='', help='comma-separated robot models')
    options = parser.parse_args(argv)
    robots = [r for r in options.robots.split(',') if r] or None
    figures = run(quick=options.quick, robots=robots)
    print(figures['markdown'])
    print(f'wrote {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
