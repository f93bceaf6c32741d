#!/usr/bin/env python3
"""
Print the slowest tests of one or more pytest JUnit XML reports, slowest first.

Usage: ``python scripts/slowest_tests.py [-n 20] [--cpu DIR] REPORT.xml ...`` (scripts/test.sh
runs it at the end of a run over its phases' reports, so the list covers the whole run). Times
are the reports' ``time`` attributes [s] (setup, call and teardown of a test together).

``--cpu DIR``: also the modules that cost the most CPU, from the ``*.jsonl`` files test/conftest.py
writes there (one line per test: ``test``, ``cpu_s``, ``wall_s``; CPU of the test process and
of its children once reaped), with the cores each used while it ran (CPU / wall).
"""
import argparse
import glob
import json
import os
import sys
import xml.etree.ElementTree as ET


def slowest(paths, count: int):
    """Return [(seconds, test id)] of the ``count`` slowest test cases in the reports."""
    cases = []
    for path in paths:
        try:
            root = ET.parse(path).getroot()
        except (OSError, ET.ParseError) as exc:
            print(f'slowest_tests: {path}: {exc}', file=sys.stderr)
            continue
        for case in root.iter('testcase'):
            name = f"{case.get('classname', '')}::{case.get('name', '')}".lstrip(':')
            cases.append((float(case.get('time') or 0.0), name))
    return sorted(cases, reverse=True)[:count]


def cpu_by_module(folder: str):
    """Return [(cpu s, wall s, tests, module)] from the folder's jsonl files, costliest first."""
    modules = {}
    for path in sorted(glob.glob(os.path.join(folder, '*.jsonl'))):
        with open(path, encoding='utf-8') as f:
            for line in f:
                try:
                    row = json.loads(line)
                    module = row['test'].split('::')[0]
                    cpu, wall = float(row['cpu_s']), float(row['wall_s'])
                except (ValueError, KeyError, TypeError, AttributeError):
                    print(f"slowest_tests: {path}: a line that is not a test's CPU: "
                          f'{line.strip()[:80]!r}', file=sys.stderr)
                    continue
                total = modules.setdefault(module, [0.0, 0.0, 0])
                total[0] += cpu
                total[1] += wall
                total[2] += 1
    return sorted(((c, w, n, m) for m, (c, w, n) in modules.items()), reverse=True)


def main(argv=None) -> int:
    """Print the table; 0 even when a report is missing (the run's result is pytest's)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('-n', type=int, default=20, help='how many (default 20)')
    parser.add_argument('--cpu', metavar='DIR', help="also the costliest modules' CPU from "
                        "DIR's jsonl files (test/conftest.py writes out/cpu/)")
    parser.add_argument('reports', nargs='+')
    opts = parser.parse_args(argv)
    rows = slowest(opts.reports, opts.n)
    print(f'===== slowest {len(rows)} tests of this run (all phases) =====')
    for seconds, name in rows:
        print(f'{seconds:8.2f}s  {name}')
    if opts.cpu:
        modules = cpu_by_module(opts.cpu)
        cpu = sum(m[0] for m in modules)
        print(f'===== CPU of this run: {cpu:.0f} s over {len(modules)} modules; the '
              f'{min(opts.n, len(modules))} costliest (CPU s, wall s, cores, tests) =====')
        for c, w, n, module in modules[:opts.n]:
            print(f'{c:8.1f}  {w:8.1f}  {c / w if w > 0 else 0.0:5.2f}  {n:4d}  {module}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
