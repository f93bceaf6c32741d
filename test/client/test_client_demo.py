"""
The README's main job: scripts/pick_and_place_demo.py through the client, end to end.

Runs the demo as a user would (its own process, in-process nodes) on one of seed 000's objects
and checks what it promises: the object moved with seed 001's waypoint sequence, an MCAP bag
with the run's topics, and the two PNG plots. Marked slow (about 25 s): an extra on top of the
issue's test list.
"""
import os
import subprocess
import sys

from client_support import SLOW
from px100_control.bag.reader import open_bag
import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_demo_moves_an_object_records_a_bag_and_plots(tmp_path):
    """One object: every waypoint ok, bag with joint states and goals, two non-empty PNGs."""
    env = os.environ.copy()
    env['MPLBACKEND'] = 'Agg'
    env['PYTHONPATH'] = os.pathsep.join([ROOT] + [p for p in env.get('PYTHONPATH', '').split(
        os.pathsep) if p])
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, 'scripts', 'pick_and_place_demo.py'),
         '--objects', 'object3', '--out', str(tmp_path)],
        env=env, capture_output=True, text=True, timeout=60 + 120 * SLOW)
    out = proc.stdout
    assert proc.returncode == 0, out[-3000:] + proc.stderr[-3000:]
    assert 'moved 1/1 objects (object3)' in out
    for step in ('Approach Pick', 'Pick', 'Approach Drop', 'Drop'):
        assert f'  {step:<15} ok' in out
    assert 'FAILED' not in out
    bag_line = next(line for line in out.splitlines() if line.startswith('bag:'))
    bag_dir = bag_line.split()[1]
    assert os.path.isfile(os.path.join(bag_dir, 'metadata.yaml'))
    with open_bag(bag_dir) as bag:
        summary = bag.summary()
    counts = {name: t.message_count for name, t in summary.topics.items()}
    assert counts.get('/px100/joint_states', 0) > 100
    assert counts.get('/px100/trajectory/goal', 0) >= 7
    assert counts.get('/px100/ik/request', 0) >= 2
    for name in ('pick_and_place_joints.png', 'pick_and_place_ee_path.png'):
        path = tmp_path / name
        assert path.is_file() and path.stat().st_size > 20_000, path
        assert str(path) in out
