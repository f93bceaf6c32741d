"""Iterative IK: damped least squares with null-space tasks, and seed 003's Newton-Raphson."""
import dataclasses
import math

import numpy as np
from px100_control.kinematics.analytic import px100 as ana
from px100_control.kinematics.iterative import (chain, fk_and_jacobian, newton_raphson_twist,
                                                solve_dls, solve_newton, Task)
from px100_control.kinematics.rotations import euler_sxyz_to_matrix
from px100_control.kinematics.se3 import transform
from px100_control.kinematics.solve import make_task, solve_ik
from px100_control.models.registry import load_robot, model_from_spec
import pytest


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


@pytest.fixture(scope='module')
def px100_iterative(px100):
    """Return the px100 without its analytic solver (forces the iterative path)."""
    return dataclasses.replace(px100, name='px100_no_analytic', analytic_ik=None)


MYARM_SPEC = {
    # seed 003's Elephant myArm 300 Pi PoE table (d1 = 0.1695, d3 = 0.1155, d5 = 0.1278,
    # d7 = 0.066 m) and its joint limits; the tool frame is taken at the flange.
    'name': 'myarm_seed003',
    'kinematics': {
        'convention': 'poe',
        'joints': [
            {'name': 'j1', 'omega': [0, 0, 1], 'point': [0, 0, 0], 'lower': -2.7925,
             'upper': 2.7925},
            {'name': 'j2', 'omega': [0, 1, 0], 'point': [0, 0, 0.1695], 'lower': -1.2217,
             'upper': 2.0071},
            {'name': 'j3', 'omega': [0, 0, 1], 'point': [0, 0, 0.285], 'lower': -2.9671,
             'upper': 2.9671},
            {'name': 'j4', 'omega': [1, 0, 0], 'point': [0, 0, 0.285], 'lower': -1.9722,
             'upper': 1.309},
            {'name': 'j5', 'omega': [0, 0, 1], 'point': [0, 0, 0.4128], 'lower': -2.9671,
             'upper': 2.9671},
            {'name': 'j6', 'omega': [1, 0, 0], 'point': [0, 0, 0.4128], 'lower': -2.0071,
             'upper': 2.0071},
            {'name': 'j7', 'omega': [0, 0, 1], 'point': [0, 0, 0.4788], 'lower': -3.1416,
             'upper': 3.1416},
        ],
        'M': [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.4788], [0, 0, 0, 1]],
    },
}


@pytest.fixture(scope='module')
def myarm():
    return model_from_spec(dict(MYARM_SPEC))


@pytest.mark.parametrize('mode', ['full', 'pitch'])
def test_dls_reaches_random_targets(px100_iterative, mode):
    """DLS (with restarts) reaches 60 random reachable targets to 1e-9 and reports residuals."""
    rng = np.random.default_rng(21)
    for q0 in px100_iterative.random_configurations(60, rng):
        T = px100_iterative.fk(q0)
        res = solve_ik(px100_iterative, T, mode=mode)
        assert res.success, res.reason
        assert res.method == 'dls' and res.iterations > 0
        assert res.position_error <= 1e-9 and res.orientation_error <= 1e-9
        assert px100_iterative.within_limits(res.q)
        Ts = px100_iterative.fk(res.q)
        assert np.linalg.norm(Ts[:3, 3] - T[:3, 3]) <= 1e-9


def test_newton_method_generic(px100_iterative):
    """method='newton' (seed 003 step) solves px100 targets in all three modes."""
    rng = np.random.default_rng(22)
    for q0 in px100_iterative.random_configurations(30, rng):
        T = px100_iterative.fk(q0)
        for mode in ('full', 'pitch', 'position'):
            res = solve_ik(px100_iterative, T, mode=mode, method='newton')
            assert res.success, (mode, res.reason)
            assert res.method == 'newton-raphson'
            assert np.linalg.norm(px100_iterative.fk(res.q)[:3, 3] - T[:3, 3]) <= 1e-9


def _best_distance_over_pitch(px100, p, q_nom, n=3600):
    """Brute force: min over a pitch grid of the in-limit closed-form solution's distance."""
    best = math.inf
    for pitch in np.linspace(-math.pi, math.pi, n, endpoint=False):
        for s in ana.ik_xyz_pitch(px100, *p, pitch):
            best = min(best, float(np.linalg.norm(np.array(s) - q_nom)))
    return best


def test_position_mode_free_pitch_is_chosen_by_the_secondary_task(px100):
    """Position mode: the pitch minimises |q - q_nominal| (seed 000 V.8); brute-force check."""
    rng = np.random.default_rng(23)
    for q_nom in (px100.home, np.array([0.0, -1.0, 0.8, 0.6])):
        for q0 in px100.random_configurations(6, rng):
            p = px100.fk(q0)[:3, 3]
            res = solve_ik(px100, transform(np.eye(3), p), mode='position', q_nominal=q_nom)
            assert res.success, res.reason
            np.testing.assert_allclose(px100.fk(res.q)[:3, 3], p, atol=1e-9)
            # stationary: the null-space component of (q_nom - q) has vanished, unless the
            # optimum lies on a joint limit (then it is a constrained minimum)
            at_limit = np.any(np.minimum(res.q - px100.lower, px100.upper - res.q) < 1e-9)
            _, J = fk_and_jacobian(chain(px100), res.q)
            Jv = J[3:]
            N = np.eye(4) - np.linalg.pinv(Jv) @ Jv
            assert at_limit or np.linalg.norm(N @ (q_nom - res.q)) < 1e-6
            # and the solution closest to q_nominal is the global optimum over the pitch
            best = min(np.linalg.norm(s - q_nom) for s in res.solutions)
            assert best <= _best_distance_over_pitch(px100, p, q_nom) + 1e-6


