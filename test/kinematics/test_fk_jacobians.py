"""Forward kinematics and Jacobians of the px100: finite differences and the seed 000 Jacobian."""
import numpy as np
from px100_control.kinematics.iterative import chain, fk_and_jacobian, fk_batch
from px100_control.kinematics.poe import jacobian_geometric
from px100_control.kinematics.se3 import log_se3
from px100_control.models.registry import load_robot
import pytest


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


@pytest.fixture(scope='module')
def configs(px100):
    return px100.random_configurations(40, np.random.default_rng(3))


def test_home_pose_is_m(px100):
    """At q = 0 the end effector is at M = (0.248575, 0, 0.1931) with identity rotation."""
    np.testing.assert_allclose(px100.fk(px100.home), px100.M, atol=1e-15)
    np.testing.assert_allclose(px100.M[:3, 3], [0.248575, 0.0, 0.1931], atol=1e-12)


def test_space_jacobian_matches_finite_differences(px100, configs):
    """J_s columns equal the spatial twist (dT/dq_i) T^-1 by central differences."""
    h = 1e-6
    for q in configs:
        T = px100.fk(q)
        J = px100.jacobian_space(q)
        for i in range(px100.dof):
            dq = np.zeros(px100.dof)
            dq[i] = h
            Tp, Tm = px100.fk(q + dq), px100.fk(q - dq)
            twist = (log_se3(Tp @ np.linalg.inv(T)) - log_se3(Tm @ np.linalg.inv(T))) / (2 * h)
            np.testing.assert_allclose(J[:, i], twist, atol=1e-8)


def test_body_jacobian_matches_finite_differences(px100, configs):
    """J_b columns equal the body twist T^-1 (dT/dq_i) by central differences."""
    h = 1e-6
    for q in configs:
        T_inv = np.linalg.inv(px100.fk(q))
        J = px100.jacobian_body(q)
        for i in range(px100.dof):
            dq = np.zeros(px100.dof)
            dq[i] = h
            twist = (log_se3(T_inv @ px100.fk(q + dq))
                     - log_se3(T_inv @ px100.fk(q - dq))) / (2 * h)
            np.testing.assert_allclose(J[:, i], twist, atol=1e-8)


def test_geometric_jacobian_moves_the_end_effector(px100, configs):
    """The linear rows of the geometric Jacobian are d p_ee / dq (finite differences)."""
    h = 1e-6
    for q in configs:
        Jg = jacobian_geometric(px100.S_list, px100.M, q)
        for i in range(px100.dof):
            dq = np.zeros(px100.dof)
            dq[i] = h
            dp = (px100.fk(q + dq)[:3, 3] - px100.fk(q - dq)[:3, 3]) / (2 * h)
            np.testing.assert_allclose(Jg[:3, i], dp, atol=1e-9)


def test_fast_kernels_agree_with_reference(px100, configs):
    """The plain-float FK/Jacobian kernel and the vectorised batch FK equal poe.py."""
    c = chain(px100)
    for q in configs:
        T, J = fk_and_jacobian(c, q)
        np.testing.assert_allclose(T, px100.fk(q), atol=1e-14)
        Jg = jacobian_geometric(px100.S_list, px100.M, q)     # rows [v; w]
        np.testing.assert_allclose(J, np.vstack([Jg[3:], Jg[:3]]), atol=1e-14)
    Ts = fk_batch(c, configs)
    for q, T in zip(configs, Ts):
        np.testing.assert_allclose(T, px100.fk(q), atol=1e-14)
