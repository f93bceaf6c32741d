"""
IK round trips for every registered robot: random in-limit configurations -> FK -> IK -> FK.

Non-redundant arms: the closed form must return the generating configuration among its
candidates (all branches are found) and every candidate that the FK check keeps reproduces the
target pose to 1e-9. The 7-DOF myArm: at the generating configuration's swivel angle the 8
branches contain it, and the swivel search returns in-limit solutions that reach the target.
Through ``solve_ik``: every returned solution reproduces the target to 1e-9 and lies within the
limits. 10,000 configurations per non-redundant robot; the myArm (a 1-D swivel search per
target, a few ms) uses 1,000 / 300 by default and 10,000 with PX100_STRESS=full.
"""
import os

import numpy as np
from px100_control.kinematics.analytic import get_solver
from px100_control.kinematics.analytic import myarm300pi
from px100_control.kinematics.iterative import chain, fk_batch
from px100_control.kinematics.solve import solve_ik
from px100_control.models.registry import available_robots, load_robot
import pytest
from tiers import robots

POSE_TOL = 1e-9
FULL = 10000
NON_REDUNDANT = [n for n in available_robots() if load_robot(n).dof <= 6]


def _wrapped(d: np.ndarray) -> np.ndarray:
    return np.abs(np.remainder(d + np.pi, 2.0 * np.pi) - np.pi)


def _pose_errors(model, Q: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Return max |FK(q) - T| (4x4 entries: m and rotation entries) per row."""
    return np.abs(fk_batch(chain(model), Q) - T).max(axis=(1, 2))


def _closed_form_roundtrip(name: str, count: int, seed: int) -> dict:
    m = load_robot(name)
    module = get_solver(m.analytic_ik)
    Q = m.random_configurations(count, rng=seed)
    T = fk_batch(chain(m), Q)
    cands = [module.candidates(m, Ti, 'full') for Ti in T]
    sizes = np.array([len(c) for c in cands])
    assert sizes.min() >= 1, f'{name}: a reachable target got no candidate'
    C = np.concatenate(cands)
    owner = np.repeat(np.arange(count), sizes)
    err = _pose_errors(m, C, T[owner])
    kept = err <= POSE_TOL
    revolute = np.array([t != 'prismatic' for t in m.joint_types])
    d = np.where(revolute, _wrapped(C - Q[owner]), np.abs(C - Q[owner]))
    is_origin = kept & (d.max(axis=1) < 1e-6)
    found = np.zeros(count, dtype=bool)
    np.logical_or.at(found, owner, is_origin)
    missing = np.flatnonzero(~found)
    assert missing.size == 0, (f'{name}: generating configuration not among the verified '
                               f'candidates for {missing.size} of {count} targets, e.g. '
                               f'q = {Q[missing[0]].tolist()}')
    return {'targets': count, 'candidates': int(C.shape[0]), 'verified': int(kept.sum()),
            'max_verified_error': float(err[kept].max())}


@pytest.mark.parametrize('name', robots(NON_REDUNDANT))
def test_closed_form_roundtrip_10k(name):
    """10,000 configurations per robot: every branch found, verified candidates exact."""
    stats = _closed_form_roundtrip(name, FULL, seed=10_000)
    assert stats['verified'] >= FULL


def _myarm_swivel_roundtrip(count: int, seed: int):
    m = load_robot('myarm300pi')
    Q = m.random_configurations(count, rng=seed)
    T = fk_batch(chain(m), Q)
    for q, Ti in zip(Q, T):
        psi = myarm300pi.swivel_angle(m, q)
        C = myarm300pi.solve_swivel(m, Ti, [psi])[0]
        assert np.isfinite(C).all()
        assert _pose_errors(m, C, Ti[None]).max() <= POSE_TOL
        assert _wrapped(C - q).max(axis=1).min() < 1e-7


def _myarm_search_roundtrip(count: int, seed: int) -> float:
    m = load_robot('myarm300pi')
    Q = m.random_configurations(count, rng=seed)
    T = fk_batch(chain(m), Q)
    ok = 0
    for Ti in T:
        C = myarm300pi.candidates(m, Ti, 'full')
        good = (_pose_errors(m, C, Ti[None]) <= POSE_TOL) & np.all(
            (C >= m.lower - 1e-12) & (C <= m.upper + 1e-12), axis=1)
        ok += bool(good.any())
    return ok / count


def test_myarm_swivel_parameterisation_is_complete():
    """At q's own swivel angle the 8 closed-form branches contain q; all reach the target."""
    _myarm_swivel_roundtrip(1000, seed=300)


def test_myarm_swivel_search_reaches_targets():
    """The swivel search (farthest from limits) finds in-limit exact solutions."""
    assert _myarm_search_roundtrip(300, seed=301) >= 0.995


def test_myarm_branch_sign_flips_match_the_closed_form():
    """The 7 other branches of a swivel follow from branch 0 by the documented sign flips."""
    m = load_robot('myarm300pi')
    g = myarm300pi.geometry(m)
    rng = np.random.default_rng(302)
    Q = m.random_configurations(200, rng)
    for T, psi in zip(fk_batch(chain(m), Q), rng.uniform(-np.pi, np.pi, 200)):
        S = myarm300pi.solve_swivel(m, T, [psi])[0]            # (8, 7), branch k: bits q2 q4 q6
        if not np.all(np.isfinite(S)):
            continue
        base = S[0] * g.signs                                  # geometric angles of branch 0
        for k in range(8):
            t = myarm300pi._branch_angles(base, (k >> 2) & 1, (k >> 1) & 1, k & 1)
            assert _wrapped(np.array(t) * g.signs - S[k]).max() < 1e-9, (k, psi)


def test_myarm_fast_path_round_trip_and_seed_continuity():
    """
    ik_fast: in-limit exact solutions for 1,000 FK targets; FK(seed) gives back the seed.

    Unreachable wrist points get None.
    """
    m = load_robot('myarm300pi')
    Q = m.random_configurations(1000, np.random.default_rng(303))
    T_all = fk_batch(chain(m), Q)
    found = 0
    for q_gen, T in zip(Q, T_all):
        q, tried = myarm300pi.ik_fast(m, T)
        assert tried >= 1
        if q is None:
            continue
        found += 1
        q = np.array(q)
        assert _pose_errors(m, q[None], T[None]).max() <= POSE_TOL
        assert np.all((q >= m.lower - 1e-9) & (q <= m.upper + 1e-9))
    assert found >= 999
    for q_gen, T in zip(Q[:200], T_all[:200]):
        q, tried = myarm300pi.ik_fast(m, T, q_seed=q_gen)
        assert tried == 1 and np.abs(np.array(q) - q_gen).max() < 1e-7
    far = np.eye(4)
    far[:3, 3] = [0.0, 0.0, 2.0]
    assert myarm300pi.ik_fast(m, far) == (None, 0)


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get('PX100_STRESS', '').lower() != 'full',
                    reason='about 1 min; runs with PX100_STRESS=full')
