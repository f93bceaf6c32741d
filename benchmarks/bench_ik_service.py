"""
Benchmark of the ik_service node over DDS, and of the trajectory_server setpoint timing.

- IK throughput and latency: the ik_service runs as its own process (``python -m
  px100_control.ros.ik_service_node``, the ``ros2 run`` entry point's code); clients in this
  process call ``compute_ik`` (reachable random px100 targets, default 'pitch' mode)
  closed-loop: each client makes its next call from the done callback of the previous one.
  Reported for 1 client and for 8 concurrent clients (8 nodes, each with its own service
  client, the service's deep request QoS): calls/s, round trip p50/p99/max [ms], lost calls (no
  response when the round ends) and the server's CPU time per call.
- Trajectory setpoint jitter: a trajectory_server (own process) executes one
  FollowJointTrajectory goal against a joint-state echo in this process; the period of the
  received ``commands/joint_setpoints`` (stamps and arrival times) against 1/rate.

- Baseline: the same rounds against a 'null' service (the same service type, QoS and
  introspection, a fixed response, no IK: the floor of an rclpy service on this machine).

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


def _targets(count: int, seed: int = 0):
    from px100_control.models.registry import load_robot
    from px100_control.ros.conversions import matrix_to_pose
    model = load_robot('px100')
    qs = model.random_configurations(count, seed, margin=0.05)
    return [matrix_to_pose(model.fk(q)) for q in qs]


class _Client:
    """One closed-loop compute_ik client: its own node; the next call from the last's callback."""

    def __init__(self, ctx, index: int, tag: int, poses, n_requests: int, done):
        from px100_control.ros.ik_services import SERVICE_QOS
        from px100_control_msgs.srv import ComputeIK
        from rclpy.node import Node
        self.node = Node(f'ik_bench_client_{tag}_{index}', context=ctx)
        self.client = self.node.create_client(ComputeIK, '/px100/compute_ik',
                                              qos_profile=SERVICE_QOS)
        self.request = ComputeIK.Request()
        self.poses = poses
        self.n = n_requests
        self.rtt = []
        self.refused = 0
        self.done = done
        self.seq = 0
        self.t_sent = 0.0

    def send_next(self) -> None:
        if self.seq >= self.n:
            self.done.release()
            return
        self.seq += 1
        self.request.target.pose = self.poses[self.seq % len(self.poses)]
        self.t_sent = time.perf_counter()
        self.client.call_async(self.request).add_done_callback(self._on_response)

    def _on_response(self, future) -> None:
        self.rtt.append(time.perf_counter() - self.t_sent)
        if not future.result().success:
            self.refused += 1
        self.send_next()


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

    def __init__(self, ctx, nodes, kind=None):
        self.ctx, self.nodes = ctx, list(nodes)
        self.executor = make_executor(context=ctx, kind=kind)
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


def _ik_round(ctx, clients: int, n_requests: int, poses, tag: int, server_pid: int = 0,
              label: str = '') -> dict:
    done = threading.Semaphore(0)
    cl = [_Client(ctx, k, tag, poses, n_requests, done) for k in range(clients)]
    spinner = _Spinner(ctx, [c.node for c in cl])
    try:
        bound.stage(f'{label}: discovery of the service')
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and not all(c.client.service_is_ready() for c in cl):
            time.sleep(0.05)
        time.sleep(1.0)  # discovery of the reply readers settles
        bound.stage(f'{label}: {clients} x {n_requests} calls')
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
    finally:
        bound.stage(f'{label}: stopping the clients')
        spinner.stop()
    rtt = np.array([x for c in cl for x in c.rtt]) * 1e3
    sent = sum(c.seq for c in cl)
    return {'clients': clients, 'requests': sent, 'answered': int(rtt.size),
            'elapsed_s': round(elapsed, 3),
            'requests_per_s': round(rtt.size / elapsed, 1) if elapsed > 0 else 0.0,
            'rtt_p50_ms': round(float(np.percentile(rtt, 50)), 3) if rtt.size else None,
            'rtt_p99_ms': round(float(np.percentile(rtt, 99)), 3) if rtt.size else None,
            'rtt_max_ms': round(float(rtt.max()), 3) if rtt.size else None,
            'lost': int(sent - rtt.size), 'refused': sum(c.refused for c in cl),
            'server_cpu_ms_per_request': round(cpu / max(rtt.size, 1) * 1e3, 3)}


def null_server() -> int:
    """
    Run a 'null' ik_service: the same compute_ik service (QoS, introspection), a fixed response.

    The floor of an rclpy service on this machine, for comparison.
    """
    import rclpy
    from px100_control.ros.ik_services import SERVICE_QOS
    from px100_control_msgs.srv import ComputeIK
    from rclpy.executors import ExternalShutdownException
    from rclpy.node import Node
    from rclpy.qos import qos_profile_system_default
    from rclpy.service_introspection import ServiceIntrospectionState
    rclpy.init()
    node = Node('ik_service_null')

    def on_call(request, response):
        response.solution.name = list(ARM)
        response.solution.position = [0.0] * 4
        response.success, response.message = True, 'solved'
        return response
    service = node.create_service(ComputeIK, '/px100/compute_ik', on_call,
                                  qos_profile=SERVICE_QOS)
    service.configure_introspection(node.get_clock(), qos_profile_system_default,
                                    ServiceIntrospectionState.CONTENTS)
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
        tag = int(time.time()) % 100000
        n1 = 1000 if quick else 5000
        out['single_client'] = _ik_round(ctx, 1, n1, poses, tag, server.pid,
                                         f'{name}, 1 client')
        out['eight_clients'] = _ik_round(ctx, 8, n1 // 4 if quick else n1 // 2, poses,
                                         tag + 1, server.pid, f'{name}, 8 clients')
    finally:
        ctx.try_shutdown()
        _stop(server)
    return out


def bench_setpoint_jitter(quick: bool) -> dict:
    """Run one trajectory goal against a joint-state echo; return the setpoint period stats."""
    import rclpy
    from builtin_interfaces.msg import Duration
    from control_msgs.action import FollowJointTrajectory
    from rclpy.action import ActionClient
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectoryPoint
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
    arm = ActionClient(node, FollowJointTrajectory,
                       '/px100/arm_controller/follow_joint_trajectory')
    node.create_subscription(JointState, '/px100/commands/joint_setpoints', on_setpoint, 100)
    node.create_timer(0.01, publish_state)
    # rclpy 7.1's EventsExecutor does not serve action clients
    spinner = _Spinner(ctx, [node], kind='single')
    duration = 2.0 if quick else 5.0
    try:
        bound.stage('trajectory_server: discovery, then one goal')
        deadline = time.monotonic() + 20.0
        while not arm.server_is_ready() and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(1.0)
        goal = FollowJointTrajectory.Goal()
        goal.trajectory.joint_names = list(ARM)
        goal.trajectory.points = [JointTrajectoryPoint(
            positions=[0.5, -1.0, 1.0, 0.5], time_from_start=Duration(sec=int(duration)))]
        # sent from the executor's thread (ros2/rclpy#1123)
        spinner.executor.create_task(lambda: arm.send_goal_async(goal))
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
              f"refused {r['refused']}; server CPU {r['server_cpu_ms_per_request']} ms "
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
