"""
Robustness campaign: fuzzed inputs, injected faults and load against the real px100 nodes.

Runs the scenarios of ``test/stress`` at full size (10,000 hypothesis inputs per subscribed topic
and service, 8 IK clients x 1,000 requests, every fault) and writes the figures (inputs tried
and answered per target, node deaths, the largest goal's answer time, faults injected and
survived, replies lost) to
``benchmarks/results/robustness.json``. ``--quick`` runs the reduced sizes of the CI suite.
Needs the package built and sourced (``bash scripts/setup.sh; source scripts/env.sh``); uses
``ROS_DOMAIN_ID`` (a private one is picked when unset). Usage:
``python benchmarks/bench_robustness.py [--quick] [--only fuzz|largest_goal|faults|load]
[--count N]``.
"""
import argparse
import json
import os
import signal
import sys
import tempfile
import time

import bound

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'robustness.json')
#: the run's bound [s] with --quick and without: past it the run fails naming its stage
BOUND_S = (900.0, 10800.0)
for p in (ROOT, os.path.join(ROOT, 'test')):
    if p not in sys.path:
        sys.path.insert(0, p)
os.environ.setdefault('ROS_DOMAIN_ID', str(10 + os.getpid() % 90))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)

NODES = ('sim_driver', 'ik_service', 'trajectory_server')
FULL = 10_000


def _fuzz(graph, probe, lim, model, count_for, log, progress=None, targets_only=None) -> dict:
    from stress.harness import FuzzFailure, fuzz
    from stress.targets import driver_works, goal_works, ik_works, make_targets
    from stress.targets import REDUCED
    params = {n: [p for p in probe.list_parameters(n) if p != 'use_sim_time'] for n in NODES}
    targets = make_targets(probe, lim, params)
    out = {}
    for name in (targets_only or REDUCED):
        t = targets[name]
        n = count_for(name)
        deaths_before = len(graph.deaths)
        violations_before = len(probe.violations)
        log(f'fuzz {name}: {n} inputs')
        failure = None
        if t.before:
            t.before()
        try:
            camp = fuzz(t.strategy, t.send, n, graph, probe, name, derandomize=False)
        except FuzzFailure as exc:
            failure = str(exc)
            camp = None
        except Exception as exc:  # noqa: B902 - hypothesis' own errors (Flaky...) too
            failure = f'{type(exc).__name__}: {exc}'
            camp = None
        graph.revive(probe, cause=f'after fuzzing {name}')
        not_restored = t.after() if t.after else None
        still = [p for p in (driver_works(probe), ik_works(probe, model),
                             goal_works(probe, lim)) if p]
        fig = camp.summary() if camp is not None else {'target': name}
        fig.update({'failure': failure[:3000] if failure else None,
                    'deaths': graph.deaths[deaths_before:],
                    'violations': probe.violations[violations_before:][:10],
                    'violation_count': len(probe.violations) - violations_before,
                    'still_working_problems': still,
                    'parameters_not_restored': not_restored})
        out[name] = fig
        log(f'  -> tried {fig.get("tried")}, unanswered {fig.get("unanswered")}, deaths '
            f'{len(fig["deaths"])}, violations {fig["violation_count"]}, '
            f'failure {bool(failure)}, {fig.get("seconds")} s')
        if progress is not None:
            progress(out)
    return out


def _faults(graph, probe, lim, model, log) -> dict:
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
    from stress import scenarios as sc
    out = {}
    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm',
                                  gripper_name='gripper', connect_timeout=30.0)
    robot_startup()
    try:
        for sig in (signal.SIGKILL, signal.SIGINT):
            log(f'fault: sim_driver {sig.name} mid-trajectory')
            out[f'kill_driver_{sig.name}'] = sc.kill_driver_mid_trajectory(graph, probe, bot,
                                                                           sig)
        for sig in (signal.SIGKILL, signal.SIGINT):
            log(f'fault: ik_service {sig.name}')
            out[f'kill_ik_service_{sig.name}'] = sc.kill_ik_service(graph, probe, bot, model,
                                                                    sig)
    finally:
        robot_shutdown()
    log('fault: recorder SIGKILL')
    out['recorder_sigkill'] = sc.recorder_sigkill(
        graph, probe, lim, tempfile.mkdtemp(prefix='px100_killed_bag_') + '/bag')
    for mode in ('nospin', 'sleep'):
        log(f'fault: slow subscriber ({mode})')
        out[f'slow_subscriber_{mode}'] = sc.slow_subscriber(graph, probe, lim, model, mode)
    return out


