"""
Seed 000's printed numbers, reproduced with its own model (examples/seed000_model.py).

The seed works in mm: L1 = 89.54, Lm = 35, L2 = L3 = 100, L4 = 109. Its model with the real
lengths is also cross-checked against the URDF px100.
"""
import math

import numpy as np
from px100_control.kinematics.analytic import px100 as ana
from px100_control.kinematics.poe import jacobian_geometric
from px100_control.models.registry import load_robot
import pytest
import seed000_model as seed
from seed000_model import SeedPx100


def test_q_nom_and_offsets():
    """q_nom = [0, -1.2341, 1.2341, 0] (V.1) and the V.2 conversions are each other's inverse."""
    np.testing.assert_allclose(seed.q_nom, [0.0, -1.2341215, 1.2341215, 0.0], atol=1e-7)
    q = np.array([0.1, -0.2, 0.3, 0.4])
    np.testing.assert_allclose(seed.q_dh_to_q_actuator(seed.q_actuator_to_q_dh(q)), q)


def test_matrix_at_q_nom_is_stretched_arm():
    """At q_nom the tool is at (Lm + L3 + L4, 0, L1 + L2) = (244, 0, 189.54) mm."""
    T = seed.matrice_t_h(seed.q_nom)
    np.testing.assert_allclose(T[:3, 3], [244.0, 0.0, 189.54], atol=1e-12)


def test_inverse_geometric_model_printed_solution():
    """V.8 second test: convert_param_op_to_qdh prints [-0.00505783 -0.48857186 ...]."""
    x_test = np.array([seed.Lm + seed.L3 + seed.L4, 0.0, seed.L1 + seed.L2, -1.0])
    q = seed.convert_param_op_to_qdh(seed.q_actuator_to_q_dh(x_test))
    np.testing.assert_allclose(q, [-0.00505783, -0.48857186, 0.90243115, -1.41385929],
                               atol=5e-9)


def test_every_seed_solution_reaches_its_target():
    """All branches of seed eq. (2) reproduce (px, py, pz) and psi = q2 + q3 + q4."""
    rng = np.random.default_rng(1)
    m = SeedPx100()
    for _ in range(200):
        q = rng.uniform([-math.pi, -1.5, -1.5, -1.5], [math.pi, 1.5, 1.5, 1.5])
        target = np.append(m.position(q), q[1:].sum())
        sols = m.all_solutions(target)
        assert len(sols) >= 2
        for s in sols:
            np.testing.assert_allclose(m.position(s), target[:3], atol=1e-9)
            assert abs(math.remainder(s[1:].sum() - target[3], 2 * math.pi)) < 1e-9
        assert any(np.abs(np.remainder(s - q + math.pi, 2 * math.pi) - math.pi).max() < 1e-7
                   for s in sols)


def test_unreachable_returns_empty():
    """Out of reach gives the seed's empty (0, 4) array, not an exception."""
    assert seed.convert_param_op_to_qdh([1000.0, 0.0, 0.0, 0.0]).shape == (0, 4)


@pytest.mark.parametrize('case', ['first', 'second'])
def test_iterative_algorithm_printed_results(case):
    """
    Reproduce the two V.8 runs of the iterative algorithm.

    35 iterations -> [1.10714871 -0.68382443 1.45740347 0.10058747] (psi 0.874);
    47 iterations -> [-2.48e-10 -1.23412154 1.23412164 -1.87e-07]. Reproduced exactly with the
    stop tolerance 1e-7 (the listing says 1e-11; see module docstring).
    """
    m = SeedPx100()
    if case == 'first':
        x_but = np.array([100.0, 200.0, 3.0, np.pi / 4])
        q_start = m.convert_param_op_to_qdh(m.q_actuator_to_q_dh(x_but))
        target = np.array([100.0, 200.0, 3.0])
        q_print = [1.10714871, -0.68382443, 1.45740347, 0.10058747]
        real_print = [99.99999953, 199.9999944, 3.00000576, 0.87416651]
        iterations = 35
    else:
        x_test = np.array([m.Lm + m.L3 + m.L4, 0.0, m.L1 + m.L2, -1.0])
        q_start = m.convert_param_op_to_qdh(m.q_actuator_to_q_dh(x_test))
        target = x_test[:3]
        q_print = [-2.48477522e-10, -1.23412154, 1.23412164, -1.86862729e-07]
        real_print = [2.43999997e+02, -6.06285147e-08, 1.89539999e+02, -7.97795007e-08]
        iterations = 47
    q, info = m.iterative_algorithm(q_start, target, tolerance=1e-7, qnom=m.q_nom,
                                    return_info=True)
    assert info['iterations'] == iterations and info['converged']
    np.testing.assert_allclose(q, q_print, atol=6e-9, rtol=1e-8)
    np.testing.assert_allclose(np.append(info['position'], info['psi']), real_print,
                               rtol=2e-9, atol=1e-9)


