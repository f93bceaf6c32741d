"""
IK load clients (run as a process): each sends ``count`` closed-loop requests to ik_service.

``--clients K`` runs K clients in this process (threads, each with its own rclpy context and
node, so each is its own DDS participant), numbered from ``--index``; one JSON line per client.

Each request is a reachable pose (FK of a random in-limit configuration) with a unique stamp
(sec = 2,000,000 + worker index, nanosec = request number). A reply is matched by stamp on
``ik/status`` and ``ik/solution``; it is *lost* if either is missing after ``--timeout`` s and
*mismatched* if its solution does not put the end effector on that request's position (1 mm:
a reply meant for another request) or if more than one reply names it. A solution at the right
position whose orientation differs from the (reachable) request by more than 1e-3 rad is counted
apart as *wrong_orientation*. Prints one JSON line of figures.
Usage: ``python ik_load_worker.py --index I [--clients K] --count N [--timeout S]``.
"""
import argparse
import json
import sys
import threading
import time


def main(argv=None) -> int:
    """Run the clients; exit 0 when they ran (the figures tell whether replies were lost)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--index', type=int, required=True)
    parser.add_argument('--clients', type=int, default=1,
                        help='clients in this process (threads, each its own rclpy context '
                             'and node), numbered from --index')
    parser.add_argument('--count', type=int, default=100)
    parser.add_argument('--timeout', type=float, default=5.0)
    parser.add_argument('--robot-name', default='px100')
    parser.add_argument('--start-at', type=float, default=0.0,
                        help='wall time (time.time()) to start sending at, for a common start')
    opts = parser.parse_args(argv)
    results = [None] * opts.clients

    def one(k):
        results[k] = run_client(opts.index + k, opts.count, opts.timeout, opts.robot_name,
                                opts.start_at)

    threads = [threading.Thread(target=one, args=(k,)) for k in range(opts.clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        print(json.dumps(r), flush=True)
    return 0


def run_client(index: int, count: int, timeout: float, robot_name: str,
               start_at: float = 0.0) -> dict:
    """Run one closed-loop IK client in its own rclpy context; return its figures."""
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
    rng = np.random.default_rng(1000 + index)
    qs = model.random_configurations(count, rng, margin=0.1)
    ns = f'/{robot_name}'
    qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)

    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node(f'ik_load_{index}', context=ctx)
    cond = threading.Condition()
    solutions, statuses = {}, {}
    foreign = [0]
    sec = 2_000_000 + index

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
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    spin = threading.Thread(target=ex.spin, daemon=True)
    spin.start()
    deadline = time.monotonic() + 30.0
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)  # let ik_service's publishers match our subscriptions
    if start_at:
        time.sleep(max(0.0, start_at - time.time()))

    lost, mismatched, unsolved, latencies, errors = 0, 0, 0, [], []
    wrong_orientation, orientation_examples = 0, []
    t_start = time.monotonic()
    for i, q in enumerate(qs):
        T = model.fk(q)
        msg = PoseStamped()
        msg.header.stamp = Time(sec=sec, nanosec=i + 1)
        msg.header.frame_id = f'{robot_name}/base_link'
        msg.pose = matrix_to_pose(T)
        key = i + 1
        t0 = time.monotonic()
        pub.publish(msg)
        with cond:
            ok = cond.wait_for(lambda: key in solutions and key in statuses, timeout)
        if not ok:
            lost += 1
            errors.append(f'request {sec}.{key:09d}: no reply within {timeout} s')
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
        if not dp < 1e-3:
            mismatched += 1
            errors.append(f'request {key}: solution misses its position by {dp:.3g} m '
                          f'(a reply to another request?)')
        elif not dr < 1e-3:
            # right position, other orientation: not a mix-up but an IK answer that differs
            # from the requested (reachable) pose; counted apart
            wrong_orientation += 1
            if len(orientation_examples) < 3:
                orientation_examples.append(
                    f'request q {np.round(q, 4).tolist()} -> solution {np.round(qsol, 4).tolist()}'
                    f': orientation off by {dr:.3g} rad, status {st.message!r} '
                    f'{[(kv.key, kv.value) for kv in st.values]}')
    elapsed = time.monotonic() - t_start
    lat = np.array(latencies) if latencies else np.array([np.nan])
    result = {
        'index': index, 'sent': len(qs), 'lost': lost, 'mismatched': mismatched,
        'unsolved': unsolved, 'wrong_orientation': wrong_orientation,
        'orientation_examples': orientation_examples,
        'foreign_replies_seen': foreign[0], 'seconds': elapsed,
        'latency_median_ms': float(np.median(lat) * 1e3),
        'latency_p99_ms': float(np.percentile(lat, 99) * 1e3),
        'latency_max_ms': float(np.max(lat) * 1e3), 'errors': errors[:10]}
    ex.shutdown(timeout_sec=1.0)
    node.destroy_node()
    ctx.try_shutdown()
    return result


if __name__ == '__main__':
    sys.exit(main())
