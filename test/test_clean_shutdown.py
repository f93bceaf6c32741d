"""
Clean shutdown of every long-running executable under every way a terminal or launcher stops it.

Ways: one SIGINT (Ctrl-C), two SIGINTs 10-300 ms apart (``ros2 launch``: the terminal's SIGINT
to the process group, then launch's own), SIGTERM (launch's escalation, ``kill``); executors:
``PX100_EXECUTOR`` events, single, multi. Each executable runs as ``ros2 run`` starts it, in a
namespace of its own (``-r __ns:=``), and gets its signal once it is up (its nodes in the graph;
``viewer --bag``, which has no node: its page served) at a random 0-0.4 s (all of a round's
processes within those 0.4 s, as ``ros2 launch`` stops them), so signals land in different
phases of its callbacks. ``viewer --bag`` (no node) runs in the events rounds only, ``camera``
(single-threaded under ``multi``) not in the multi rounds (SAME_AS_IN). Every stop must exit 0
(what a plain rclpy node does on one SIGINT or SIGTERM) with no abort, no ``[FATAL]`` line, no
traceback, and the recorder's bag closed (metadata.yaml written, MCAP footer present).

Rounds. By default one round per executor, in which the executables take the three ways in
rotation (ROTATION: executable k stops the way ``WAYS[(k + e) % 3]`` in the round of executor
``e``; one left out of some rounds by SAME_AS_IN stops its other ways as extra instances in its
first round): across the three rounds every executable is stopped every way and under every
executor it runs under, and every (executor, way) pair is met; 36 stops in 3 rounds.
A round costs its processes' starts (10 to 12 at once: 25-40 s on 2 cores), so the full product
(9 rounds, one per executor and way, every executable stopped that way) ran 99 stops in about
330 s of the suite's time; it runs with ``PX100_STRESS=full`` (20 repeats of each of the 9
rounds) or ``PX100_SHUTDOWN_PRODUCT=1``. ``PX100_SHUTDOWN_REPEATS=N`` sets the repeats of either
form. The random choices are seeded by the case, so a failure repeats with the same delays. The
figures of the last run of each case are appended to ``out/shutdown_stress.jsonl``.
"""
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
FULL = os.environ.get('PX100_STRESS', '').lower() == 'full'
REPEATS = int(os.environ.get('PX100_SHUTDOWN_REPEATS') or (20 if FULL else 1))
WAYS = ('sigint', 'sigint_twice', 'sigterm')
EXECUTORS = ('events', 'single', 'multi')
#: the way of the rotation: each executable's way changes from one executor's round to the next
ROTATION = 'rotation'
#: True: one round per executor and way (9), every executable stopped that way
PRODUCT = FULL or os.environ.get('PX100_SHUTDOWN_PRODUCT', '').lower() in ('1', 'true', 'yes')
#: stops whose participant teardown hung and px100_control.tools.exit_watchdog ended (a Fast
#: DDS 2.14 deadlock, docs/guide.md): the status is still checked, the count is a figure
WATCHDOG_EXITS = []
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
    'pc_filter': ('pc_filter', [], ['pointcloud_pipeline']),
}
#: the executable that runs each of CORE's nodes where their names differ
EXECUTABLE_OF_NODE = {'robot_state_publisher': 'state_publisher'}
#: how long the processes of a round, started at once, may take to be up [s] (10 s alone on
#: the 2-core machine, 30 s beside the other worker)
READY_TIMEOUT = 90.0
#: executables that end by themselves (nothing to stop)
ONE_SHOT = ('inspect', 'bag_reindex')


def test_every_long_running_executable_is_stopped():
    """EXECUTABLES holds every executable of setup.py that runs until stopped."""
    from px100_control.entry_points import TARGETS
    assert {exe for exe, _, _ in EXECUTABLES.values()} == set(TARGETS) - set(ONE_SHOT)


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
    # faulthandler: a process that never comes up is sent SIGABRT and prints where it hangs
    env = dict(os.environ, PX100_EXECUTOR=executor, PYTHONUNBUFFERED='1', PYTHONFAULTHANDLER='1')
    log = open(os.path.join(tmp, f'{ns.strip("/")}_{key}.log'), 'w+b')
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


