"""
Recorder throughput: a 1 kHz JointState stream recorded by the ``record`` process.

- ``live``: a publisher process sends ``sensor_msgs/JointState`` (7 joints, its sequence number
  in ``position[0]``) on ``/px100/joint_states`` at 1 kHz for N seconds (5 quick, 20 full), to
  the installed ``record`` executable in its own process (default options: zstd chunks, /tf at
  50 Hz from the joint states). Figures: messages published and achieved rate, messages
  written, dropped (published sequence numbers missing from the bag) and out of order, written
  messages/s, the recorder's CPU share over the publishing window (from /proc: user + system
  CPU seconds / wall seconds; 1.0 = one full core), bag size per message.
- ``writer``: BagWriter alone in this process (no ROS): messages/s and MB/s of the same message
  bytes, the ceiling of the recorder's I/O path.
- ``reader``: BagReader on the recorded bag: raw messages/s, and decoded messages/s (mcap_ros2).

The machine's load average is recorded with the figures (a shared 2-core machine).
Writes ``benchmarks/results/recorder.json``. Usage (venv + install sourced, e.g.
``source scripts/env.sh``): ``python benchmarks/bench_recorder.py [--quick]``.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import bound

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'recorder.json')
#: the run's bound [s] with --quick and without: past it the run fails naming its stage
BOUND_S = (120.0, 300.0)
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
os.environ.setdefault('ROS_DOMAIN_ID', str(10 + os.getpid() % 90))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)

TOPIC = '/px100/joint_states'
NAMES = ['waist', 'shoulder', 'elbow', 'wrist_angle', 'gripper', 'left_finger', 'right_finger']


def _cpu_seconds(pid: int) -> float:
    """Return user + system CPU seconds of a process (from /proc)."""
    with open(f'/proc/{pid}/stat') as f:
        fields = f.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def publisher_main(seconds: float, rate: float) -> int:
    """Publish JointState at rate [Hz] for seconds once the recorder listens; print JSON."""
    import rclpy
    from rclpy.node import Node
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState
    rclpy.init()
    node = Node('bench_joint_state_publisher')
    pub = node.create_publisher(JointState, TOPIC, QoSProfile(depth=1000))
    deadline = time.monotonic() + 120.0
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(1.0)  # let the recorder's subscription settle
    msg = JointState(name=NAMES, position=[0.0] * 7, velocity=[0.0] * 7, effort=[0.0] * 7)
    count = int(seconds * rate)
    print('publishing', flush=True)
    t0 = time.monotonic()
    late = 0
    for seq in range(count):
        due = t0 + seq / rate
        wait = due - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        elif wait < -0.005:
            late += 1
        msg.header.stamp = node.get_clock().now().to_msg()
        msg.position[0] = float(seq)
        pub.publish(msg)
    elapsed = time.monotonic() - t0
    print('done', flush=True)
    pub.wait_for_all_acked(rclpy.duration.Duration(seconds=10.0))
    print(json.dumps({'published': count, 'seconds': elapsed, 'rate_hz': count / elapsed,
                      'late_over_5ms': late}), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def _wait_line(proc, text: str, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            return False
        if line.strip() == text:
            return True
    return False


def _live(seconds: float, work: str, log) -> dict:
    from px100_control.bag.reader import BagReader
    from px100_control.tools.processes import NodeProcess
    bag = os.path.join(work, 'live')
    rec = NodeProcess('record', ['-o', bag, 'joint_states'])
    pub = None
    try:
        if not rec.wait_for_output('recording to', 180.0):
            raise RuntimeError(f'record did not start: {rec.output()[-500:]}')
        pub = subprocess.Popen([sys.executable, os.path.abspath(__file__), '--publisher',
                                str(seconds)], stdout=subprocess.PIPE, text=True,
                               env=os.environ.copy())
        if not _wait_line(pub, 'publishing', 240.0):
            raise RuntimeError('the publisher never found the recorder')
        c0, t0 = _cpu_seconds(rec.pid), time.monotonic()
        _wait_line(pub, 'done', seconds * 5 + 60)
        c1, t1 = _cpu_seconds(rec.pid), time.monotonic()
        out, _ = pub.communicate(timeout=60)
        published = json.loads(out.strip().splitlines()[-1])
        time.sleep(1.5)
    finally:
        if pub is not None and pub.poll() is None:
            pub.kill()
        rec.stop(30.0)
    log(f'record exited with {rec.returncode}')
    seqs, times = [], []
    with BagReader(bag) as reader:
        summary = reader.summary()
        decode = reader.decoder('sensor_msgs/msg/JointState')
        for raw in reader.iter_raw([TOPIC]):
            seqs.append(int(decode(raw.data).position[0]))
            times.append(raw.log_time_ns)
    n = published['published']
    got = set(seqs)
    span = (times[-1] - times[0]) * 1e-9 if len(times) > 1 else float('nan')
    size = sum(os.path.getsize(f) for f in summary.files)
    return {
        'seconds': seconds, 'published': n, 'publish_rate_hz': published['rate_hz'],
        'publisher_late_over_5ms': published['late_over_5ms'],
        'written': len(seqs), 'dropped': len(set(range(n)) - got),
        'duplicates': len(seqs) - len(got),
        'out_of_order': sum(1 for a, b in zip(seqs, seqs[1:]) if b < a),
        'written_msgs_per_s': (len(seqs) - 1) / span if span else float('nan'),
        'tf_messages': summary.topics['/tf'].message_count if '/tf' in summary.topics else 0,
        'recorder_cpu_share': (c1 - c0) / (t1 - t0),
        'bag_bytes_per_message': size / max(1, summary.message_count),
        'recorder_exit': rec.returncode,
        '_bag': bag,
    }


def _writer(count: int, work: str) -> dict:
    from px100_control.bag.writer import BagWriter
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    msg = JointState(name=NAMES, position=[0.1] * 7, velocity=[0.0] * 7, effort=[0.0] * 7)
    data = serialize_message(msg)  # only the size matters here
    t0 = time.perf_counter()
    with BagWriter(os.path.join(work, 'writer')) as bag:
        bag.add_topic(TOPIC, 'sensor_msgs/msg/JointState')
        for i in range(count):
            bag.write(TOPIC, data, 1_700_000_000_000_000_000 + i * 1_000_000)
    dt = time.perf_counter() - t0
    return {'messages': count, 'msgs_per_s': count / dt,
            'mb_per_s': count * len(data) / dt / 1e6, 'message_bytes': len(data)}


def _reader(bag: str) -> dict:
    from px100_control.bag.reader import BagReader
    with BagReader(bag) as reader:
        t0 = time.perf_counter()
        n = sum(1 for _ in reader.iter_raw([TOPIC]))
        t1 = time.perf_counter()
        m = sum(1 for _ in reader.iter_decoded([TOPIC]))
        t2 = time.perf_counter()
    return {'messages': n, 'raw_msgs_per_s': n / (t1 - t0), 'decoded_msgs_per_s': m / (t2 - t1)}


def run(quick: bool = False, log=print) -> dict:
    """Run the benchmark; return the figures (also written to benchmarks/results/)."""
    seconds = 5.0 if quick else 20.0
    load = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix='px100_bench_recorder_') as work:
        log(f'live: 1 kHz JointState for {seconds:g} s into the record process')
        live = _live(seconds, work, log)
        log(f"  written {live['written']}/{live['published']}, dropped {live['dropped']}, "
            f"{live['written_msgs_per_s']:.0f} msg/s, recorder CPU "
            f"{100 * live['recorder_cpu_share']:.1f} % of a core")
        reader = _reader(live.pop('_bag'))
        writer = _writer(20_000 if quick else 100_000, work)
    result = {'quick': quick, 'load_average_1_5_15': [round(x, 2) for x in load],
              'live_1khz': live, 'writer_only': writer, 'reader': reader}
    result['markdown'] = '\n'.join([
        '| recorder, 1 kHz JointState | value |', '| --- | --- |',
        f"| published / written / dropped | {live['published']} / {live['written']} / "
        f"{live['dropped']} |",
        f"| publish rate achieved | {live['publish_rate_hz']:.0f} Hz |",
        f"| written | {live['written_msgs_per_s']:.0f} msg/s |",
        f"| recorder CPU | {100 * live['recorder_cpu_share']:.1f} % of one core |",
        f"| BagWriter alone | {writer['msgs_per_s']:.0f} msg/s |",
        f"| BagReader raw / decoded | {reader['raw_msgs_per_s']:.0f} / "
        f"{reader['decoded_msgs_per_s']:.0f} msg/s |",
        f'| load average (1, 5, 15 min) | {load[0]:.1f}, {load[1]:.1f}, {load[2]:.1f} |'])
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)
    with open(RESULTS, 'w') as f:
        json.dump(result, f, indent=2)
    return result


def main(argv=None) -> int:
    """Run the benchmark, print the table, write benchmarks/results/recorder.json."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='5 s instead of 20 s')
    parser.add_argument('--publisher', type=float, default=None, help=argparse.SUPPRESS)
    bound.add_argument(parser, *BOUND_S)
    options = parser.parse_args(argv)
    if options.publisher is not None:
        return publisher_main(options.publisher, 1000.0)
    with bound.bounded('bench_recorder', bound.seconds(options, options.quick)):
        result = run(quick=options.quick, log=bound.log)
    print(result['markdown'])
    print(f'wrote {RESULTS}')
    return 0 if result['live_1khz']['dropped'] == 0 else 1


if __name__ == '__main__':
    sys.exit(main())
