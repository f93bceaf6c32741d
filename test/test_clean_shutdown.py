"""
Clean shutdown of every long-running executable under every way a terminal or launcher stops it.

Ways: one SIGINT (Ctrl-C), two SIGINTs 10-300 ms apart (``ros2 launch``: the terminal's SIGINT
to the process group, then launch's own), SIGTERM (launch's escalation, ``kill``); executors:
``PX100_EXECUTOR`` events, single, multi. Each executable runs as ``ros2 run`` starts it, in a
namespace of its own (``-r __ns:=``), and gets its signal once its nodes are in the graph (plus
a random 0-0.4 s, so signals land in different phases of its callbacks). Every stop must exit
0 (what a plain rclpy node does on one SIGINT or SIGTERM) with no abort, no ``[FATAL]`` line,
no traceback, and the recorder's bag closed (metadata.yaml written, MCAP footer present).

Repeats per executable, way and executor: 2 by default, 20 with ``PX100_STRESS=full``
(``PX100_SHUTDOWN_REPEATS=N`` overrides). The figures of the last run of each case are appended
to ``out/shutdown_stress.jsonl``.
"""
import json
import os
import random
import signal
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


def _executables():
    """Return {executable: node names it creates} for every long-running executable."""
    with open(os.path.join(ROOT, 'setup.py'), encoding='utf-8') as f:
        text = f.read()
    exes = {'sim_driver': ['sim_driver'], 'ik_service': ['ik_service'],
            'trajectory_server': ['trajectory_server'],
            'bringup': ['sim_driver', 'ik_service', 'trajectory_server'],
            'record': ['recorder'], 'replay': ['replayer']}
    if "'viewer'" in text:
        exes['viewer'] = ['viewer']
    return exes


EXECUTABLES = _executables()


@pytest.fixture(scope='module')
def replay_bag():
    """Write a small bag of joint_states for the replayer to loop over."""
    from px100_control.bag.writer import BagWriter
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    path = os.path.join(tempfile.mkdtemp(prefix='px100_shutdown_'), 'bag')
    with BagWriter(path) as bag:
        bag.add_topic('/px100/joint_states', 'sensor_msgs/msg/JointState')
        for i in range(200):
            msg = JointState(name=['waist'], position=[0.001 * i])
            bag.write('/px100/joint_states', serialize_message(msg), 10**18 + i * 10**7)
    return path


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


def _start(name, ns, tmp, replay_bag, executor):
    from px100_control.tools.processes import executable_path
    args = []
    if name == 'record':
        args = ['-a', '-o', os.path.join(tmp, f'bag_{ns.strip("/")}'), '--flush-period', '0.2']
    elif name == 'replay':
        # the bag's /px100/joint_states into the process's own namespace (not the robot's)
        args = [replay_bag, '--loop', '--no-progress', '--remap',
                '/px100/joint_states:=joint_states']
    elif name == 'viewer':
        args = ['--ros-args', '-p', f'port:={8140 + random.randrange(10)}']
    ros_args = ['-r', f'__ns:={ns}']
    args = args + (ros_args if '--ros-args' in args else ['--ros-args'] + ros_args)
    env = dict(os.environ, PX100_EXECUTOR=executor, PYTHONUNBUFFERED='1')
    log = open(os.path.join(tmp, f'{ns.strip("/")}.log'), 'w+b')
    proc = subprocess.Popen([executable_path(name), *args], stdout=log,
                            stderr=subprocess.STDOUT, env=env)
    return proc, log


def _wait_ready(graph, expected, procs, timeout):
    """Wait until every (namespace, node) of expected is in the graph or its process died."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        seen = {(ns, n) for n, ns in graph.get_node_names_and_namespaces()}
        missing = [key for key, nodes in expected.items()
                   if procs[key][0].poll() is None and not all((key, n) in seen for n in nodes)]
        if not missing:
            return []
        time.sleep(0.05)
    return missing


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
    tag = f'{executor[0]}{way[-4:]}{rng.randrange(10**6)}'
    procs, expected = {}, {}
    for name, nodes in EXECUTABLES.items():
        ns = f'/sd_{tag}_{name}'
        procs[ns] = _start(name, ns, tmp, replay_bag, executor) + (name,)
        expected[ns] = nodes
    missing = _wait_ready(graph, expected, procs, timeout=90.0)
    results = {}
    order = list(procs)
    rng.shuffle(order)
    for ns in order:
        proc = procs[ns][0]
        if ns in missing:
            continue
        time.sleep(rng.uniform(0.0, 0.4))
        _stop(proc, way, rng)
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
            problems.append('never appeared in the graph')
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
    rng = random.Random(hash((executor, way, REPEATS)))
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
