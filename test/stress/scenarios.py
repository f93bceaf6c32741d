"""
Fault and load scenarios over the real nodes; each returns its figures as a dict.

The tests in this directory assert on the figures; ``benchmarks/bench_robustness.py`` runs the
same scenarios at full size and writes them to ``benchmarks/results/robustness.json``.
Times are wall seconds measured with ``time.monotonic()``.
"""
import json
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Dict, List, Optional

from action_msgs.msg import GoalStatus

from .harness import Graph, Probe, script_env
from .targets import goal_works, ik_works, level_of, SLEEP

HERE = os.path.dirname(os.path.abspath(__file__))
#: the trajectory action's goal requests (the client's moves), as service events
GOAL_EVENTS = '/px100/arm_controller/follow_joint_trajectory/_action/send_goal/_service_event'
#: how long [s] after a driver restart the same client may take to move again: Fast DDS's
#: default participant lease (20 s) bounds how long a SIGKILLed driver's participant lingers
RECOVERY_WAIT = 25.0


def run_script(name: str, *args: str) -> subprocess.Popen:
    """Start test/stress/<name> with this interpreter; stdout piped, stderr to a log file."""
    log = open(os.path.join(_tmp(), f'{name}.{os.getpid()}.{time.monotonic_ns()}.log'), 'w')
    return subprocess.Popen([sys.executable, os.path.join(HERE, name), *args],
                            stdout=subprocess.PIPE, stderr=log, text=True, env=script_env())


def _tmp() -> str:
    import tempfile
    return tempfile.gettempdir()


def _json_line(text: str) -> Optional[dict]:
    for line in reversed(text.strip().splitlines()):
        line = line.strip()
        if line.startswith('{'):
            try:
                return json.loads(line)
            except ValueError:
                return None
    return None


def client_goal_key(bot) -> Optional[str]:
    """Return the id of the client's last goal (an action goal's UUID in hex)."""
    last = getattr(bot.arm, '_last_goal', None)
    return None if last is None else last.uuid.hex()


# -- faults ----------------------------------------------------------------------------------