def test_iterative_algorithm_default_tolerance_converges_further():
    """With the listing's 1e-11 the same run goes on to the exact target (< 1e-8 mm)."""
    x_but = np.array([100.0, 200.0, 3.0, np.pi / 4])
    q_start = seed.convert_param_op_to_qdh(seed.q_actuator_to_q_dh(x_but))
    q = seed.iterative_algorithm(q_start, x_but[:3], qnom=seed.q_nom)
    np.testing.assert_allclose(seed.matrice_t_h(q)[:3, 3], x_but[:3], atol=1e-8)


def test_seed_model_with_real_lengths_is_the_urdf_px100():
    """SeedPx100.real() and the URDF px100 agree; seed solutions are among solve_ik's."""
    px100 = load_robot('px100')
    m = SeedPx100.real()
    rng = np.random.default_rng(7)
    for q in px100.random_configurations(100, rng):
        q_dh = m.q_actuator_to_q_dh(q)
        np.testing.assert_allclose(m.position(q_dh), px100.fk(q)[:3, 3], atol=1e-12)
        # seed (x, y, z, psi) with psi the joint-sum pitch: the front branch is ours
        target = np.append(px100.fk(q)[:3, 3], q[1:].sum())
        ours = ana.solve_xyz_pitch(ana.geometry(px100), *target)
        for s in m.all_solutions(target):
            if abs(math.remainder(s[0] - math.atan2(target[1], target[0]), 2 * math.pi)) > 1e-9:
                continue        # back branch: the seed keeps psi, we keep the tool direction
            qa = np.remainder(m.q_dh_to_q_actuator(s) + math.pi, 2 * math.pi) - math.pi
            assert any(np.abs(np.array(o) - qa).max() < 1e-9 for o in ours)


def test_seed000_position_jacobian_cross_check():
    """Seed 000's analytic 3x4 Jacobian (real px100 lengths, q_dh = q + q_nom) = J_v of PoE."""
    seed = SeedPx100.real()
    px100 = load_robot('px100')
    configs = px100.random_configurations(50, rng=7)
    for q in configs:
        q_dh = seed.q_actuator_to_q_dh(q)
        np.testing.assert_allclose(seed.jacobienne(q_dh),
                                   jacobian_geometric(px100.S_list, px100.M, q)[:3], atol=1e-12)
        np.testing.assert_allclose(seed.position(q_dh), px100.fk(q)[:3, 3], atol=1e-12)


def test_seed000_matrix_is_urdf_frame_turned_about_x():
    """Seed 000's end-effector frame is the URDF's rotated by -pi/2 about x (tool Rx(pi/2))."""
    seed = SeedPx100.real()
    px100 = load_robot('px100')
    configs = px100.random_configurations(50, rng=7)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])   # Rx(-pi/2)
    for q in configs:
        T_seed = seed.matrice_t_h(seed.q_actuator_to_q_dh(q))
        np.testing.assert_allclose(T_seed[:3, :3], px100.fk(q)[:3, :3] @ Rx, atol=1e-12)
