"""ArmSimulator: the plant + servo + PID loop behaves like the real arm (pure, no ROS)."""
import math

import numpy as np
from px100_control.control.pid import PidGains
from px100_control.errors import InvalidInputError, JointLimitError, UnknownJointError
from px100_control.models.registry import load_robot
from px100_control.sim.simulator import ArmSimulator, parse_setpoints
import pytest

ARM = ['waist', 'shoulder', 'elbow', 'wrist_angle']
HOME = [0.0, 0.0, 0.0, 0.0]


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


@pytest.fixture
def sim(px100):
    return ArmSimulator(px100)


def run(sim, seconds):
    sim.advance(int(round(seconds / sim.dt)))


def trapezoid(q0, q1, T, Ta, t):
    """Return the position and velocity of an Interbotix-style trapezoid profile at time t."""
    vmax = 1.0 / (T - Ta)
    t = min(max(t, 0.0), T)
    if t < Ta:
        s, sd = 0.5 * vmax / Ta * t * t, vmax / Ta * t
    elif t < T - Ta:
        s, sd = 0.5 * vmax * Ta + vmax * (t - Ta), vmax
    else:
        r = T - t
        s, sd = 1.0 - 0.5 * vmax / Ta * r * r, vmax / Ta * r
    return q0 + s * (q1 - q0), sd * (q1 - q0)


def test_starts_at_the_sleep_pose(sim, px100):
    """Joint states start at sleep, gripper 0 rad, fingers +-0.01949 m, Interbotix order."""
    js = sim.joint_state()
    assert js.name == ('waist', 'shoulder', 'elbow', 'wrist_angle', 'gripper', 'left_finger',
                       'right_finger')
    np.testing.assert_allclose(js.position[:4], px100.sleep)
    assert js.position[4] == 0.0
    assert js.position[5] == pytest.approx(0.019494, abs=1e-6)
    assert js.position[6] == -js.position[5]
    assert len(js.velocity) == len(js.effort) == 7


@pytest.mark.parametrize('pose', [None, HOME, [1.0, 0.4, -0.6, 0.9], [-2.0, -1.2, 1.0, -1.0]])
def test_default_gains_hold_within_one_milliradian(px100, pose):
    """Under gravity and friction the default PID holds every joint within 1 mrad."""
    sim = ArmSimulator(px100)
    target = px100.sleep if pose is None else np.array(pose)
    sim.command(ARM, list(target))
    run(sim, 4.0)
    err = np.abs(np.array(sim.q) - target)
    assert err.max() < 1e-3, err
    assert np.abs(sim.qd).max() < 1e-3
    # gravity is really loading the joints: the servos push back (effort != 0)
    if pose == HOME:
        assert abs(sim.effort[1]) > 0.2


def test_trapezoid_move_tracks_closely(px100):
    """A 2 s Interbotix-style trapezoid (0.3 s accel) is tracked within 10 mrad, ends < 1 mrad."""
    sim = ArmSimulator(px100)
    run(sim, 2.0)                            # the servos have settled at sleep
    q0 = np.array(px100.sleep)
    q1 = np.array([1.0, 0.3, -0.4, 0.5])
    worst = 0.0
    for k in range(int(3.0 / sim.dt)):
        q, qd = trapezoid(q0, q1, 2.0, 0.3, k * sim.dt)
        if k % 5 == 0:                       # setpoints at 200 Hz, as trajectory_server sends
            sim.command(ARM, list(q), list(qd))
        sim.step()
        worst = max(worst, float(np.abs(np.array(sim.q) - q).max()))
    assert worst < 0.010
    assert np.abs(np.array(sim.q) - q1).max() < 1e-3


def test_factory_gains_sag_under_gravity(px100):
    """P-only XL430 factory gains (640/0/4000) leave a visible sag, as on the real arm."""
    sim = ArmSimulator(px100, gains={j: PidGains.from_dynamixel(640, 0, 4000, u_clamp=1.4)
                                     for j in ARM})
    sim.command(ARM, HOME)
    run(sim, 3.0)
    sag = np.array(sim.q) - np.array(HOME)
    assert sag[1] > 0.03            # shoulder droops forward by degrees (manipulators#217)
    assert sag[2] > 0.03


