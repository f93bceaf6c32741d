"""
What the scripts and examples print to a user: one 'pose N:', and one line without the venv.

Each runs as a user runs it (its own process). Without the project's packages (``python -S``:
no site-packages, so no numpy, matplotlib or rclpy) every example and script says in one line
to run ``bash scripts/setup.sh`` then ``source scripts/env.sh``, and exits 1 without a
traceback.
"""
import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENTRY_POINTS = ['scripts/kinematics_demo.py', 'scripts/pick_and_place_demo.py',
                'scripts/pid_experiment.py', 'examples/seed000_px100.py',
                'examples/seed001_aik_and_cartesian.py', 'examples/seed002_rrrp_candidates.py',
                'examples/seed003_myarm_newton.py', 'examples/seed004_rrrr_elbow.py']


def test_kinematics_demo_names_an_unreachable_pose_once(tmp_path):
    proc = subprocess.run([sys.executable, os.path.join(ROOT, 'scripts', 'kinematics_demo.py'),
                           '--png', str(tmp_path / 'ws.png')],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    line = [x for x in proc.stdout.split('straight line')[-1].splitlines() if 'beyond' in x]
    assert line and re.match(r'^  pose \d+: target is', line[0]), proc.stdout[-1500:]
    assert not re.search(r'pose (\d+): pose \1:', proc.stdout), proc.stdout[-1500:]


@pytest.mark.parametrize('script', ENTRY_POINTS)
def test_without_the_venv_one_line_says_what_to_run(script):
    env = {'PATH': '/usr/bin:/bin', 'HOME': os.environ.get('HOME', '/tmp')}
    proc = subprocess.run([sys.executable, '-S', os.path.join(ROOT, script)], env=env,
                          cwd=ROOT, capture_output=True, text=True, timeout=60)
    out = (proc.stdout + proc.stderr).strip()
    assert proc.returncode == 1, out
    assert 'Traceback' not in out and len(out.splitlines()) == 1, out
    assert 'run `bash scripts/setup.sh` then `source scripts/env.sh` first' in out, out
    assert 'numpy' in out, out


def test_examples_say_what_their_source_document_is(tmp_path):
    script = os.path.join(ROOT, 'examples', 'seed004_rrrr_elbow.py')
    proc = subprocess.run([sys.executable, script, '--out', str(tmp_path)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    head = proc.stdout.splitlines()[1]
    assert "'document' below = this example's source notes: a report on a 4-DOF RRRR arm" \
        in head and 'not in this repository' in head, head
