"""ament_flake8 (the ROS 2 Python style) over the package, tests, scripts, benchmarks, examples."""
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: flake8 checks files in a pool of forked processes: it runs in a process of its own, since a
#: fork of this one, where earlier tests left DDS threads, can hang on a lock a thread held
CHECK = ('import sys\n'
         'from ament_flake8.main import main_with_errors\n'
         'rc, errors = main_with_errors(argv=sys.argv[1:])\n'
         "print('\\n'.join(errors))\n"
         'sys.exit(rc)\n')


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8():
    """Every file passes ament's flake8 configuration."""
    proc = subprocess.run([sys.executable, '-c', CHECK, 'px100_control', 'test', 'scripts',
                           'benchmarks', 'examples', 'setup.py'], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f'code style errors / warnings:\n{proc.stdout[-20000:]}' \
                                 f'\n{proc.stderr[-3000:]}'
