"""
Clean shutdown of every long-running executable under every way a terminal or launcher stops it.

Ways: one SIGINT (Ctrl-C), two SIGINTs 10-300 ms apart (``ros2 launch``: the terminal's SIGINT
to the process group, then launch's own), SIGTERM (launch's escalation, ``kill``); executors:
``PX100_EXECUTOR`` events, single, multi. Each executable runs as ``ros2 run`` starts it, in a
namespace of its own (``-r __ns:=``), and gets its signal once it is up (its nodes in the graph;
``viewer --bag``, which has no node: its page served) plus a random 0-0.4 s, so signals land in
different phases of its callbacks. Every stop must exit 0 (what a plain rclpy node does on one
SIGINT or SIGTERM) with no abort, no ``[FATAL]`` line, no traceback, and the recorder's bag
closed (metadata.yaml written, MCAP footer present).

Repeats per executable, way and executor: 2 by default, 20 with ``PX100_STRESS=full``
(``PX100_SHUTDOWN_REPEATS=N`` overrides); the random choices are seeded by the case, so a
failure repeats with the same delays. The figures of the last run of each case are appended to
``out/shutdown_stress.jsonl``.
"""
import ast
import json
import os
import random
import signal
import socket
import subprocess
import tempfile
import time

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REPEATS = int(os.environ.get('PX100_SHUTDOWN_REPEATS')
              or (20 if os.environ.get('PX100_STRESS', '').lower() == 'full' else 2))
WAYS = ('sigint', 'sigint_twice', 'sigterm')
EXECUTORS = ('events', 'single', 'multi')
#: what must never appear in a stopped node's output
BAD_OUTPUT = ('[FATAL]', 'terminate called', 'Traceback', 'Segmentation fault', 'Aborted')
CORE = ['sim_driver', 'ik_service', 'trajectory_server', 'robot_state_publisher']
#: every long-running executable and the forms of one that run more: (executable, its own
#: arguments, what shows it is up: the node names it puts in the graph, or a line it prints)
EXECUTABLES = {
    'sim_driver': ('sim_driver', [], ['sim_driver']),
    'ik_service': ('ik_service', [], ['ik_service']),
    'trajectory_server': ('trajectory_server', [], ['trajectory_server']),
    'state_publisher': ('state_publisher', [], ['robot_state_publisher']),
    'bringup': ('bringup', [], CORE + ['camera']),
    'bringup --viewer': ('bringup', ['--viewer'], CORE + ['viewer', 'camera']),
    'camera': ('camera', [], ['camera']),
    'record': ('record', ['-a', '--flush-period', '0.2'], ['recorder']),
    'replay': ('replay', ['--loop', '--no-progress'], ['replayer']),
    'viewer': ('viewer', [], ['viewer']),
    'viewer --bag': ('viewer', ['--bag'], ' on http://'),
}
#: how long the processes of a round, started at once, may take to be up [s]
READY_TIMEOUT = 150.0
#: executables that end by themselves (nothing to stop)
ONE_SHOT = ('inspect', 'bag_reindex')


def test_every_long_running_executable_is_stopped():
    """EXECUTABLES holds every executable of setup.py that runs until stopped."""
    with open(os.path.join(ROOT, 'setup.py'), encoding='utf-8') as f:
        tree = ast.parse(f.read())
    exes = next(ast.literal_eval(n.value) for n in ast.walk(tree) if isinstance(n, ast.Assign)
                and any(getattr(t, 'id', '') == 'EXECUTABLES' for t in n.targets))
    assert {exe for exe, _, _ in EXECUTABLES.values()} == set(exes) - set(ONE_SHOT)


@pytest.fixture(scope='module')
def replay_bag():
    """
    Write a small bag for the replayer to loop over and the bag viewer to show.

    joint_states of the px100 (waist moving) and its robot_description.
    """
    from px100_control.bag.writer import BagWriter
    from px100_control.models.registry import load_robot
    from px100_control.models.urdf_prefix import prefix_urdf
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String
    model = load_robot('px100')
    path = os.path.join(tempfile.mkdtemp(prefix='px100_shutdown_'), 'bag')
    with BagWriter(path) as bag:
        bag.add_topic('/px100/robot_description', 'std_msgs/msg/String')
        bag.write('/px100/robot_description',
                  serialize_message(String(data=prefix_urdf(model.urdf_xml, 'px100'))), 10**18)
        bag.add_topic('/px100/joint_states', 'sensor_msgs/msg/JointState')
        for i in range(200):
            msg = JointState(name=list(model.joint_names), position=[0.001 * i] + [0.0] * 3)
            bag.write('/px100/joint_states', serialize_message(msg), 10**18 + i * 10**7)
    return path


def _free_port() -> int:
    """Return a TCP port free on this machine now (for a viewer's page)."""
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


@pytest.fixture(scope='module')
def graph():
    """Yield an rclpy node of the test that watches the graph."""
    rclpy = pytest.importorskip('rclpy')
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node('shutdown_watcher', context=ctx)
    yield node
    node.destroy_node()
    ctx.try_shutdown()


def _start(key, ns, tmp, replay_bag, executor):
    from px100_control.tools.processes import executable_path
    name, args, _ = EXECUTABLES[key]
    ros_args = ['--ros-args', '-r', f'__ns:={ns}']
    if name == 'record':
        args = args + ['-o', os.path.join(tmp, f'bag_{ns.strip("/")}')]
    elif name == 'replay':
        # the bag's /px100/joint_states into the process's own namespace (not the robot's)
        args = [replay_bag] + args + ['--topics', '/px100/joint_states', '--remap',
                                      '/px100/joint_states:=joint_states']
    elif args == ['--bag']:
        args = ['--bag', replay_bag, '--port', str(_free_port())]
    elif name == 'viewer' or '--viewer' in args:
        ros_args += ['-p', f'port:={_free_port()}']
    env = dict(os.environ, PX100_EXECUTOR=executor, PYTHONUNBUFFERED='1')
    log = open(os.path.join(tmp, f'{ns.strip("/")}.log'), 'w+b')
    proc = subprocess.Popen([executable_path(name), *args, *ros_args], stdout=log,
                            stderr=subprocess.STDOUT, env=env)
    return proc, log


