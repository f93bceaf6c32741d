"""
IK per robot model: success rate and solve time, closed form vs iterative, on reachable targets.

For every registered robot: N random in-limit configurations give N full-pose targets (so every
target is reachable within the limits). Each is solved by ``solve_ik`` with
method='analytic' (the robot's closed-form plug-in, FK-verified, limits filtered), and on a
subset with the iterative methods 'dls' and 'newton' (seed 003's Newton-Raphson), all to
1e-9 m / 1e-9 rad. The plug-in's ``candidates()`` alone is timed too. Figures: success rate,
median and 95th percentile wall time per solve [us]. Writes ``benchmarks/results/robots.json``.

``--vs-ik-lm``: the default path users call, ``solve_ik(model, T)`` (method 'auto', with its
input checks), against tuned roboticstoolbox ``ik_LM`` (``bench_kinematics.rtb_solver``) in the
same process, the two calls interleaved target by target (alternating which goes first), on the
same reachable targets; then the traps: singular configurations (Jacobian rank-deficient) and
unreachable poses (3 m away; on < 6-DOF arms also orientations turned off the reachable set).
Every success of solve_ik is checked independently (numpy FK within 1e-6 m / 1e-6 rad, joint
limits): a success that fails the check is a false success; ik_LM's answers are counted with
bench_kinematics' criterion (1e-4 m, 1e-3 rad: it stops at its own tol 1e-10 on the squared
error). Runs in the bench venv
(``scripts/bench_setup.sh``; re-executed there when this interpreter lacks roboticstoolbox).
Writes ``benchmarks/results/ik_dispatch.json``.
Usage: ``python benchmarks/bench_robots.py [--quick] [--robots px100,rrrp] [--vs-ik-lm]``.
"""
import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time

import bound
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: the run's bound [s] with --quick and without: past it the run fails naming its stage
BOUND_S = (180.0, 600.0)
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'robots.json')
DISPATCH_RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'ik_dispatch.json')
BENCH_VENV = os.environ.get('PX100_BENCH_VENV', '/tmp/pxvenv/bench')
CHECK_TOL = 1e-6


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


def _check(m, q, T, tol: float = CHECK_TOL, tol_o: float = CHECK_TOL) -> bool:
    """Independent check of an answer: numpy FK within tol [m] / tol_o [rad], in the limits."""
    if q is None:
        return False
    q = np.asarray(q, dtype=float)
    if not np.all(np.isfinite(q)) or not m.within_limits(q, tol=1e-9):
        return False
    Tq = m.fk(q)
    E = Tq[:3, :3].T @ T[:3, :3]
    angle = math.acos(max(-1.0, min(1.0, (np.trace(E) - 1.0) / 2.0)))
    return float(np.linalg.norm(Tq[:3, 3] - T[:3, 3])) <= tol and angle <= tol_o


def singular_configurations(m, count: int, rng) -> list:
    """
    Return up to ``count`` in-limit configurations where the Jacobian loses rank.

    From random configurations, one joint at a time is swept over its range (181 samples) and
    the smallest singular value of the space Jacobian minimised around the best sample (golden
    section); kept when it falls below 1e-9 (elbow straight, wrist axes aligned, wrist point on
    the waist axis, ...).
    """
    from px100_control.kinematics.iterative import chain, fk_and_jacobian
    c = chain(m)

    def smin(q):
        return float(np.linalg.svd(fk_and_jacobian(c, q)[1], compute_uv=False)[-1])
    out = []
    for _ in range(20 * count):
        q = m.random_configurations(1, rng)[0]
        j = int(rng.integers(m.dof))
        grid = np.linspace(m.lower[j], m.upper[j], 181)
        vals = []
        for x in grid:
            q[j] = x
            vals.append(smin(q))
        k = int(np.argmin(vals))
        a, b = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
        gr = (math.sqrt(5.0) - 1.0) / 2.0
        for _ in range(60):
            x1, x2 = b - gr * (b - a), a + gr * (b - a)
            q[j] = x1
            f1 = smin(q)
            q[j] = x2
            if f1 < smin(q):
                b = x2
            else:
                a = x1
        q[j] = 0.5 * (a + b)
        if smin(q) < 1e-9 and m.within_limits(q):
            out.append(q.copy())
            if len(out) >= count:
                break
    return out


