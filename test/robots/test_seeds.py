"""
The numbers and facts printed in seeds 002, 003 and 004, reproduced.

Seed 003 prints its joint tables in degrees with 2 decimals: each value is within 0.005 deg of
what the solver produced. The pose error that rounding can cause is bounded, to first order, by
sum_i |d p / d q_i| * 0.005 deg for the position and 7 * 0.005 deg for the orientation; the
tables must reproduce the printed targets within that bound (and it is below 0.2 mm / 0.04 deg,
so a wrong model or table would fail).
"""
import math

import numpy as np
from px100_control.kinematics.analytic import myarm300pi, rrrp, rrrr
from px100_control.kinematics.dh import DHRow, fk_dh
from px100_control.kinematics.iterative import newton_raphson_twist
from px100_control.kinematics.se3 import pose_error, rot_x, rot_y, transform
from px100_control.models.registry import load_robot
import pytest

# ---------------------------------------------------------------------------- seed 003 (myArm)
GRASP_TABLE_DEG = [-12.73, 68.82, -60.13, -81.36, -44.14, -41.83, -55.14]
PLACE_TABLE_DEG = [46.83, 64.76, -70.94, -103.01, -83.66, -108.91, -100.89]
THETA_INIT_DEG = [0, 30, 0, -45, 0, -45, 0]
T_GRASP = transform(rot_x(math.pi), [0.175, 0.025, 0.05])          # Rx(180 deg) at 17.5, 2.5, 5 cm
T_PLACE = transform(rot_y(math.pi / 2) @ rot_x(math.pi / 4), [0.105, 0.075, 0.10])   # section 6.2
T_PLACE_PRINTED = np.array([[0.0, 0.7071, 0.7071, 0.1050], [0.0, 0.7071, -0.7071, 0.0750],
                            [-1.0, 0.0, 0.0, 0.1000], [0.0, 0.0, 0.0, 1.0]])
HALF_LSB = math.radians(0.005)


def _rounding_bounds(model, q):
    """Return (position bound [m], orientation bound [rad]) of +-0.005 deg on every joint."""
    T = model.fk(q)
    Js = model.jacobian_space(q)
    p = T[:3, 3]
    lever = [np.linalg.norm(Js[3:, i] + np.cross(Js[:3, i], p)) for i in range(model.dof)]
    second_order = 0.5 * (model.dof * HALF_LSB) ** 2 * 0.5     # |d2p| <= (sum dq)^2 * reach
    return sum(lever) * HALF_LSB + second_order, model.dof * HALF_LSB


def test_seed003_place_matrix_is_as_printed():
    """R_y(90) R_x(45) at (0.105, 0.075, 0.1) m is the printed 4-decimal T_place."""
    np.testing.assert_allclose(T_PLACE, T_PLACE_PRINTED, atol=0.5e-4)


@pytest.mark.parametrize('table, target', [(GRASP_TABLE_DEG, T_GRASP),
                                           (PLACE_TABLE_DEG, T_PLACE)])
def test_seed003_tables_give_the_targets_within_rounding(table, target):
    """FK of the printed joint table is the target within the table's rounding bound."""
    m = load_robot('myarm300pi')
    q = np.radians(table)
    assert m.within_limits(q)
    dp, dr = pose_error(m.fk(q), target)
    bound_p, bound_r = _rounding_bounds(m, q)
    assert bound_p < 2e-4 and bound_r < math.radians(0.04)
    assert dp <= bound_p, (dp, bound_p)
    assert dr <= bound_r, (dr, bound_r)


def test_seed003_newton_raphson_reproduced():
    """
    Seed 003's Newton-Raphson: grasp in 8 iterations from theta_init, place in 6 from the grasp.

    The place solve converges from the grasp solution (the seed's sequence), not from
    theta_init. Results agree with the printed tables to 0.01 / 0.03 deg (a redundant arm:
    the null-space drift depends on the exact path).
    """
    m = load_robot('myarm300pi')
    q_grasp, info = newton_raphson_twist(m, T_GRASP, np.radians(THETA_INIT_DEG))
    assert info['converged'] and info['iter'] == 8
    assert np.linalg.norm(m.fk(q_grasp)[:3, 3] - T_GRASP[:3, 3]) < 1e-8   # seed: 5.91e-9 m
    assert np.abs(np.degrees(q_grasp) - GRASP_TABLE_DEG).max() <= 0.011
    q_place, info = newton_raphson_twist(m, T_PLACE, q_grasp)
    assert info['converged'] and info['iter'] == 6
    assert np.linalg.norm(m.fk(q_place)[:3, 3] - T_PLACE[:3, 3]) < 1e-5   # seed: 0.00000 m
    assert np.abs(np.degrees(q_place) - PLACE_TABLE_DEG).max() <= 0.03
    _, info = newton_raphson_twist(m, T_PLACE, np.radians(THETA_INIT_DEG))
    assert not info['converged']