def test_secondary_task_away_from_limits(px100):
    """The 'limits' secondary task keeps the target and moves the joints toward mid-range."""
    q0 = np.array([0.2, 1.6, -1.9, 1.9])
    task = Task(px100.fk(q0)[:3, 3], np.eye(3), 'position')
    res = solve_dls(px100, task, q0, secondary='limits', max_iterations=300)
    assert res.success
    np.testing.assert_allclose(px100.fk(res.q)[:3, 3], task.p, atol=1e-9)
    mid, span = (px100.lower + px100.upper) / 2, px100.upper - px100.lower

    def cost(q):
        return float(np.sum(((q - mid) / span) ** 2))
    assert cost(res.q) < cost(q0) - 0.05


def test_seed003_newton_raphson_on_7dof(myarm):
    """Seed 003's solver converges for reachable 7-DOF targets, |Xi| history recorded."""
    rng = np.random.default_rng(24)
    ok = 0
    for q0 in myarm.random_configurations(20, rng, margin=0.2):
        T = myarm.fk(q0)
        q, info = newton_raphson_twist(myarm, T, q0 + rng.normal(0.0, 0.2, 7))
        assert len(info['err']) >= 1
        if info['converged']:
            ok += 1
            assert info['err'][-1] < 1e-4
            assert np.linalg.norm(myarm.fk(q)[:3, 3] - T[:3, 3]) < 1e-4
    assert ok >= 18


def test_seed003_grasp_target(myarm):
    """The seed 003 top grasp (17.5, 2.5, 5 cm, gripper down) is reached by the generic solver."""
    T = transform(np.diag([1.0, -1.0, -1.0]), [0.175, 0.025, 0.05])
    q_init = np.radians([0, 30, 0, -45, 0, -45, 0])
    res = solve_ik(myarm, T, mode='full', method='newton', q_seed=q_init)
    assert res.success, res.reason
    np.testing.assert_allclose(myarm.fk(res.q), T, atol=1e-8)
    assert myarm.within_limits(res.q)
    res = solve_ik(myarm, T, mode='full', method='dls', q_seed=q_init)
    assert res.success, res.reason


def test_unreachable_iterative_reports_residuals(px100_iterative):
    """Out of reach: failure with the best residuals in the reason, not an exception."""
    T = transform(euler_sxyz_to_matrix(0, 0, 0), [0.6, 0.0, 0.1])
    res = solve_ik(px100_iterative, T, mode='pitch', max_iterations=50)
    assert not res.success
    assert 'no solution' in res.reason and 'position error' in res.reason
    assert res.position_error > 0.2
    assert res.details['starts'] >= 4


def test_solve_dls_direct_call_reports_iterations(px100):
    """solve_dls from a nearby start: a few iterations, quadratic-speed convergence."""
    q0 = np.array([0.3, -0.2, 0.4, 0.5])
    task, _, _ = make_task(px100, px100.fk(q0), 'full')
    res = solve_dls(px100, task, q0 + 0.05)
    assert res.success and 1 <= res.iterations <= 8
    res = solve_newton(px100, task, q0 + 0.05)
    assert res.success and 1 <= res.iterations <= 8


def test_unrolled_normal_solver_matches_the_looped_cholesky():
    """The generated straight-line solve equals the generic Cholesky path (n <= m <= 6)."""
    from px100_control.kinematics import iterative as it
    rng = np.random.default_rng(17)
    for n in range(1, 7):
        for m in range(n, 7):
            solve = it._unrolled_normal_solver(n, m)
            for _ in range(50):
                J = rng.normal(size=(m, n))
                e = rng.normal(size=m).tolist()
                lam2 = 10 ** rng.uniform(-6, 0)
                cols = [tuple(J[:, j]) for j in range(n)]
                ref = it.cholesky_solve(it._cholesky(it._gram(cols, lam2)),
                                        [float(J[:, j] @ e) for j in range(n)])
                np.testing.assert_allclose(solve(cols, e, lam2), ref, rtol=1e-9, atol=1e-12)
                direct = np.linalg.solve(J.T @ J + lam2 * np.eye(n), J.T @ np.array(e))
                np.testing.assert_allclose(ref, direct, rtol=1e-6, atol=1e-9)


def test_dls_solve_redundant_chain_matches_numpy():
    """More joints than task rows (the 7-DOF myArm): J^T (J J^T + lam2 I)^-1 e, unrolled."""
    from px100_control.kinematics import iterative as it
    rng = np.random.default_rng(18)
    for n, m in ((7, 6), (7, 3), (8, 6), (12, 6)):
        for _ in range(50):
            J = rng.normal(size=(m, n))
            e = rng.normal(size=m)
            lam2 = 10 ** rng.uniform(-6, 0)
            got = it._dls_solve([tuple(J[:, j]) for j in range(n)], e.tolist(), lam2)
            ref = J.T @ np.linalg.solve(J @ J.T + lam2 * np.eye(m), e)
            np.testing.assert_allclose(got, ref, rtol=1e-6, atol=1e-9)