def trap_targets(m, count: int, seed: int) -> dict:
    """Return {'singular': [T], 'unreachable': [T], 'orientation': [T]} (see the module doc)."""
    rng = np.random.default_rng(seed)
    singular = [m.fk(q) for q in singular_configurations(m, count, rng)]
    far = []
    for k in range(count):
        a = 2.0 * math.pi * k / count
        T = m.fk(m.random_configurations(1, rng)[0])
        T[:3, 3] = (3.0 * math.cos(a), 3.0 * math.sin(a), 0.5)
        far.append(T)
    turned = []
    if m.dof < 6:
        from px100_control.kinematics.se3 import exp_so3
        for q in m.random_configurations(count, rng):
            T = m.fk(q)
            w = rng.normal(size=3)
            T[:3, :3] = T[:3, :3] @ exp_so3(w / np.linalg.norm(w), 0.5)
            turned.append(T)
    return {'singular': singular, 'unreachable': far, 'orientation': turned}


def _vs_ik_lm_robot(name: str, n: int, seed: int) -> dict:
    """Time solve_ik (default path) and tuned ik_LM interleaved on the same targets."""
    sys.path.insert(0, os.path.join(ROOT, 'benchmarks'))
    from bench_kinematics import ORI_TOL, POS_TOL, rtb_solver
    from px100_control.kinematics.solve import solve_ik
    from px100_control.models.registry import load_robot
    m = load_robot(name)
    rng = np.random.default_rng(seed)
    targets = [m.fk(q) for q in m.random_configurations(n, rng)]
    lm, source = rtb_solver(m)
    for T in targets[:20]:                       # warm caches of both
        solve_ik(m, T)
        if lm is not None:
            lm(T)
    t_ours, t_lm, ok_ours, ok_lm, false_ours = [], [], 0, 0, 0
    clock = time.perf_counter
    for i, T in enumerate(targets):
        if i % 2 or lm is None:
            t0 = clock()
            res = solve_ik(m, T)
            t1 = clock()
            q_lm = lm(T) if lm is not None else None
            t2 = clock()
            t_ours.append(t1 - t0)
            t_lm.append(t2 - t1)
        else:
            t0 = clock()
            q_lm = lm(T)
            t1 = clock()
            res = solve_ik(m, T)
            t2 = clock()
            t_lm.append(t1 - t0)
            t_ours.append(t2 - t1)
        good = _check(m, res.q, T)
        ok_ours += res.success and good
        false_ours += res.success and not good
        ok_lm += _check(m, q_lm, T, POS_TOL, ORI_TOL)
    out = {'dof': m.dof, 'analytic_module': m.analytic_ik, 'targets': n,
           'solve_ik_median_us': float(np.median(t_ours) * 1e6),
           'solve_ik_p90_us': float(np.percentile(t_ours, 90) * 1e6),
           'solve_ik_success': ok_ours / n, 'solve_ik_false_success': false_ours,
           'ik_lm_source': source}
    if lm is not None:
        out.update(ik_lm_median_us=float(np.median(t_lm) * 1e6),
                   ik_lm_p90_us=float(np.percentile(t_lm, 90) * 1e6), ik_lm_success=ok_lm / n)
        out['speedup'] = out['ik_lm_median_us'] / out['solve_ik_median_us']
    traps = {}
    for kind, Ts in trap_targets(m, 20, seed + 1).items():
        results = [solve_ik(m, T) for T in Ts]
        traps[kind] = {'targets': len(Ts),
                       'success': sum(bool(r.success) for r in results),
                       'false_success': sum(bool(r.success and not _check(m, r.q, T))
                                            for r, T in zip(results, Ts))}
    out['traps'] = traps
    return out


