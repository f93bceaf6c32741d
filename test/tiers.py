"""
What the quick tier runs (``pytest -m quick``, ``bash scripts/test_quick.sh``).

The full suite runs everything. The tier is the tests under QUICK_PATHS that carry none of
NOT_QUICK's markers (test/conftest.py marks them ``quick`` and fails one that starts a ROS
graph). A sweep over every registered robot runs in the quick tier for one robot of each
kinematic family (QUICK_ROBOTS); the other robots' cases carry the ``slow`` marker, which keeps
them out of the quick tier and nothing else.
"""
import pytest

#: test files and folders of the pure layers (kinematics, models, control, sim engine, bag I/O,
#: wire, parameter schemas, architecture, perception, interface type hashes), relative to the
#: repository
QUICK_PATHS = ('test/kinematics/', 'test/control/', 'test/sim/', 'test/bag/', 'test/robots/',
               'test/nodes/test_trajectory_core.py', 'test/nodes/test_cdr_replies.py',
               'test/test_architecture.py', 'test/test_parameter_schema.py',
               'test/test_path_timing.py', 'test/test_queue_delay.py',
               'test/test_stall_meter.py', 'test/perception/test_camera_model.py',
               'test/perception/test_cloud_filter.py', 'test/perception/test_pointcloud2.py',
               'test/perception/test_tf_buffer.py', 'test/interfaces/')
#: markers that keep a test out of the quick tier
NOT_QUICK = ('ros', 'slow', 'stress', 'linter')
#: one robot per family: the px100 (4-DOF closed form, the project's robot), a 6-DOF wrist arm,
#: the 7-DOF myArm 300 Pi and the prismatic RRRP arm
QUICK_ROBOTS = ('px100', 'wx250s', 'myarm300pi', 'rrrp')


def robots(names):
    """Return pytest parameters of ``names``; those not in QUICK_ROBOTS are marked slow."""
    return [n if n in QUICK_ROBOTS else pytest.param(n, marks=pytest.mark.slow) for n in names]
