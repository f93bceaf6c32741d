"""
The ik_service over DDS: the installed node as a process, clients and a joint-state source here.

Reachable, unreachable, NaN and position-only targets, the orientation modes, frames, the best
solution closest to the measured state, paths (``compute_ik`` and ``compute_cartesian_path``),
and concurrent clients each answered for their own requests.
"""
import re
import threading
import time

from geometry_msgs.msg import Pose
from nodes_fake_driver import FakeDriver
from nodes_helpers import IkClient, start_node, STARTUP_TIMEOUT, wait_for, wait_seeded_by
import numpy as np
from px100_control.kinematics.se3 import rot_x
from px100_control.kinematics.solve import solve_ik
from px100_control.models.registry import load_robot
from px100_control.ros.conversions import matrix_to_pose
import pytest
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient

pytestmark = pytest.mark.ros

MODEL = load_robot('px100')


def _x_axis_angle(Ta, Tb) -> float:
    a, b = Ta[:3, 0], Tb[:3, 0]
    return float(np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b))


class Env:
    """ik_service process, a joint-state source and a client."""

    def __init__(self, server, driver, client, params):
        self.server, self.driver, self.client, self.params = server, driver, client, params

    def set_params(self, **values):
        """Set ik_service parameters and wait for the answer."""
        fut = self.params.set_parameters([Parameter(k, value=v) for k, v in values.items()])
        assert wait_for(fut.done, 10.0), 'set_parameters timed out'
        assert all(r.successful for r in fut.result().results), fut.result()

    def set_state(self, q):
        """Make the joint-state source report q and wait until the node answers from it."""
        with self.driver.lock:
            old = list(self.driver.q)
            self.driver.q = [float(x) for x in q]
            self.driver.target = list(self.driver.q)
        wait_seeded_by(MODEL, q, old, lambda T: self.client.reply(
            self.client.request(matrix_to_pose(T), mode='pitch')))

    def solve(self, T=None, pose=None, frame_id=''):
        """Call compute_ik for a (4, 4) target (or a Pose); return (q or None, response)."""
        res = self.client.reply(self.client.request(
            pose if pose is not None else matrix_to_pose(T), frame_id))
        assert list(res.solution.name) == list(MODEL.joint_names)
        assert res.success == (len(res.solution.position) > 0), res
        return (np.array(res.solution.position) if res.success else None), res


@pytest.fixture(scope='module')
def env(ros_ctx, spinner, processes):
    """Start the ik_service and the test nodes once for the module."""
    driver = spinner.add(FakeDriver(context=ros_ctx, rate=50.0))
    client = spinner.add(IkClient(context=ros_ctx))
    server = start_node(processes, 'ik_service')
    params = AsyncParameterClient(client, '/px100/ik_service')
    assert params.wait_for_services(STARTUP_TIMEOUT), server.output()
    assert wait_for(client.ready, STARTUP_TIMEOUT), server.output()
    time.sleep(0.5)
    return Env(server, driver, client, params)


@pytest.fixture
def fresh(env):
    """Reset the parameters before each test; check that the node still runs after it."""
    env.set_params(orientation_mode='pitch')
    yield env
    assert env.server.alive(), env.server.output()


def test_reachable_target_is_solved_exactly(fresh):
    """A reachable pose: OK, the solution reproduces position and tool pitch, values filled."""
    env = fresh
    rng = np.random.default_rng(4)
    for q in MODEL.random_configurations(5, rng, margin=0.1):
        T = MODEL.fk(q)
        q_sol, res = env.solve(T)
        assert res.success and res.message == 'solved', res.message
        T_sol = MODEL.fk(q_sol)
        np.testing.assert_allclose(T_sol[:3, 3], T[:3, 3], atol=1e-9)
        assert _x_axis_angle(T_sol, T) < 1e-9
        assert MODEL.within_limits(q_sol)
        assert res.method.startswith('analytic') and res.iterations == 0
        assert res.num_solutions >= 1
        assert res.position_error < 1e-9 and res.orientation_error < 1e-9


def test_best_solution_is_the_one_closest_to_the_measured_state(fresh):
    """With two valid branches, the reply follows the measured joint state."""
    env = fresh
    rng = np.random.default_rng(11)
    for q in MODEL.random_configurations(200, rng, margin=0.2):
        T = MODEL.fk(q)
        sols = solve_ik(MODEL, T, mode='pitch').solutions
        # two upright branches (same waist: the elbow-up/down pair), far apart
        if len(sols) >= 2 and abs(sols[0][0] - sols[1][0]) < 1e-9 and \
                np.max(np.abs(sols[0] - sols[1])) > 0.3:
            break
    else:
        pytest.fail('no target with two distinct branches found')
    for pick in (sols[1], sols[0]):
        env.set_state(pick + 0.01)
        q_sol, res = env.solve(T)
        assert res.success, res.message
        np.testing.assert_allclose(q_sol, pick, atol=1e-9)