def kill_driver_mid_trajectory(graph: Graph, probe: Probe, bot, sig=signal.SIGKILL,
                               moving_time: float = 4.0, kill_after: float = 1.0) -> dict:
    """
    Kill sim_driver while the client waits for a long move; restart it; move again.

    The move turns the waist by 0.8 rad in ``moving_time`` from where the arm is (gentle, so it
    is still running when the driver dies); a move the server ended before the kill (tracking,
    on a starved CPU) is retried up to 3 times.
    :return: figures: client_return_s (kill -> the blocking call returned), client_ok,
        client_reason, abort_s (kill -> ABORTED on the action's status), diagnostic (level and
        reason on /diagnostics), recovered (a move of the same client SUCCEEDED within
        RECOVERY_WAIT of the restart), recover_s, recovery_failures (s since the restart,
        status, the client's last_error, diagnostics)
    """
    arm = bot.arm
    out = {'signal': signal.Signals(sig).name, 'pre_kill_endings': []}
    for _attempt in range(3):
        q = list(bot.core.joint_positions(arm.joint_names))
        target = list(q)
        target[0] = q[0] + 0.8 if q[0] < 1.0 else q[0] - 0.8
        result = {}

        def move(target=target, result=result):
            pending = bot.core.send_trajectory(arm.joint_names, [target], [moving_time])
            result['key'] = pending.uuid.hex()   # the action goal's id (status by it)
            ok, reason = bot.core.wait_for_goal(pending, moving_time + 10.0)
            result['t_return'] = time.monotonic()
            result['ok'], result['reason'] = ok, reason

        th = threading.Thread(target=move, daemon=True)
        th.start()
        running = probe.wait_for(lambda: 'key' in result and probe.goal_status.get(
            result['key']) == GoalStatus.STATUS_EXECUTING, 5.0)
        time.sleep(kill_after)
        if running and 't_return' not in result:
            break
        th.join(moving_time + 12)
        out['pre_kill_endings'].append(result.get('reason') or f'never ran: {result}')
    else:
        out['error'] = f'no move was still running {kill_after} s after it started'
        return out
    server_log_at_kill = len(graph.procs['trajectory_server'].output())
    t_kill = time.monotonic()
    graph.procs['sim_driver'].signal(sig)
    th.join(moving_time + 12.0)
    key = result['key']
    out['client_ok'] = result.get('ok')
    out['client_reason'] = result.get('reason')
    out['client_return_s'] = result['t_return'] - t_kill if 't_return' in result else None
    ended = probe.wait_for(lambda: probe.goal_status.get(key) in
                           (GoalStatus.STATUS_ABORTED, GoalStatus.STATUS_CANCELED,
                            GoalStatus.STATUS_SUCCEEDED), 10.0)
    out['abort_s'] = time.monotonic() - t_kill if ended else None
    out['final_status'] = probe.goal_status.get(key)
    out['status_history'] = probe.goal_history.get(key)
    probe.wait_for(lambda: any(d.hardware_id == key for d in probe.diagnostics), 2.0)
    diags = [d for d in list(probe.diagnostics) if d.hardware_id == key]
    out['diagnostic'] = [(level_of(d), d.message) for d in diags]
    # evidence for a late abort: was the machine stalled (the watcher's own heartbeat), or only
    # the server (its log says 'not scheduled for ...' with what ran longest meanwhile)?
    t_end = t_kill + (out['abort_s'] if out['abort_s'] is not None else 10.0)
    out['machine_stall_s'] = round(probe.heartbeat.stats(t_kill, t_end)['max_gap'], 3)
    out['server_log_after_kill'] = [
        line[:400] for line in
        graph.procs['trajectory_server'].output()[server_log_at_kill:].splitlines()
        if 'not scheduled' in line or 'ABORTED' in line][:5]
    deadline = time.monotonic() + 15.0
    while graph.procs['sim_driver'].alive() and time.monotonic() < deadline:
        time.sleep(0.05)
    out['driver_exit'] = graph.procs['sim_driver'].proc.poll()
    # restart: the same client must work again without being re-created
    t_restart = time.monotonic()
    graph.start('sim_driver')
    probe.wait_ready(['sim_driver'], timeout=30.0)
    deadline = time.monotonic() + 10.0
    while bot.core.joint_state_age() > 0.2 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    # the same client object must move again. The first moves after the restart can fail: the
    # server not yet matched with the new driver (after a SIGKILL the dead participant stays in
    # the graph until its DDS lease ends: one run saw the server without joint_states for 5 s),
    # or tracking on a starved CPU. Attempts until RECOVERY_WAIT, each failure with its time
    # since the restart, the client's reason and the goal's diagnostics
    out['recovery_failures'] = []
    attempt, ok = 0, False
    while not ok:
        target = [0.3, -1.88, 1.5, 0.8] if attempt % 2 == 0 else list(SLEEP)
        attempt += 1
        ok = arm.set_joint_positions(target, moving_time=2.0, blocking=True)
        if ok:
            break
        last = client_goal_key(bot)
        out['recovery_failures'].append(
            [round(time.monotonic() - t_restart, 2), arm.last_goal_status(), arm.last_error,
             [d.message for d in list(probe.diagnostics) if d.hardware_id == last]])
        if time.monotonic() - t_restart > RECOVERY_WAIT:
            break
        time.sleep(1.0)
    out['recovered'] = bool(ok)
    out['recover_s'] = time.monotonic() - t_restart
    out['recovery_goal_status'] = arm.last_goal_status()
    return out


