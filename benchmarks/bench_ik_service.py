"""
Benchmark of the ik_service node over DDS, and of the trajectory_server setpoint timing.

- IK throughput and latency: the ik_service runs as its own process (``python -m
  px100_control.ros.ik_service_node``, the ``ros2 run`` entry point's code); clients in this
  process send ``ik/request`` (reachable random px100 targets, default 'pitch' mode) closed-loop:
  each client sends its next request as soon as both replies (``ik/solution`` and ``ik/status``)
  of the previous one arrived. Reported for 1 client and for 8 concurrent clients (8 nodes,
  each with its own publisher and request id space): requests/s, round trip p50/p99/max [ms],
  lost replies (a request without its solution or status when the run ends) and duplicated
  replies. The replies are read by one raw (serialized CDR) reader pair that routes them by id
  to their client, so that the client side costs as little as possible and the numbers are the
  service's, not those of eight Python deserialisers sharing two cores with it.
- Trajectory setpoint jitter: a trajectory_server (own process) executes a 3 s goal against a
  joint-state echo in this process; the period of the received ``commands/joint_setpoints``
  (stamps and arrival times) against 1/rate.

- Baseline: the same rounds against a 'null' service (same topics, QoS and replies, no IK: the
  floor of the request/reply protocol in rclpy on this machine).

``run(quick)`` returns the numbers as a dict; ``main()`` prints them and writes
``benchmarks/results/ik_service.json`` (``--quick``: fewer requests). Set ROS_DOMAIN_ID to a
private domain (default 23). Usage: ``python benchmarks/bench_ik_service.py [--quick]
[--bound SECONDS]`` (default bound BOUND_S: 180 s quick, 600 s full; past it the run fails
naming its stage, see bound.py).
"""
import argparse
import json
import os
import platform
import signal
import struct
import subprocess
import sys
import threading
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

import bound  # noqa: E402, I100 - benchmarks/bound.py, beside this file
from px100_control.ros.common import make_executor  # noqa: E402 - after the path fix

RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'ik_service.json')
#: the run's bound [s] with --quick and without: past it the run fails naming its stage
BOUND_S = (180.0, 600.0)
ARM = ['waist', 'shoulder', 'elbow', 'wrist_angle']


def _env():
    env = os.environ.copy()
    env.setdefault('ROS_DOMAIN_ID', '23')
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.pop('ROS_LOCALHOST_ONLY', None)
    env['PYTHONPATH'] = ROOT + os.pathsep + env.get('PYTHONPATH', '')
    return env