def ways_of_round(executor, way):
    """
    Return {executable: [the ways its instances are stopped]} in the round of ``executor``.

    ``way`` one of WAYS: every executable of the round, one instance, that way. ROTATION:
    executable k (in EXECUTABLES' order) takes WAYS[(k + e) % 3] in the round of EXECUTORS[e],
    so over the three executors' rounds it takes each way once; one left out of some rounds
    (SAME_AS_IN) runs the ways those rounds would have given it as extra instances in its first
    round. An executable not in the executor's round is absent.
    """
    out = {}
    for k, key in enumerate(EXECUTABLES):
        rounds = [e for e in EXECUTORS if e not in SAME_AS_IN.get(key, ())]
        if executor not in rounds:
            continue
        if way != ROTATION:
            out[key] = [way]
            continue
        own = {e: WAYS[(k + EXECUTORS.index(e)) % len(WAYS)] for e in rounds}
        extra = [w for w in WAYS if w not in own.values()] if executor == rounds[0] else []
        out[key] = [own[executor]] + extra
    return out


def _signal_schedule(procs, rng):
    """
    Send each process its signal(s) at a random time within 0.4 s of the others.

    ``procs``: [(process, way)]. The times are drawn per process (a second SIGINT 10-300 ms
    after the first), then sent in time order: the stops overlap as under ``ros2 launch``, and
    the round does not wait for each delay in turn.
    """
    events = []
    for proc, way in procs:
        at = rng.uniform(0.0, 0.4)
        sig = signal.SIGTERM if way == 'sigterm' else signal.SIGINT
        events.append((at, proc, sig))
        if way == 'sigint_twice':
            events.append((at + rng.uniform(0.010, 0.300), proc, signal.SIGINT))
    start = time.monotonic()
    for at, proc, sig in sorted(events, key=lambda e: e[0]):
        time.sleep(max(0.0, start + at - time.monotonic()))
        if proc.poll() is None:
            proc.send_signal(sig)


def _stacks_then_kill(proc) -> str:
    """
    Stop a process that hung on its stop signal; return how it ended.

    SIGABRT first: with PYTHONFAULTHANDLER (as _start sets it) the process prints every
    thread's stack into its log, the evidence of where it hung (a CI run: one ik_service of
    the single-threaded rotation ignored SIGTERM for 30 s, its log ending at 'ready').
    """
    proc.send_signal(signal.SIGABRT)
    try:
        return f'hung, SIGABRT for its stacks, exit {proc.wait(5.0)}'
    except subprocess.TimeoutExpired:
        proc.kill()
        return f'hung, SIGABRT then killed, exit {proc.wait(10.0)}'


#: executables left out of some executors' rounds, where they would run as in another round:
#: ``viewer --bag`` has no ROS node; camera spins single-threaded under multi (one GL thread)
SAME_AS_IN = {'viewer --bag': ('single', 'multi'), 'camera': ('multi',)}