def kill_ik_service(graph: Graph, probe: Probe, bot, model, sig=signal.SIGKILL,
                    recover_timeout: float = 15.0) -> dict:
    """
    Kill ik_service, then ask the client for IK; restart it and ask again.

    :return: figures: raised (the exception text of ``core.request_ik``), request_s (how long
        that call took), arm_ok / arm_s (``arm.set_ee_pose_matrix`` result and time),
        recovered (a client request after the restart is solved), recover_s (restart -> the
        first solved client request), recover_attempts
    """
    out = {'signal': signal.Signals(sig).name}
    T = model.fk([0.3, -0.2, 0.4, 0.2])
    graph.procs['ik_service'].signal(sig)
    graph.procs['ik_service'].proc.wait(10.0)
    time.sleep(0.1)
    t0 = time.monotonic()
    try:
        bot.core.request_ik(T)
        out['raised'] = None
    except Exception as exc:  # noqa: B902 - the client's error, whatever its class
        out['raised'] = f'{type(exc).__name__}: {exc}'
    out['request_s'] = time.monotonic() - t0
    t0 = time.monotonic()
    _, ok = bot.arm.set_ee_pose_matrix(T, execute=False)
    out['arm_ok'], out['arm_s'] = bool(ok), time.monotonic() - t0
    t0 = time.monotonic()
    graph.start('ik_service')
    probe.wait_ready(['ik_service'], timeout=30.0)
    attempts, errors = 0, []
    out['recovered'] = False
    while time.monotonic() - t0 < recover_timeout:
        attempts += 1
        try:
            reply = bot.core.request_ik(T, timeout=2.0)
            if reply.success:
                out['recovered'] = True
                break
            errors.append(reply.reason)
        except Exception as exc:  # noqa: B902
            errors.append(f'{type(exc).__name__}: {exc}')
        time.sleep(0.2)
    out['recover_s'] = time.monotonic() - t0
    out['recover_attempts'] = attempts
    out['recover_errors'] = errors[:3]
    _, ok = bot.arm.set_ee_pose_matrix(T, execute=False)
    out['arm_recovered'] = bool(ok)
    return out


def slow_subscriber(graph: Graph, probe: Probe, lim, model, mode: str,
                    window: float = 4.0) -> dict:
    """
    Run a subscriber that never spins (or sleeps in callbacks) and measure the nodes meanwhile.

    :return: figures: rates (joint_states, ee_pose over the window), goal ('' if a goal
        SUCCEEDED meanwhile), ik ('' if IK answered), slow_alive
    """
    proc = run_script('slow_subscriber.py', '--mode', mode)
    line = proc.stdout.readline()
    out = {'mode': mode, 'started': line.strip() == 'ready'}
    time.sleep(1.0)  # matched by the nodes' publishers
    t0 = time.monotonic()
    out['goal'] = goal_works(probe, lim)
    out['ik'] = ik_works(probe, model)
    out['goal_back'] = goal_works(probe, lim, target=SLEEP)
    rest = window - (time.monotonic() - t0)
    if rest > 0:
        time.sleep(rest)
    t1 = time.monotonic()
    out['rates'] = {n: probe.rates[n].stats(t0, t1) for n in ('joint_states', 'ee_pose')}
    out['window_s'] = t1 - t0
    out['nodes_alive'] = graph.alive()
    out['slow_alive'] = proc.poll() is None
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(10.0)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5.0)
    return out


# -- load ------------------------------------------------------------------------------------

