"""The oracle rigid-body dynamics (oracle_dynamics.py) against independent derivations."""
import dataclasses

import numpy as np
from numpy.testing import assert_allclose
from oracle_dynamics import (chain_dynamics_from_urdf, dynamics_for_model, lump_inertias,
                             point_mass_dynamics, spatial_inertia)
from px100_control.errors import RobotModelError
from px100_control.models.registry import load_robot, model_from_spec
import pytest

EPS = 1e-6


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


@pytest.fixture(scope='module')
def dyn(px100):
    return dynamics_for_model(px100, armature=0.0,
                              fixed_values={'gripper': 0.0, 'left_finger': 0.0195})


def _random_states(model, count, seed=0):
    rng = np.random.default_rng(seed)
    qs = model.random_configurations(count, rng)
    qds = rng.uniform(-3.0, 3.0, size=qs.shape)
    return list(zip(qs, qds))


def test_mass_matrix_is_symmetric_positive_definite(px100, dyn):
    """M(q) is symmetric and positive definite at random configurations."""
    for q, _ in _random_states(px100, 50):
        M = dyn.mass_matrix(q)
        assert_allclose(M, M.T, atol=1e-15)
        assert np.linalg.eigvalsh(M).min() > 0.0


def test_gravity_is_the_gradient_of_potential_energy(px100, dyn):
    """g(q) equals dV/dq by central finite differences."""
    for q, _ in _random_states(px100, 20, seed=1):
        fd = np.array([(dyn.potential_energy(q + EPS * e) - dyn.potential_energy(q - EPS * e))
                       / (2 * EPS) for e in np.eye(px100.dof)])
        assert_allclose(dyn.gravity_torque(q), fd, atol=1e-8)


def test_coriolis_terms_match_the_lagrangian(px100, dyn):
    """Coriolis terms h - g = Mdot qd - 0.5 d(qd^T M qd)/dq (Euler-Lagrange, finite diff.)."""
    for q, qd in _random_states(px100, 20, seed=2):
        Mdot = (dyn.mass_matrix(q + EPS * qd) - dyn.mass_matrix(q - EPS * qd)) / (2 * EPS)
        dT = np.array([(dyn.kinetic_energy(q + EPS * e, qd) - dyn.kinetic_energy(q - EPS * e, qd))
                       / (2 * EPS) for e in np.eye(px100.dof)])
        coriolis = dyn.bias_forces(q, qd) - dyn.gravity_torque(q)
        assert_allclose(coriolis, Mdot @ qd - dT, atol=1e-8)


def test_scalar_and_vectorized_paths_agree(px100, dyn):
    """The plain-float fast path equals the batched numpy path (two implementations)."""
    for q, qd in _random_states(px100, 20, seed=3):
        M1, h1 = dyn.evaluate(q, qd)
        M2, h2 = dyn.evaluate_vectorized(q, qd)
        assert_allclose(M1, M2, atol=1e-13)
        assert_allclose(h1, h2, atol=1e-13)


def test_inverse_and_forward_dynamics_are_inverses(px100):
    """forward_dynamics(q, qd, inverse_dynamics(q, qd, qdd)) = qdd, armature included."""
    d = dynamics_for_model(px100, armature=0.01)
    rng = np.random.default_rng(4)
    for q, qd in _random_states(px100, 10, seed=4):
        qdd = rng.uniform(-10, 10, px100.dof)
        tau = d.inverse_dynamics(q, qd, qdd)
        assert_allclose(d.forward_dynamics(q, qd, tau), qdd, atol=1e-9)


