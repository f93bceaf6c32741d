"""
One IK call as another process makes it: the ``compute_ik`` service, one call at a time.

The server runs as its own process, first the ik_service alone (``python -m
px100_control.ros.ik_service_node``), then the whole ``bringup`` (sim_driver, ik_service,
trajectory_server and robot_state_publisher in one process). A client process (this one) makes
sequential calls, each as soon as the previous one was answered, from an rclpy node spinning
in an executor thread (:func:`px100_control.ros.common.make_executor`, not
``spin_until_future_complete``, which is 30-100x slower): ``compute_ik`` through
``Client.call_async``, the round trip ending in the future's done callback.

Reachable px100 targets (default 'pitch' mode); a warm-up block of ``BLOCK`` calls first.
Reported per server: p50, p99 and max of the round trip [ms], and the machine's load average
before and after. Bounded: every call must be answered within
``CALL_TIMEOUT`` s and the whole run ends within ``RUN_BOUND`` s, else it fails with what was
missing.

``run(quick)`` returns the figures; ``main()`` prints them and writes
``benchmarks/results/ik_call.json``. Set ROS_DOMAIN_ID to a private domain (default 23).
Usage: ``python benchmarks/bench_ik_call.py [--quick]``.
"""
import json
import os
import platform
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from px100_control.ros.common import make_executor  # noqa: E402 - after the path fix

RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'ik_call.json')
#: warm-up calls (not counted), and how often the run's bound is checked
BLOCK = 50
#: largest wait for one answer [s]
CALL_TIMEOUT = 5.0
#: largest time for the whole run [s] (both servers, start-up included)
RUN_BOUND = 600.0
#: largest wait for a server to come up [s]
STARTUP_BOUND = 90.0
SERVERS = {'ik_service': 'px100_control.ros.ik_service_node',
           'bringup': 'px100_control.ros.bringup'}


class BenchError(RuntimeError):
    """The benchmark could not measure (a server did not start, a call went unanswered)."""


def _env():
    env = os.environ.copy()
    env.setdefault('ROS_DOMAIN_ID', '23')
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.pop('ROS_LOCALHOST_ONLY', None)
    env['PYTHONPATH'] = ROOT + os.pathsep + env.get('PYTHONPATH', '')
    return env


def _start(module: str) -> subprocess.Popen:
    """Start a server; its output goes to a file (a pipe nobody reads could block it)."""
    log = tempfile.TemporaryFile(mode='w+')
    proc = subprocess.Popen([sys.executable, '-m', module], cwd=ROOT, env=_env(),
                            stdout=log, stderr=subprocess.STDOUT)
    proc.log = log
    return proc


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


def _targets(count: int, seed: int = 0):
    from px100_control.models.registry import load_robot
    from px100_control.ros.conversions import matrix_to_pose
    model = load_robot('px100')
    return [matrix_to_pose(model.fk(q))
            for q in model.random_configurations(count, seed, margin=0.05)]


class _Caller:
    """One client node with a compute_ik client, one call at a time."""

    def __init__(self, ctx, tag: int):
        from px100_control_msgs.srv import ComputeIK
        from rclpy.node import Node
        self.node = Node(f'ik_call_bench_{tag}', context=ctx)
        self.client = self.node.create_client(ComputeIK, '/px100/compute_ik')
        self.request = ComputeIK.Request()
        self.done = threading.Event()
        self.last = None

    def ready(self) -> bool:
        """Return True once the service is matched with the server."""
        return self.client.service_is_ready()

    def _on_response(self, future) -> None:
        self.last = future.result()
        self.done.set()

    def call_service(self, pose) -> float:
        """Return the round trip [s] of one compute_ik call."""
        self.request.target.pose = pose
        self.done.clear()
        t0 = time.perf_counter()
        self.client.call_async(self.request).add_done_callback(self._on_response)
        if not self.done.wait(CALL_TIMEOUT):
            raise BenchError(f'compute_ik: no response within {CALL_TIMEOUT} s')
        dt = time.perf_counter() - t0
        if not self.last.success:
            raise BenchError(f'compute_ik refused a reachable target: {self.last.message}')
        return dt


