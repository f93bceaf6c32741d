"""scripts/slowest_tests.py: the slowest tests of a run's JUnit reports, over all its phases."""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(ROOT, 'scripts', 'slowest_tests.py')

REPORT = """<?xml version="1.0" encoding="utf-8"?><testsuites><testsuite name="pytest">
<testcase classname="{module}" name="{a}" time="{ta}"/>
<testcase classname="{module}" name="{b}" time="{tb}"/></testsuite></testsuites>"""


def test_the_slowest_of_every_report_first(tmp_path):
    """Two reports merged, slowest first, cut at -n; a missing report is named, not fatal."""
    one, two = tmp_path / 'one.xml', tmp_path / 'two.xml'
    one.write_text(REPORT.format(module='test.a', a='t1', ta='3.5', b='t2', tb='0.25'))
    two.write_text(REPORT.format(module='test.stress', a='s1', ta='12', b='s2', tb='1'))
    out = subprocess.run([sys.executable, SCRIPT, '-n', '3', str(one), str(two),
                          str(tmp_path / 'missing.xml')], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert 'slowest 3 tests' in lines[0]
    names = [ln.split()[-1] for ln in lines[1:]]
    assert names == ['test.stress::s1', 'test.a::t1', 'test.stress::s2']
    assert lines[1].split()[0] == '12.00s'
    assert 'missing.xml' in out.stderr
