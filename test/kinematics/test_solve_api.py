"""The solve_ik / solve_path / solve_ik_batch contract that the nodes and the client rely on."""
import dataclasses
import math

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.kinematics.ik_types import IkResult
from px100_control.kinematics.rotations import euler_sxyz_to_matrix
from px100_control.kinematics.se3 import transform
from px100_control.kinematics.solve import pitch_target, solve_ik, solve_ik_batch, solve_path
from px100_control.models.registry import load_robot
import pytest


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


def _pose(x, y, z, pitch, roll=0.0, yaw=None):
    yaw = math.atan2(y, x) if yaw is None else yaw
    return transform(euler_sxyz_to_matrix(roll, pitch, yaw), [x, y, z])


def test_result_unpacks_like_interbotix(px100):
    """The result unpacks as (theta_list, success), the Modern Robotics / Interbotix shape."""
    theta, ok = solve_ik(px100, px100.fk([0.2, -0.3, 0.4, 0.1]))
    assert ok and isinstance(theta, np.ndarray) and theta.shape == (4,)
    theta, ok = solve_ik(px100, _pose(0.9, 0.0, 0.1, 0.0), mode='pitch')
    assert not ok and theta is None


def test_sleep_and_home_conventions(px100):
    """Interbotix joint order, home = zeros, sleep = [0, -1.88, 1.5, 0.8]; pitch = q2+q3+q4."""
    assert px100.joint_names == ('waist', 'shoulder', 'elbow', 'wrist_angle')
    np.testing.assert_allclose(px100.home, 0.0)
    np.testing.assert_allclose(px100.sleep, [0.0, -1.88, 1.5, 0.8])
    T = px100.fk(px100.sleep)
    res = solve_ik(px100, T, mode='pitch', q_seed=px100.sleep)
    np.testing.assert_allclose(res.q, px100.sleep, atol=1e-12)
    assert res.details['pitch'] == pytest.approx(-1.88 + 1.5 + 0.8, abs=1e-12)


def test_path_is_continuous_and_stops_at_first_failure(px100):
    """solve_path seeds each pose with the previous one; stops with the reason on failure."""
    xs = np.linspace(0.12, 0.24, 25)
    poses = [_pose(x, 0.05, 0.12, 0.5) for x in xs]
    q_start = solve_ik(px100, poses[0], mode='pitch').q
    results = solve_path(px100, poses, q_start)
    assert len(results) == len(poses) and all(r.success for r in results)
    Q = np.array([r.q for r in results])
    assert np.abs(np.diff(Q, axis=0)).max() < 0.2        # no branch jump
    for r, T in zip(results, poses):
        np.testing.assert_allclose(px100.fk(r.q)[:3, 3], T[:3, 3], atol=1e-9)
    far = poses[:5] + [_pose(0.6, 0.0, 0.1, 0.0)] + poses[5:]
    results = solve_path(px100, far, q_start)
    assert len(results) == 6 and not results[-1].success
    assert results[-1].reason.startswith('pose 5: target is') and 'beyond reach' in (
        results[-1].reason)
    assert results[-1].details['index'] == 5


def test_path_keeps_the_branch_of_the_start(px100):
    """Started on the other elbow branch, the path stays on it (closest to the previous q)."""
    poses = [_pose(x, 0.0629, 0.3334, -0.355) for x in np.linspace(0.0688, 0.06, 10)]
    sols = solve_ik(px100, poses[0], mode='pitch').solutions
    assert len(sols) == 4
    for start in sols:
        results = solve_path(px100, poses, start)
        assert all(r.success for r in results)
        np.testing.assert_allclose(results[0].q, start, atol=1e-12)
        Q = np.array([start] + [r.q for r in results])
        assert np.abs(np.diff(Q, axis=0)).max() < 0.1, 'branch jump'


def test_pitch_target_folds_backward_yaw(px100):
    """A tool pointing back over the base keeps its direction: yaw forced to azimuth + pi."""
    T = _pose(0.05, 0.0, 0.25, -0.4, yaw=math.pi)
    Tf, det = pitch_target(px100, T)
    assert det['unreachable_yaw'] == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(Tf[:3, 0], T[:3, 0], atol=1e-12)
    res = solve_ik(px100, T, mode='pitch')
    assert res.success
    np.testing.assert_allclose(px100.fk(res.q)[:3, 0], T[:3, 0], atol=1e-9)


def test_analytic_method_without_solver(px100):
    """method='analytic' on a model without a closed form is a failure with a reason."""
    plain = dataclasses.replace(px100, name='plain', analytic_ik=None)
    res = solve_ik(plain, px100.fk([0.1, 0.1, 0.1, 0.1]), method='analytic')
    assert not res.success and 'no analytic IK solver' in res.reason
    res = solve_ik(plain, px100.fk([0.1, 0.1, 0.1, 0.1]))        # auto -> dls
    assert res.success and res.method == 'dls'


def test_batch_generic_fallback(px100):
    """A model without a batch solver is looped through solve_ik (rows and poses)."""
    plain = dataclasses.replace(px100, name='plain', analytic_ik=None)
    rows = np.array([[0.2, 0.0, 0.1, 0.2], [0.15, 0.1, 0.2, -0.3], [0.8, 0.0, 0.0, 0.0]])
    Q, ok = solve_ik_batch(plain, rows)
    assert ok.tolist() == [True, True, False] and np.isnan(Q[2]).all()
    for q, (x, y, z, _) in zip(Q[:2], rows[:2]):
        np.testing.assert_allclose(px100.fk(q)[:3, 3], [x, y, z], atol=1e-9)


def test_bad_arguments(px100):
    """Unknown method, non-positive tolerance or a NaN seed raise InvalidInputError."""
    T = px100.fk([0.1, 0.2, 0.3, 0.1])
    with pytest.raises(InvalidInputError, match='method'):
        solve_ik(px100, T, method='magic')
    with pytest.raises(InvalidInputError, match='tol_position'):
        solve_ik(px100, T, tol_position=0.0)
    with pytest.raises(InvalidInputError, match='NaN'):
        solve_ik(px100, T, q_seed=[np.nan, 0, 0, 0])
    with pytest.raises(InvalidInputError):
        solve_ik(px100, 'not a pose')
    bottom = T.copy()
    bottom[3, 0] = 1.0
    with pytest.raises(InvalidInputError, match='bottom row'):
        solve_ik(px100, bottom)
    with pytest.raises(InvalidInputError):
        solve_path(px100, [T], [0.0, 0.0, 0.0])


def test_position_mode_reports_free_orientation(px100):
    """Position mode: orientation ignored, orientation_error 0, solutions verified."""
    T = _pose(0.15, -0.05, 0.1, 0.0, roll=0.7, yaw=2.0)       # unreachable orientation
    res = solve_ik(px100, T, mode='position')
    assert isinstance(res, IkResult) and res.success
    assert res.orientation_error == 0.0 and res.position_error < 1e-9
    for s in res.solutions:
        np.testing.assert_allclose(px100.fk(s)[:3, 3], T[:3, 3], atol=1e-9)
