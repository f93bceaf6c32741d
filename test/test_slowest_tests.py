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


def test_the_costliest_modules_by_cpu(tmp_path):
    """--cpu sums each module's tests over the workers' files, costliest first; bad lines named."""
    report = tmp_path / 'one.xml'
    report.write_text(REPORT.format(module='test.a', a='t1', ta='3.5', b='t2', tb='0.25'))
    cpu = tmp_path / 'cpu'
    cpu.mkdir()
    (cpu / 'gw0.jsonl').write_text(
        '{"test": "test/a.py::t1", "cpu_s": 2.0, "wall_s": 4.0}\n'
        '{"test": "test/b.py::t1", "cpu_s": 1.0, "wall_s": 1.0}\nnot json\n')
    (cpu / 'gw1.jsonl').write_text('{"test": "test/b.py::t2", "cpu_s": 3.0, "wall_s": 2.0}\n')
    out = subprocess.run([sys.executable, SCRIPT, '--cpu', str(cpu), str(report)],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    head = lines.index(next(ln for ln in lines if ln.startswith('===== CPU')))
    assert 'CPU of this run: 6 s over 2 modules' in lines[head]
    rows = [ln.split() for ln in lines[head + 1:]]
    assert rows == [['4.0', '3.0', '1.33', '2', 'test/b.py'],
                    ['2.0', '4.0', '0.50', '1', 'test/a.py']]
    assert 'not json' in out.stderr
