"""
Same scene, same commands, stepped as fast as possible: identical object end poses run to run.

The engine on its own (what sim_driver at ``real_time_factor`` 0 steps): a pick and place of
the green cube of ``pick_place`` scripted as joint setpoints at fixed simulated times (closed-form
IK of the grasp waypoints, minimum-jerk moves at 1 kHz, the gripper closed by effort). Two runs
from fresh simulators must end with bit-identical object poses; the script really moves the cube
(it is lifted and ends near its target), so contacts and friction are part of what is compared.
"""
import math

import numpy as np
from px100_control.control.trajectory import minimum_jerk_scaling
from px100_control.kinematics.analytic.px100 import ik_xyz_pitch
from px100_control.models.registry import load_robot
from px100_control.sim.scene import load_scene
from px100_control.sim.simulator import ArmSimulator, SimConfig
import pytest

ARM = ['waist', 'shoulder', 'elbow', 'wrist_angle']
TARGET = (0.20, -0.09)          # where the green cube goes (x, y) [m]
GRIP = 0.6                      # gripper effort [N*m] while opening / closing


def _script(model, start):
    """Return [(duration [s], arm target (4,) or None, gripper effort or None)]."""
    x, y, z = start
    tx, ty = TARGET
    q = None
    steps = []

    def pitch(px, py):       # the steepest pitch reaching the grasp and 5 cm above it
        return next(p for p in np.arange(math.pi / 2, 0.5, -0.05)
                    if ik_xyz_pitch(model, px, py, z, p) and
                    ik_xyz_pitch(model, px, py, z + 0.05, p))

    def at(px, py, pz, p):
        nonlocal q
        sols = ik_xyz_pitch(model, px, py, pz, p, q)
        assert sols, (px, py, pz)
        q = np.array(sols[0][:4], dtype=float)
        return q

    pp, tp = pitch(x, y), pitch(tx, ty)
    steps.append((0.6, None, +GRIP))                      # open
    steps.append((1.5, at(x, y, z + 0.05, pp), None))     # approach pick
    steps.append((1.0, at(x, y, z, pp), None))            # pick
    steps.append((0.8, None, -GRIP))                      # grasp
    steps.append((1.0, at(x, y, z + 0.05, pp), None))     # lift
    steps.append((1.5, at(tx, ty, z + 0.05, tp), None))   # carry
    steps.append((1.0, at(tx, ty, z + 0.002, tp), None))  # place
    steps.append((0.6, None, +GRIP))                      # release
    steps.append((1.0, at(tx, ty, z + 0.05, tp), None))   # retreat
    return steps


def _run(model, scene):
    sim = ArmSimulator(model, SimConfig(), scene=scene)
    start = np.array(sim.object_poses()['green_cube'][0])
    q0 = np.array(sim.positions(), dtype=float)
    highest = start[2]
    rate = int(round(1.0 / sim.dt))
    for duration, q1, effort in _script(model, start):
        if effort is not None:
            sim.apply(sim.command(['gripper'], effort=[effort]))
        n = int(round(duration * rate))
        for k in range(1, n + 1):
            if q1 is not None:
                s = float(minimum_jerk_scaling(k / rate, duration)[0])
                sim.apply(sim.command(ARM, position=list(q0 + s * (q1 - q0))))
            sim.step()
            if k % 50 == 0:
                highest = max(highest, sim.object_poses()['green_cube'][0][2])
        if q1 is not None:
            q0 = q1
    for _ in range(500):                                # let everything settle
        sim.step()
    poses = {name: (tuple(p), tuple(o)) for name, (p, o) in sim.object_poses().items()}
    return poses, start, highest


@pytest.fixture(scope='module')
def two_runs():
    model = load_robot('px100')
    scene = load_scene('pick_place', robot=model)
    return _run(model, scene), _run(model, scene)


def test_same_commands_give_identical_object_poses(two_runs):
    """Bit-identical end poses of every object in two runs of the same script."""
    (a, _, _), (b, _, _) = two_runs
    assert a.keys() == b.keys() and len(a) >= 3
    for name in a:
        assert a[name] == b[name], (name, a[name], b[name])


def test_the_script_really_moves_the_cube(two_runs):
    """The compared run is a real pick and place: lifted by > 3 cm, ends near the target."""
    (poses, start, highest), _ = two_runs
    assert highest > start[2] + 0.03, (start, highest)
    end = np.array(poses['green_cube'][0])
    assert np.hypot(end[0] - TARGET[0], end[1] - TARGET[1]) < 0.01, end