def _round(graph, replay_bag, executor, way, rng, tmp):
    """
    Start every executable, stop each instance as ways_of_round says.

    :return: {(executable, way): (exit code, problem or '')}
    """
    tag = f'{executor[0]}{way[-4:]}{os.getpid()}_{rng.randrange(10**6)}'
    procs, expected = {}, {}
    for key, ways in ways_of_round(executor, way).items():
        for its_way in ways:
            ns = f"/sd_{tag}_{key.replace(' --', '_')}_{its_way[-4:]}"
            procs[ns] = _start(key, ns, tmp, replay_bag, executor) + (key, its_way)
            expected[ns] = EXECUTABLES[key][2]
    missing = _wait_ready(graph, expected, procs, READY_TIMEOUT)
    for ns in missing:      # the evidence: every thread's Python stack, into its log
        if procs[ns][0].poll() is None:
            procs[ns][0].send_signal(signal.SIGABRT)
    results = {}
    order = list(procs)
    rng.shuffle(order)
    # one not up yet is stopped too: its exit is reported with it
    _signal_schedule([(procs[ns][0], procs[ns][3]) for ns in order], rng)
    for ns in order:
        proc, log, name, its_way = procs[ns]
        try:
            rc = proc.wait(30.0)
        except subprocess.TimeoutExpired:
            rc = _stacks_then_kill(proc)
        log.seek(0)
        out = log.read().decode('utf-8', 'replace')
        log.close()
        problems = []
        if ns in missing:
            problems.append(f'not up after {READY_TIMEOUT:g} s, then SIGABRT for its stacks '
                            f'(its nodes in the graph: '
                            f"{', '.join(missing[ns]) or 'none'})")
        if rc != 0:
            problems.append(f'exit {rc}')
        problems += [f'{bad!r} in output' for bad in BAD_OUTPUT if bad in out]
        if 'participant teardown hung' in out:      # exit_watchdog ended it: counted, no fail
            WATCHDOG_EXITS.append(f'{name} ({executor}, {its_way})')
        if name == 'record' and rc == 0:
            reason = _bag_closed(os.path.join(tmp, f'bag_{ns.strip("/")}'))
            if reason:
                problems.append('bag not closed: ' + reason)
        results[name, its_way] = (rc, '; '.join(problems)
                                  + ('\n' + out[-(6000 if isinstance(rc, str) else 1500):]
                                     if problems else ''))
    return results


def test_rotation_stops_every_executable_every_way_under_every_executor():
    """
    The default rounds (ROTATION) keep what the product's 9 rounds test, pairwise.

    Every executable is stopped each way and runs under each executor it runs under in the
    product; every (executor, way) pair is met; no executable runs where SAME_AS_IN leaves it out.
    """
    runs = [(key, w, e) for e in EXECUTORS for key, ways in ways_of_round(e, ROTATION).items()
            for w in ways]
    for key in EXECUTABLES:
        rounds = {e for e in EXECUTORS if e not in SAME_AS_IN.get(key, ())}
        assert sorted(w for k, w, _ in runs if k == key) == sorted(WAYS), key
        assert {e for k, _, e in runs if k == key} == rounds, key
    assert {(e, w) for _, w, e in runs} == {(e, w) for e in EXECUTORS for w in WAYS}
    product = [(key, w, e) for e in EXECUTORS for w in WAYS
               for key in ways_of_round(e, w)]
    assert len(runs) == len(EXECUTABLES) * len(WAYS) < len(product)


@pytest.mark.parametrize('way', WAYS if PRODUCT else (ROTATION,))
@pytest.mark.parametrize('executor', EXECUTORS)
def test_every_executable_stops_cleanly(graph, replay_bag, executor, way, tmp_path):
    """REPEATS rounds: each executable stopped `way` (or ROTATION's) under that executor."""
    rng = random.Random(f'{executor}/{way}/{REPEATS}')     # str seeds do not vary per run
    counts = {name: {'runs': 0, 'exit_0': 0, 'aborts': 0, 'fatal': 0, 'problems': 0}
              for name in EXECUTABLES if executor not in SAME_AS_IN.get(name, ())}
    failures = []
    for i in range(REPEATS):
        tmp = str(tmp_path / f'round{i}')
        os.makedirs(tmp)
        for (name, its_way), (rc, problem) in _round(graph, replay_bag, executor, way, rng,
                                                     tmp).items():
            c = counts[name]
            c['runs'] += 1
            c['exit_0'] += rc == 0
            c['aborts'] += rc == -signal.SIGABRT or 'terminate called' in problem
            c['fatal'] += '[FATAL]' in problem
            if problem:
                c['problems'] += 1
                failures.append(f'{name} ({executor}, {its_way}, round {i}): {problem}')
    os.makedirs(os.path.join(ROOT, 'out'), exist_ok=True)
    with open(os.path.join(ROOT, 'out', 'shutdown_stress.jsonl'), 'a', encoding='utf-8') as f:
        f.write(json.dumps({'time': time.strftime('%Y-%m-%dT%H:%M:%S'), 'executor': executor,
                            'way': way, 'repeats': REPEATS, 'counts': counts,
                            'teardown_watchdog_exits': WATCHDOG_EXITS}) + '\n')
    assert not failures, '\n\n'.join(failures[:5]) + f'\n({len(failures)} problems)'


