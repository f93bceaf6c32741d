"""
Shared test setup: a private DDS domain for this run, localhost-only discovery, and fixtures.

The domain comes from ROS_DOMAIN_ID if the runner set one (scripts/test.sh picks a random one),
otherwise one derived from the process id, so parallel runs do not see each other.

Parallel workers (pytest-xdist, ``-n N``; scripts/test.sh): worker ``gwK`` runs in domain
ROS_DOMAIN_ID + K and serves its viewer tests from PX100_VIEWER_TEST_PORT + 40 K, so workers share
no DDS graph and no port, and the stray-process cleanup (by domain) sees only its own worker's
programs. The scheduler (pytest_xdist_make_scheduler) hands out a test module at a time, so a
module's shared fixture (a bringup, a demo run) is set up once; the tests of SPREAD_MODULES
(each starts its own processes) go out one by one; SERIAL_GROUPS put modules on one worker.

The quick tier (``pytest -m quick``, ``bash scripts/test_quick.sh``): the tests of the pure
layers (QUICK_PATHS) not marked ros, slow, stress or linter get the ``quick`` marker. A quick
test that starts a ROS graph (an rclpy context, a node executable) fails, so a graph test cannot
slip into the tier unnoticed; with ``-m quick`` only QUICK_PATHS are collected (test/tiers.py).
"""
import os
import signal
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

os.environ.setdefault('ROS_DOMAIN_ID', str(10 + os.getpid() % 90))
#: this process's pytest-xdist worker number (gw0 -> 0), None outside a parallel run
WORKER = (int(os.environ['PYTEST_XDIST_WORKER'][2:])
          if os.environ.get('PYTEST_XDIST_WORKER', '').startswith('gw') else None)
#: viewer test ports a worker may use (test/viewer/viewer_support.py takes base .. base + 29)
WORKER_PORT_STRIDE = 40
if WORKER is not None and 'PX100_WORKER_DOMAIN_BASE' not in os.environ:
    os.environ['PX100_WORKER_DOMAIN_BASE'] = os.environ['ROS_DOMAIN_ID']
    os.environ['ROS_DOMAIN_ID'] = str(int(os.environ['ROS_DOMAIN_ID']) + WORKER)
    os.environ['PX100_VIEWER_TEST_PORT'] = str(
        int(os.environ.get('PX100_VIEWER_TEST_PORT', '8130')) + WORKER_PORT_STRIDE * WORKER)
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)

import pytest  # noqa: E402
from tiers import CHEAP_SHARED_FIXTURES, longest_first, NOT_QUICK, QUICK_PATHS, \
    SPREAD_MODULES, worker_scope  # noqa: E402


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """
    Schedule by worker_scope (xdist's loadgroup marks do not reach pytest 9's node ids).

    The first unit handed out reorders the queue: tiers.LONGEST_FIRST's scopes go out first.
    """
    from xdist.scheduler import LoadScopeScheduling

    class _Scheduling(LoadScopeScheduling):
        ordered = False

        def _split_scope(self, nodeid):
            return worker_scope(nodeid)

        def _assign_work_unit(self, node):
            if not self.ordered:
                for scope in reversed(longest_first(self.workqueue)):
                    self.workqueue.move_to_end(scope, last=False)
                self.ordered = True
            super()._assign_work_unit(node)
    return _Scheduling(config, log)


def _shared_fixtures(item) -> list:
    """Return the module, class or package fixtures of a test not in CHEAP_SHARED_FIXTURES."""
    info = getattr(item, '_fixtureinfo', None)
    found = []
    for name, defs in (info.name2fixturedefs.items() if info else ()):
        for d in defs:
            where = f'{os.path.basename(d.func.__code__.co_filename)}::{name}'
            if d.scope in ('module', 'class', 'package') and where not in CHEAP_SHARED_FIXTURES:
                found.append(where)
    return found


