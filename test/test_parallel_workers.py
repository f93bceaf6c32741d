"""The parallel run's units (test/tiers.py, test/conftest.py): modules named exist; scopes."""
import os

import tiers

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_spread_and_serial_modules_exist():
    """A renamed module would silently fall back to whole-module scheduling."""
    for path in (*tiers.SPREAD_MODULES, *tiers.SERIAL_GROUPS):
        assert os.path.exists(os.path.join(ROOT, path)), path


def test_worker_scope_is_group_then_test_then_module():
    assert tiers.worker_scope('test/stress/test_load.py::test_x[1]') == 'stress'
    assert tiers.worker_scope('test/viewer/test_viewer_demo_end.py::test_page') == \
        'port_8080'
    one = 'test/test_clean_shutdown.py::test_every_executable_stops_cleanly[events-sigint]'
    assert tiers.worker_scope(one) == one
    assert tiers.worker_scope('test/client/test_client_arm.py::test_home') == \
        'test/client/test_client_arm.py'


def test_workers_get_a_domain_and_ports_of_their_own():
    """Worker gwK: ROS_DOMAIN_ID = base + K, viewer ports base + 40 K; outside xdist: as set."""
    worker = os.environ.get('PYTEST_XDIST_WORKER')
    if worker is None:
        return
    k = int(worker[2:])
    base = int(os.environ['PX100_WORKER_DOMAIN_BASE'])
    assert int(os.environ['ROS_DOMAIN_ID']) == base + k
