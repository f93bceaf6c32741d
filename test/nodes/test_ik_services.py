"""
The ik_service's services over DDS: ``compute_ik`` and ``compute_cartesian_path``.

The installed node runs as a process; a joint-state source and a service client spin here. The
services answer what solve_ik answers, refuse bad input with the reason (the node keeps
running) and publish their introspection events.
"""
import math
import threading

from geometry_msgs.msg import Pose, PoseArray, PoseStamped
from nodes_fake_driver import FakeDriver
from nodes_helpers import start_node, STARTUP_TIMEOUT, wait_for, wait_seeded_by
import numpy as np
from px100_control.kinematics.se3 import rot_x
from px100_control.kinematics.solve import solve_ik
from px100_control.models.registry import load_robot
from px100_control.ros.conversions import matrix_to_pose
from px100_control_msgs.srv import ComputeCartesianPath, ComputeIK
import pytest
from rclpy.node import Node

pytestmark = pytest.mark.ros

MODEL = load_robot('px100')


class ServiceClient(Node):
    """compute_ik / compute_cartesian_path clients and the service event readers."""

    def __init__(self, **kwargs):
        super().__init__('test_ik_service_client', namespace='/px100', **kwargs)
        self.ik = self.create_client(ComputeIK, 'compute_ik')
        self.path = self.create_client(ComputeCartesianPath, 'compute_cartesian_path')
        self.lock = threading.Lock()
        self.events = []
        self.create_subscription(ComputeIK.Event, 'compute_ik/_service_event',
                                 self._on_event, 100)

    def _on_event(self, msg):
        with self.lock:
            self.events.append(msg)

    def call(self, client, request, timeout: float = 10.0):
        """Call a service (the spinner thread spins this node); return the response."""
        fut = client.call_async(request)
        assert wait_for(fut.done, timeout), f'{client.srv_name}: no response in {timeout} s'
        return fut.result()

    def compute_ik(self, T=None, pose=None, frame_id='', mode='', seed=()):
        """Call compute_ik for a (4, 4) target (or a Pose)."""
        req = ComputeIK.Request()
        req.target = PoseStamped()
        req.target.header.frame_id = frame_id
        req.target.pose = pose if pose is not None else matrix_to_pose(T)
        req.orientation_mode = mode
        req.seed = [float(x) for x in seed]
        return self.call(self.ik, req)


class Env:
    """The ik_service process, a joint-state source, a service client."""

    def __init__(self, server, driver, client):
        self.server, self.driver, self.client = server, driver, client

    def set_state(self, q):
        """Make the joint-state source report q and wait until the node answers from it."""
        with self.driver.lock:
            old = list(self.driver.q)
            self.driver.q = [float(x) for x in q]
            self.driver.target = list(self.driver.q)
        wait_seeded_by(MODEL, q, old, lambda T: self.client.compute_ik(T, mode='pitch'))


@pytest.fixture(scope='module')
def env(ros_ctx, spinner, processes):
    """Start the ik_service and the test nodes once for the module."""
    driver = spinner.add(FakeDriver(context=ros_ctx, rate=50.0))
    client = spinner.add(ServiceClient(context=ros_ctx))
    server = start_node(processes, 'ik_service')
    assert client.ik.wait_for_service(STARTUP_TIMEOUT), server.output()
    assert client.path.wait_for_service(STARTUP_TIMEOUT), server.output()
    return Env(server, driver, client)


@pytest.fixture
def fresh(env):
    """Check that the node still runs after each test."""
    yield env
    assert env.server.alive(), env.server.output()