def _in_quick_paths(path) -> bool:
    rel = os.path.relpath(str(path), ROOT).replace(os.sep, '/')
    return any(rel == q.rstrip('/') or rel.startswith(q) for q in QUICK_PATHS)


def _quick_run(config) -> bool:
    return (config.getoption('markexpr', '') or '').strip() == 'quick'


def pytest_ignore_collect(collection_path, config):
    """With ``-m quick``, collect only QUICK_PATHS (the other modules import ROS: slow)."""
    if not _quick_run(config) or collection_path.is_dir():
        return None
    if collection_path.suffix == '.py' and collection_path.name.startswith('test_'):
        return None if _in_quick_paths(collection_path) else True
    return None


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Mark ``quick`` the tests of QUICK_PATHS that carry none of NOT_QUICK's markers."""
    for item in items:
        if _in_quick_paths(item.path) and not any(
                item.get_closest_marker(m) for m in NOT_QUICK):
            item.add_marker(pytest.mark.quick)
        rel = os.path.relpath(str(item.path), ROOT).replace(os.sep, '/')
        shared = _shared_fixtures(item) if rel in SPREAD_MODULES else []
        if shared:
            raise pytest.UsageError(
                f'{item.nodeid} is in SPREAD_MODULES (test/conftest.py) but uses the shared '
                f'fixture(s) {shared}: each worker would set them up; remove it from the list')


class QuickTierViolation(RuntimeError):
    """A quick-tier test started a ROS graph (an rclpy context or a node executable)."""


def _starts_a_node(args) -> bool:
    """Return whether a command line runs one of this package's ROS executables (not --help)."""
    argv = [str(a) for a in ([args] if isinstance(args, (str, bytes, os.PathLike)) else args)]
    text = ' '.join(argv)
    node = ('px100_control.ros.' in text or '/lib/px100_control/' in text
            or os.path.basename(argv[0]) in ('ros2', 'launch') if argv else False)
    return node and not any(a in ('--help', '-h') for a in argv)


def guard_ros_graph(patch, started: list) -> None:
    """
    Make starting a ROS graph raise QuickTierViolation and note it in ``started``.

    Guarded: ``rclpy.Context.init`` (what ``rclpy.init`` calls) and ``subprocess.Popen`` of
    this package's node executables (``NodeProcess``, ``python -m px100_control.ros.*``).

    :param patch: ``patch(owner, name, value)``, e.g. a MonkeyPatch's setattr
    :param started: a list the guard appends a description of each attempt to
    """
    try:
        import rclpy.context  # optional: guarded only where rclpy is installed
    except ImportError:
        rclpy = None
    if rclpy is not None:
        def _no_context(self, *args, **kwargs):
            started.append('rclpy.Context.init (an rclpy context: a ROS graph)')
            raise QuickTierViolation('a quick-tier test created an rclpy context')
        patch(rclpy.context.Context, 'init', _no_context)
    popen_init = subprocess.Popen.__init__

    def _popen(self, args, *rest, **kwargs):
        if _starts_a_node(args):
            started.append(f'subprocess {args!r} (a ROS node process)')
            raise QuickTierViolation(f'a quick-tier test started a ROS node: {args!r}')
        popen_init(self, args, *rest, **kwargs)
    patch(subprocess.Popen, '__init__', _popen)


#: ROS graphs started in a ``-m quick`` run (guarded for the whole session: module fixtures too)
_QUICK_RUN_STARTED = []


def pytest_configure(config):
    """In a ``-m quick`` run, guard against a ROS graph from the start (fixtures included)."""
    if _quick_run(config):
        guard_ros_graph(setattr, _QUICK_RUN_STARTED)


