"""
sim_driver timing: publish-period jitter of joint_states at real time.

- ``jitter``: the ``sim_driver`` process at real time, ``publish_rate`` 100 Hz: period of
  joint_states as received here (monotonic clock at the callback) and as stamped by the driver
  (the nominal sample times: 0 by construction), |period - 10 ms| p50 / p99 / max; and the
  driver's own send times (in-process node, monotonic clock at each publish).

The driver's speed (unthrottled, with and without the default scene) is measured by
bench_physics.py, side by side with the step costs; :func:`bench_unthrottled` here is the
measurement it uses. The machine's load average is recorded with the figures: on a shared
2-core machine they vary with what else runs. Writes ``benchmarks/results/sim_driver.json``
(also when run by run_all.py).
Usage (venv + install sourced, e.g. ``source scripts/env.sh``):
``python benchmarks/bench_sim_driver.py [--quick]``.
"""
import argparse
import json
import os
import sys
import threading
import time

import bound
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: the run's bound [s] with --quick and without: past it the run fails naming its stage
BOUND_S = (120.0, 300.0)
RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'sim_driver.json')
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
os.environ.setdefault('ROS_DOMAIN_ID', str(10 + os.getpid() % 90))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)


def machine_busy() -> tuple:
    """Return (busy, total) CPU jiffies of the whole machine so far (from /proc/stat)."""
    with open('/proc/stat') as f:
        fields = [int(x) for x in f.readline().split()[1:]]
    idle = fields[3] + fields[4]                  # idle + iowait
    return sum(fields) - idle, sum(fields)


def busy_share(before: tuple, after: tuple) -> float:
    """Return the share of the machine's CPU time that was busy between two machine_busy()."""
    return round((after[0] - before[0]) / max(after[1] - before[1], 1), 2)


def _cpu_seconds(pid: int) -> float:
    """Return user + system CPU seconds of a process (from /proc)."""
    with open(f'/proc/{pid}/stat') as f:
        fields = f.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


class _Listener:
    """Records joint_states arrivals in this process."""

    def __init__(self):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from sensor_msgs.msg import JointState
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.node = rclpy.create_node('bench_sim_driver', context=self.ctx)
        self.js = []
        self.node.create_subscription(JointState, '/px100/joint_states', self._on_js, 1000)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def _on_js(self, msg):
        self.js.append((time.monotonic(),
                        msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9))

    def wait(self, store, count, timeout):
        deadline = time.monotonic() + timeout
        while len(store) < count and time.monotonic() < deadline:
            time.sleep(0.05)
        return len(store) >= count

    def close(self):
        self.executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        self.ctx.try_shutdown()
        self.thread.join(5.0)


def _window(store, seconds):
    n0 = len(store)
    time.sleep(seconds)
    return list(store[n0:])


class _ClockProbe:
    """
    Reads the latest /clock when asked, and costs (almost) nothing in between.

    The subscription is a use_sim_time node's (rclpy's TimeSource: best effort, depth 1), but
    no executor runs it between readings: the middleware keeps the newest message and
    :meth:`read` takes it. A subscriber whose Python callback ran for each of the driver's
    thousands of /clock messages per second would load the machine's other core and slow the
    driver it measures.
    """

    def __init__(self):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.node = rclpy.create_node('bench_sim_driver_clock', context=self.ctx)
        self.last = None
        self.node.create_subscription(
            Clock, '/clock', self._on_clock,
            QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)

    def _on_clock(self, msg):
        self.last = (time.monotonic(), msg.clock.sec + msg.clock.nanosec * 1e-9)

    def read(self, timeout: float):
        """Return (monotonic wall time [s], simulated time [s]) of the newest /clock, or None."""
        self.last = None
        deadline = time.monotonic() + timeout
        while self.last is None and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.1)
        return self.last

    def close(self):
        self.executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        self.ctx.try_shutdown()


def bench_unthrottled(seconds: float, scene: str) -> dict:
    """
    Return simulated s per wall s and per driver CPU s of sim_driver at real_time_factor 0.

    Simulated time is read from /clock at the window's two ends (:class:`_ClockProbe`).

    :param seconds: the measurement window [s of wall time], after /clock passed 1 s of
        simulated time and one more second (start-up excluded)
    :param scene: the driver's ``scene`` parameter ('' = no objects)
    """
    from px100_control.tools.processes import NodeProcess
    probe = _ClockProbe()
    value = scene or "''"
    proc = NodeProcess('sim_driver', ['--ros-args', '-p', 'real_time_factor:=0.0',
                                      '-p', f'scene:={value}'])
    try:
        deadline = time.monotonic() + 60.0
        first = probe.read(1.0)
        while (first is None or first[1] < 1.0) and time.monotonic() < deadline:
            first = probe.read(1.0)
        if first is None:
            return {'error': 'no /clock from sim_driver', 'log': proc.output()[-2000:]}
        time.sleep(1.0)
        start = probe.read(5.0)
        cpu0, busy0 = _cpu_seconds(proc.pid), machine_busy()
        time.sleep(seconds)
        end = probe.read(5.0)
        cpu1, busy1 = _cpu_seconds(proc.pid), machine_busy()
        if start is None or end is None:
            return {'error': '/clock stopped', 'log': proc.output()[-2000:]}
        wall = end[0] - start[0]
        sim = end[1] - start[1]
        return {'sim_s_per_wall_s': round(sim / wall, 2),
                'driver_cpu_share': round((cpu1 - cpu0) / seconds, 2),
                'sim_s_per_driver_cpu_s': round(sim / max(cpu1 - cpu0, 1e-9), 2),
                'window_s': seconds, 'load_average_1min': round(os.getloadavg()[0], 2),
                'machine_busy': busy_share(busy0, busy1)}
    finally:
        proc.stop()
        probe.close()


