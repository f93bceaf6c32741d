"""
One IK load client (run as its own process): ``count`` closed-loop requests to ik_service.

Each request is a reachable pose (FK of a random in-limit configuration) with a unique stamp
(sec = 2,000,000 + worker index, nanosec = request number). A reply is matched by stamp on
``ik/status`` and ``ik/solution``; it is *lost* if either is missing after ``--timeout`` s and
*mismatched* if its solution does not put the end effector on that request's pose (1 mm,
1e-3 rad) or if its status does not name the request. Prints one JSON line of figures.
Usage: ``python ik_load_worker.py --index I --count N [--timeout S] [--robot-name px100]``.
"""
import argparse
import json
import sys
import threading
import time


def main(argv=None) -> int:
    """Run the worker; exit 0 when it ran (the figures tell whether replies were lost)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--index', type=int, required=True)
    parser.add_argument('--count', type=int, default=100)
    parser.add_argument('--timeout', type=float, default=5.0)
    parser.add_argument('--robot-name', default='px100')
    parser.add_argument('--start-at', type=float, default=0.0,
                        help='wall time (time.time()) to start sending at, for a common start')
    opts = parser.parse_args(argv)

    from builtin_interfaces.msg import Time
    from diagnostic_msgs.msg import DiagnosticStatus
    from geometry_msgs.msg import PoseStamped
    import numpy as np
    from px100_control.kinematics.se3 import pose_error
    from px100_control.models.registry import load_robot
    from px100_control.ros.conversions import matrix_to_pose
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    model = load_robot('px100')
    rng = np.random.default_rng(1000 + opts.index)
    qs = model.random_configurations(opts.count, rng, margin=0.1)
    ns = f'/{opts.robot_name}'
    qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)

    rclpy.init()
    node = rclpy.create_node(f'ik_load_{opts.index}')
    cond = threading.Condition()
    solutions, statuses = {}, {}
    foreign = [0]
    sec = 2_000_000 + opts.index

    def on_solution(msg):
        if msg.header.stamp.sec != sec:
            foreign[0] += 1
            return
        with cond:
            solutions.setdefault(msg.header.stamp.nanosec, []).append(msg)
            cond.notify_all()

    def on_status(msg):
        try:
            s, n = msg.hardware_id.split('.')
            s, n = int(s), int(n)
        except ValueError:
            return
        if s != sec:
            return
        with cond:
            statuses.setdefault(n, []).append(msg)
            cond.notify_all()

    node.create_subscription(JointState, f'{ns}/ik/solution', on_solution, qos)
    node.create_subscription(DiagnosticStatus, f'{ns}/ik/status', on_status, qos)
    pub = node.create_publisher(PoseStamped, f'{ns}/ik/request', qos)
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    spin = threading.Thread(target=ex.spin, daemon=True)
    spin.start()
    deadline = time.monotonic() + 30.0
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)  # let ik_service's publishers match our subscriptions
    if opts.start_at:
        time.sleep(max(0.0, opts.start_at - time.time()))

    lost, mismatched, unsolved, latencies, errors = 0, 0, 0, [], []
    t_start = time.monotonic()
    for i, q in enumerate(qs):
        T = model.fk(q)
        msg = PoseStamped()
        msg.header.stamp = Time(sec=sec, nanosec=i + 1)
        msg.header.frame_id = f'{opts.robot_name}/base_link'
        msg.pose = matrix_to_pose(T)
        key = i + 1
        t0 = time.monotonic()
        pub.publish(msg)
        with cond:
            ok = cond.wait_for(lambda: key in solutions and key in statuses, opts.timeout)
        if not ok:
            lost += 1
            errors.append(f'request {sec}.{key:09d}: no reply within {opts.timeout} s')
            continue
        latencies.append(time.monotonic() - t0)
        sol, st = solutions[key][0], statuses[key][0]
        if len(solutions[key]) > 1 or len(statuses[key]) > 1:
            mismatched += 1
            errors.append(f'request {key}: {len(solutions[key])} solutions, '
                          f'{len(statuses[key])} statuses')
        if st.level != DiagnosticStatus.OK or not sol.position:
            unsolved += 1
            errors.append(f'request {key} (reachable) not solved: {st.message}')
            continue
        by_name = dict(zip(sol.name, sol.position))
        try:
            qsol = np.array([by_name[n] for n in model.joint_names])
        except KeyError:
            mismatched += 1
            errors.append(f'request {key}: solution names {list(sol.name)}')
            continue
        dp, dr = pose_error(model.fk(qsol), T)
        if not (dp < 1e-3 and dr < 1e-3):
            mismatched += 1
            errors.append(f'request {key}: solution misses its pose by {dp:.3g} m / '
                          f'{dr:.3g} rad')
    elapsed = time.monotonic() - t_start
    lat = np.array(latencies) if latencies else np.array([np.nan])
    print(json.dumps({
        'index': opts.index, 'sent': len(qs), 'lost': lost, 'mismatched': mismatched,
        'unsolved': unsolved, 'foreign_replies_seen': foreign[0], 'seconds': elapsed,
        'latency_median_ms': float(np.median(lat) * 1e3),
        'latency_p99_ms': float(np.percentile(lat, 99) * 1e3),
        'latency_max_ms': float(np.max(lat) * 1e3), 'errors': errors[:10]}), flush=True)
    ex.shutdown(timeout_sec=1.0)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