def largest_goal(probe: Probe, points: int = 10_000, values: int = 10_000) -> dict:
    """
    Send the largest goal the fuzz strategy draws and time its answer.

    The goal is one point with ``values`` velocities (for one joint), repeated ``points`` times:
    8 * points * values bytes.

    :return: figures: size [MB], seconds to the goal response and to the answer (the goal's
        result), the reason given, the watcher's and the probe's longest joint_states silence
        meanwhile [s]
    """
    import array

    from control_msgs.action import FollowJointTrajectory
    from trajectory_msgs.msg import JointTrajectoryPoint
    point = JointTrajectoryPoint(positions=[0.1], velocities=array.array('d', [0.5]) * values)
    point.time_from_start.sec = 1
    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = ['waist']
    goal.trajectory.points = [point] * points
    t0 = time.monotonic()
    handle = probe.send_goal(goal, 60.0)
    t1 = time.monotonic()
    response = probe.goal_result(handle, 60.0) if handle is not None else None
    t2 = time.monotonic()
    del goal, point
    time.sleep(0.5)
    t3 = time.monotonic()
    return {'megabytes': round(8 * points * values / 1e6, 1), 'publish_s': round(t1 - t0, 3),
            'answered': response is not None, 'answer_s': round(t2 - t0, 3),
            'reason': response.result.error_string if response is not None else None,
            'joint_states_max_gap_s': round(
                probe.rates['joint_states'].stats(t0, t3)['max_gap'], 3),
            'probe_joint_states_max_gap_s': round(
                probe.rates['probe/joint_states'].stats(t0, t3)['max_gap'], 3)}


def ik_load(clients: int, count: int, timeout: float = 5.0, processes: bool = True) -> dict:
    """
    Run ``clients`` IK clients, ``count`` closed-loop requests each, all at once.

    :param processes: one process per client; else all clients in one process (threads with
        a DDS participant each: same traffic, far less start-up time on 2 cores)
    :return: figures: sent, lost, mismatched, unsolved, wrong_orientation, latencies
    """
    start_at = time.time() + (4.0 if processes else 2.0)
    common = ('--count', str(count), '--timeout', str(timeout), '--start-at', str(start_at))
    if processes:
        procs = [run_script('ik_load_worker.py', '--index', str(i), *common)
                 for i in range(clients)]
    else:
        procs = [run_script('ik_load_worker.py', '--index', '0', '--clients', str(clients),
                            *common)]
    workers = []
    for p in procs:
        try:
            stdout, _ = p.communicate(timeout=60.0 + count * timeout)
        except subprocess.TimeoutExpired:
            p.kill()
            stdout, _ = p.communicate()
        lines = [_json_line(line) for line in stdout.splitlines() if line.startswith('{')]
        workers.extend(w for w in lines if w)
    missing = clients - len(workers)
    workers.extend({'error': 'no result'} for _ in range(max(0, missing)))
    total = {k: sum(w.get(k, 0) for w in workers) for k in ('sent', 'lost', 'mismatched',
                                                            'unsolved', 'wrong_orientation')}
    total['orientation_examples'] = [e for w in workers
                                     for e in w.get('orientation_examples', [])][:3]
    total['clients'] = clients
    total['per_client'] = count
    total['client_processes'] = len(procs)
    total['workers_failed'] = sum(1 for w in workers if 'error' in w)
    total['seconds'] = max((w.get('seconds', 0.0) for w in workers), default=0.0)
    total['latency_median_ms'] = max((w.get('latency_median_ms', 0.0) for w in workers),
                                     default=0.0)
    total['latency_p99_ms'] = max((w.get('latency_p99_ms', 0.0) for w in workers), default=0.0)
    total['latency_max_ms'] = max((w.get('latency_max_ms', 0.0) for w in workers), default=0.0)
    total['errors'] = [e for w in workers for e in w.get('errors', [])][:10]
    return total


def read_bag_messages(bag_dir: str, topics: List[str]) -> Dict[str, list]:
    """
    Return {topic: [decoded message, ...]} of every MCAP file in a rosbag2 directory.

    Reads with the mcap library directly (streaming, so a file without summary/footer is read
    up to its last complete record).
    """
    from mcap.records import Channel, Message, Schema
    from mcap.stream_reader import StreamReader
    from mcap_ros2.decoder import DecoderFactory
    out = {t: [] for t in topics}
    files = sorted(os.path.join(bag_dir, f) for f in os.listdir(bag_dir) if f.endswith('.mcap'))
    factory = DecoderFactory()
    for path in files:
        schemas, channels, decoders = {}, {}, {}
        with open(path, 'rb') as f:
            try:
                for rec in StreamReader(f, skip_magic=False).records:
                    if isinstance(rec, Schema):
                        schemas[rec.id] = rec
                    elif isinstance(rec, Channel):
                        channels[rec.id] = rec
                    elif isinstance(rec, Message):
                        ch = channels.get(rec.channel_id)
                        if ch is None or ch.topic not in out:
                            continue
                        if ch.id not in decoders:
                            decoders[ch.id] = factory.decoder_for(ch.message_encoding,
                                                                  schemas[ch.schema_id])
                        out[ch.topic].append((rec.log_time, decoders[ch.id](rec.data)))
            except Exception:  # noqa: B902 - a truncated tail ends the read, as it should
                pass
    return out


