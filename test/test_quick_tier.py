"""
The quick tier (``pytest -m quick``): what it selects, and that a ROS graph in it fails.

Each check runs pytest in a subprocess on a scratch tree that holds this suite's conftest.py and
tiers.py, a pure-layer folder (test/sim) and one outside the tier (test/viewer).
"""
import os
import shutil
import subprocess
import sys

import pytest
from tiers import QUICK_PATHS

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

SCRATCH_TESTS = """
import subprocess
import sys

import pytest
import rclpy


def test_pure():
    assert sum([1, 2]) == 3


def test_makes_a_graph():
    ctx = rclpy.Context()
    try:
        rclpy.init(context=ctx)
    except Exception:
        pass                                 # caught: the guard fails the test all the same


def test_starts_a_node():
    subprocess.Popen([sys.executable, '-m', 'px100_control.ros.sim_driver_node'])


@pytest.mark.ros
def test_marked_ros_is_left_out():
    assert False
"""


def test_quick_paths_exist():
    """Every entry of QUICK_PATHS names a test file or folder (a rename must not empty it)."""
    missing = [p for p in QUICK_PATHS if not os.path.exists(os.path.join(ROOT, p))]
    assert not missing, f'QUICK_PATHS entries that do not exist: {missing}'


@pytest.fixture
def scratch(tmp_path):
    """Return a scratch repository: test/conftest.py, tiers.py, sim/ (quick), viewer/ (not)."""
    test = tmp_path / 'test'
    (test / 'sim').mkdir(parents=True)
    (test / 'viewer').mkdir()
    for name in ('conftest.py', 'tiers.py'):
        shutil.copy(os.path.join(ROOT, 'test', name), test / name)
    (test / 'sim' / 'test_scratch.py').write_text(SCRATCH_TESTS)
    (test / 'viewer' / 'test_outside.py').write_text('def test_outside():\n    assert False\n')
    (tmp_path / 'pytest.ini').write_text(
        '[pytest]\ntestpaths = test\nmarkers =\n    ros: r\n    slow: s\n    stress: s\n'
        '    linter: l\n    quick: q\n')
    return tmp_path


def _pytest(cwd, *args) -> str:
    res = subprocess.run([sys.executable, '-m', 'pytest', '-q', '-rA', '-p', 'no:cacheprovider',
                          *args], cwd=str(cwd), capture_output=True, text=True, timeout=120,
                         env=dict(os.environ, PYTHONPATH=ROOT))
    return res.stdout + res.stderr


@pytest.mark.parametrize('args', [('-m', 'quick'), ('test/sim',)],
                         ids=['quick run', 'full run'])
def test_a_ros_graph_fails_a_quick_test(scratch, args):
    """An rclpy context or a node process fails a quick test, caught or not; pure ones pass."""
    out = _pytest(scratch, *args)
    assert 'PASSED test/sim/test_scratch.py::test_pure' in out, out
    for name, what in (('test_makes_a_graph', 'rclpy.Context.init'),
                       ('test_starts_a_node', 'px100_control.ros.sim_driver_node')):
        failed = [line for line in out.splitlines()
                  if f'test_scratch.py::{name}' in line and line.startswith(('FAILED', 'ERROR'))]
        assert failed, out
        assert 'is in the quick tier' in out and what in out, out
    if args[0] == '-m':
        assert 'test_outside' not in out and 'test_marked_ros_is_left_out' not in out, out