def survived(name: str, fig: dict) -> bool:
    """Return True if a fault's figures meet the issue's requirements."""
    if name.startswith('kill_driver'):
        return (fig.get('client_ok') is False and (fig.get('client_return_s') or 99) <= 2.0
                and fig.get('final_status') == 6 and (fig.get('abort_s') or 99) <= 2.0
                and any(level == 2 for level, _ in fig.get('diagnostic', []))
                and bool(fig.get('recovered')))
    if name.startswith('kill_ik'):
        return bool(fig.get('raised')) and 'ik_service' in fig['raised'] and \
            fig.get('arm_ok') is False and bool(fig.get('recovered'))
    if name == 'recorder_sigkill':
        return fig.get('stream_read_joint_states', 0) > 0 and fig.get('reindex_exit') == 0 \
            and isinstance(fig.get('reader_messages'), int)
    if name.startswith('slow_subscriber'):
        return fig.get('goal') == '' and fig.get('ik') == '' and all(
            s['rate'] >= 50.0 and s['max_gap'] <= 1.0 for s in fig.get('rates', {}).values())
    return False


def _load(graph, probe, quick: bool, log) -> dict:
    from stress import scenarios as sc
    per = 100 if quick else 1000
    log(f'load: 8 IK clients x {per}')
    out = {'ik_clients': sc.ik_load(8, per)}
    log('load: 4 client scripts in turn with a recorder')
    out['scripts_with_recorder'] = sc.scripts_with_recorder(
        graph, probe, tempfile.mkdtemp(prefix='px100_load_bag_') + '/bag', scripts=4,
        moves=2 if quick else 10)
    return out


def run(quick: bool = False, only=None, count=None, log=print, output=None,
        targets=None, base=None) -> dict:
    """
    Run the campaign and return its figures (see the module docstring).

    :param quick: reduced sizes (those of the CI suite)
    :param only: None for everything, or a subset of {'fuzz', 'largest_goal', 'faults', 'load'}
    :param count: inputs per fuzz target (overrides quick/full)
    :param output: write the figures so far to this JSON file after every step
    :param targets: fuzz only these targets (names as in ``stress.targets.REDUCED``)
    :param base: sections of an earlier run to keep (those not run again)
    """
    from px100_control.models.registry import load_robot
    from px100_control.tools.processes import NodeProcess
    from stress.harness import Graph, Limits, Probe
    from stress.targets import REDUCED

    model = load_robot('px100')
    lim = Limits.from_model(model)
    only = set(only or ('fuzz', 'largest_goal', 'faults', 'load'))

    def count_for(name):
        if count is not None:
            return count
        return REDUCED[name] if quick else FULL

    graph = Graph(lambda name, *args: NodeProcess(name, args))
    probe = Probe(lim)
    result = dict(base or {})
    result.update({'quick': quick, 'domain': os.environ.get('ROS_DOMAIN_ID'),
                   'started': time.strftime('%Y-%m-%dT%H:%M:%S')})
    t0 = time.monotonic()
    try:
        for n in NODES:
            graph.start(n)
        probe.wait_ready(NODES, timeout=60.0)

        def progress(part, key):
            # a partial fuzz run (--target) adds to the earlier run's targets
            result[key] = {**(base or {}).get(key, {}), **part} if key == 'fuzz' else part
            if output:
                write(result, output)

        if 'fuzz' in only:
            progress(_fuzz(graph, probe, lim, model, count_for, log,
                           lambda part: progress(part, 'fuzz'), targets), 'fuzz')
        if 'largest_goal' in only:
            from stress.scenarios import largest_goal
            points = 1_000 if quick else 10_000
            log(f'largest goal: {points:,} points x 10,000 velocities')
            progress(largest_goal(probe, points=points), 'largest_goal')
            log(f'  -> {result["largest_goal"]}')
        if 'faults' in only:
            progress(_faults(graph, probe, lim, model, log), 'faults')
        if 'load' in only:
            progress(_load(graph, probe, quick, log), 'load')
    finally:
        stop_codes = {}
        for name, p in graph.procs.items():
            stop_codes[name] = p.stop()
        probe.close()
        result['stop_exit_codes'] = stop_codes
    result['seconds'] = round(time.monotonic() - t0, 1)
    result['summary'] = summarize(result)
    return result


