"""ament_pep257 (docstring conventions of ROS 2) over the package and the tests."""
from ament_pep257.main import main
import pytest


@pytest.mark.linter
@pytest.mark.pep257
def test_pep257():
    """Every docstring passes ament's pep257 configuration."""
    rc = main(argv=['px100_control', 'test'])
    assert rc == 0, 'Found code style errors / warnings'