def test_myarm_10k():
    """10,000 configurations: swivel completeness, and the search success rate."""
    _myarm_swivel_roundtrip(FULL, seed=10_300)
    assert _myarm_search_roundtrip(FULL, seed=10_301) >= 0.995


@pytest.mark.parametrize('name', available_robots())
def test_solve_ik_full_returns_only_exact_in_limit_solutions(name):
    """solve_ik: success, every solution within 1e-9 of the target and inside the limits."""
    m = load_robot(name)
    rng = np.random.default_rng(500)
    Q = m.random_configurations(40 if m.dof < 7 else 15, rng=rng)
    for q in Q:
        T = m.fk(q)
        res = solve_ik(m, T, mode='full', q_seed=q)
        assert res.success, (name, q.tolist(), res.reason)
        S = np.array(res.solutions)
        assert _pose_errors(m, S, T[None]).max() <= POSE_TOL
        assert np.all((S >= m.lower - 1e-9) & (S <= m.upper + 1e-9))
        if m.dof < 7:
            # the generating configuration is a solution, and the closest to itself as seed
            assert np.abs(res.q - q).max() < 1e-6


@pytest.mark.parametrize('name', [n for n in available_robots()
                                  if load_robot(n).analytic_ik in ('interbotix5', 'interbotix6',
                                                                   'px100')])
def test_solve_ik_pitch_mode_interbotix(name):
    """Interbotix-style arms: 'pitch' targets (yaw forced to the azimuth) are solved exactly."""
    m = load_robot(name)
    for q in m.random_configurations(20, rng=600):
        T = m.fk(q)
        res = solve_ik(m, T, mode='pitch', q_seed=q)
        assert res.success, (name, res.reason)
        assert res.position_error <= POSE_TOL and res.orientation_error <= POSE_TOL


@pytest.mark.parametrize('name', available_robots())
def test_solve_ik_position_mode(name):
    """Orientation-free targets: the position is reached and the limits hold."""
    m = load_robot(name)
    for q in m.random_configurations(2, rng=700):
        T = m.fk(q)
        res = solve_ik(m, T, mode='position')
        assert res.success, (name, res.reason)
        assert np.linalg.norm(m.fk(res.q)[:3, 3] - T[:3, 3]) <= POSE_TOL
        assert m.within_limits(res.q)


@pytest.mark.parametrize('name', [n for n in available_robots()
                                  if load_robot(n).analytic_ik in ('interbotix5', 'rrrr')])
def test_position_mode_exact_secondary_task(name):
    """
    Closed-form position mode: the free angles minimise |q - q_nominal| over every branch.

    The generating configuration is one feasible point, so the best returned solution is at
    least as close to q_nominal as it is.
    """
    m = load_robot(name)
    rng = np.random.default_rng(800)
    for q in m.random_configurations(30, rng=rng):
        qn = m.random_configurations(1, rng=rng)[0]
        T = m.fk(q)
        res = solve_ik(m, T, mode='position', q_nominal=qn, q_seed=qn)
        assert res.success and res.method == f'analytic:{m.analytic_ik}', res.reason
        assert np.linalg.norm(m.fk(res.q)[:3, 3] - T[:3, 3]) <= POSE_TOL
        assert np.linalg.norm(res.q - qn) <= np.linalg.norm(q - qn) + 1e-9


@pytest.mark.parametrize('name', ['rrrp', 'rrrr', 'myarm300pi', 'px150', 'wx250s'])
def test_unreachable_targets_fail_with_a_reason(name):
    """A target far outside the workspace is a result with a reason, not an exception."""
    m = load_robot(name)
    T = np.eye(4)
    T[:3, 3] = (3.0, 0.0, 0.5)
    for mode in ('full', 'position'):
        res = solve_ik(m, T, mode=mode)
        assert not res.success and res.reason
