"""
The ik_service over DDS: the installed node as a process, clients and a joint-state source here.

Reachable, unreachable, NaN and position-only targets, the orientation modes, frames, the best
solution closest to the measured state, paths, and request/reply matching under concurrency
(exactly one solution and one status per request, each for the right request).
"""
import threading
import time

from geometry_msgs.msg import Pose
from nodes_fake_driver import FakeDriver
from nodes_helpers import (IkClient, start_node, STARTUP_TIMEOUT, status_values, unique_stamp,
                           wait_for)
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
OK, ERROR = b'\x00', b'\x02'


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
        """Make the joint-state source report q and wait until the node has seen it."""
        with self.driver.lock:
            self.driver.q = [float(x) for x in q]
            self.driver.target = list(self.driver.q)
        time.sleep(0.3)

    def solve(self, T=None, pose=None, frame_id=''):
        """Request IK of a (4, 4) target (or a Pose); return (q or None, status)."""
        stamp = self.client.request(pose if pose is not None else matrix_to_pose(T), frame_id)
        sol, status = self.client.reply(stamp)
        assert status.hardware_id == f'{stamp.sec}.{stamp.nanosec:09d}'
        assert sol.header.stamp == stamp
        assert list(sol.name) == list(MODEL.joint_names)
        return (np.array(sol.position) if len(sol.position) else None), status


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
        q_sol, status = env.solve(T)
        assert status.level == OK and status.message == 'solved', status.message
        T_sol = MODEL.fk(q_sol)
        np.testing.assert_allclose(T_sol[:3, 3], T[:3, 3], atol=1e-9)
        assert _x_axis_angle(T_sol, T) < 1e-9
        assert MODEL.within_limits(q_sol)
        vals = status_values(status)
        assert vals['method'].startswith('analytic') and vals['iterations'] == '0'
        assert int(vals['solutions']) >= 1 and vals['mode'] == 'pitch'
        assert float(vals['position_error']) < 1e-9
        assert abs(float(vals['unreachable_roll'])) < 1e-9
        assert status.name == 'px100/ik_service'


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
        q_sol, status = env.solve(T)
        assert status.level == OK
        np.testing.assert_allclose(q_sol, pick, atol=1e-9)


def test_unreachable_target_is_refused_with_the_reason(fresh):
    """Out of reach: ERROR, empty solution, a reason that says by how much."""
    q, status = fresh.solve(np.array([[1, 0, 0, 0.6], [0, 1, 0, 0], [0, 0, 1, 0.2],
                                      [0, 0, 0, 1.0]]))
    assert q is None and status.level == ERROR
    assert 'reach' in status.message, status.message


def test_nan_and_malformed_requests_are_refused_once(fresh):
    """NaN, a non-unit quaternion, a foreign frame: one empty solution and one ERROR each."""
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
        stamp = env.client.request(pose, frame)
        sol, status = env.client.reply(stamp)
        assert status.level == ERROR and words in status.message, status.message
        assert len(sol.position) == 0
        time.sleep(0.2)
        assert env.client.counts(stamp) == (1, 1)
    for frame in ('px100/base_link', 'base_link'):
        q, status = env.solve(pose=good, frame_id=frame)
        assert status.level == OK and q is not None


def test_position_only_target_takes_the_nominal_pitch(fresh):
    """An all-zero quaternion: position-only IK (mode 'position'), position reached."""
    env = fresh
    env.set_state(np.asarray(MODEL.home, float))   # the reply follows the measured state
    T = MODEL.fk(np.array([0.4, -0.3, 0.5, 0.2]))
    pose = matrix_to_pose(T)
    pose.orientation.x = pose.orientation.y = pose.orientation.z = pose.orientation.w = 0.0
    q, status = env.solve(pose=pose)
    assert status.level == OK, status.message
    np.testing.assert_allclose(MODEL.fk(q)[:3, 3], T[:3, 3], atol=1e-6)
    assert status_values(status)['mode'] == 'position'
    # the free pitch goes toward the nominal (home) pose: as close to it as the target allows
    ref = solve_ik(MODEL, T, mode='position', q_nominal=MODEL.home, q_seed=MODEL.home)
    assert np.linalg.norm(q - MODEL.home) <= np.linalg.norm(ref.q - MODEL.home) + 1e-6


def test_orientation_modes_pitch_reports_and_strict_refuses(fresh):
    """A roll a 4-DOF arm cannot make: 'pitch' solves and names it, 'strict' refuses."""
    env = fresh
    T = MODEL.fk(np.array([0.3, -0.2, 0.4, 0.3]))
    T_roll = T.copy()
    T_roll[:3, :3] = T[:3, :3] @ rot_x(0.3)
    q, status = env.solve(T_roll)
    assert status.level == OK and 'warning' in status.message, status.message
    assert abs(abs(float(status_values(status)['unreachable_roll'])) - 0.3) < 1e-6
    np.testing.assert_allclose(MODEL.fk(q)[:3, 3], T[:3, 3], atol=1e-9)
    env.set_params(orientation_mode='strict')
    q, status = env.solve(T_roll)
    assert q is None and status.level == ERROR
    q, status = env.solve(T)
    assert status.level == OK and q is not None


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
    stamp = env.client.request_path(poses)
    traj, status = env.client.path_reply(stamp)
    assert status.level == OK, status.message
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
    traj, status = env.client.path_reply(env.client.request_path(poses))
    assert status.level == ERROR
    assert status_values(status)['failed_index'] == '3'
    assert 'pose 3' in status.message, status.message
    assert len(traj.points) == 3
    nan_path = [matrix_to_pose(T0), Pose()]
    nan_path[1].position.x = float('nan')
    traj, status = env.client.path_reply(env.client.request_path(nan_path))
    assert status.level == ERROR and 'pose 1' in status.message and len(traj.points) == 0