def _stats(seconds) -> dict:
    ms = np.asarray(seconds) * 1e3
    return {'calls': int(ms.size), 'p50_ms': round(float(np.percentile(ms, 50)), 3),
            'p99_ms': round(float(np.percentile(ms, 99)), 3),
            'max_ms': round(float(ms.max()), 3)}


def _spin(executor, ctx) -> None:
    """Spin until the context shuts down (EventsExecutor.spin() would not return)."""
    try:
        while ctx.ok():
            executor.spin_once(timeout_sec=0.1)
    except Exception:  # noqa: B902 - context shut down under the executor
        pass


def bench_server(name: str, calls: int, poses, deadline: float) -> dict:
    """Start one server, time ``calls`` calls against it; return the figures."""
    import rclpy
    server = _start(SERVERS[name])
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    executor = make_executor(context=ctx)
    caller = _Caller(ctx, int(time.time()) % 100000)
    executor.add_node(caller.node)
    spinner = threading.Thread(target=_spin, args=(executor, ctx), daemon=True)
    spinner.start()
    load0 = os.getloadavg()
    try:
        up = time.monotonic() + STARTUP_BOUND
        while not caller.ready():
            if server.poll() is not None or time.monotonic() > min(up, deadline):
                raise BenchError(f'{name} not up within {STARTUP_BOUND} s '
                                 f'(exit {server.poll()}): {_tail(server)}')
            time.sleep(0.05)
        time.sleep(1.0)    # discovery of the reply readers settles
        times = []
        seq = 0
        for k in range(calls // BLOCK + 1):              # the first block is the warm-up
            for i in range(BLOCK):
                seq += 1
                dt = caller.call_service(poses[seq % len(poses)])
                if k:
                    times.append(dt)
            if time.monotonic() > deadline:
                raise BenchError(f'{name}: the run passed its {RUN_BOUND} s bound')
    finally:
        executor.shutdown(timeout_sec=2.0)
        caller.node.destroy_node()
        ctx.try_shutdown()
        _stop(server)
    out = {'service': _stats(times)}
    out['loadavg_before'] = [round(x, 2) for x in load0]
    out['loadavg_after'] = [round(x, 2) for x in os.getloadavg()]
    return out


def _tail(proc: subprocess.Popen) -> str:
    """Return the end of a server's output."""
    proc.log.seek(0)
    return proc.log.read()[-2000:]


def run(quick: bool = True) -> dict:
    """Run both servers; return the figures (and the machine's load while they ran)."""
    deadline = time.monotonic() + RUN_BOUND
    poses = _targets(500)
    calls = 500 if quick else 2000
    out = {name: bench_server(name, calls, poses, deadline) for name in SERVERS}
    out['machine'] = {'cpus': os.cpu_count(), 'python': platform.python_version()}
    out['quick'] = quick
    rows = ['| server | calls | p50 [ms] | p99 [ms] | max [ms] | load before / after |',
            '| --- | ---: | ---: | ---: | ---: | --- |']
    for name in SERVERS:
        r = out[name]
        s = r['service']
        rows.append(f"| {name} | {s['calls']} | {s['p50_ms']} | {s['p99_ms']} | "
                    f"{s['max_ms']} | {r['loadavg_before'][0]} / {r['loadavg_after'][0]} |")
    out['markdown'] = '\n'.join(rows)
    return out


def main() -> int:
    """Print the figures and write benchmarks/results/ik_call.json."""
    quick = '--quick' in sys.argv
    try:
        res = run(quick)
    except BenchError as exc:
        print(f'bench_ik_call failed: {exc}', file=sys.stderr)
        return 1
    print(res['markdown'])
    print(f"machine: {res['machine']}")
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)
    with open(RESULTS, 'w') as f:
        json.dump(res, f, indent=2)
    print(f'wrote {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
