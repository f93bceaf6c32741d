"""The parallel run's units (test/tiers.py, test/conftest.py): modules named exist; scopes."""
import os
import random
import subprocess
import sys

from scripts_support import load_script
import tiers

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_spread_and_serial_modules_exist():
    """A renamed module would silently fall back to whole-module scheduling."""
    for path in (*tiers.SPREAD_MODULES, *tiers.SERIAL_GROUPS):
        assert os.path.exists(os.path.join(ROOT, path)), path
    groups = set(tiers.SERIAL_GROUPS.values())
    for scope in tiers.LONGEST_FIRST:
        assert scope in groups or os.path.exists(os.path.join(ROOT, scope)), scope


def test_longest_scopes_go_first_the_rest_keep_their_order():
    scopes = ['test/a.py', 'port_8080', 'test/b.py', 'camera', 'test/c.py']
    assert tiers.longest_first(scopes) == ['camera', 'port_8080', 'test/a.py', 'test/b.py',
                                           'test/c.py']


def test_worker_scope_is_group_then_test_then_module():
    assert tiers.worker_scope('test/stress/test_load.py::test_x[1]') == 'stress'
    assert tiers.worker_scope('test/viewer/test_viewer_demo_end.py::test_page') == \
        'port_8080'
    one = 'test/test_clean_shutdown.py::test_every_executable_stops_cleanly[events-rotation]'
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


def _free_domain_module():
    """Import scripts/free_domain.py (a script, not a package module)."""
    return load_script('free_domain')


def test_free_domain_skips_a_domain_a_real_participant_holds():
    """A real rclpy node in domain d makes d 'in use'; the picker then never returns d."""
    free_domain = _free_domain_module()
    domain = free_domain.free_domains(1)
    assert domain is not None and not free_domain.domain_in_use(domain)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    code = ('import rclpy, sys\nrclpy.init()\nnode = rclpy.create_node("domain_holder")\n'
            'print("ready", flush=True)\nsys.stdin.readline()\n')
    holder = subprocess.Popen([sys.executable, '-c', code], env=env, text=True,
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        assert holder.stdout.readline().strip() == 'ready', 'the holder node did not start'
        assert free_domain.domain_in_use(domain), \
            f'a node in domain {domain} holds none of its discovery ports'
        only_that_one = random.Random(0)
        only_that_one.shuffle = lambda starts: starts.sort(key=lambda d: d != domain)
        assert free_domain.free_domains(1, rng=only_that_one) != domain
        assert free_domain.free_domains(2, rng=only_that_one) not in (domain, domain - 1)
    finally:
        holder.stdin.close()
        assert holder.wait(timeout=30) == 0


def test_free_domain_refuses_a_worker_count_that_is_no_number():
    """One line naming the bad value, exit 2, no domain printed."""
    done = subprocess.run([sys.executable, os.path.join(ROOT, 'scripts', 'free_domain.py'),
                           'two'], capture_output=True, text=True, timeout=30)
    assert done.returncode == 2 and done.stdout == ''
    assert "WORKERS must be a whole number, not 'two'" in done.stderr
