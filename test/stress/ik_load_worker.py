"""
IK load clients (run as a process): each sends ``count`` closed-loop requests to ik_service.

``--clients K`` runs K clients in this process (threads, each with its own rclpy context and
node, so each is its own DDS participant), numbered from ``--index``; one JSON line per client.

Each request is a compute_ik call for a reachable pose (FK of a random in-limit
configuration), with the service's deep request QoS; a call is *lost* if no response came
after ``--timeout`` s and *mismatched* if its solution does not put the end effector on that
request's position (1 mm: a response meant for another request). A solution at the right
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
    from geometry_msgs.msg import PoseStamped
    import numpy as np
    from px100_control.kinematics.se3 import pose_error
    from px100_control.models.registry import load_robot
    from px100_control.ros.conversions import matrix_to_pose
    from px100_control.ros.ik_services import SERVICE_QOS
    from px100_control_msgs.srv import ComputeIK
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    model = load_robot('px100')
    rng = np.random.default_rng(1000 + index)
    qs = model.random_configurations(count, rng, margin=0.1)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node(f'ik_load_{index}', context=ctx)
    client = node.create_client(ComputeIK, f'/{robot_name}/compute_ik', qos_profile=SERVICE_QOS)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    spin = threading.Thread(target=ex.spin, daemon=True)
    spin.start()
    client.wait_for_service(timeout_sec=30.0)
    time.sleep(0.5)  # let ik_service's reply writer match this client's reader
    if start_at:
        time.sleep(max(0.0, start_at - time.time()))

    lost, mismatched, unsolved, latencies, errors = 0, 0, 0, [], []
    wrong_orientation, orientation_examples = 0, []
    t_start = time.monotonic()
    for i, q in enumerate(qs):
        T = model.fk(q)
        target = PoseStamped(pose=matrix_to_pose(T))
        target.header.frame_id = f'{robot_name}/base_link'
        done = threading.Event()
        t0 = time.monotonic()
        future = client.call_async(ComputeIK.Request(target=target))
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout):
            client.remove_pending_request(future)
            lost += 1
            errors.append(f'request {i}: no response within {timeout} s')
            continue
        latencies.append(time.monotonic() - t0)
        res = future.result()
        sol = res.solution
        if not res.success or not sol.position:
            unsolved += 1
            errors.append(f'request {i} (reachable) not solved: {res.message}')
            continue
        by_name = dict(zip(sol.name, sol.position))
        try:
            qsol = np.array([by_name[n] for n in model.joint_names])
        except KeyError:
            mismatched += 1
            errors.append(f'request {i}: solution names {list(sol.name)}')
            continue
        dp, dr = pose_error(model.fk(qsol), T)
        if not dp < 1e-3:
            mismatched += 1
            errors.append(f'request {i}: solution misses its position by {dp:.3g} m '
                          f'(a response to another request?)')
        elif not dr < 1e-3:
            # right position, other orientation: not a mix-up but an IK answer that differs
            # from the requested (reachable) pose; counted apart
            wrong_orientation += 1
            if len(orientation_examples) < 3:
                orientation_examples.append(
                    f'request q {np.round(q, 4).tolist()} -> solution {np.round(qsol, 4).tolist()}'
                    f': orientation off by {dr:.3g} rad, message {res.message!r}')
    elapsed = time.monotonic() - t_start
    lat = np.array(latencies) if latencies else np.array([np.nan])
    result = {
        'index': index, 'sent': len(qs), 'lost': lost, 'mismatched': mismatched,
        'unsolved': unsolved, 'wrong_orientation': wrong_orientation,
        'orientation_examples': orientation_examples,
        'seconds': elapsed,
        'latency_median_ms': float(np.median(lat) * 1e3),
        'latency_p99_ms': float(np.percentile(lat, 99) * 1e3),
        'latency_max_ms': float(np.max(lat) * 1e3), 'errors': errors[:10]}
    ex.shutdown(timeout_sec=1.0)
    node.destroy_node()
    ctx.try_shutdown()
    return result


if __name__ == '__main__':
    sys.exit(main())