def test_unreachable_target_is_refused_with_the_reason(fresh):
    """Out of reach: ERROR, empty solution, a reason that says by how much."""
    q, res = fresh.solve(np.array([[1, 0, 0, 0.6], [0, 1, 0, 0], [0, 0, 1, 0.2],
                                   [0, 0, 0, 1.0]]))
    assert q is None and not res.success
    assert 'reach' in res.message, res.message


def test_nan_and_malformed_requests_are_refused_once(fresh):
    """NaN, a non-unit quaternion, a foreign frame: refused with the reason, no solution."""
    env = fresh
    bad = Pose()
    bad.position.x = float('nan')
    bad.orientation.w = 1.0
    squashed = Pose()
    squashed.position.x = 0.2
    squashed.orientation.w = 0.2
    good = matrix_to_pose(MODEL.fk(np.zeros(4)))
    cases = [(bad, '', 'NaN'), (squashed, '', 'quaternion'), (good, 'world', 'frame_id')]
    for pose, frame, words in cases:
        q, res = env.solve(pose=pose, frame_id=frame)
        assert not res.success and words in res.message, res.message
        assert q is None
    for frame in ('px100/base_link', 'base_link'):
        q, res = env.solve(pose=good, frame_id=frame)
        assert res.success and q is not None


def test_position_only_target_takes_the_nominal_pitch(fresh):
    """An all-zero quaternion: position-only IK, position reached, pitch toward nominal."""
    env = fresh
    env.set_state(np.asarray(MODEL.home, float))   # the reply follows the measured state
    T = MODEL.fk(np.array([0.4, -0.3, 0.5, 0.2]))
    pose = matrix_to_pose(T)
    pose.orientation.x = pose.orientation.y = pose.orientation.z = pose.orientation.w = 0.0
    q, res = env.solve(pose=pose)
    assert res.success, res.message
    np.testing.assert_allclose(MODEL.fk(q)[:3, 3], T[:3, 3], atol=1e-6)
    # the free pitch goes toward the nominal (home) pose: as close to it as the target allows
    ref = solve_ik(MODEL, T, mode='position', q_nominal=MODEL.home, q_seed=MODEL.home)
    assert np.linalg.norm(q - MODEL.home) <= np.linalg.norm(ref.q - MODEL.home) + 1e-6


def test_orientation_modes_pitch_reports_and_strict_refuses(fresh):
    """A roll a 4-DOF arm cannot make: 'pitch' solves and names it, 'strict' refuses."""
    env = fresh
    T = MODEL.fk(np.array([0.3, -0.2, 0.4, 0.3]))
    T_roll = T.copy()
    T_roll[:3, :3] = T[:3, :3] @ rot_x(0.3)
    q, res = env.solve(T_roll)
    assert res.success and 'warning' in res.message, res.message
    roll = float(re.search(r'roll ([0-9.e-]+) rad', res.message).group(1))
    assert abs(roll - 0.3) < 1e-3, res.message
    np.testing.assert_allclose(MODEL.fk(q)[:3, 3], T[:3, 3], atol=1e-9)
    env.set_params(orientation_mode='strict')
    q, res = env.solve(T_roll)
    assert q is None and not res.success
    q, res = env.solve(T)
    assert res.success and q is not None


def test_path_is_solved_point_by_point_without_branch_jumps(fresh):
    """A straight line of poses: one point per pose, each near the previous, FK on the line."""
    env = fresh
    env.set_state(MODEL.sleep)
    T0 = MODEL.fk(np.array([0.2, -0.4, 0.6, 0.3]))
    poses, targets = [], []
    for k in range(10):
        T = T0.copy()
        T[:3, 3] += np.array([0.005, 0.004, -0.003]) * k
        targets.append(T)
        poses.append(matrix_to_pose(T))
    res = env.client.reply(env.client.request_path(poses), timeout=20.0)
    traj = res.trajectory
    assert res.success, res.message
    assert len(traj.points) == 10 and list(traj.joint_names) == list(MODEL.joint_names)
    Q = np.array([p.positions for p in traj.points])
    assert np.max(np.abs(np.diff(Q, axis=0))) < 0.1
    for q, T in zip(Q, targets):
        np.testing.assert_allclose(MODEL.fk(q)[:3, 3], T[:3, 3], atol=1e-9)


