"""
solve_ik's default path (closed forms first, on plain floats) against its general path.

For every registered robot: the default ``solve_ik(model, T)`` gives the general analytic
path's answer (``method='analytic'``: numpy candidates, every branch verified by FK) on random
reachable targets and seeds: the same q and the same solutions in the same order (the 7-DOF
myArm: the in-limit solution at the swivel nearest the seed's, verified, then the general
branches). Traps: singular configurations (Jacobian rank-deficient) are solved exactly or
refused, never a false success; poses out of reach, and on < 6-DOF arms orientations turned off
the reachable set, are refused with a reason unless the answer really reaches them.
"""
import math
import os
import sys

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.kinematics.iterative import chain, fk_batch
from px100_control.kinematics.solve import pose_rows, solve_ik
from px100_control.models.registry import available_robots, load_robot
import pytest
from tiers import robots

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))), 'benchmarks'))
from bench_robots import singular_configurations, trap_targets  # noqa: E402, I100

TOL = 1e-9


def _reaches(m, q, T, tol=1e-8) -> bool:
    """Independent check: numpy FK of q within tol of T (entries) and q within the limits."""
    return bool(np.abs(m.fk(q) - T).max() <= tol and m.within_limits(q, tol=1e-9))


@pytest.mark.parametrize('name', available_robots())
def test_default_path_equals_general_path(name):
    m = load_robot(name)
    rng = np.random.default_rng(11)
    Q = m.random_configurations(60, rng)
    seeds = m.random_configurations(60, rng)
    for k, T in enumerate(fk_batch(chain(m), Q)):
        seed = None if k % 3 == 0 else seeds[k]
        fast = solve_ik(m, T, q_seed=seed)
        assert fast.success and _reaches(m, fast.q, T), (name, k, fast.reason)
        assert fast.position_error <= TOL and fast.orientation_error <= TOL
        assert fast.iterations == 0 and fast.method == f'analytic:{m.analytic_ik}'
        sols = fast.solutions
        assert np.array_equal(sols[0], fast.q)
        assert all(_reaches(m, s, T) for s in sols)
        if m.dof == 7:
            continue
        ref = solve_ik(m, T, q_seed=seed, method='analytic')
        assert ref.success
        np.testing.assert_allclose(fast.q, ref.q, atol=1e-12)
        assert len(sols) == len(ref.solutions)
        for a, b in zip(sols, ref.solutions):
            np.testing.assert_allclose(a, b, atol=1e-12)


def test_myarm_default_path_continues_from_the_seed():
    """The 7-DOF default answer stays near the seed's swivel: a small move, a small step."""
    m = load_robot('myarm300pi')
    rng = np.random.default_rng(12)
    for q in m.random_configurations(30, rng):
        q2 = np.clip(q + rng.normal(scale=0.01, size=m.dof), m.lower, m.upper)
        res = solve_ik(m, m.fk(q2), q_seed=q)
        assert res.success and _reaches(m, res.q, m.fk(q2))
        assert np.abs(res.q - q).max() < 0.5


@pytest.mark.parametrize('name', robots(available_robots()))
def test_traps_have_no_false_success(name):
    m = load_robot(name)
    traps = trap_targets(m, 8, seed=21)
    for T in traps['singular']:
        res = solve_ik(m, T)
        assert not res.success or _reaches(m, res.q, T, tol=1e-6), (name, res.q)
    for T in traps['unreachable']:
        res = solve_ik(m, T)
        assert not res.success and res.reason and res.q is None
    for T in traps['orientation']:
        res = solve_ik(m, T)
        assert (_reaches(m, res.q, T) if res.success else bool(res.reason)), name


@pytest.mark.parametrize('name', ['px100', 'wx250s', 'vx300s', 'myarm300pi'])
def test_singular_configurations_are_found_and_solved(name):
    """The trap generator finds rank-deficient configurations and solve_ik reaches them."""
    m = load_robot(name)
    Q = singular_configurations(m, 4, np.random.default_rng(3))
    assert len(Q) == 4
    for q in Q:
        T = m.fk(q)
        res = solve_ik(m, T, q_seed=q)
        assert res.success and _reaches(m, res.q, T, tol=1e-6), (name, q, res.reason)


def test_pose_rows_checks_like_check_pose():
    """The plain-float pose check refuses what check_pose refuses, with its message."""
    T = np.eye(4)
    assert pose_rows(T) == T.tolist()
    assert pose_rows(T.tolist()) == T.tolist()
    inf = np.eye(4)
    inf[0, 3] = math.inf
    bad = {'NaN': np.where(np.eye(4) > 0, math.nan, 0.0), 'inf': inf,
           'bottom row': np.vstack([np.eye(4)[:3], [[0, 0, 1, 1]]]),
           'rotation': np.diag([1.0, 1.0, -1.0, 1.0]), 'shape': np.eye(3),
           'numeric': [['a'] * 4] * 4}
    for words, B in bad.items():
        with pytest.raises(InvalidInputError, match=words):
            pose_rows(B)
    scaled = np.eye(4)
    scaled[:3, :3] *= 1.01
    with pytest.raises(InvalidInputError, match='rotation'):
        solve_ik(load_robot('px100'), scaled)