def test_concurrent_clients_each_get_exactly_their_replies(fresh, ros_ctx, spinner):
    """Four clients firing at once: one solution and one status per request, each matching."""
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
        for stamp, T in sent[id(c)]:
            sol, status = c.reply(stamp, timeout=60.0)
            if np.linalg.norm(T[:3, 3]) > 0.5:
                assert status.level == ERROR and len(sol.position) == 0
            else:
                assert status.level == OK, status.message
                np.testing.assert_allclose(MODEL.fk(np.array(sol.position))[:3, 3], T[:3, 3],
                                           atol=1e-9)
    time.sleep(1.0)
    for c in clients:
        for stamp, _ in sent[id(c)]:
            assert c.counts(stamp) == (1, 1), 'lost or duplicated reply'
        with c.lock:   # every client sees every reply, and only one of each
            assert all(len(v) == 1 for v in c.solutions.values())


def test_burst_answers_equal_solve_ik(fresh):
    """A burst (served in batches) answers exactly what solve_ik does for the same seed."""
    env = fresh
    seed = np.array([0.1, -0.5, 0.7, 0.2])
    env.set_state(seed)
    rng = np.random.default_rng(3)
    targets = [MODEL.fk(q) for q in MODEL.random_configurations(150, rng, margin=0.05)]
    stamps = [env.client.request(matrix_to_pose(T)) for T in targets]
    for stamp, T in zip(stamps, targets):
        sol, status = env.client.reply(stamp, timeout=60.0)
        ref = solve_ik(MODEL, T, mode='pitch', q_seed=seed)
        assert (status.level == OK) == ref.success
        if ref.success:
            np.testing.assert_allclose(np.array(sol.position), ref.q, atol=1e-9)
            assert int(status_values(status)['solutions']) == len(ref.solutions)


def test_node_replies_with_solve_ik(ros_ctx):
    """In-process: every reply is solve_ik's answer (q, level, solutions, method, dropped roll)."""
    from px100_control.kinematics.solve import solve_ik
    from px100_control.ros.ik_service_node import IkServiceNode
    node = IkServiceNode(context=ros_ctx)
    try:
        replies = []
        node._reply = lambda stamp, q, level, message, values: replies.append(
            (stamp, None if q is None else np.array(q), level, message, dict(values)))
        rng = np.random.default_rng(5)
        targets = [MODEL.fk(q) for q in MODEL.random_configurations(60, rng, margin=0.0)]
        targets.append(np.array([[1, 0, 0, 0.7], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1.0]]))
        T_roll = targets[0].copy()
        T_roll[:3, :3] = T_roll[:3, :3] @ rot_x(0.2)
        targets.append(T_roll)
        seed = np.array([0.3, -0.4, 0.5, 0.1])
        for k, T in enumerate(targets):
            node._solve_one(k, T, 'pitch', seed)
        assert [r[0] for r in replies] == list(range(len(targets)))
        for (_, q, level, message, values), T in zip(replies, targets):
            ref = solve_ik(MODEL, T, mode='pitch', q_seed=seed, method='analytic')
            assert (level == OK) == ref.success, message
            if not ref.success:
                assert q is None and message == ref.reason
                continue
            np.testing.assert_allclose(q, ref.q, atol=1e-12)
            assert values['method'] == ref.method and values['iterations'] == '0'
            assert int(values['solutions']) == len(ref.solutions)
            assert float(values['unreachable_roll']) == pytest.approx(
                ref.details['unreachable_roll'], abs=1e-9)
        assert 'warning' in replies[-1][3]          # the dropped roll of T_roll is named
    finally:
        node.destroy_node()


def test_parameters_are_validated(fresh):
    """A bad orientation_mode is refused by the node (and the old one stays)."""
    env = fresh
    fut = env.params.set_parameters([Parameter('orientation_mode', value='sideways')])
    assert wait_for(fut.done, 10.0)
    assert not fut.result().results[0].successful
    q, status = env.solve(MODEL.fk(np.zeros(4)))
    assert status.level == OK


def test_unique_stamps_are_unique():
    """The helper gives distinct ids (the tests rely on it)."""
    stamps = {(s.sec, s.nanosec) for s in (unique_stamp() for _ in range(1000))}
    assert len(stamps) == 1000


@pytest.mark.parametrize('frame', ['', 'a', 'px100/base_link', 'abcdefg', 'abcdefgh', 'é' * 5])
def test_serialized_request_is_read_like_the_deserializer(frame):
    """parse_pose_stamped (the raw fast path) equals rclpy's deserializer for any frame_id."""
    from geometry_msgs.msg import PoseStamped
    from px100_control.ros.ik_service_node import parse_pose_stamped
    from rclpy.serialization import serialize_message
    msg = PoseStamped()
    msg.header.stamp.sec, msg.header.stamp.nanosec = -5, 999_999_999
    msg.header.frame_id = frame
    vals = [0.1, -0.2, 0.3, float('nan'), 0.0, -0.0, 1.0]
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z, o.x, o.y, o.z, o.w = vals
    raw = serialize_message(msg)
    stamp, got_frame, got = parse_pose_stamped(raw)
    assert (stamp.sec, stamp.nanosec, got_frame) == (-5, 999_999_999, frame)
    np.testing.assert_array_equal(np.array(got), np.array(vals))
    with pytest.raises(Exception):  # unreadable bytes raise (the node logs and drops them)
        parse_pose_stamped(b'\x00\x00' + raw[2:9])
