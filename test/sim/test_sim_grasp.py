"""
Grasps by contact in the MuJoCo world (engine level, no ROS), the scene API and control modes.

A pick: open, go above the object, descend with the tool pointing down (pitch pi/2), squeeze
with a gripper effort, lift, swing the waist 90 degrees in 1.5 s. The object moves only
because the finger pads squeeze it with friction.
"""
import dataclasses
import math

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.kinematics.rotations import euler_sxyz_to_matrix
from px100_control.kinematics.solve import solve_ik
from px100_control.models.registry import load_robot
from px100_control.sim.scene import available_scenes, load_scene
from px100_control.sim.simulator import ArmSimulator
import pytest

STRONG, WEAK = -0.4, -0.25        # gripper efforts [N*m] (250 and 158 PWM)
#: the most a held object may move in the tool frame through the swing [m] (measured 0.17-0.18
#: mm centred with MuJoCo 4.0; the issue's bound)
SLIP = 0.0005


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


@pytest.fixture(scope='module')
def scene(px100):
    return load_scene('pick_place', px100)


def _ik(sim, p, pitch=math.pi / 2):
    T = np.eye(4)
    T[:3, :3] = euler_sxyz_to_matrix(0.0, pitch, math.atan2(p[1], p[0]))
    T[:3, 3] = p
    result = solve_ik(sim.model, T, mode='pitch', q_seed=sim.positions())
    assert result.success, result.reason
    return result.q


