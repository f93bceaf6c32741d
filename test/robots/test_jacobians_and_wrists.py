"""
Per-robot Jacobians, and the Interbotix 6-DOF solver on wrists that are only nearly spherical.

Space and body Jacobians of every robot are checked against finite differences of the FK
(twist of T(q + h e_i) T(q)^-1 in the space frame, T(q)^-1 T(q + h e_i) in the body frame).
"""
import copy

import numpy as np
from px100_control.errors import RobotModelError
from px100_control.kinematics.analytic import interbotix6
from px100_control.kinematics.iterative import chain, fk_batch
from px100_control.kinematics.se3 import inv_transform, log_se3
from px100_control.kinematics.solve import solve_ik
from px100_control.models.registry import available_robots, load_robot, model_from_spec, \
    read_robot_file
import pytest


@pytest.mark.parametrize('name', available_robots())
def test_space_and_body_jacobians_match_finite_differences(name):
    """J_s and J_b columns equal the FK twists per unit joint motion (central differences)."""
    m = load_robot(name)
    h = 1e-6
    for q in m.random_configurations(3, rng=900):
        T = m.fk(q)
        Js, Jb = m.jacobian_space(q), m.jacobian_body(q)
        for i in range(m.dof):
            dq = np.zeros(m.dof)
            dq[i] = h
            Tp, Tm = m.fk(q + dq), m.fk(q - dq)
            vs = (log_se3(Tp @ inv_transform(T)) - log_se3(Tm @ inv_transform(T))) / (2 * h)
            vb = (log_se3(inv_transform(T) @ Tp) - log_se3(inv_transform(T) @ Tm)) / (2 * h)
            np.testing.assert_allclose(Js[:, i], vs, atol=1e-7)
            np.testing.assert_allclose(Jb[:, i], vb, atol=1e-7)


def _wx250s_with_wrist_offset(dz: float):
    """Return a wx250s whose wrist_angle axis is moved up by dz [m] (axes no longer meet)."""
    spec = copy.deepcopy(read_robot_file('wx250s'))
    spec['name'] = f'wx250s_offset_{dz}'
    spec.pop('urdf', None)
    for j in spec['kinematics']['joints']:
        if j['name'] == 'wrist_angle':
            j['point'] = [j['point'][0], 0.0, j['point'][2] + dz]
    return model_from_spec(spec)


def test_interbotix6_wrist_axes_meet_exactly():
    """In the section 6 tables the three wrist axes of the 6-DOF arms meet in one point."""
    for name in available_robots():
        m = load_robot(name)
        if m.analytic_ik == 'interbotix6':
            assert interbotix6.geometry(m).offset == 0.0 and interbotix6.is_exact(m)


def test_interbotix6_near_spherical_wrist_is_refined():
    """A 1 mm wrist offset: closed-form guesses + Gauss-Newton still give exact solutions."""
    m = _wx250s_with_wrist_offset(0.001)
    assert not interbotix6.is_exact(m)
    c = chain(m)
    Q = m.random_configurations(40, rng=901)
    T = fk_batch(c, Q)
    found = 0
    for q, Ti in zip(Q, T):
        C = interbotix6.candidates(m, Ti, 'full')
        err = np.abs(fk_batch(c, C) - Ti).max(axis=(1, 2))
        assert err.min() <= 1e-9
        d = np.abs(np.remainder(C - q + np.pi, 2 * np.pi) - np.pi).max(axis=1)
        found += bool(np.any((err <= 1e-9) & (d < 1e-6)))
    for q, Ti in zip(Q[:10], T[:10]):
        res = solve_ik(m, Ti, mode='full', q_seed=q)
        assert res.success and res.position_error <= 1e-9
    assert found >= 0.95 * len(Q)


def test_interbotix6_refuses_a_wrist_far_from_spherical():
    """Beyond 5 mm the family does not apply: a clear model error, not a wrong answer."""
    m = _wx250s_with_wrist_offset(0.02)
    with pytest.raises(RobotModelError):
        interbotix6.candidates(m, m.fk(m.home), 'full')