#: rounds of the during-a-move test (``ros2 launch`` stopping a moving arm; 20 when full)
MOVE_REPEATS = int(os.environ.get('PX100_SHUTDOWN_REPEATS')
                   or (20 if os.environ.get('PX100_STRESS', '').lower() == 'full' else 3))


class _MoveWatcher:
    """A test-side node that sends a goal and sees the setpoints of the server streaming it."""

    def __init__(self, ctx, ns):
        from control_msgs.action import FollowJointTrajectory
        from rclpy.action import ActionClient
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from sensor_msgs.msg import JointState
        import threading
        self.node = Node('move_watcher', namespace=ns, context=ctx)
        self.setpoints, self.goals_sent = 0, 0
        self.action = ActionClient(self.node, FollowJointTrajectory,
                                   'arm_controller/follow_joint_trajectory')
        self.node.create_subscription(JointState, 'commands/joint_setpoints', self._on_sp, 100)
        self.executor = SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def _on_sp(self, msg):
        self.setpoints += 1

    def send_waist_move(self, seconds):
        """Send a FollowJointTrajectory goal (from the executor's thread: ros2/rclpy#1123)."""
        from builtin_interfaces.msg import Duration
        from control_msgs.action import FollowJointTrajectory
        from trajectory_msgs.msg import JointTrajectoryPoint
        goal = FollowJointTrajectory.Goal()
        goal.trajectory.joint_names = ['waist']
        goal.trajectory.points = [JointTrajectoryPoint(positions=[1.0], time_from_start=Duration(
            sec=int(seconds)))]
        if self.action.server_is_ready():
            self.goals_sent += 1
            self.executor.create_task(lambda: self.action.send_goal_async(goal))

    def close(self):
        self.executor.shutdown(timeout_sec=2.0)
        self.thread.join(5.0)
        self.node.destroy_node()


def _log_tail(log, size: int = 1500) -> str:
    """Return the end of a process's log file (open, being written) without moving its end."""
    log.flush()
    with open(log.name, 'rb') as f:
        return f.read().decode('utf-8', 'replace')[-size:]


def _move_round(graph, rng, tmp, index):
    """Start the core nodes, move the arm, SIGINT each (twice at random); return problems."""
    ns = f'/mv_{os.getpid()}_{index}'
    procs = {}
    for name in CORE:
        procs[name] = _start(EXECUTABLE_OF_NODE.get(name, name), ns, tmp, None, 'events')
    missing = _wait_ready(graph, {ns: CORE}, {ns: procs['sim_driver']}, READY_TIMEOUT)
    watcher = _MoveWatcher(graph.context, ns)
    problems = []
    try:
        deadline = time.monotonic() + 60.0
        while not missing and watcher.setpoints < 20 and time.monotonic() < deadline:
            if watcher.setpoints == 0:
                watcher.send_waist_move(4)
            time.sleep(0.25)
        if watcher.setpoints < 20:
            publishers = watcher.node.count_publishers('commands/joint_setpoints')
            problems.append(f'no move streamed (setpoints seen: {watcher.setpoints}; '
                            f'not up: {missing}; goals sent: {watcher.goals_sent}; action '
                            f'server ready: {watcher.action.server_is_ready()}; setpoint '
                            f'publishers: {publishers})\n-- trajectory_server:\n'
                            f"{_log_tail(procs['trajectory_server'][1])}")
        time.sleep(rng.uniform(0.0, 0.3))
        for name in rng.sample(CORE, len(CORE)):    # as launch: every process, any order
            _stop(procs[name][0], rng.choice(('sigint', 'sigint_twice')), rng)
    finally:
        watcher.close()
    for name, (proc, log) in procs.items():
        try:
            rc = proc.wait(30.0)
        except subprocess.TimeoutExpired:
            rc = _stacks_then_kill(proc)
        log.seek(0)
        out = log.read().decode('utf-8', 'replace')
        log.close()
        bad = [b for b in BAD_OUTPUT if b in out]
        if rc != 0 or bad:
            problems.append(f'{name}: exit {rc}, {bad} in output\n{out[-1500:]}')
    return problems