def scripts_with_recorder(graph: Graph, probe: Probe, bag_dir: str, scripts: int = 4,
                          moves: int = 3, script_args=()) -> dict:
    """
    Record while ``scripts`` client processes drive the arm one after the other.

    The scripts' goals are trajectory action goals: the bag must hold each one's request
    event (by goal id).

    :return: figures: goals sent by the scripts, goals missing from the bag, setpoints the
        probe saw and those missing from the bag, moves failed
    """
    topics = [GOAL_EVENTS, '/px100/commands/joint_setpoints',
              '/px100/arm_controller/follow_joint_trajectory/_action/status',
              '/px100/joint_states']
    rec = graph.start('record', '-o', bag_dir, *topics)
    deadline = time.monotonic() + 20.0
    while probe.node.count_subscribers(GOAL_EVENTS) < 1 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(1.0)
    # from here on (the recorder subscribed), not before: a setpoint of an earlier goal sent
    # while the recorder was starting is not one the scripts caused
    probe.record_setpoints(True)
    # the scripts start (and connect) together, then drive the arm one after the other
    turn = os.path.join(os.path.dirname(os.path.abspath(bag_dir)), 'turn')
    with open(turn, 'w', encoding='utf-8') as f:
        f.write('0')
    procs = [run_script('client_script.py', '--index', str(i), '--moves', str(moves),
                        '--turn-file', turn, *script_args) for i in range(scripts)]
    results = []
    for p in procs:
        try:
            stdout, _ = p.communicate(timeout=180.0)
        except subprocess.TimeoutExpired:
            p.kill()
            stdout, _ = p.communicate()
        results.append(_json_line(stdout) or {'error': f'no result (exit {p.returncode})'})
    time.sleep(1.0)
    seen = probe.record_setpoints(False)
    rec.stop()
    graph.procs.pop('record', None)
    bag = read_bag_messages(bag_dir, topics[1:])
    bag_goals = _goal_ids(bag_dir)
    bag_setpoints = {_setpoint_key(m) for _, m in bag['/px100/commands/joint_setpoints']}
    goals = [g for r in results for g in r.get('goals', [])]
    missing_goals = [g for g in goals if g not in bag_goals]
    # where the lost goals were: (script, n-th goal of that script) and whether the probe saw it
    missing_where = [(i, r['goals'].index(g)) for i, r in enumerate(results)
                     for g in r.get('goals', []) if g in missing_goals]
    missing_sp = [k for k in seen if k not in bag_setpoints]
    return {
        'scripts': scripts, 'moves_per_script': moves,
        'moves_succeeded': sum(r.get('succeeded', 0) for r in results),
        'moves_tracking_aborted': sum(r.get('tracking_aborts', 0) for r in results),
        'script_errors': [r.get('error') or r.get('failures') for r in results
                          if r.get('error') or r.get('failures')],
        'scripts_without_result': [r['error'] for r in results if 'error' in r],
        'goals_sent': len(goals), 'goals_missing_in_bag': len(missing_goals),
        'setpoints_seen': len(seen), 'setpoints_in_bag': len(bag_setpoints),
        'setpoints_missing_in_bag': len(missing_sp),
        'joint_states_in_bag': len(bag['/px100/joint_states']),
        'recorder_exit': rec.returncode, 'missing_examples': (missing_goals + missing_sp)[:5],
        'missing_goals_where': missing_where,
        'missing_goals_seen_by_probe': [g for g in missing_goals if g in probe.goal_status],
        'script_connect_s': [r.get('connect_s') for r in results],
        'script_waited_for_subscribers_s': [r.get('waited_for_subscribers_s') for r in results],
    }