def _vs_markdown(results: dict) -> str:
    rows = ['| robot | DOF | solve_ik median us | ik_LM median us | ik_LM / solve_ik | '
            'solve_ik success | ik_LM success | singular traps: solved / false | '
            'unreachable traps: false success |',
            '| --- | --- | --- | --- | --- | --- | --- | --- | --- |']
    for name, r in results.items():
        tr = r['traps']
        unreach = tr['unreachable']['false_success'] + tr['orientation']['false_success']
        lm = (f"{r['ik_lm_median_us']:.1f} | {r['speedup']:.2f} | " if 'speedup' in r
              else f"skipped ({r['ik_lm_source']}) | - | ")
        lm_ok = f"{100 * r['ik_lm_success']:.1f} %" if 'ik_lm_success' in r else '-'
        rows.append(f"| {name} | {r['dof']} | {r['solve_ik_median_us']:.1f} | {lm}"
                    f"{100 * r['solve_ik_success']:.1f} % | {lm_ok} | "
                    f"{tr['singular']['success']}/{tr['singular']['targets']} / "
                    f"{tr['singular']['false_success']} | {unreach} of "
                    f"{tr['unreachable']['targets'] + tr['orientation']['targets']} |")
    return '\n'.join(rows)


def run_vs_ik_lm(quick: bool = False, robots=None, log=print) -> dict:
    """Compare the default solve_ik with tuned ik_LM on every robot; write ik_dispatch.json."""
    try:
        import roboticstoolbox  # noqa: F401 - optional: the peer lives in the bench venv
    except ImportError:
        return _in_bench_venv(quick, robots, log)
    from px100_control.models.registry import available_robots
    n = 300 if quick else 2000
    results = {}
    for i, name in enumerate(robots or available_robots()):
        results[name] = r = _vs_ik_lm_robot(name, n, seed=2000 + i)
        log(f"{name}: solve_ik {r['solve_ik_median_us']:.1f} us "
            f"({100 * r['solve_ik_success']:.1f} %), ik_LM "
            f"{r.get('ik_lm_median_us', float('nan')):.1f} us, x{r.get('speedup', 0):.2f}")
    figures = {'targets': n, 'check_tolerance': CHECK_TOL, 'robots': results,
               'markdown': _vs_markdown(results),
               'machine': f'{platform.processor() or platform.machine()}, {os.cpu_count()} '
                          f'cores, Python {platform.python_version()}',
               'load_average': os.getloadavg(), 'quick': quick}
    os.makedirs(os.path.dirname(DISPATCH_RESULTS), exist_ok=True)
    with open(DISPATCH_RESULTS, 'w') as f:
        json.dump(figures, f, indent=2)
    return figures


def _in_bench_venv(quick: bool, robots, log) -> dict:
    py = os.path.join(BENCH_VENV, 'bin', 'python')
    if not os.path.isfile(py):
        raise SystemExit(f'roboticstoolbox is not installed here and {py} does not exist: '
                         'run scripts/bench_setup.sh')
    cmd = [py, os.path.abspath(__file__), '--vs-ik-lm'] + (['--quick'] if quick else []) + (
        ['--robots', ','.join(robots)] if robots else [])
    subprocess.run(cmd, check=True)
    with open(DISPATCH_RESULTS) as f:
        return json.load(f)


def main(argv=None) -> int:
    """Run the benchmark, print the table and write benchmarks/results/robots.json."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='reduced sizes')
    parser.add_argument('--robots', default='', help='comma-separated robot models')
    parser.add_argument('--vs-ik-lm', action='store_true',
                        help='default solve_ik against tuned roboticstoolbox ik_LM')
    bound.add_argument(parser, *BOUND_S)
    options = parser.parse_args(argv)
    robots = [r for r in options.robots.split(',') if r] or None
    limit = bound.seconds(options, options.quick)
    if options.vs_ik_lm:
        with bound.bounded('bench_robots --vs-ik-lm', limit):
            figures = run_vs_ik_lm(quick=options.quick, robots=robots, log=bound.log)
        print(figures['markdown'])
        print(f'wrote {DISPATCH_RESULTS}')
        return 0
    with bound.bounded('bench_robots', limit):
        figures = run(quick=options.quick, robots=robots, log=bound.log)
    print(figures['markdown'])
    print(f'wrote {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