def _start(module: str, *ros_args: str) -> subprocess.Popen:
    args = [sys.executable, '-m', module]
    if ros_args:
        args += ['--ros-args', *ros_args]
    return subprocess.Popen(args, cwd=ROOT, env=_env(), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


def _cdr_string(buf: bytes, off: int):
    """Return (text, next offset) of a CDR string at off (4-aligned length incl. NUL)."""
    off = (off + 3) & ~3
    n = struct.unpack_from('<I', buf, off)[0]
    return buf[off + 4:off + 3 + n].decode(), off + 4 + n


def solution_id(raw: bytes):
    """Return (sec, nanosec) of a serialized sensor_msgs/JointState (its header.stamp)."""
    return struct.unpack_from('<iI', raw, 4)


def status_id(raw: bytes):
    """Return (sec, nanosec) of a serialized DiagnosticStatus from its hardware_id."""
    _, off = _cdr_string(raw, 5)    # name (after the int8 level at offset 4)
    _, off = _cdr_string(raw, off)  # message
    hw, _ = _cdr_string(raw, off)
    sec, nsec = hw.split('.')
    return int(sec), int(nsec)


def _targets(count: int, seed: int = 0):
    from px100_control.models.registry import load_robot
    from px100_control.ros.conversions import matrix_to_pose
    model = load_robot('px100')
    qs = model.random_configurations(count, seed, margin=0.05)
    return [matrix_to_pose(model.fk(q)) for q in qs]


class _Client:
    """One closed-loop IK client: its own node and publisher; replies come via a _Receiver."""

    def __init__(self, ctx, index: int, run_sec: int, poses, n_requests: int, qos, done):
        from geometry_msgs.msg import PoseStamped
        from rclpy.node import Node
        self.node = Node(f'ik_bench_client_{run_sec % 1000}_{index}', context=ctx)
        self.pub = self.node.create_publisher(PoseStamped, '/px100/ik/request', qos)
        self.sec = run_sec + index
        self.poses = poses
        self.n = n_requests
        self.sent = {}       # nanosec -> send time
        self.got = [{}, {}]  # kind (solution, status) -> nanosec -> count
        self.rtt = []
        self.done = done
        self.seq = 0
        self.lock = threading.Lock()
        self.msg = PoseStamped()

    def send_next(self) -> None:
        with self.lock:
            if self.seq >= self.n:
                self.done.release()
                return
            self.seq += 1
            i = self.seq
            msg = self.msg
            msg.header.stamp.sec = self.sec
            msg.header.stamp.nanosec = i
            msg.pose = self.poses[i % len(self.poses)]
            self.sent[i] = time.perf_counter()
        self.pub.publish(msg)

    def on_reply(self, kind: int, i: int) -> None:
        now = time.perf_counter()
        with self.lock:
            seen = self.got[kind]
            seen[i] = seen.get(i, 0) + 1
            complete = seen[i] == 1 and self.got[1 - kind].get(i, 0) >= 1
            if complete and i in self.sent:
                self.rtt.append(now - self.sent[i])
        if complete and i == self.seq:
            self.send_next()


class _Receiver:
    """The reply side of the clients: raw ik/solution + ik/status readers, routed by id."""

    def __init__(self, ctx, clients, qos, tag: int):
        from diagnostic_msgs.msg import DiagnosticStatus
        from rclpy.node import Node
        from sensor_msgs.msg import JointState
        self.by_sec = {c.sec: c for c in clients}
        self.node = Node(f'ik_bench_receiver_{tag}', context=ctx)
        self.node.create_subscription(JointState, '/px100/ik/solution',
                                      lambda raw: self._route(0, solution_id(raw)), qos,
                                      raw=True)
        self.node.create_subscription(DiagnosticStatus, '/px100/ik/status',
                                      lambda raw: self._route(1, status_id(raw)), qos,
                                      raw=True)

    def _route(self, kind: int, rid) -> None:
        client = self.by_sec.get(rid[0])
        if client is not None:
            client.on_reply(kind, rid[1])


def _cpu_seconds(pid: int) -> float:
    """Return the user + system CPU time [s] a process has used (Linux /proc)."""
    try:
        with open(f'/proc/{pid}/stat') as f:
            fields = f.read().rsplit(')', 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')
    except (OSError, IndexError, ValueError):
        return float('nan')


class _Spinner:
    """
    An executor spinning some nodes in a thread, for one round; ``stop()`` ends it cleanly.

    rclpy 7.1's EventsExecutor applies add_node / remove_node in its spinning thread, later:
    a node destroyed right after remove_node while that thread spins leaves the executor with
    destroyed rcl entities (measured: an abort in shutdown, "Failed to clear the on new request
    callback for service: service pointer is invalid", in the 8th null-service run under load;
    most likely also the 8-client round that hung with its main thread in ``done.acquire``,
    which waits for the GIL the spinning thread held). So the nodes are added before the thread
    starts, and the thread is joined and the executor shut down before any node is destroyed.
    """

    def __init__(self, ctx, nodes):
        self.ctx, self.nodes = ctx, list(nodes)
        self.executor = make_executor(context=ctx)
        for node in self.nodes:
            self.executor.add_node(node)
        self.running = threading.Event()
        self.running.set()
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        try:
            while self.running.is_set() and self.ctx.ok():
                self.executor.spin_once(timeout_sec=0.1)
        except Exception:  # noqa: B902 - context shut down under the executor
            if self.running.is_set():
                raise

    def stop(self) -> None:
        """Join the spinning thread, shut the executor down, then destroy the nodes."""
        self.running.clear()
        self.thread.join(10.0)
        if self.thread.is_alive():
            raise RuntimeError('the executor thread did not return from spin_once within 10 s')
        self.executor.shutdown(timeout_sec=2.0)
        for node in self.nodes:
            node.destroy_node()


def _ik_round(ctx, clients: int, n_requests: int, poses, qos, run_sec: int,
              server_pid: int = 0, label: str = '') -> dict:
    done = threading.Semaphore(0)
    cl = [_Client(ctx, k, run_sec, poses, n_requests, qos, done) for k in range(clients)]
    rx = _Receiver(ctx, cl, qos, run_sec % 1000)
    spinner = _Spinner(ctx, [c.node for c in cl] + [rx.node])
    try:
        bound.stage(f'{label}: discovery of the service')
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and not (
                all(c.pub.get_subscription_count() > 0 for c in cl)
                and rx.node.count_publishers('/px100/ik/status') > 0):
            time.sleep(0.05)
        time.sleep(1.0)  # discovery of the reply readers settles
        bound.stage(f'{label}: {clients} x {n_requests} requests')
        cpu0 = _cpu_seconds(server_pid)
        t0 = time.perf_counter()
        for c in cl:
            c.send_next()
        finished = 0
        limit = time.monotonic() + max(60.0, n_requests * 0.05)
        while finished < clients and time.monotonic() < limit:
            if done.acquire(timeout=0.5):
                finished += 1
        elapsed = time.perf_counter() - t0
        cpu = _cpu_seconds(server_pid) - cpu0
        time.sleep(0.5)  # late duplicates would arrive now
    finally:
        bound.stage(f'{label}: stopping the clients')
        spinner.stop()
    rtt = np.array([x for c in cl for x in c.rtt]) * 1e3
    sent = sum(len(c.sent) for c in cl)
    lost = sum(1 for c in cl for i in c.sent
               if c.got[0].get(i, 0) == 0 or c.got[1].get(i, 0) == 0)
    dup = sum(1 for c in cl for kind in (0, 1) for v in c.got[kind].values() if v > 1)
    return {'clients': clients, 'requests': sent, 'answered': int(rtt.size),
            'elapsed_s': round(elapsed, 3),
            'requests_per_s': round(rtt.size / elapsed, 1) if elapsed > 0 else 0.0,
            'rtt_p50_ms': round(float(np.percentile(rtt, 50)), 3) if rtt.size else None,
            'rtt_p99_ms': round(float(np.percentile(rtt, 99)), 3) if rtt.size else None,
            'rtt_max_ms': round(float(rtt.max()), 3) if rtt.size else None,
            'lost': int(lost), 'duplicated': int(dup),
            'server_cpu_ms_per_request': round(cpu / max(rtt.size, 1) * 1e3, 3)}


def null_server() -> int:
    """
    Run a 'null' ik_service: same topics, QoS and replies (fixed, no IK), one reply pair each.

    The floor of the request/reply protocol in rclpy on this machine, for comparison.
    """
    import rclpy
    from diagnostic_msgs.msg import DiagnosticStatus
    from geometry_msgs.msg import PoseStamped
    from rclpy.executors import ExternalShutdownException
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from px100_control.ros.ik_service_node import parse_pose_stamped, REQUEST_QOS
    rclpy.init()
    node = Node('ik_service_null')
    pub_sol = node.create_publisher(JointState, '/px100/ik/solution', REQUEST_QOS)
    pub_st = node.create_publisher(DiagnosticStatus, '/px100/ik/status', REQUEST_QOS)
    sol = JointState(name=list(ARM), position=[0.0] * 4)
    st = DiagnosticStatus(name='px100/ik_service', message='solved')

    def on_request(raw):
        stamp, _, _ = parse_pose_stamped(raw)
        sol.header.stamp = stamp
        st.hardware_id = f'{stamp.sec}.{stamp.nanosec:09d}'
        pub_sol.publish(sol)
        pub_st.publish(st)
    node.create_subscription(PoseStamped, '/px100/ik/request', on_request, REQUEST_QOS,
                             raw=True)
    executor = make_executor()
    executor.add_node(node)
    try:
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def bench_ik(quick: bool, null: bool = False) -> dict:
    """Run the ik_service benchmark rounds (1 client, 8 clients); null: the null server."""
    import rclpy
    from px100_control.ros.ik_service_node import REQUEST_QOS
    poses = _targets(500)
    if null:
        server = subprocess.Popen([sys.executable, os.path.abspath(__file__), '--null-server'],
                                  cwd=ROOT, env=_env(), stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL)
    else:
        server = _start('px100_control.ros.ik_service_node')
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    out = {}
    name = 'null service' if null else 'ik_service'
    try:
        run_sec = int(time.time()) % 100000 * 100
        n1 = 1000 if quick else 5000
        out['single_client'] = _ik_round(ctx, 1, n1, poses, REQUEST_QOS, run_sec,
                                         server.pid, f'{name}, 1 client')
        out['eight_clients'] = _ik_round(ctx, 8, n1 // 4 if quick else n1 // 2,
                                         poses, REQUEST_QOS, run_sec + 10, server.pid,
                                         f'{name}, 8 clients')
    finally:
        ctx.try_shutdown()
        _stop(server)
    return out


def bench_setpoint_jitter(quick: bool) -> dict:
    """Run one trajectory goal against a joint-state echo; return the setpoint period stats."""
    import rclpy
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    from builtin_interfaces.msg import Duration
    server = _start('px100_control.ros.trajectory_server_node')
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = Node('setpoint_jitter_bench', context=ctx)
    state = {'q': [0.0, -1.88, 1.5, 0.8]}
    stamps, arrivals = [], []
    lock = threading.Lock()

    def on_setpoint(msg):
        with lock:
            arrivals.append(time.perf_counter())
            stamps.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
            state['q'] = list(msg.position)

    def publish_state():
        js = JointState()
        js.header.stamp = node.get_clock().now().to_msg()
        js.name = list(ARM)
        with lock:
            js.position = list(state['q'])
        pub_js.publish(js)

    pub_js = node.create_publisher(JointState, '/px100/joint_states', 10)
    pub_goal = node.create_publisher(JointTrajectory, '/px100/trajectory/goal', 10)
    node.create_subscription(JointState, '/px100/commands/joint_setpoints', on_setpoint, 100)
    node.create_timer(0.01, publish_state)
    spinner = _Spinner(ctx, [node])
    duration = 2.0 if quick else 5.0
    try:
        bound.stage('trajectory_server: discovery, then one goal')
        deadline = time.monotonic() + 20.0
        while pub_goal.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(1.0)
        goal = JointTrajectory()
        goal.header.stamp = node.get_clock().now().to_msg()
        goal.joint_names = list(ARM)
        goal.points = [JointTrajectoryPoint(positions=[0.5, -1.0, 1.0, 0.5],
                                            time_from_start=Duration(sec=int(duration)))]
        pub_goal.publish(goal)
        time.sleep(duration + 1.5)
    finally:
        spinner.stop()
        ctx.try_shutdown()
        _stop(server)
    with lock:
        st, ar = np.array(stamps), np.array(arrivals)
    if st.size < 3:
        return {'setpoints': int(st.size)}
    period = 1.0 / 200.0
    ds, da = np.diff(st) * 1e3, np.diff(ar) * 1e3
    return {'rate_hz': 200.0, 'setpoints': int(st.size),
            'stamp_period_mean_ms': round(float(ds.mean()), 3),
            'stamp_period_std_ms': round(float(ds.std()), 3),
            'stamp_jitter_p99_ms': round(float(np.percentile(np.abs(ds - period * 1e3), 99)),
                                         3),
            'arrival_period_std_ms': round(float(da.std()), 3),
            'arrival_gap_max_ms': round(float(da.max()), 3)}


def run(quick: bool = True) -> dict:
    """Run every part; return the results (also the machine's load while they ran)."""
    load0 = os.getloadavg()
    out = {'ik_service': bench_ik(quick), 'null_service_baseline': bench_ik(quick, null=True),
           'trajectory_server': bench_setpoint_jitter(quick)}
    out['machine'] = {'cpus': os.cpu_count(), 'python': platform.python_version(),
                      'loadavg_before': [round(x, 2) for x in load0],
                      'loadavg_after': [round(x, 2) for x in os.getloadavg()]}
    out['quick'] = quick
    return out


def main(argv=None) -> int:
    """Print the benchmark results and write benchmarks/results/ik_service.json."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='fewer requests')
    parser.add_argument('--null-server', action='store_true', help=argparse.SUPPRESS)
    bound.add_argument(parser, *BOUND_S)
    options = parser.parse_args(argv)
    if options.null_server:
        return null_server()
    with bound.bounded('bench_ik_service', bound.seconds(options, options.quick)):
        res = run(options.quick)
    for part, key in [(p, k) for p in ('ik_service', 'null_service_baseline')
                      for k in ('single_client', 'eight_clients')]:
        r = res[part][key]
        print(f"{part} {r['clients']} client(s): {r['requests_per_s']:.0f} requests/s, "
              f"round trip p50 {r['rtt_p50_ms']} ms, p99 {r['rtt_p99_ms']} ms, "
              f"max {r['rtt_max_ms']} ms; {r['requests']} sent, lost {r['lost']}, "
              f"duplicated {r['duplicated']}; server CPU {r['server_cpu_ms_per_request']} ms "
              'per request')
    t = res['trajectory_server']
    print(f'trajectory_server setpoints at 200 Hz: {t}')
    print(f"machine: {res['machine']}")
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)
    with open(RESULTS, 'w') as f:
        json.dump(res, f, indent=2)
    print(f'wrote {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