def bench_jitter(seconds: float) -> dict:
    """Return joint_states period jitter at 100 Hz, real time, received and stamped."""
    from px100_control.tools.processes import NodeProcess
    listener = _Listener()
    proc = NodeProcess('sim_driver', ['--ros-args', '-p', 'publish_rate:=100.0'])
    try:
        if not listener.wait(listener.js, 50, 60.0):
            return {'error': 'no joint_states from sim_driver', 'log': proc.output()[-2000:]}
        samples = _window(listener.js, seconds)
        out = {'messages': len(samples), 'window_s': seconds,
               'rate_hz': round((len(samples) - 1) / (samples[-1][1] - samples[0][1]), 3)}
        for key, col in (('received', 0), ('stamped', 1)):
            dev = np.abs(np.diff([s[col] for s in samples]) - 0.01) * 1e3
            out[key] = {'p50_ms': round(float(np.percentile(dev, 50)), 3),
                        'p99_ms': round(float(np.percentile(dev, 99)), 3),
                        'max_ms': round(float(dev.max()), 3)}
        return out
    finally:
        proc.stop()
        listener.close()


def bench_send_jitter(seconds: float) -> dict:
    """Return the driver's own publish-time jitter at 100 Hz (in-process, send side)."""
    import rclpy
    from px100_control.client.robot import SpinThread
    from px100_control.ros.common import make_executor
    from px100_control.ros.sim_driver_node import SimDriverNode
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = SimDriverNode(context=ctx)
    executor = make_executor(context=ctx)      # the executor the node runs in everywhere
    executor.add_node(node)
    spinner = SpinThread(executor, 'bench_sim_driver').start()
    try:
        time.sleep(1.0)
        n0 = len(node.publish_times)
        time.sleep(seconds)
        sent = list(node.publish_times)[n0:]
    finally:
        spinner.stop()
        node.destroy_node()
        ctx.try_shutdown()
    dev = np.abs(np.diff(sent) - 0.01) * 1e3
    return {'messages': len(sent), 'p50_ms': round(float(np.percentile(dev, 50)), 3),
            'p99_ms': round(float(np.percentile(dev, 99)), 3),
            'max_ms': round(float(dev.max()), 3)}


def run(quick: bool = False, log=print) -> dict:
    """Run the jitter measurements; return the figures."""
    load0 = os.getloadavg()[0]
    figures = {'jitter_100hz': bench_jitter(5.0 if quick else 20.0)}
    log(f"jitter at 100 Hz: {figures['jitter_100hz']}")
    figures['jitter_100hz']['sent'] = bench_send_jitter(5.0 if quick else 20.0)
    log(f"send-side jitter at 100 Hz: {figures['jitter_100hz']['sent']}")
    figures['load_average_1min'] = [round(load0, 2), round(os.getloadavg()[0], 2)]
    figures['cpu_count'] = os.cpu_count()
    figures['quick'] = quick
    rec = figures['jitter_100hz'].get('received', {})
    stp = figures['jitter_100hz'].get('stamped', {})
    snt = figures['jitter_100hz'].get('sent', {})
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)
    with open(RESULTS, 'w') as f:
        json.dump(figures, f, indent=2)
    figures['markdown'] = '\n'.join([
        '| sim_driver | value |', '| --- | --- |',
        '| joint_states 100 Hz, received period jitter p50 / p99 [ms] | '
        f'{rec.get("p50_ms")} / {rec.get("p99_ms")} |',
        '| joint_states 100 Hz, send-time period jitter p50 / p99 [ms] | '
        f'{snt.get("p50_ms")} / {snt.get("p99_ms")} |',
        '| joint_states 100 Hz, stamped period jitter p50 / p99 [ms] | '
        f'{stp.get("p50_ms")} / {stp.get("p99_ms")} |',
        f'| load average (start, end) on {os.cpu_count()} cores | '
        f'{figures["load_average_1min"]} |',
        '| unthrottled speed | see physics (bench_physics.py) |',
    ])
    return figures


def main(argv=None) -> int:
    """Run the benchmark, print the figures and write benchmarks/results/sim_driver.json."""
    parser = argparse.ArgumentParser(description='sim_driver publish jitter')
    parser.add_argument('--quick', action='store_true', help='short windows')
    bound.add_argument(parser, *BOUND_S)
    args = parser.parse_args(argv)
    with bound.bounded('bench_sim_driver', bound.seconds(args, args.quick)):
        figures = run(args.quick, log=bound.log)
    print(figures['markdown'])
    print(f'wrote {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