def test_service_answers_what_solve_ik_answers(fresh):
    """Reachable, rolled, unreachable targets: solve_ik's solution, the reason when none."""
    env = fresh
    seed = np.array([0.1, -0.5, 0.7, 0.2])
    env.set_state(seed)
    rng = np.random.default_rng(21)
    targets = [MODEL.fk(q) for q in MODEL.random_configurations(20, rng, margin=0.05)]
    rolled = targets[0].copy()
    rolled[:3, :3] = rolled[:3, :3] @ rot_x(0.3)
    far = np.eye(4)
    far[:3, 3] = [0.7, 0.0, 0.1]
    for T in targets + [rolled, far]:
        res = env.client.compute_ik(T)
        assert list(res.solution.name) == list(MODEL.joint_names)
        ref = solve_ik(MODEL, T, mode='pitch', q_seed=seed)
        assert res.method == ref.method and res.iterations == ref.iterations
        assert res.success == ref.success
        if ref.success:
            np.testing.assert_allclose(res.solution.position, ref.q, atol=1e-12)
            assert res.num_solutions == len(ref.solutions) >= 1
            assert res.position_error < 1e-9
        else:
            assert 'reach' in res.message and len(res.solution.position) == 0
    assert 'warning' in env.client.compute_ik(rolled).message


def test_seed_orientation_mode_and_frames(fresh):
    """The request's seed picks the branch, its orientation_mode overrides the node's."""
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
        res = env.client.compute_ik(T, seed=pick + 0.01)
        assert res.success, res.message
        np.testing.assert_allclose(res.solution.position, pick, atol=1e-9)
    rolled = T.copy()
    rolled[:3, :3] = T[:3, :3] @ rot_x(0.3)
    assert env.client.compute_ik(rolled, mode='pitch').success
    strict = env.client.compute_ik(rolled, mode='strict')
    assert not strict.success and len(strict.solution.position) == 0, strict.message
    for frame in ('px100/base_link', 'base_link'):
        assert env.client.compute_ik(T, frame_id=frame).success
    free = matrix_to_pose(T)
    o = free.orientation
    o.x = o.y = o.z = o.w = 0.0
    res = env.client.compute_ik(pose=free)
    assert res.success, res.message
    np.testing.assert_allclose(MODEL.fk(np.array(res.solution.position))[:3, 3], T[:3, 3],
                               atol=1e-6)


def _pose(x=0.2, y=0.0, z=0.1, q=(0.0, 0.0, 0.0, 1.0)) -> Pose:
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = x, y, z
    o = pose.orientation
    o.x, o.y, o.z, o.w = q
    return pose


@pytest.mark.parametrize('case, kwargs, words', [
    ('nan', {'pose': _pose(x=math.nan)}, 'NaN'),
    ('inf', {'pose': _pose(z=math.inf)}, 'inf'),
    ('underflowing quaternion', {'pose': _pose(q=(1e-200, 0.0, 0.0, 0.0))}, 'norm 0'),
    ('squashed quaternion', {'pose': _pose(q=(0.0, 0.0, 0.0, 0.2))}, 'quaternion'),
    ('frame', {'pose': _pose(), 'frame_id': 'world'}, "frame_id 'world'"),
    ('unreachable', {'pose': _pose(x=0.7)}, 'reach'),
    ('short seed', {'pose': _pose(), 'seed': [0.0, 0.1]}, 'seed needs 4 values'),
    ('nan seed', {'pose': _pose(), 'seed': [0.0, math.nan, 0.0, 0.0]}, 'seed must be finite'),
    ('mode', {'pose': _pose(), 'mode': 'sideways'}, "orientation_mode must be 'pitch'"),
])
def test_bad_input_is_refused_with_the_reason(fresh, case, kwargs, words):
    """Each bad request: success false, empty position, the reason in one line."""
    res = fresh.client.compute_ik(**kwargs)
    assert not res.success and words in res.message, (case, res.message)
    assert '\n' not in res.message and len(res.solution.position) == 0
    assert fresh.client.compute_ik(pose=_pose(x=0.2, z=0.15)).success