def _goal_ids(bag_dir: str) -> set:
    """
    Return the ids (hex) of the goal requests the trajectory action took, from a closed bag.

    Read with rosbags from the bag's type definitions (mcap_ros2 cannot decode the service
    event types).
    """
    from pathlib import Path

    from rosbags.highlevel import AnyReader
    with AnyReader([Path(bag_dir)]) as reader:
        conns = [c for c in reader.connections if c.topic == GOAL_EVENTS]
        events = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(conns)]
    return {bytes(e.request[0].goal_id.uuid).hex() for e in events
            if e.info.event_type == 1 and len(e.request)}   # REQUEST_RECEIVED


def _setpoint_key(msg) -> tuple:
    return (msg.header.stamp.sec, msg.header.stamp.nanosec, tuple(msg.name),
            tuple(round(v, 12) for v in msg.position))


def recorder_sigkill(graph: Graph, probe: Probe, lim, bag_dir: str, run_s: float = 3.0) -> dict:
    """
    SIGKILL the recorder while it records; the bag must be readable up to its last chunk.

    :return: figures: messages read back (streaming read and H4's reader after reindex), the
        time between the last message recorded and the kill (what the kill lost)
    """
    topics = ['/px100/joint_states', '/px100/commands/joint_setpoints', GOAL_EVENTS,
              '/px100/arm_controller/follow_joint_trajectory/_action/status']
    rec = graph.start('record', '-o', bag_dir, *topics)
    deadline = time.monotonic() + 20.0
    while probe.node.count_subscribers(GOAL_EVENTS) < 1 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    t_start = time.time()
    goal_works(probe, lim)
    goal_works(probe, lim, target=SLEEP)
    rest = run_s - (time.time() - t_start)
    if rest > 0:
        time.sleep(rest)
    t_kill_ns = time.time_ns()
    rec.signal(signal.SIGKILL)
    rec.proc.wait(5.0)
    graph.procs.pop('record', None)
    out = {'recorded_s': (t_kill_ns * 1e-9) - t_start}
    files = [f for f in os.listdir(bag_dir) if f.endswith('.mcap')] if os.path.isdir(bag_dir) \
        else []
    out['files'] = files
    out['bytes'] = sum(os.path.getsize(os.path.join(bag_dir, f)) for f in files)
    # the goal events are recorded, not decoded here (mcap_ros2 cannot decode service events)
    msgs = read_bag_messages(bag_dir, [t for t in topics if t != GOAL_EVENTS])
    js = msgs['/px100/joint_states']
    out['stream_read_messages'] = sum(len(v) for v in msgs.values())
    out['stream_read_joint_states'] = len(js)
    out['lost_tail_s'] = (t_kill_ns - max(t for t, _ in js)) * 1e-9 if js else None
    # the project's own tools: reindex, then read
    reindex = subprocess.run([_exe('bag_reindex'), bag_dir], capture_output=True, text=True,
                             timeout=60, env=os.environ.copy())
    out['reindex_exit'] = reindex.returncode
    out['reindex_output'] = (reindex.stdout + reindex.stderr)[-800:]
    out['reader_messages'] = _project_reader_count(bag_dir)
    return out


def _exe(name: str) -> str:
    from px100_control.tools.processes import executable_path
    return executable_path(name)


def _project_reader_count(bag_dir: str):
    """Return how many messages px100_control's own bag reader yields (or the error text)."""
    try:
        from px100_control.bag.reader import open_bag
        with open_bag(bag_dir) as bag:
            return sum(1 for _ in bag.iter_raw())
    except Exception as exc:  # noqa: B902 - report what the reader said
        return f'{type(exc).__name__}: {exc}'