@pytest.fixture(autouse=True)
def _quick_tests_start_no_ros_graph(request, monkeypatch):
    """Fail a test marked ``quick`` that started a ROS graph (even if it caught the error)."""
    if request.node.get_closest_marker('quick') is None:
        yield
        return
    if _quick_run(request.config):
        started, before = _QUICK_RUN_STARTED, len(_QUICK_RUN_STARTED)
    else:
        started, before = [], 0
        guard_ros_graph(monkeypatch.setattr, started)
    yield
    if len(started) > before:
        pytest.fail(f'{request.node.nodeid} is in the quick tier (pure layers, no ROS graph) '
                    f'but started {"; ".join(started[before:])}: mark it ros, or move it out '
                    'of QUICK_PATHS (test/tiers.py)', pytrace=False)


@pytest.fixture(autouse=True)
def _default_signal_handlers():
    """
    Give every test the interpreter's SIGINT/SIGTERM handlers, and leave them so afterwards.

    A node's main() run in this process (``run_nodes``, the recorder's) ends by ignoring SIGINT
    while the interpreter finalises; left so, every later child process would inherit SIG_IGN
    and a Ctrl-C test's script would not see its SIGINT.
    """
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    yield
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


@pytest.fixture
def rclpy_context():
    """Yield an initialised rclpy Context of its own; shut it down afterwards."""
    rclpy = pytest.importorskip('rclpy')
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    ctx.try_shutdown()


@pytest.fixture
def spin_node(rclpy_context):
    """
    Spin nodes handed to the returned factory in a background executor.

    Everything is destroyed and the executor stopped at teardown.
    """
    import threading

    from px100_control.ros.common import make_executor

    # single-threaded: a Python MultiThreadedExecutor here lags behind fast publishers on 2
    # cores (a reliable keep-last writer then drops samples); not the EventsExecutor, which
    # rclpy 7.1 cannot run raw subscriptions with message info on (test listeners use them)
    executor = make_executor(context=rclpy_context, kind='single')
    nodes = []
    spinning = threading.Event()
    spinning.set()

    def _spin():
        try:
            while spinning.is_set() and rclpy_context.ok():
                executor.spin_once(timeout_sec=0.05)
        except Exception:  # noqa: B902 - the context was shut down under the executor
            if spinning.is_set():
                raise

    thread = threading.Thread(target=_spin, daemon=True)
    started = []

    def _add(*new_nodes):
        for n in new_nodes:
            executor.add_node(n)
            nodes.append(n)
        if not started:
            thread.start()
            started.append(True)
        return new_nodes[0] if len(new_nodes) == 1 else new_nodes

    yield _add
    spinning.clear()
    if started:
        thread.join(timeout=5.0)
    executor.shutdown(timeout_sec=2.0)
    for n in nodes:
        n.destroy_node()


@pytest.fixture
def node_process():
    """
    Start this package's executables through the returned factory (name, *args).

    Each process is stopped with SIGINT and waited for at teardown; a process that had to be
    killed fails the test.
    """
    from px100_control.tools.processes import NodeProcess

    procs = []

    def _start(name, *args, env=None):
        p = NodeProcess(name, args, env=env)
        procs.append(p)
        return p

    yield _start
    killed = []
    for p in procs:
        p.stop()
        if p.killed:
            killed.append(p.name)
    assert not killed, f'processes ignored SIGINT and were killed: {killed}'


