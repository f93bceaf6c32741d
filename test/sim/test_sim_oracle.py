"""
The model transfer: MuJoCo's mass matrix and bias forces equal the hand-written dynamics.

The oracle (oracle_dynamics.py, the rigid-body code the simulator used before MuJoCo) and the
simulator's MuJoCo model are built from the same URDF inertials (placeholder inertias turned
into point masses by both), same rotor armature, gravity on, the gripper frozen at angle 0.
They must agree on 1,000 random states of the PX100 and on 100 of every other robot; and
closed-loop moves of the old simulator (oracle_simulator.py) and the MuJoCo one agree.
"""
import numpy as np
from oracle_dynamics import dynamics_for_model
from oracle_simulator import ArmSimulator as OracleSimulator, SimConfig as OracleConfig
from px100_control.models.registry import available_robots, load_robot
from px100_control.sim.simulator import ArmSimulator
import pytest
from tiers import robots


def _oracle(sim):
    model = sim.model
    fixed = {}
    if model.gripper is not None:
        fixed = {model.gripper.joint: 0.0,
                 model.gripper.fingers[0]: sim.linkage.finger_position(0.0)}
    return dynamics_for_model(model, [s.armature for s in sim.servos], fixed_values=fixed)


@pytest.mark.parametrize('name', robots(available_robots()))
def test_mass_matrix_and_bias_forces_equal_the_oracle(name):
    """M(q) + armature and h(q, qd) = C qd + g agree to 1e-12 relative on random states."""
    model = load_robot(name)
    sim = ArmSimulator(model)
    oracle = _oracle(sim)
    count = 1000 if name == 'px100' else 100
    rng = np.random.default_rng(2026)
    qs = model.random_configurations(count, rng)
    qds = rng.uniform(-3.0, 3.0, size=qs.shape)
    worst_m = worst_h = 0.0
    gravity_seen = 0.0
    for q, qd in zip(qs, qds):
        M, h = sim.dynamics.evaluate(q, qd)
        Mo, ho = oracle.evaluate(q, qd)
        worst_m = max(worst_m, float(np.abs(M - Mo).max() / np.abs(Mo).max()))
        worst_h = max(worst_h, float(np.abs(h - ho).max() / max(np.abs(ho).max(), 1e-9)))
        gravity_seen = max(gravity_seen, float(np.abs(sim.dynamics.gravity_torque(q)).max()))
    assert worst_m < 1e-12, f'{name}: mass matrix differs by {worst_m:.3g} (relative)'
    assert worst_h < 1e-12, f'{name}: bias forces differ by {worst_h:.3g} (relative)'
    assert gravity_seen > 0.05                 # gravity is on: the bias forces carry weight
    assert sim.dynamics.notes == tuple(n for n in oracle.notes if 'placeholder' in n)


def test_closed_loop_moves_match_the_old_simulator():
    """Same PID + servo, old exact plant vs MuJoCo: a 1.5 s trapezoid move agrees closely."""
    from test_sim_simulator import trapezoid
    px100 = load_robot('px100')
    q0, q1 = np.array(px100.sleep), np.array([1.0, 0.3, -0.4, 0.5])
    paths = []
    for sim in (OracleSimulator(px100, OracleConfig(dynamics_divider=1)), ArmSimulator(px100)):
        path = []
        for k in range(2000):
            if k % 5 == 0:
                q, qd = trapezoid(q0, q1, 1.5, 0.3, k * sim.dt)
                sim.command(list(px100.joint_names), list(q), list(qd))
            sim.step()
            path.append(list(sim.q))
        paths.append(np.array(path))
    diff = np.abs(paths[0] - paths[1]).max()
    print(f'largest difference old vs MuJoCo plant: {diff * 1000:.3f} mrad')
    assert np.abs(paths[1][-1] - q1).max() < 1e-3
    assert diff < 3e-3, diff