def summarize(result: dict) -> dict:
    """Return the headline figures: inputs tried, deaths, invalid outputs, faults, lost."""
    s = {}
    fuzz = result.get('fuzz', {})
    if fuzz:
        s['fuzz_inputs_tried'] = sum(f.get('tried', 0) for f in fuzz.values())
        s['fuzz_targets'] = len(fuzz)
        s['fuzz_unanswered'] = sum(f.get('unanswered', 0) for f in fuzz.values())
        s['node_deaths'] = sum(len(f.get('deaths', [])) for f in fuzz.values())
        s['invalid_outputs'] = sum(f.get('violation_count', 0) for f in fuzz.values())
        s['targets_failed'] = sorted(n for n, f in fuzz.items() if f.get('failure'))
    big = result.get('largest_goal')
    if big:
        s['largest_goal_mb'] = big.get('megabytes')
        s['largest_goal_answer_s'] = big.get('answer_s')
    faults = result.get('faults', {})
    if faults:
        s['faults_injected'] = len(faults)
        s['faults_survived'] = sum(1 for n, f in faults.items() if survived(n, f))
    load = result.get('load', {})
    if load:
        ik = load.get('ik_clients', {})
        s['ik_requests'] = ik.get('sent')
        s['ik_replies_lost'] = ik.get('lost')
        s['ik_replies_mismatched'] = ik.get('mismatched')
        rec = load.get('scripts_with_recorder', {})
        s['script_goals'] = rec.get('goals_sent')
        s['bag_goals_missing'] = rec.get('goals_missing_in_bag')
        s['bag_setpoints_missing'] = rec.get('setpoints_missing_in_bag')
    return s


def write(result: dict, path: str) -> None:
    """Write the figures (with their summary) to a JSON file."""
    result = dict(result, summary=summarize(result))
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, 'w', encoding='utf-8') as f:
        json.dump(result, f, indent=1, default=str)


def main(argv=None) -> int:
    """Run the campaign, print the summary and write benchmarks/results/robustness.json."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--quick', action='store_true', help='reduced sizes (as in CI)')
    parser.add_argument('--only', action='append',
                        choices=('fuzz', 'largest_goal', 'faults', 'load'))
    parser.add_argument('--count', type=int, help='inputs per fuzz target')
    parser.add_argument('--output', default=RESULTS)
    parser.add_argument('--target', action='append', help='fuzz only this target (repeatable)')
    bound.add_argument(parser, *BOUND_S)
    opts = parser.parse_args(argv)

    def log(text):
        print(f'[robustness {time.strftime("%H:%M:%S")}] {text}', flush=True)
        bound.stage(text)

    base = {}
    if opts.only and os.path.exists(opts.output):  # add these sections to an earlier run
        with open(opts.output, encoding='utf-8') as f:
            base = {k: v for k, v in json.load(f).items()
                    if k in ('fuzz', 'largest_goal', 'faults', 'load')}
    with bound.bounded('bench_robustness', bound.seconds(opts, opts.quick)):
        result = run(quick=opts.quick, only=opts.only, count=opts.count, log=log,
                     output=opts.output, targets=opts.target, base=base)
    write(result, opts.output)
    print(json.dumps(result['summary'], indent=1))
    print(f'written to {opts.output}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