def _move(sim, q1, duration):
    """Minimum-jerk joint move, setpoints at 200 Hz with velocity feed-forward, then settle."""
    q0 = sim.positions()
    names = list(sim.names)
    for k in range(int(duration / sim.dt) + 200):
        if k % 5 == 0:
            s = min(k * sim.dt / duration, 1.0)
            b = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5
            bd = (30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / duration
            sim.command(names, list(q0 + b * (q1 - q0)), list(bd * (q1 - q0)))
        sim.step()


def _grip(sim, effort, seconds):
    sim.command(['gripper'], effort=[effort])
    sim.advance(int(seconds / sim.dt))


def _in_tool(sim, name):
    T = sim.ee_pose()
    return T[:3, :3].T @ (np.array(sim.object_poses()[name][0]) - T[:3, 3])


def _pick(sim, name, squeeze=STRONG, offset=(0.0, 0.0, 0.0), close_time=2.5):
    """Pick ``name`` (offset [m] added to the grasp point); return the object's p before."""
    p0 = np.array(sim.object_poses()[name][0])
    _grip(sim, 0.4, 1.5)
    _move(sim, _ik(sim, p0 + [0.0, 0.0, 0.06]), 1.5)
    _move(sim, _ik(sim, p0 + np.asarray(offset)), 1.0)
    _grip(sim, squeeze, close_time)
    _move(sim, _ik(sim, p0 + [0.0, 0.0, 0.06]), 1.0)
    return p0


def _swing(sim):
    q1 = sim.positions()
    q1[0] += math.pi / 2
    _move(sim, q1, 1.5)


def _finger_axis(p):
    az = math.atan2(p[1], p[0])
    return np.array([-math.sin(az), math.cos(az), 0.0])


@pytest.mark.parametrize('name', ['red_cube', 'green_cube', 'blue_cylinder'])
def test_good_grasp_holds_through_a_fast_swing(px100, scene, name):
    """Centred grasp, 250 PWM: lifted, held through a 90 deg swing in 1.5 s, slip < 0.5 mm."""
    sim = ArmSimulator(px100, scene=scene)
    p0 = _pick(sim, name)
    assert sim.held_object() == name
    assert sim.object_poses()[name][0][2] > p0[2] + 0.05           # lifted 6 cm with the tool
    before = _in_tool(sim, name)
    _swing(sim)
    assert sim.held_object() == name
    slip = float(np.linalg.norm(_in_tool(sim, name) - before))
    print(f'{name}: slip during the swing {slip * 1000:.2f} mm')
    assert slip < SLIP
    others = [o.name for o in scene.objects if o.name != name]
    for other in others:                                           # nothing else moved
        np.testing.assert_allclose(sim.object_poses()[other][0], scene.body(other).position,
                                   atol=1e-4)


def test_set_down_between_closed_pads_is_gripped_not_lifted(px100, scene):
    """Picked, lowered back onto the table: both pads still on it, on its support; open: free."""
    sim = ArmSimulator(px100, scene=scene)
    assert sim.gripped_objects() == {}
    p0 = _pick(sim, 'green_cube')
    assert sim.gripped_objects() == {'green_cube': True}
    _move(sim, _ik(sim, p0 - [0.0, 0.0, 0.002]), 1.0)              # pushed onto the table
    assert sim.gripped_objects() == {'green_cube': False} and sim.held_object() is None
    _grip(sim, 0.4, 1.0)
    assert sim.gripped_objects() == {}


def test_grasp_planned_at_the_nominal_pose_tolerates_jitter(px100, scene):
    """The cube moved +-5 mm and turned +-10 deg, picked where the file says: 5 of 5 held."""
    rng = np.random.default_rng(5)
    nominal = np.array(scene.body('red_cube').position)
    for _ in range(5):
        dx, dy = rng.uniform(-0.005, 0.005, 2)
        dyaw = rng.uniform(-math.radians(10), math.radians(10))
        bodies = tuple(dataclasses.replace(
            b, position=(b.position[0] + dx, b.position[1] + dy, b.position[2]),
            rpy=(0.0, 0.0, b.rpy[2] + dyaw)) if b.name == 'red_cube' else b
            for b in scene.bodies)
        sim = ArmSimulator(px100, scene=dataclasses.replace(scene, bodies=bodies))
        _grip(sim, 0.4, 1.5)
        _move(sim, _ik(sim, nominal + [0.0, 0.0, 0.06]), 1.5)
        _move(sim, _ik(sim, nominal), 1.0)
        _grip(sim, STRONG, 2.5)
        _move(sim, _ik(sim, nominal + [0.0, 0.0, 0.06]), 1.0)
        before = _in_tool(sim, 'red_cube')
        _swing(sim)
        assert sim.held_object() == 'red_cube', (dx, dy, dyaw)
        slip = float(np.linalg.norm(_in_tool(sim, 'red_cube') - before))
        print(f'jitter ({dx * 1e3:.1f}, {dy * 1e3:.1f}) mm, {math.degrees(dyaw):.1f} deg: slip '
              f'{slip * 1000:.2f} mm')
        assert slip < SLIP, (dx, dy, dyaw)


def test_off_centre_weak_grasp_fails(px100, scene):
    """12 mm off centre along the fingers, 158 PWM: one pad pushes the cube, nothing lifts it."""
    sim = ArmSimulator(px100, scene=scene)
    p0 = np.array(scene.body('red_cube').position)
    _pick(sim, 'red_cube', WEAK, 0.012 * _finger_axis(p0))
    assert sim.held_object() is None
    p = np.array(sim.object_poses()['red_cube'][0])
    assert p[2] == pytest.approx(p0[2], abs=1e-3)                  # still on the table
    assert np.linalg.norm(p[:2] - p0[:2]) > 0.003                  # pushed by one pad


def test_off_centre_strong_grasp_centres_the_cube(px100, scene):
    """The same 12 mm offset with 250 PWM: the closing pads centre the cube and lift it."""
    sim = ArmSimulator(px100, scene=scene)
    p0 = np.array(scene.body('red_cube').position)
    _pick(sim, 'red_cube', STRONG, 0.012 * _finger_axis(p0))
    assert sim.held_object() == 'red_cube'


def test_closing_on_air_holds_nothing(px100, scene):
    """Closing 5 cm beside every object: nothing held, every object where it was."""
    sim = ArmSimulator(px100, scene=scene)
    p0 = np.array(scene.body('green_cube').position)
    _pick(sim, 'green_cube', STRONG, (-0.06, 0.0, 0.0))
    assert sim.held_object() is None
    assert sim.finger_position == pytest.approx(sim.linkage.finger_lower, abs=2e-4)
    for body in scene.objects:
        np.testing.assert_allclose(sim.object_poses()[body.name][0], body.position, atol=1e-4)
    assert p0[2] > 0


def test_same_commands_give_identical_object_poses(px100, scene):
    """
    Determinism: the same scene and commands stepped twice -> bit-identical object poses.

    The second run also reads held_object(), energy() and object_poses() every 33 steps, as a
    node publishing the world does: reading never changes the motion.
    """
    results = []
    for probe in (False, True):
        sim = ArmSimulator(px100, scene=scene)
        if probe:
            plain_step, count = sim.step, [0]

            def step():
                plain_step()
                count[0] += 1
                if count[0] % 33 == 0:
                    sim.held_object(), sim.energy(), sim.object_poses()
            sim.step = step
        _pick(sim, 'red_cube')
        _swing(sim)
        _grip(sim, 0.4, 1.0)                   # let go in mid-air: the cube falls and lands
        sim.advance(1000)
        results.append(sim.object_poses())
    assert results[0] == results[1]
    assert results[0]['red_cube'][0][2] < 0.05                    # it fell


def test_scene_api_and_resets(px100, scene):
    """objects(), object_poses() in the base frame, reset() and reset_scene()."""
    sim = ArmSimulator(px100, scene=scene)
    infos = {o.name: o for o in sim.objects()}
    assert set(infos) == {b.name for b in scene.bodies}
    cube = infos['red_cube']
    expected = ('object', 'box', (0.028, 0.028, 0.028), 0.03)
    assert (cube.kind, cube.shape, cube.size, cube.mass) == expected
    assert infos['table'].kind == 'table' and infos['pedestal'].kind == 'fixture'
    poses = sim.object_poses()
    assert set(poses) == set(infos)
    pos, quat = poses['red_cube']
    np.testing.assert_allclose(pos, scene.body('red_cube').position, atol=1e-4)
    np.testing.assert_allclose(quat, scene.body('red_cube').quaternion_xyzw, atol=1e-6)
    _pick(sim, 'red_cube')
    assert sim.held_object() == 'red_cube'
    q_arm = sim.positions()
    sim.reset_scene()                                      # objects back, the arm untouched
    np.testing.assert_allclose(sim.positions(), q_arm)
    np.testing.assert_allclose(sim.object_poses()['red_cube'][0],
                               scene.body('red_cube').position, atol=1e-9)
    _grip(sim, 0.4, 0.5)
    sim.reset()                                            # arm to sleep and objects back
    np.testing.assert_allclose(sim.positions(), px100.sleep)
    np.testing.assert_allclose(sim.object_poses()['red_cube'][0],
                               scene.body('red_cube').position, atol=1e-9)
    sim.advance(500)
    for body in scene.objects:                             # they rest where they were put
        np.testing.assert_allclose(sim.object_poses()[body.name][0], body.position, atol=1e-4)
    assert ArmSimulator(px100).objects() == [] and ArmSimulator(px100).held_object() is None


def test_resting_objects_sleep_and_wake_when_touched_or_moved(px100, scene):
    """Objects at rest sleep (no contacts computed); a written pose or the fingers wake them."""
    sim = ArmSimulator(px100, scene=scene)
    data = sim.mj_data
    trees = {b.name: sim.mj_model.body_treeid[sim.mj_model.body(f'scene/{b.name}').id]
             for b in scene.objects}

    def asleep(name):
        return data.tree_asleep[trees[name]] >= 0

    sim.advance(1000)
    assert all(asleep(name) for name in trees), list(data.tree_asleep)
    assert data.ncon == 0                          # the table contacts of sleepers are skipped
    pos = sim.object_poses()['green_cube'][0]
    _, qadr, _ = next(a for a in sim._object_adr if a[0] == 'green_cube')
    sim._qpos[qadr] += 0.03                        # a written pose wakes the object
    sim.step()
    assert not asleep('green_cube')
    np.testing.assert_allclose(sim.object_poses()['green_cube'][0][0], pos[0] + 0.03,
                               atol=1e-6)
    sim.advance(1000)
    assert asleep('green_cube')
    sim.reset_scene()                              # back where the scene put it, awake
    assert not asleep('green_cube')
    np.testing.assert_allclose(sim.object_poses()['green_cube'][0],
                               scene.body('green_cube').position, atol=1e-9)
    sim.advance(1000)
    assert asleep('red_cube')
    p0 = _pick(sim, 'red_cube')                    # the pads wake it and lift it
    assert not asleep('red_cube') and sim.held_object() == 'red_cube'
    assert sim.object_poses()['red_cube'][0][2] > p0[2] + 0.04


@pytest.mark.parametrize('name', available_scenes())
def test_every_scene_rests_in_the_simulator(px100, name):
    """Each scene file runs: after 1 s with the arm at sleep every object rests where it was."""
    scene = load_scene(name, px100)
    sim = ArmSimulator(px100, scene=scene)
    sim.advance(1000)
    for body in scene.objects:
        np.testing.assert_allclose(sim.object_poses()[body.name][0], body.position, atol=2e-4)
    assert sim.held_object() is None


def test_scene_out_of_reach_is_refused_by_the_simulator(px100, scene):
    """A scene whose objects the robot cannot reach is refused when the simulator is built."""
    far = dataclasses.replace(scene, bodies=tuple(
        dataclasses.replace(b, position=(0.6, 0.0, b.position[2])) if b.name == 'red_cube'
        else b for b in scene.bodies))
    with pytest.raises(InvalidInputError, match="'red_cube'.position.*out of reach"):
        ArmSimulator(px100, scene=far)


def test_control_modes(px100):
    """Velocity, torque and duty modes drive the joint; a mismatched field is refused."""
    sim = ArmSimulator(px100)
    sim.command(['waist', 'shoulder', 'elbow', 'wrist_angle'], [0.0, 0.0, 0.0, 0.0])
    sim.advance(2000)
    sim.set_mode('waist', 'velocity')
    assert sim.mode('waist') == 'velocity' and sim.mode('elbow') == 'position'
    with pytest.raises(InvalidInputError, match="'waist' is in velocity mode"):
        sim.command(['waist'], [0.5])
    with pytest.raises(InvalidInputError, match="'elbow' is in position mode"):
        sim.command(['elbow'], velocity=[0.5])
    with pytest.raises(InvalidInputError, match='exceeds its limit'):
        sim.command(['waist'], velocity=[10.0])
    sim.command(['waist'], velocity=[0.5])
    sim.advance(1000)
    assert sim.qd[0] == pytest.approx(0.5, abs=0.02)
    with pytest.raises(InvalidInputError, match='unknown control mode'):
        sim.set_mode('waist', 'current')
    # torque mode with 0 N*m: the shoulder falls; holding torque = the gravity torque holds it
    sim.set_mode('shoulder', 'torque')
    with pytest.raises(InvalidInputError, match='exceeds the servo maximum'):
        sim.command(['shoulder'], effort=[3.0])
    sim.advance(100)
    assert sim.qd[1] > 0.05
    sim.set_mode('shoulder', 'position')
    sim.command(['shoulder'], [0.0])
    sim.advance(2000)
    sim.set_mode('shoulder', 'torque')
    g = float(sim.dynamics.gravity_torque(sim.q)[1])
    sim.command(['shoulder'], effort=[g])
    sim.advance(300)
    assert abs(sim.qd[1]) < 0.05
    # duty mode: a duty in [-1, 1], outside refused
    sim.set_mode('elbow', 'duty')
    with pytest.raises(InvalidInputError, match='duty'):
        sim.command(['elbow'], effort=[1.5])
    with pytest.raises(InvalidInputError, match="'elbow' is in duty mode"):
        sim.command(['elbow'], [0.1])
    sim.command(['elbow'], effort=[-0.6])
    sim.advance(200)
    assert sim.qd[2] < -0.5
