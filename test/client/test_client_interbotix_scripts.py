"""
Interbotix-style scripts (test/client/interbotix_style/, one per demo kind) run unchanged.

Each script is written as for the real API; only its import lines name px100_control. It runs as
a user would run it (its own process, ``PX100_BRINGUP=1``: the nodes in the script's process; at
SPEED times real time, except REAL_TIME) and must exit 0, print no traceback and no ERROR
log, and report the poses it was asked for.
"""
import os
import re
import subprocess
import sys

from client_support import SLOW
import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
SCRIPTS = os.path.join(HERE, 'interbotix_style')

#: script -> regular expressions its output must contain
EXPECTED = {
    'joint_position.py': [r'set_joint_positions True \[0\.5, -0\.4, 0\.3, 0\.2\]',
                          r'set_single_joint_position True -0\.5'],
    'ee_pose.py': [r'ee_pose True True True \[0\.2, -?0\.0, 0\.15\]'],
    'cartesian.py': [r'cartesian True True True'],
    'gripper.py': [r'gripper 0\.01[5-6]\d* 0\.03[67]\d* 0\.01[5-6]'],
    'dual_arm.py': [r'arm_1 \[0\.5, -?0\.0, -?0\.0, -?0\.0\]',
                    r'arm_2 \[-0\.5, -?0\.0, -?0\.0, -?0\.0\]'],
    'ros1_style.py': [r'trajectory 0\.6', r'standalone 0\.01[5-6]\d* True'],
    'current_control.py': [r'current moved True', r'current hold True'],
    'pwm_control.py': [r'pwm moved True', r'pwm stopped True'],
    # the simulation plays the last command out at robot_shutdown: the waist turns on
    'pwm_then_exit.py': [r'robot_shutdown: the last pwm command played out [1-9]\.\d s in '
                         r'the simulation \(waist \+(0\.[3-9]|[1-9]\.)\d* rad'],
}


#: simulated s per wall s of the in-process bringup (its driver owns the clock): the scripts'
#: results are poses and outputs, not their pacing (dual_arm: the second arm's driver follows
#: the first one's clock)
SPEED = 3.0
#: scripts run at real time: current_control's arm sags between its mode switch and its
#: currents (as the real arm does); at SPEED a 0.1 s wall gap dropped it onto the table
REAL_TIME = ('current_control.py',)


def test_only_import_lines_name_px100_control():
    """Every px100_control mention in the scripts is an import line (the only difference)."""
    for name in sorted(os.listdir(SCRIPTS)):
        if not name.endswith('.py'):
            continue
        with open(os.path.join(SCRIPTS, name), encoding='utf-8') as f:
            lines = f.read().splitlines()
        code = [x for x in lines if 'px100_control' in x and not x.startswith('"""')]
        for line in code:
            assert re.match(r'\s*(from px100_control\.client[\w.]* import|import px100_control'
                            r'|\s+robot_shutdown|\s+InterbotixManipulatorXS)', line), \
                (name, line)


@pytest.mark.parametrize('name', sorted(EXPECTED))
def test_script_runs_like_on_the_real_api(name):
    """The script exits 0 without traceback or ERROR log and prints the expected results."""
    path = os.path.join(SCRIPTS, name)
    if not os.path.exists(path):
        pytest.fail(f'{name} is missing')
    env = os.environ.copy()
    env['PYTHONPATH'] = os.pathsep.join([ROOT] + [p for p in env.get('PYTHONPATH', '').split(
        os.pathsep) if p])
    env['PX100_BRINGUP'] = '1'
    env['PX100_REAL_TIME_FACTOR'] = str(1.0 if name in REAL_TIME else SPEED)
    env['PYTHONUNBUFFERED'] = '1'
    proc = subprocess.run([sys.executable, path], env=env, capture_output=True, text=True,
                          timeout=60 + 120 * SLOW)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0, text[-4000:]
    assert 'Traceback' not in text, text[-4000:]
    assert '[ERROR]' not in text, [x for x in text.splitlines() if '[ERROR]' in x]
    for pattern in EXPECTED[name]:
        assert re.search(pattern, proc.stdout), (pattern, proc.stdout[-3000:])
