#!/usr/bin/env python3
"""
Print the slowest tests of one or more pytest JUnit XML reports, slowest first.

Usage: ``python scripts/slowest_tests.py [-n 20] REPORT.xml ...`` (scripts/test.sh runs it at
the end of a run over its phases' reports, so the list covers the whole run). Times are the
reports' ``time`` attributes [s] (setup, call and teardown of a test together).
"""
import argparse
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


def main(argv=None) -> int:
    """Print the table; 0 even when a report is missing (the run's result is pytest's)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('-n', type=int, default=20, help='how many (default 20)')
    parser.add_argument('reports', nargs='+')
    opts = parser.parse_args(argv)
    rows = slowest(opts.reports, opts.n)
    print(f'===== slowest {len(rows)} tests of this run (all phases) =====')
    for seconds, name in rows:
        print(f'{seconds:8.2f}s  {name}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
