"""
What the quick tier runs, and how the full suite is split over parallel workers.

The quick tier: ``pytest -m quick``, ``bash scripts/test_quick.sh``. The parallel workers:
``scripts/test.sh`` (pytest-xdist), scheduled by worker_scope (test/conftest.py).

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
               'test/test_stall_meter.py', 'test/test_slowest_tests.py',
               'test/test_exit_watchdog.py',
               'test/perception/test_camera_model.py',
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


#: modules that share a pytest-xdist worker (run one after another, never beside each other):
#: the stress package shares one graph (a package fixture) and loads the machine on purpose; the
#: demo's viewer and the documented commands (viewer, demo --viewer) serve the default port 8080;
#: the perception examples and demo (camera, filter, bringup and a script each: about 1.5 cores)
#: starved each other's nodes when two ran at once (joint_states 1.07 s old, a shoulder that did
#: not settle), so they take turns
SERIAL_GROUPS = {'test/stress/': 'stress', 'test/docs/test_documented_commands.py': 'port_8080',
                 'test/viewer/test_viewer_demo_end.py': 'port_8080',
                 'test/perception/test_perception_examples.py': 'camera',
                 'test/perception/test_perception_demo.py': 'camera'}
#: slow modules whose tests share no module fixture (each starts its own processes): their tests
#: are handed out one by one, to run beside each other (checked at collection)
SPREAD_MODULES = ('test/test_clean_shutdown.py', 'test/client/test_client_demo.py',
                  'test/bag/test_bag_complete.py', 'test/examples/test_examples.py',
                  'test/client/test_client_interbotix_scripts.py',
                  'test/client/test_client_seed000.py', 'test/client/test_client_interrupt.py',
                  'test/client/test_client_lifecycle.py', 'test/nodes/test_duplicate_nodes.py',
                  'test/nodes/test_world_nodes.py', 'test/test_launch_files.py',
                  'test/robots/test_client_robots.py', 'test/robots/test_ik_service_robots.py',
                  'test/sim/test_sim_driver_node.py')
#: the scopes that cost the most wall time (CI's per-test times, scripts/slowest_tests.py:
#: camera 288 s, port_8080 141 s, the browser page 94 s, the rest under 50 s each), handed out
#: first and in this order: the longest units start at once instead of lengthening the run's tail
#: when dealt last (xdist orders by test count)
LONGEST_FIRST = ('camera', 'port_8080', 'test/viewer/test_viewer_browser.py',
                 'test/viewer/test_viewer_switches.py', 'test/client/test_demo_output.py',
                 'test/nodes/test_first_hour_nodes.py')
#: module fixtures cheap enough to set up on every worker that runs a SPREAD_MODULES test:
#: 'file::fixture'
CHEAP_SHARED_FIXTURES = {'conftest.py::_no_stray_processes', 'test_clean_shutdown.py::graph',
                         'test_clean_shutdown.py::replay_bag'}


def worker_scope(nodeid: str) -> str:
    """Return the unit a pytest-xdist worker gets a test in: its group, its module, or itself."""
    module = nodeid.split('::', 1)[0]
    for prefix, group in SERIAL_GROUPS.items():
        if module.startswith(prefix):
            return group
    return nodeid if module in SPREAD_MODULES else module


def longest_first(scopes) -> list:
    """Return ``scopes`` with those of LONGEST_FIRST first, in its order; the others as given."""
    rank = {scope: i for i, scope in enumerate(LONGEST_FIRST)}
    return sorted(scopes, key=lambda scope: rank.get(scope, len(rank)))