def test_torque_off_makes_the_arm_fall(px100):
    """With torque off the arm falls under gravity until the joint limits stop it."""
    sim = ArmSimulator(px100)
    sim.command(ARM, HOME)
    run(sim, 2.0)
    sim.set_torque_enabled(False)
    run(sim, 0.2)
    assert sim.q[1] > 0.05 and sim.qd[1] > 0.3          # shoulder falling forward
    assert all(e == 0.0 for e in sim.effort)
    run(sim, 3.0)
    assert sim.q[1] == pytest.approx(px100.upper[1], abs=1e-4)   # resting on the hard stop
    # torque back on: the servos hold where the arm is now
    sim.set_torque_enabled(True)
    held = list(sim.q)
    run(sim, 1.0)
    assert np.abs(np.array(sim.q) - held).max() < 2e-3


def test_speed_and_torque_limits_hold_on_a_big_step(px100):
    """A large step never exceeds the velocity limit (pi rad/s) or the stall torque."""
    sim = ArmSimulator(px100)
    sim.command(ARM, [3.0, 1.5, -1.5, 2.0])
    top_speed, top_drive = 0.0, 0.0
    for _ in range(2000):
        sim.step()
        top_speed = max(top_speed, float(np.abs(sim.qd).max()))
        top_drive = max(top_drive, max(abs(e + 1.4 / 6.0 * v)
                                       for e, v in zip(sim.effort, sim.qd)))
    assert top_speed <= math.pi + 1e-9
    assert top_speed > 3.0                    # it did run at the limit
    assert top_drive <= 1.4 + 1e-9


def test_out_of_limit_setpoints_are_refused_and_never_executed(sim):
    """Position outside the URDF limits or velocity above the limit: refused, nothing applied."""
    run(sim, 2.0)
    before = list(sim.q_ref)
    with pytest.raises(JointLimitError, match='shoulder'):
        sim.command(['waist', 'shoulder'], [0.5, 2.5])
    with pytest.raises(InvalidInputError, match='velocity'):
        sim.command(['elbow'], [0.1], [10.0])
    with pytest.raises(JointLimitError, match='gripper'):
        sim.command(['gripper'], [2.0])
    with pytest.raises(InvalidInputError, match='exceeds'):
        sim.command(['gripper'], effort=[5.0])
    assert sim.q_ref == before
    run(sim, 0.5)
    np.testing.assert_allclose(sim.q, before, atol=1e-3)


@pytest.mark.parametrize('args, error, words', [
    (([], [1.0]), InvalidInputError, 'no joint'),
    ((['waist', 'waist'], [0.0, 0.1]), InvalidInputError, 'duplicate'),
    ((['wrist_rotate'], [0.0]), UnknownJointError, 'wrist_rotate'),
    ((['waist', 'elbow'], [0.0]), InvalidInputError, '2 joint names but 1 position'),
    ((['waist'], [float('nan')]), InvalidInputError, 'NaN'),
    ((['waist'], [float('inf')]), InvalidInputError, 'NaN or inf'),
    ((['waist'], [], [], []), InvalidInputError, 'neither'),
    ((['gripper'], [0.1], [], [0.2]), InvalidInputError, 'both'),
    ((['waist'], [], [0.1]), InvalidInputError, 'velocity'),
    ((['waist'], [], [], [0.2]), InvalidInputError, 'only for the gripper'),
])
def test_malformed_setpoints_are_refused_with_a_reason(sim, args, error, words):
    """Every malformed setpoint raises with a reason that names the problem."""
    names, *arrays = args
    with pytest.raises(error, match=words):
        parse_setpoints(names, *arrays, known=sim.command_joints, gripper='gripper')