def _up(graph_nodes, ns, ready, log) -> bool:
    """Return True once the process of namespace ns shows it is up (see EXECUTABLES)."""
    if isinstance(ready, str):
        with open(log.name, 'rb') as f:
            return ready.encode() in f.read()
    return all((ns, n) in graph_nodes for n in ready)


def _wait_ready(graph, expected, procs, timeout):
    """
    Wait until every process of expected {namespace: ready} is up or died.

    :return: {namespace: its nodes in the graph} of the processes not up in time
    """
    end = time.monotonic() + timeout
    while True:
        seen = {(ns, n) for n, ns in graph.get_node_names_and_namespaces()}
        missing = [key for key, ready in expected.items()
                   if procs[key][0].poll() is None and not _up(seen, key, ready, procs[key][1])]
        if not missing or time.monotonic() > end:
            return {key: sorted(n for ns, n in seen if ns == key) for key in missing}
        time.sleep(0.05)


def _stop(proc, way, rng):
    if way == 'sigterm':
        proc.send_signal(signal.SIGTERM)
    else:
        proc.send_signal(signal.SIGINT)
        if way == 'sigint_twice':
            time.sleep(rng.uniform(0.010, 0.300))
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)


def _bag_closed(path):
    from px100_control.bag.reader import check_mcap_file
    if not os.path.isfile(os.path.join(path, 'metadata.yaml')):
        return 'no metadata.yaml'
    mcaps = [f for f in os.listdir(path) if f.endswith('.mcap')]
    try:
        for f in mcaps:
            check_mcap_file(os.path.join(path, f))
    except Exception as exc:   # noqa: B902 - the reason is the finding
        return f'bad MCAP: {exc}'
    return '' if mcaps else 'no .mcap file'


def _round(graph, replay_bag, executor, way, rng, tmp):
    """Start every executable, stop each one the given way; return {exe: problem or ''}."""
    tag = f'{executor[0]}{way[-4:]}{os.getpid()}_{rng.randrange(10**6)}'
    procs, expected = {}, {}
    for key, (_, _, ready) in EXECUTABLES.items():
        ns = f"/sd_{tag}_{key.replace(' --', '_')}"
        procs[ns] = _start(key, ns, tmp, replay_bag, executor) + (key,)
        expected[ns] = ready
    missing = _wait_ready(graph, expected, procs, READY_TIMEOUT)
    results = {}
    order = list(procs)
    rng.shuffle(order)
    for ns in order:     # one not up yet is stopped too: its exit is reported with it
        time.sleep(rng.uniform(0.0, 0.4))
        _stop(procs[ns][0], way, rng)
    for ns in order:
        proc, log, name = procs[ns]
        try:
            rc = proc.wait(30.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            rc = f'hung (killed), exit {proc.wait(10.0)}'
        log.seek(0)
        out = log.read().decode('utf-8', 'replace')
        log.close()
        problems = []
        if ns in missing:
            problems.append(f'not up after {READY_TIMEOUT:g} s (its nodes in the graph: '
                            f"{', '.join(missing[ns]) or 'none'})")
        if rc != 0:
            problems.append(f'exit {rc}')
        problems += [f'{bad!r} in output' for bad in BAD_OUTPUT if bad in out]
        if name == 'record' and rc == 0:
            reason = _bag_closed(os.path.join(tmp, f'bag_{ns.strip("/")}'))
            if reason:
                problems.append('bag not closed: ' + reason)
        results[name] = (rc, '; '.join(problems) + ('\n' + out[-1500:] if problems else ''))
    return results


@pytest.mark.parametrize('way', WAYS)
@pytest.mark.parametrize('executor', EXECUTORS)
def test_every_executable_stops_cleanly(graph, replay_bag, executor, way, tmp_path):
    """REPEATS rounds: each executable stopped `way` under PX100_EXECUTOR=executor."""
    rng = random.Random(f'{executor}/{way}/{REPEATS}')     # str seeds do not vary per run
    counts = {name: {'runs': 0, 'exit_0': 0, 'aborts': 0, 'fatal': 0, 'problems': 0}
              for name in EXECUTABLES}
    failures = []
    for i in range(REPEATS):
        tmp = str(tmp_path / f'round{i}')
        os.makedirs(tmp)
        for name, (rc, problem) in _round(graph, replay_bag, executor, way, rng, tmp).items():
            c = counts[name]
            c['runs'] += 1
            c['exit_0'] += rc == 0
            c['aborts'] += rc == -signal.SIGABRT or 'terminate called' in problem
            c['fatal'] += '[FATAL]' in problem
            if problem:
                c['problems'] += 1
                failures.append(f'{name} ({executor}, {way}, round {i}): {problem}')
    os.makedirs(os.path.join(ROOT, 'out'), exist_ok=True)
    with open(os.path.join(ROOT, 'out', 'shutdown_stress.jsonl'), 'a', encoding='utf-8') as f:
        f.write(json.dumps({'time': time.strftime('%Y-%m-%dT%H:%M:%S'), 'executor': executor,
                            'way': way, 'repeats': REPEATS, 'counts': counts}) + '\n')
    assert not failures, '\n\n'.join(failures[:5]) + f'\n({len(failures)} problems)'