def _stray_processes():
    """Return [(pid, cmdline)] of this project's programs in this run's DDS domain (not pytest)."""
    domain = f"ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID')}".encode()
    mine, pid = set(), os.getpid()
    while pid > 1:                               # this process and its ancestors
        mine.add(pid)
        try:
            with open(f'/proc/{pid}/stat', 'rb') as f:
                pid = int(f.read().rsplit(b')', 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            break
    stray = []
    for entry in os.listdir('/proc'):
        if not entry.isdigit() or int(entry) in mine:
            continue
        try:
            with open(f'/proc/{entry}/environ', 'rb') as f:
                environ = f.read().split(b'\0')
            # a package fixture's processes (the stress graph) outlive a module by design
            if domain not in environ or b'PX100_TEST_LIFETIME=package' in environ:
                continue
            with open(f'/proc/{entry}/cmdline', 'rb') as f:
                cmd = f.read().replace(b'\0', b' ').decode(errors='replace').strip()
        except OSError:
            continue
        # this project's Python programs only (not a shell's `| tail` beside pytest, nor the
        # session's browser)
        argv = cmd.split(' ')
        if 'python' in os.path.basename(argv[0]) and \
                any(a.startswith(ROOT) or 'px100' in a for a in argv[1:]):
            stray.append((int(entry), cmd))
    return stray


_STRAYS = []


@pytest.fixture(scope='module', autouse=True)
def _no_stray_processes(request):
    """
    After each test module, stop every process it left running in this run's DDS domain.

    A node left running by one module would be a duplicate in the next module's graph (its goals
    aborted, its latched topics mixed in); it is listed in the summary and in out/strays.log.
    """
    yield
    import time
    stray = _stray_processes()
    if not stray:
        return
    for pid, _ in stray:
        try:
            os.kill(pid, signal.SIGINT)
        except OSError:
            pass
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline and any(os.path.exists(f'/proc/{p}') for p, _ in stray):
        time.sleep(0.1)
    for pid, _ in stray:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass
    out = os.path.join(ROOT, 'out')
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, 'strays.log'), 'a', encoding='utf-8') as f:
        for pid, cmd in stray:
            _STRAYS.append((request.node.nodeid, pid, cmd))
            f.write(f'{request.node.nodeid}: {pid} {cmd}\n')


_RERUN_FAILURES = []


def _cpu_seconds() -> float:
    """Return the user + system CPU [s] of this process and of its children waited for."""
    import resource
    own, children = (resource.getrusage(w) for w in (resource.RUSAGE_SELF,
                                                     resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """
    Note each test's CPU and wall time in out/cpu/<worker>.jsonl (scripts/slowest_tests.py).

    CPU is this process's and its children's once reaped: node processes of the test's own,
    and a module fixture's (the browser, a shared bringup) in the module's last test, so sums
    per module are what a module costs.
    """
    import json
    import time
    cpu, wall = _cpu_seconds(), time.monotonic()
    yield
    row = {'test': item.nodeid, 'cpu_s': round(_cpu_seconds() - cpu, 3),
           'wall_s': round(time.monotonic() - wall, 3)}
    folder = os.path.join(ROOT, 'out', 'cpu')
    os.makedirs(folder, exist_ok=True)
    worker = os.environ.get('PYTEST_XDIST_WORKER', 'main')
    with open(os.path.join(folder, f'{worker}.jsonl'), 'a', encoding='utf-8') as f:
        f.write(json.dumps(row) + '\n')


def pytest_runtest_logreport(report):
    """Keep why a test failed before a rerun (``--reruns``) passed it: out/reruns.log."""
    if report.outcome != 'rerun':
        return
    import time
    text = report.longreprtext
    _RERUN_FAILURES.append((report.nodeid, report.when, text))
    out = os.path.join(ROOT, 'out')
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, 'reruns.log'), 'a', encoding='utf-8') as f:
        f.write(f'=== {time.strftime("%Y-%m-%dT%H:%M:%S")} {report.nodeid} ({report.when})\n'
                f'{text}\n')


def pytest_terminal_summary(terminalreporter):
    """Print the processes a module left running, and every failure a rerun then passed."""
    if _STRAYS:
        terminalreporter.section('processes left running by a test module (stopped)')
        for nodeid, pid, cmd in _STRAYS:
            terminalreporter.write_line(f'{nodeid}: {pid} {cmd[:200]}')
    if not _RERUN_FAILURES:
        return
    terminalreporter.section('failures before a rerun (full text: out/reruns.log)')
    for nodeid, when, text in _RERUN_FAILURES:
        lines = [x for x in text.splitlines() if x.strip()]
        terminalreporter.write_line(f'{nodeid} ({when}):')
        for line in lines[-12:]:
            terminalreporter.write_line(f'    {line[:300]}')