def test_path_stops_at_the_failing_pose_and_says_which(fresh):
    """An unreachable pose in a path: the points before it, ERROR naming its index."""
    env = fresh
    T0 = MODEL.fk(np.array([0.0, -0.4, 0.6, 0.3]))
    poses = [matrix_to_pose(T0) for _ in range(3)]
    far = T0.copy()
    far[:3, 3] = [0.7, 0.0, 0.1]
    poses += [matrix_to_pose(far), matrix_to_pose(T0)]
    res = env.client.reply(env.client.request_path(poses), timeout=20.0)
    assert not res.success
    assert 'pose 3' in res.message, res.message
    assert len(res.trajectory.points) == 3
    nan_path = [matrix_to_pose(T0), Pose()]
    nan_path[1].position.x = float('nan')
    res = env.client.reply(env.client.request_path(nan_path), timeout=20.0)
    assert not res.success and 'pose 1' in res.message and len(res.trajectory.points) == 0


def test_concurrent_clients_each_get_exactly_their_replies(fresh, ros_ctx, spinner):
    """Four clients calling at once: each response answers its own request."""
    env = fresh
    env.set_state(MODEL.sleep)
    clients = [spinner.add(IkClient(f'test_ik_client_{k}', context=ros_ctx)) for k in range(4)]
    assert wait_for(lambda: all(c.ready() for c in clients), 30.0)
    time.sleep(0.5)
    rng = np.random.default_rng(7)
    plan = []
    for c in clients:
        for q in MODEL.random_configurations(40, rng, margin=0.05):
            plan.append((c, MODEL.fk(q)))
        far = np.eye(4)
        far[:3, 3] = [0.0, 0.9, 0.1]
        plan.append((c, far))
    sent = {id(c): [] for c in clients}

    def fire(c):
        for cc, T in plan:
            if cc is c:
                sent[id(c)].append((c.request(matrix_to_pose(T)), T))
    threads = [threading.Thread(target=fire, args=(c,)) for c in clients]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for c in clients:
        for future, T in sent[id(c)]:
            res = c.reply(future, timeout=60.0)
            if np.linalg.norm(T[:3, 3]) > 0.5:
                assert not res.success and len(res.solution.position) == 0
            else:
                assert res.success, res.message
                np.testing.assert_allclose(MODEL.fk(np.array(res.solution.position))[:3, 3],
                                           T[:3, 3], atol=1e-9)


def test_burst_answers_equal_solve_ik(fresh):
    """A burst of calls answers exactly what solve_ik does for the same seed."""
    env = fresh
    seed = np.array([0.1, -0.5, 0.7, 0.2])
    env.set_state(seed)
    rng = np.random.default_rng(3)
    targets = [MODEL.fk(q) for q in MODEL.random_configurations(150, rng, margin=0.05)]
    futures = [env.client.request(matrix_to_pose(T)) for T in targets]
    for future, T in zip(futures, targets):
        res = env.client.reply(future, timeout=60.0)
        ref = solve_ik(MODEL, T, mode='pitch', q_seed=seed)
        assert res.success == ref.success
        if ref.success:
            np.testing.assert_allclose(np.array(res.solution.position), ref.q, atol=1e-9)
            assert res.num_solutions == len(ref.solutions)


def test_node_replies_with_solve_ik(ros_ctx):
    """In-process: every compute_ik answer is solve_ik's (q, success, branches, dropped roll)."""
    from geometry_msgs.msg import PoseStamped
    from px100_control.ros.ik_service_node import IkServiceNode
    from px100_control_msgs.srv import ComputeIK
    node = IkServiceNode(context=ros_ctx)
    try:
        rng = np.random.default_rng(5)
        targets = [MODEL.fk(q) for q in MODEL.random_configurations(60, rng, margin=0.0)]
        targets.append(np.array([[1, 0, 0, 0.7], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1.0]]))
        T_roll = targets[0].copy()
        T_roll[:3, :3] = T_roll[:3, :3] @ rot_x(0.2)
        targets.append(T_roll)
        seed = np.array([0.3, -0.4, 0.5, 0.1])
        for T in targets:
            req = ComputeIK.Request(target=PoseStamped(pose=matrix_to_pose(T)),
                                    seed=[float(x) for x in seed])
            res = node._ik_services._on_ik(req, ComputeIK.Response())
            ref = solve_ik(MODEL, T, mode='pitch', q_seed=seed, method='analytic')
            assert res.success == ref.success, res.message
            if not ref.success:
                assert len(res.solution.position) == 0 and res.message == ref.reason
                continue
            np.testing.assert_allclose(res.solution.position, ref.q, atol=1e-12)
            assert res.method == ref.method and res.iterations == 0
            assert res.num_solutions == len(ref.solutions)
        assert 'warning' in res.message          # the dropped roll of T_roll is named
    finally:
        node.destroy_node()


def test_parameters_are_validated(fresh):
    """A bad orientation_mode is refused by the node (and the old one stays)."""
    env = fresh
    fut = env.params.set_parameters([Parameter('orientation_mode', value='sideways')])
    assert wait_for(fut.done, 10.0)
    assert not fut.result().results[0].successful
    q, res = env.solve(MODEL.fk(np.zeros(4)))
    assert res.success
