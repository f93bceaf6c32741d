"""
ArmSimulator.step against its plain formulation (reference_step.py): identical bits.

The step is the simulator's hot loop and is written for speed; this pins that it computes
exactly what the plain formulation computes. One scripted run of the PX100 in the pick_place
scene covers every branch of the step: position moves with feed-forward, a saturated move at
the velocity limit, a pick by contact (the finger slides' reflected inertia changing every
step), velocity / torque / duty modes, torque off on one joint and on all, the gripper in
position, effort and velocity modes and the object_width finger stop; then the same with the
general (non-contiguous) address path. Every step's qpos, qvel, efforts and the gripper effort
must be equal bit for bit.
"""
import math

import numpy as np
from px100_control.kinematics.rotations import euler_sxyz_to_matrix
from px100_control.kinematics.solve import solve_ik
from px100_control.models.registry import load_robot
from px100_control.sim.scene import load_scene
from px100_control.sim.simulator import ArmSimulator
import pytest
from reference_step import ReferenceStepSimulator


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


def _script(sim):
    """Drive ``sim`` through every branch of the step; return the per-step states (bytes)."""
    names = list(sim.names)
    trace = []
    d = sim.mj_data

    def run(seconds):
        for _ in range(int(round(seconds / sim.dt))):
            sim.step()
            trace.append(np.concatenate([d.qpos, d.qvel, sim.effort, [sim.g_effort]]))

    def ik(p):
        T = np.eye(4)
        T[:3, :3] = euler_sxyz_to_matrix(0.0, math.pi / 2, math.atan2(p[1], p[0]))
        T[:3, 3] = p
        result = solve_ik(sim.model, T, mode='pitch', q_seed=sim.positions())
        assert result.success, result.reason
        return result.q

    def move(q1, seconds):
        q0 = sim.positions()
        for k in range(int(seconds / sim.dt)):
            s = min(k * sim.dt / seconds, 1.0)
            sim.command(names, list(q0 + (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5) * (q1 - q0)),
                        list((30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / seconds * (q1 - q0)))
            run(sim.dt)
        run(0.15)

    sim.command(['gripper'], effort=[0.4])
    run(1.5)
    p0 = np.array(sim.object_poses()['red_cube'][0])
    move(ik(p0 + [0.0, 0.0, 0.06]), 1.5)
    move(ik(p0), 1.0)
    sim.command(['gripper'], effort=[-0.4])
    run(2.5)
    move(ik(p0 + [0.0, 0.0, 0.06]), 1.0)
    held = sim.held_object()
    sim.command(['waist'], [sim.q[0] + 1.0])           # saturated: hits the velocity limit
    run(0.7)
    for joint, mode in (('waist', 'velocity'), ('elbow', 'torque'), ('wrist_angle', 'duty')):
        sim.set_mode(joint, mode)
    sim.command(['waist'], velocity=[0.8])
    sim.command(['elbow', 'wrist_angle'], effort=[0.3, -0.2])
    run(0.3)
    sim.set_torque_enabled(False, ['shoulder'])
    run(0.2)
    sim.set_torque_enabled(False)
    run(0.2)
    sim.set_torque_enabled(True)
    for joint in ('waist', 'elbow', 'wrist_angle'):
        sim.set_mode(joint, 'position')
    sim.command(['gripper'], [0.6])
    run(0.4)
    sim.set_mode('gripper', 'velocity')
    sim.command(['gripper'], velocity=[-1.0])
    run(0.3)
    sim.set_mode('gripper', 'duty')
    sim.command(['gripper'], effort=[-0.3])
    sim.set_object_width(0.04)
    run(0.5)
    return held, np.array(trace)


@pytest.mark.parametrize('contiguous', [True, pytest.param(False, marks=pytest.mark.slow)])
def test_step_is_the_reference_step_bit_for_bit(px100, contiguous):
    """Same commands, same scene: every state of every step identical to the reference."""
    scene = load_scene('pick_place', px100)
    sims = [cls(px100, scene=scene) for cls in (ArmSimulator, ReferenceStepSimulator)]
    for sim in sims:
        sim._contiguous = contiguous and sim._contiguous
    (held, fast), (held_ref, ref) = (_script(sim) for sim in sims)
    assert held == held_ref == 'red_cube'            # the pick really happened
    assert fast.shape == ref.shape
    assert fast.tobytes() == ref.tobytes(), np.abs(fast - ref).max()
    waist_speed = ref[:, sims[1].mj_model.nq + sims[1].built.arm_dof[0]]
    assert np.any(waist_speed == sims[1].vel_limit[0])  # the velocity limit was active
