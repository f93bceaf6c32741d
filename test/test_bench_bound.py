"""
benchmarks/bound.py: a benchmark past its bound fails naming its stage, its children stopped.

The hung run holds the GIL in C code (a regular expression that backtracks for minutes), the
way a benchmark blocked in a DDS call does: a watchdog thread could not run, a process can.
"""
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

HUNG = """
import re, subprocess, sys
sys.path.insert(0, {bench!r})
import bound
with bound.bounded('bench_hung', 3.0):
    child = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(120)'])
    print(child.pid, flush=True)
    bound.stage('the 8-client round')
    re.match('(a+)+$', 'a' * 60 + 'b')       # holds the GIL far beyond the bound
print('not reached', flush=True)
"""

DONE = """
import sys
sys.path.insert(0, {bench!r})
import bound
with bound.bounded('bench_fine', 30.0):
    bound.stage('working')
print('finished', flush=True)
"""


def _run(source: str):
    code = source.format(bench=os.path.join(ROOT, 'benchmarks'))
    t0 = time.monotonic()
    res = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         timeout=60)
    return res, time.monotonic() - t0


def test_a_hung_run_fails_after_its_bound_naming_its_stage():
    """Killed soon after 3 s, with the stage, a stack of its threads, and its child stopped."""
    res, took = _run(HUNG)
    out = res.stdout + res.stderr
    assert res.returncode != 0 and 'not reached' not in out, out
    assert took < 20.0, (took, out)
    assert ('[bench_hung] FAILED: still running after its bound of 3 s, at: the 8-client round'
            in res.stderr), out
    assert 'most recent call first' in res.stderr, out      # faulthandler's thread stacks
    child = int(res.stdout.split()[0])
    deadline = time.monotonic() + 5.0
    while os.path.exists(f'/proc/{child}') and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not os.path.exists(f'/proc/{child}'), f'child {child} still running'


def test_a_run_within_its_bound_is_untouched():
    """The watchdog leaves when the run ends: exit 0, nothing printed by it, no wait."""
    res, took = _run(DONE)
    assert res.returncode == 0 and res.stdout.strip() == 'finished', res.stdout + res.stderr
    assert 'FAILED' not in res.stderr and took < 10.0, (took, res.stderr)