def test_gripper_effort_opens_closes_and_grasps(px100):
    """Effort control drives the fingers to their limits; an object stops them (a grasp)."""
    sim = ArmSimulator(px100)
    squeeze = 250 / 885 * 1.4
    sim.command(['gripper'], effort=[squeeze])
    run(sim, 2.0)
    assert sim.finger_position == pytest.approx(0.037, abs=1e-6)
    sim.command(['gripper'], effort=[-squeeze])
    run(sim, 2.0)
    assert sim.finger_position == pytest.approx(0.015, abs=1e-6)
    sim.command(['gripper'], effort=[squeeze])
    run(sim, 2.0)
    sim.set_object_width(0.040)
    sim.command(['gripper'], effort=[-squeeze])
    run(sim, 2.0)
    js = sim.joint_state()
    assert js.position[5] == pytest.approx(0.020, abs=1e-6)        # stopped by the object
    assert js.position[6] == pytest.approx(-0.020, abs=1e-6)
    assert js.velocity[4] == pytest.approx(0.0, abs=1e-6)
    assert js.effort[4] == pytest.approx(-squeeze)                  # still squeezing
    assert js.effort[5] < -1.0                                      # finger force [N]
    # a small effort stays in the friction dead band (as the real PWM gripper)
    sim2 = ArmSimulator(px100)
    sim2.command(['gripper'], effort=[0.05])
    run(sim2, 0.5)
    assert sim2.joint_state().position[4] == pytest.approx(0.0, abs=1e-4)


def test_gripper_position_control(px100):
    """A gripper position setpoint [rad] is reached by its PID."""
    sim = ArmSimulator(px100)
    sim.command(['gripper'], [0.8])
    run(sim, 2.0)
    assert sim.joint_state().position[4] == pytest.approx(0.8, abs=2e-3)


def test_reset_returns_to_sleep(px100):
    """reset() puts the arm back at sleep with cleared integrators and torque on."""
    sim = ArmSimulator(px100)
    sim.command(ARM, HOME)
    run(sim, 1.0)
    sim.set_torque_enabled(False)
    sim.reset()
    np.testing.assert_allclose(sim.q, px100.sleep)
    assert sim.torque_enabled
    # integrators start holding the weight at sleep: no sag, no transient
    gravity = sim.dynamics.gravity_torque(px100.sleep)
    np.testing.assert_allclose([p.gains.i * p.integral for p in sim.pids], gravity, atol=1e-12)
    run(sim, 1.0)
    np.testing.assert_allclose(sim.q, px100.sleep, atol=1e-4)


def test_semi_implicit_euler_keeps_energy_without_losses(px100):
    """Torque off, no damping or friction: the integrator's energy error stays below 0.5 %."""
    sim = ArmSimulator(px100)
    sim.damping = [0.0] * 4
    sim.friction = [0.0] * 4
    sim.hold([0.0, 0.3, -0.5, 0.4])
    sim.set_torque_enabled(False)
    sim.qd = [1.0, -0.5, 0.8, -1.0]
    e0 = sim.energy()
    energies = []
    for _ in range(300):
        sim.step()
        energies.append(sim.energy())
    assert np.abs(sim.qd).max() > 0.5                   # still moving
    assert max(abs(e - e0) for e in energies) < 5e-3 * abs(e0)


def test_simulation_is_deterministic(px100):
    """Same commands, same steps -> bit-identical states (time is only what you step)."""
    states = []
    for _ in range(2):
        sim = ArmSimulator(px100)
        sim.command(ARM, [0.5, 0.2, 0.1, -0.3])
        run(sim, 0.5)
        states.append((list(sim.q), list(sim.qd), sim.time))
    assert states[0] == states[1]
    assert states[0][2] == pytest.approx(0.5)


@pytest.mark.parametrize('name', ['rrrp', 'rrrr', 'myarm300pi', 'wx250s'])
def test_other_robots_run_and_hold(name):
    """Every other robot model runs in the same simulator and holds a pose."""
    model = load_robot(name)
    sim = ArmSimulator(model)
    target = np.clip(np.array(model.home, float), model.lower + 0.05, model.upper - 0.05)
    sim.command(list(model.joint_names), list(target))
    run(sim, 2.0)
    assert np.all(np.isfinite(sim.q))
    assert np.abs(np.array(sim.q) - target).max() < 0.02
    js = sim.joint_state()
    assert len(js.name) == len(js.position) == model.dof + (3 if model.gripper else 0)
