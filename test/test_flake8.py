"""ament_flake8 (the ROS 2 Python style) over the package, tests, scripts, benchmarks, examples."""
from ament_flake8.main import main_with_errors
import pytest


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8():
    """Every file passes ament's flake8 configuration."""
    rc, errors = main_with_errors(argv=['px100_control', 'test', 'scripts', 'benchmarks',
                                        'examples', 'setup.py'])
    assert rc == 0, \
        'Found %d code style errors / warnings:\n' % len(errors) + '\n'.join(errors)
