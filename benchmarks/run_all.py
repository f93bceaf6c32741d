"""
Run every benchmark of this folder in one go and write one Markdown table and one JSON file.

Each ``benchmarks/bench_<name>.py`` exposes ``run(quick: bool) -> dict``; a dict may carry a
``markdown`` entry (its own table) and anything else as figures. Output:
``benchmarks/results/summary.md`` and ``benchmarks/results/summary.json``, with the date and
the machine. Usage: ``python benchmarks/run_all.py [--quick] [--only kinematics,ik_service]
[--merge] [--bound SECONDS]``. The run's bound is the sum of the chosen benchmarks' BOUND_S
(bound.py: past it the run fails naming the benchmark and its stage).
"""
import argparse
import datetime
import importlib.util
import json
import os
import platform
import sys
import time
import traceback

import bound

HERE = os.path.dirname(os.path.abspath(__file__))
ORDER = ['kinematics', 'kinematics_myarm300pi', 'robots', 'sim_driver', 'physics', 'ik_service',
         'ik_call', 'recorder', 'client', 'robustness']


def _machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open('/proc/cpuinfo') as f:
            for line in f:
                if line.startswith('model name'):
                    cpu = line.split(':', 1)[1].strip()
                    break
    except OSError:
        pass
    return f'{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}'


def _load(name):
    path = os.path.join(HERE, f'bench_{name}.py')
    spec = importlib.util.spec_from_file_location(f'bench_{name}', path)
    module = importlib.util.module_from_spec(spec)
    sys.path.insert(0, HERE)
    spec.loader.exec_module(module)
    return module


def _section(name, figures) -> str:
    """Return the Markdown section of one benchmark (its own table, or its figures flat)."""
    table = figures.get('markdown') or _flat_table(name, {
        k: v for k, v in figures.items() if k not in ('markdown', 'run_at')})
    when = f" (run {figures['run_at']})" if figures.get('run_at') else ''
    return f'## {name}{when}\n\n{table}\n'


def _flat_table(name, figures) -> str:
    rows = [f'| {k} | {v} |' for k, v in _flatten(figures).items()]
    return '\n'.join([f'| {name} | value |', '| --- | --- |', *rows])


def _flatten(d, prefix=''):
    out = {}
    for k, v in d.items():
        key = f'{prefix}{k}'
        if isinstance(v, dict):
            out.update(_flatten(v, key + '.'))
        elif isinstance(v, float):
            out[key] = f'{v:.4g}'
        elif isinstance(v, (list, tuple)) and len(v) > 8:
            continue
        else:
            out[key] = v
    return out


def main(argv=None) -> int:
    """Run the benchmarks and write the summary files."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='reduced sizes (a smoke run)')
    parser.add_argument('--only', default='', help='comma-separated benchmark names')
    parser.add_argument('--merge', action='store_true',
                        help='keep the other sections of the existing summary (each section '
                             'says when it was run)')
    parser.add_argument('--bound', type=float, default=None, metavar='SECONDS',
                        help='fail if the run takes longer (default: the sum of the bounds '
                             'BOUND_S of the chosen benchmarks)')
    options = parser.parse_args(argv)
    present = [n for n in ORDER if os.path.isfile(os.path.join(HERE, f'bench_{n}.py'))]
    present += sorted(f[6:-3] for f in os.listdir(HERE)
                      if f.startswith('bench_') and f.endswith('.py') and f[6:-3] not in present)
    names = [n for n in present if not options.only or n in options.only.split(',')]
    limit = options.bound or sum(_load(n).BOUND_S[0 if options.quick else 1] for n in names)
    with bound.bounded('run_all', limit):
        return _run(options, present, names)


def _run(options, present, names) -> int:
    """Run the chosen benchmarks and write the summary files."""
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')
    results, sections, failed = {}, {}, []
    summary_json = os.path.join(HERE, 'results', 'summary.json')
    if options.merge and os.path.isfile(summary_json):
        with open(summary_json) as f:
            old = json.load(f)
        for name, figures in old.get('results', {}).items():
            if name not in names and 'error' not in figures:
                results[name] = figures
                sections[name] = _section(name, figures)
    for name in names:
        print(f'=== {name} ===', flush=True)
        bound.stage(name)
        t0 = time.monotonic()
        try:
            figures = _load(name).run(quick=options.quick)
        except Exception:  # report and continue with the others
            traceback.print_exc()
            failed.append(name)
            results[name] = {'error': traceback.format_exc(limit=3)}
            sections[name] = f'## {name}\n\nFAILED (see the log)\n'
            continue
        figures = dict(figures or {})
        figures.setdefault('wall_time_s', round(time.monotonic() - t0, 1))
        figures.setdefault('run_at', stamp)
        results[name] = figures
        sections[name] = _section(name, figures)
        print(sections[name], flush=True)
    header = (f'# px100_control benchmarks\n\nRun {stamp} on {_machine()}'
              f'{" (quick)" if options.quick else ""}.\n')
    os.makedirs(os.path.join(HERE, 'results'), exist_ok=True)
    order = [n for n in present if n in sections] + [n for n in sections if n not in present]
    with open(os.path.join(HERE, 'results', 'summary.md'), 'w') as f:
        f.write(header + '\n' + '\n'.join(sections[n] for n in order))
    with open(summary_json, 'w') as f:
        json.dump({'date': stamp, 'machine': _machine(), 'quick': options.quick,
                   'results': results}, f, indent=2, default=str)
    print(f'wrote {os.path.join(HERE, "results", "summary.md")}')
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