def test_energy_is_conserved_without_friction_or_torque(px100, dyn):
    """With no input, friction or armature the total energy stays constant (RK4, 0.5 s)."""
    q = np.array([0.3, -0.2, 0.4, 0.5])
    qd = np.array([1.0, -0.5, 0.8, -1.2])
    zero = np.zeros(4)

    def f(x):
        return np.concatenate([x[4:], dyn.forward_dynamics(x[:4], x[4:], zero)])

    def energy(x):
        return dyn.kinetic_energy(x[:4], x[4:]) + dyn.potential_energy(x[:4])

    x = np.concatenate([q, qd])
    e0 = energy(x)
    dt = 5e-4
    speeds = []
    for _ in range(1000):
        k1 = f(x)
        k2 = f(x + 0.5 * dt * k1)
        k3 = f(x + 0.5 * dt * k2)
        k4 = f(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        speeds.append(np.abs(x[4:]).max())
    assert max(speeds) > 1.0           # it really moved
    # a missing or wrong Coriolis term changes the energy by ~1e-2 J here
    assert abs(energy(x) - e0) < 1e-6


def test_body_positions_come_from_the_urdf(px100, dyn):
    """Known values: the forearm COM at q = 0 and the masses carried by each joint."""
    # forearm_link origin (0.035, 0, 0.05085 + 0.04225 + 0.1), COM (0.077372, -0.000332, 0)
    assert_allclose(dyn.coms[2], [0.035 + 0.077372, -0.0003324882, 0.1931], atol=1e-9)
    assert dyn.masses[2] == pytest.approx(0.073058)
    # wrist body: gripper_link + ee_arm + gripper_prop + gripper_bar + fingers_link + 2 fingers
    wrist = 0.069929 + 0.001 + 0.00434 + 0.034199 + 0.001 + 2 * 0.016246
    assert dyn.masses[3] == pytest.approx(wrist)
    # the dummy links' 0.001 kg*m^2 placeholder inertias are replaced and reported
    assert any('ee_arm_link' in note for note in dyn.notes)
    assert np.abs(dyn.inertias[3]).max() < 1e-3    # the placeholders alone would be 2e-3


def test_shoulder_holds_the_arm_against_gravity_at_home(px100, dyn):
    """At q = 0 the shoulder torque is the weight moment of everything it carries."""
    moment = sum(m * 9.81 * c[0] for m, c in zip(dyn.masses[1:], dyn.coms[1:]))
    assert dyn.gravity_torque(np.zeros(4))[1] == pytest.approx(-moment, rel=1e-12)
    assert dyn.gravity_torque(np.zeros(4))[0] == pytest.approx(0.0, abs=1e-15)


def test_helpers_spatial_inertia_and_lumping():
    """spatial_inertia of a point mass and lumping two parts (parallel-axis theorem)."""
    assert_allclose(spatial_inertia(2.0, np.zeros(3), np.eye(3)),
                    np.diag([1, 1, 1, 2, 2, 2.0]))
    m, c, inertia = lump_inertias([(1.0, np.array([1.0, 0, 0]), np.zeros((3, 3))),
                                   (1.0, np.array([-1.0, 0, 0]), np.zeros((3, 3)))])
    assert m == 2.0
    assert_allclose(c, 0.0)
    assert_allclose(inertia, np.diag([0.0, 2.0, 2.0]))


def test_point_mass_fallback_for_robots_without_inertials():
    """A table robot with a prismatic joint and no URDF gets the documented approximation."""
    spec = {'name': 'rrp_test', 'kinematics': {'convention': 'dh', 'joints': [
        {'name': 'j1', 'a': 0.0, 'alpha': 1.5707963, 'd': 0.1, 'lower': -3, 'upper': 3},
        {'name': 'j2', 'a': 0.15, 'alpha': 0.0, 'd': 0.0, 'lower': -2, 'upper': 2},
        {'name': 'j3', 'type': 'prismatic', 'a': 0.0, 'alpha': 0.0, 'd': 0.0, 'theta': 0.0,
         'lower': 0.0, 'upper': 0.1, 'velocity': 0.1}]}}
    model = dataclasses.replace(model_from_spec(spec), urdf_xml=None)
    d = dynamics_for_model(model, armature=0.0)
    assert d.source == 'point-mass approximation'
    assert d.notes
    for q, qd in _random_states(model, 10, seed=5):
        M = d.mass_matrix(q)
        assert np.linalg.eigvalsh(M).min() > 0
        fd = np.array([(d.potential_energy(q + EPS * e) - d.potential_energy(q - EPS * e))
                       / (2 * EPS) for e in np.eye(3)])
        assert_allclose(d.gravity_torque(q), fd, atol=1e-8)
    direct = point_mass_dynamics(model.S_list, model.M, 0.0, link_mass=0.2)
    assert_allclose(direct.masses, 0.2)


def test_urdf_without_inertials_is_refused(px100):
    """A URDF with no inertial on the moving links raises RobotModelError."""
    import re
    bare = re.sub(r'<inertial>.*?</inertial>', '', px100.urdf_xml, flags=re.S)
    with pytest.raises(RobotModelError):
        chain_dynamics_from_urdf(bare, 'base_link', px100.joint_names, px100.S_list, 0.0)


@pytest.mark.parametrize('name', ['rrrp', 'rrrr', 'myarm300pi', 'wx250s'])
def test_other_robots_get_dynamics(name):
    """Every registered robot model yields a usable mass matrix and gravity vector."""
    model = load_robot(name)
    d = dynamics_for_model(model, armature=0.01)
    for q, qd in _random_states(model, 5, seed=6):
        M, h = d.evaluate(q, qd)
        assert np.linalg.eigvalsh(M).min() > 0
        assert np.all(np.isfinite(h))
        M2, h2 = d.evaluate_vectorized(q, qd)     # prismatic joints too (rrrp)
        assert_allclose(M, M2, atol=1e-12)
        assert_allclose(h, h2, atol=1e-12)