@pytest.mark.parametrize('table, target', [(GRASP_TABLE_DEG, T_GRASP),
                                           (PLACE_TABLE_DEG, T_PLACE)])
def test_seed003_analytic_swivel_ik_finds_the_seed_solution(table, target):
    """At the table's swivel angle the closed form gives the seed's configuration (0.03 deg)."""
    m = load_robot('myarm300pi')
    q_tab = np.radians(table)
    psi = myarm300pi.swivel_angle(m, q_tab)
    C = myarm300pi.solve_swivel(m, target, [psi])[0]
    best = C[np.argmin(np.abs(C - q_tab).max(axis=1))]
    assert np.abs(np.degrees(best - q_tab)).max() < 0.03
    dp, dr = pose_error(m.fk(best), target)
    assert dp < 1e-12 and dr < 1e-12
    # and the full search (limit-margin criterion) solves both targets within the limits
    Q = myarm300pi.candidates(m, target, 'full')
    ok = [q for q in Q if m.within_limits(q) and max(pose_error(m.fk(q), target)) < 1e-9]
    assert ok


# ---------------------------------------------------------------------------- seed 002 (RRRP)
def _seed002_dgm(q, r1=0.27, a2=0.2, r3=0.15):
    """Return 0M4 exactly as printed in seed 002 (wrist, no tool)."""
    q1, q2, q3, q4 = q
    s12, c12, s3, c3 = math.sin(q1 + q2), math.cos(q1 + q2), math.sin(q3), math.cos(q3)
    return np.array([[-s12 * c3, c12, -s3 * s12, a2 * math.cos(q1) - q4 * s3 * s12 + r3 * c12],
                     [c3 * c12, s12, s3 * c12, a2 * math.sin(q1) + q4 * s3 * c12 + r3 * s12],
                     [s3, 0.0, -c3, -q4 * c3 + r1],
                     [0.0, 0.0, 0.0, 1.0]])


def test_seed002_direct_model_matches_the_mdh_table():
    """The printed 0M4 (times the tool Tz(r4)) is the model's FK from the MDH table."""
    m = load_robot('rrrp')
    tool = transform(np.eye(3), [0.0, 0.0, 0.07])
    for q in m.random_configurations(200, rng=2):
        np.testing.assert_allclose(_seed002_dgm(q) @ tool, m.fk(q), atol=1e-12)


def test_seed002_branch_rule_both_branches_exact():
    """Both sides of the |cos q3| vs |sin q3| rule return the generating configuration."""
    m = load_robot('rrrp')
    seen = set()
    for q in m.random_configurations(400, rng=3):
        T = m.fk(q)
        C = rrrp.candidates(m, T, 'full')
        errs = np.array([np.abs(m.fk(c) - T).max() for c in C])
        assert errs.min() <= 1e-9
        d = np.abs(np.remainder(C - q + np.pi, 2 * np.pi) - np.pi)
        d[:, 3] = np.abs(C[:, 3] - q[3])
        assert d.max(axis=1).min() < 1e-9
        seen.add(abs(math.cos(q[2])) > abs(math.sin(q[2])))
        # type 5 branch: two (q1, q4) roots, t_z decides; type 3 branch: one candidate
        assert len(C) == (1 if abs(math.cos(q[2])) > abs(math.sin(q[2])) else 2)
    assert seen == {True, False}


def test_seed002_cos_q3_zero_has_two_solutions():
    """With cos q3 = 0 the prismatic joint leaves t_z alone: both type 5 roots are solutions."""
    m = load_robot('rrrp')
    q = np.array([0.4, -0.3, math.pi / 2, 0.12])
    T = m.fk(q)
    C = rrrp.candidates(m, T, 'full')
    assert len(C) == 2
    for c in C:
        assert np.abs(m.fk(c) - T).max() <= 1e-9
    assert abs(C[0, 3] - C[1, 3]) > 1e-3