def test_nodes_stop_cleanly_during_a_move(graph, tmp_path):
    """
    Ctrl-C under ``ros2 launch`` during a move: SIGINT (once or twice) to every node process.

    trajectory_server streams setpoints at 200 Hz from its timer and sim_driver publishes
    joint_states while the signals land: no timer may publish into a context already shut
    down ("[FATAL] Exception in 'timers' callback: Failed to publish: publisher's context is
    invalid"), every process exits 0. MOVE_REPEATS rounds with seeded random delays.
    """
    rng = random.Random(f'move/{MOVE_REPEATS}')
    failures = []
    for i in range(MOVE_REPEATS):
        tmp = str(tmp_path / f'move{i}')
        os.makedirs(tmp)
        failures += [f'round {i}: {p}' for p in _move_round(graph, rng, tmp, i)]
    assert not failures, '\n\n'.join(failures[:5]) + f'\n({len(failures)} problems)'


#: rounds of the streaming-server test (30 with PX100_STRESS=full; main's code before the fix
#: printed the [FATAL] line in 4 of 30 such rounds)
STREAM_REPEATS = int(os.environ.get('PX100_SHUTDOWN_REPEATS')
                     or (30 if os.environ.get('PX100_STRESS', '').lower() == 'full' else 10))


def test_trajectory_server_stops_cleanly_while_streaming(graph, tmp_path):
    """
    SIGINT (once or twice) lands on trajectory_server 0-50 ms into a streamed move.

    The sharpest form of the launch case above: one driver keeps running, a fresh server is
    started each round, gets a goal and is stopped while its 200 Hz setpoint timer publishes.
    Every stop exits 0 with no [FATAL] line and no traceback.
    """
    rng = random.Random(f'stream/{STREAM_REPEATS}')
    ns = f'/st_{os.getpid()}'
    driver, driver_log = _start('sim_driver', ns, str(tmp_path), None, 'events')
    watcher = _MoveWatcher(graph.context, ns)
    failures = []
    try:
        for i in range(STREAM_REPEATS):
            proc, log = _start('trajectory_server', ns, str(tmp_path), None, 'events')
            start = watcher.setpoints
            deadline = time.monotonic() + READY_TIMEOUT
            while watcher.setpoints < start + 20 and time.monotonic() < deadline and \
                    proc.poll() is None:
                if watcher.setpoints == start:
                    watcher.send_waist_move(3)
                time.sleep(0.2)
            streaming = watcher.setpoints >= start + 20
            time.sleep(rng.uniform(0.0, 0.05))
            _stop(proc, rng.choice(('sigint', 'sigint_twice')), rng)
            try:
                rc = proc.wait(30.0)
            except subprocess.TimeoutExpired:
                rc = _stacks_then_kill(proc)
            log.seek(0)
            out = log.read().decode('utf-8', 'replace')
            log.close()
            bad = [b for b in BAD_OUTPUT if b in out]
            if rc != 0 or bad or not streaming:
                failures.append(f'round {i}: exit {rc}, {bad} in output, streaming '
                                f'{streaming}\n{out[-1500:]}')
    finally:
        watcher.close()
        driver.send_signal(signal.SIGINT)
        driver.wait(30.0)
        driver_log.close()
    assert not failures, '\n\n'.join(failures[:5]) + f'\n({len(failures)} problems)'