def test_cartesian_path(fresh):
    """A line of waypoints: one timed point per waypoint; a failing one is named."""
    env = fresh
    env.set_state(MODEL.sleep)
    T0 = MODEL.fk(np.array([0.2, -0.4, 0.6, 0.3]))
    req = ComputeCartesianPath.Request()
    req.waypoints = PoseArray()
    targets = []
    for k in range(10):
        T = T0.copy()
        T[:3, 3] += np.array([0.005, 0.004, -0.003]) * k
        targets.append(T)
        req.waypoints.poses.append(matrix_to_pose(T))
    res = env.client.call(env.client.path, req)
    assert res.success and res.message == 'solved', res.message
    traj = res.trajectory
    assert list(traj.joint_names) == list(MODEL.joint_names) and len(traj.points) == 10
    times = [p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in traj.points]
    assert all(b > a for a, b in zip(times, times[1:])) and times[0] > 0
    for p, T in zip(traj.points, targets):
        np.testing.assert_allclose(MODEL.fk(np.array(p.positions))[:3, 3], T[:3, 3],
                                   atol=1e-9)
    far = T0.copy()
    far[:3, 3] = [0.7, 0.0, 0.1]
    req.waypoints.poses = [matrix_to_pose(T0)] * 3 + [matrix_to_pose(far)]
    res = env.client.call(env.client.path, req)
    assert not res.success and 'pose 3' in res.message and len(res.trajectory.points) == 3
    for bad, words in ((PoseArray(), 'no poses'), (None, 'orientation_mode')):
        req = ComputeCartesianPath.Request(waypoints=bad or PoseArray(poses=[_pose()]),
                                           orientation_mode='' if bad else 'upside')
        res = env.client.call(env.client.path, req)
        assert not res.success and words in res.message, res.message


def test_introspection_events_carry_request_and_response(fresh):
    """compute_ik/_service_event: the request and the reply of a call, with their contents."""
    env = fresh
    with env.client.lock:
        env.client.events.clear()
    res = env.client.compute_ik(pose=_pose(x=0.19, z=0.12))
    assert res.success

    def kinds():
        with env.client.lock:
            return {e.info.event_type for e in env.client.events}
    # REQUEST_RECEIVED (1) and RESPONSE_SENT (2) come from the server
    assert wait_for(lambda: {1, 2} <= kinds(), 10.0), kinds()
    with env.client.lock:
        events = list(env.client.events)
    received = [e for e in events if e.info.event_type == 1]
    sent = [e for e in events if e.info.event_type == 2]
    assert received[-1].request[0].target.pose.position.x == pytest.approx(0.19)
    assert sent[-1].response[0].success
    assert list(sent[-1].response[0].solution.position) == list(res.solution.position)


def test_random_bad_and_good_requests_are_all_answered(fresh):
    """300 random requests (NaN, inf, huge, tiny quaternions, odd seeds, frames, modes)."""
    env = fresh
    rng = np.random.default_rng(26)
    specials = [math.nan, math.inf, -math.inf, 1e308, -1e-320, 0.0, 1e-200]
    answers = {True: 0, False: 0}
    goods = [matrix_to_pose(MODEL.fk(q)) for q in MODEL.random_configurations(300, rng)]
    for k, good in enumerate(goods):
        p, o = good.position, good.orientation
        vals = [p.x, p.y, p.z, o.x, o.y, o.z, o.w]
        for i in rng.choice(7, rng.choice([0, 0, 1, 2]), replace=False):     # corrupt some
            vals[i] = specials[rng.integers(len(specials))]
        seed = [[], [0.1, -0.5, 0.4, 0.2], [0.1] * int(rng.choice([3, 5])),
                [0.1, specials[rng.integers(3)], 0.0, 0.0]][rng.choice(4, p=[.4, .4, .1, .1])]
        res = env.client.compute_ik(
            pose=_pose(*vals[:3], q=tuple(vals[3:])), seed=seed,
            mode=str(rng.choice(['', 'pitch', 'strict', 'sideways'], p=[.4, .3, .2, .1])),
            frame_id=str(rng.choice(['', 'base_link', 'px100/base_link', 'world'],
                                    p=[.4, .2, .3, .1])))
        assert res.message and '\n' not in res.message, (k, res.message)
        answers[res.success] += 1
        if res.success:
            q = np.array(res.solution.position)
            assert q.shape == (4,) and np.all(np.isfinite(q)) and MODEL.within_limits(q)
        else:
            assert len(res.solution.position) == 0
    assert answers[True] >= 10 and answers[False] >= 10, answers
    assert env.server.alive(), env.server.output()