# ---------------------------------------------------------------------------- seed 004 (RRRR)
def _params():
    return rrrr.parameters(load_robot('rrrr'))


def _seed004_xyz(P, q):
    return rrrr.fk_position(P, q)


def test_seed004_equations_hold_for_the_model():
    """The model (standard DH, twists +90 deg on joints 1 and 3) follows X, Y, Z of seed 004."""
    m = load_robot('rrrr')
    P = _params()
    for q in m.random_configurations(500, rng=4):
        np.testing.assert_allclose(m.fk(q)[:3, 3], _seed004_xyz(P, q), atol=1e-12)


def test_seed004_dh_table_does_not_give_its_equations():
    """
    Checked fact: the seed's own D-H table (twists -90 deg and +90 deg) does not produce X, Y, Z.

    Read as labelled (alpha_{i-1}, a_{i-1}: modified DH) or with the seed's standard-DH link
    matrix applied to each row as printed, the positions differ at random configurations; the
    standard DH table with +90 deg twists on joints 1 and 3 reproduces them exactly.
    """
    P = _params()
    d1, a2, a3, d4 = P.d1, P.a2, P.a3, P.d4
    h = math.pi / 2
    seed_as_mdh = [DHRow(0.0, 0.0, d1), DHRow(0.0, -h, 0.0), DHRow(a2, 0.0, 0.0),
                   DHRow(a3, h, d4)]
    seed_as_dh = [DHRow(0.0, 0.0, d1), DHRow(0.0, -h, 0.0), DHRow(a2, 0.0, 0.0),
                  DHRow(a3, h, d4)]
    fixed_dh = [DHRow(0.0, h, d1), DHRow(a2, 0.0, 0.0), DHRow(a3, h, 0.0), DHRow(0.0, 0.0, d4)]
    rng = np.random.default_rng(44)
    worst = {'mdh': 0.0, 'dh': 0.0, 'fixed': 0.0}
    for q in rng.uniform(-math.pi, math.pi, size=(200, 4)):
        xyz = _seed004_xyz(P, q)
        worst['mdh'] = max(worst['mdh'], np.abs(
            fk_dh(seed_as_mdh, q, modified=True)[:3, 3] - xyz).max())
        worst['dh'] = max(worst['dh'], np.abs(fk_dh(seed_as_dh, q)[:3, 3] - xyz).max())
        worst['fixed'] = max(worst['fixed'], np.abs(fk_dh(fixed_dh, q)[:3, 3] - xyz).max())
    assert worst['fixed'] < 1e-12
    assert worst['mdh'] > 0.05 and worst['dh'] > 0.05


def test_seed004_ik_elbow_up_and_down():
    """Section 3's formulas (q1 = atan2, q3 = gamma +- acos, q2 = atan2(...)) reach the point."""
    m = load_robot('rrrr')
    P = _params()
    for q in m.random_configurations(300, rng=5):
        X, Y, Z = _seed004_xyz(P, q)
        # the seed's formulas, written out here independently of the module
        q1 = math.atan2(Y, X)
        px, pz = math.hypot(X, Y), Z - P.d1
        D = px * px + pz * pz - P.a2 ** 2 - P.a3 ** 2 - P.d4 ** 2
        Rk, gamma = math.hypot(P.a3, P.d4), math.atan2(P.d4, P.a3)
        c = max(-1.0, min(1.0, D / (2 * P.a2 * Rk)))
        sols = []
        for q3 in (gamma + math.acos(c), gamma - math.acos(c)):
            A = P.a3 * math.cos(q3) + P.d4 * math.sin(q3)
            B = P.a3 * math.sin(q3) - P.d4 * math.cos(q3)
            den = (P.a2 + A) ** 2 + B ** 2
            q2 = math.atan2((-B * px + (P.a2 + A) * pz) / den, ((P.a2 + A) * px + B * pz) / den)
            sols.append((q1, q2, q3))
            np.testing.assert_allclose(_seed004_xyz(P, (q1, q2, q3)), (X, Y, Z), atol=1e-9)
        # the module returns both, plus the over-the-top branch (q1 + pi)
        mod = rrrr.arm_solutions(P, X, Y, Z)
        for s in sols:
            assert min(np.abs(np.remainder(np.subtract(s, t) + np.pi, 2 * np.pi) - np.pi).max()
                       for t in mod) < 1e-9
