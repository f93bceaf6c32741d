"""
The gripper and the core (emulated xs_sdk services) against real nodes.

Gripper: PWM pressure -> effort [N*m] at the edge, release opens / grasp closes to the finger
limits, an object between the fingers stops them (sim_driver ``object_width``), ROS 1
open()/close(). Core: robot info, registers, operating modes, torque, reboot, raw commands and
trajectories, joint-state getters.
"""
import math

from client_support import ACCEL_TIME, MOVING_TIME, pause, wait_until
import numpy as np
from px100_control.client.gripper import pwm_to_effort
import pytest

pytestmark = pytest.mark.ros

LOWER, UPPER = 0.015, 0.037


def sim_driver(bot) -> str:
    """Return the running sim_driver's full node name."""
    name = bot.core.find_node('sim_driver')
    assert name is not None, 'no sim_driver node in the graph'
    return name


def test_gripper_release_and_grasp_reach_the_finger_limits(bot):
    """release()/open() open to the upper finger limit, grasp()/close() close to the lower one."""
    g = bot.gripper
    assert g.gripper_value == pytest.approx(250.0)
    assert g.left_finger_lower_limit == pytest.approx(LOWER)
    assert g.left_finger_upper_limit == pytest.approx(UPPER)
    g.release(delay=0.1)
    assert wait_until(lambda: g.get_finger_position() > UPPER - 5e-4, 5.0), \
        g.get_finger_position()
    # the 50 Hz gripper_state timer stops the drive once the limit is reached
    assert wait_until(lambda: not g.gripper_moving, 1.0)
    g.grasp(delay=0.1)
    assert wait_until(lambda: g.get_finger_position() < LOWER + 5e-4, 5.0), \
        g.get_finger_position()
    assert wait_until(lambda: not g.gripper_moving, 1.0)
    assert g.get_gripper_position() < 0.0  # the horn angle of a closed gripper
    assert math.isfinite(g.get_gripper_velocity()) and math.isfinite(g.get_gripper_effort())
    # ROS 1 names (seed 000's scripts use them)
    g.open(delay=0.1)
    assert wait_until(lambda: g.get_finger_position() > UPPER - 5e-4, 5.0)
    g.close(delay=0.1)
    assert wait_until(lambda: g.get_finger_position() < LOWER + 5e-4, 5.0)


def test_grasp_an_object_and_pressure_maps_to_effort(bot):
    """
    An object stops the closing fingers at its width; the squeeze is the pressure's torque.

    gripper_pressure p -> PWM 150 + p * 200 -> effort pwm / 885 * 1.4 N*m (sim_driver SI).
    """
    g = bot.gripper
    g.release(delay=0.1)
    assert wait_until(lambda: g.get_finger_position() > UPPER - 5e-4, 5.0)
    width = 0.040
    assert bot.core.set_remote_parameters(sim_driver(bot), {'object_width': width}) == ''
    try:
        for pressure in (0.5, 1.0):
            g.set_pressure(pressure)
            assert g.gripper_value == pytest.approx(150 + 200 * pressure)
            g.grasp(delay=0.1)
            assert wait_until(lambda: abs(g.get_finger_width() - width) < 1e-3, 5.0), \
                g.get_finger_width()
            pause(bot, 0.3)
            # blocked by the object: still squeezing, never reaches the closed limit
            assert g.gripper_moving
            assert g.get_finger_width() == pytest.approx(width, abs=1e-3)
            expected = -pwm_to_effort(g.gripper_value)
            assert g.get_gripper_effort() == pytest.approx(expected, abs=0.05)
            g.release(delay=0.1)
            assert wait_until(lambda: g.get_finger_position() > UPPER - 5e-4, 5.0)
    finally:
        g.set_pressure(0.5)
        bot.core.set_remote_parameters(sim_driver(bot), {'object_width': 0.0})


def test_robot_info_is_the_urdf(bot):
    """robot_get_robot_info: group 'arm' limits/sleep; 'single' gripper describes left_finger."""
    info = bot.core.robot_get_robot_info('group', 'arm')
    assert info.num_joints == 4 and info.mode == 'position' and info.profile_type == 'time'
    assert info.joint_upper_limits == pytest.approx([math.pi - 1e-5, 1.867502, 1.605703,
                                                     2.146755], abs=1e-5)
    assert info.joint_velocity_limits == pytest.approx([math.pi] * 4)
    js = bot.core.robot_get_joint_states()
    assert [js.name[i] for i in info.joint_state_indices] == info.joint_names
    g = bot.core.robot_get_robot_info('single', 'gripper')
    assert g.mode == 'pwm' and g.num_joints == 1
    assert (g.joint_lower_limits, g.joint_upper_limits) == (pytest.approx([LOWER]),
                                                            pytest.approx([UPPER]))
    assert js.name[g.joint_state_indices[0]] == 'left_finger'
    assert g.joint_sleep_positions[0] == pytest.approx(0.01949, abs=1e-4)
    with pytest.raises(Exception, match='no group named'):
        bot.core.robot_get_robot_info('group', 'legs')


def test_registers_and_operating_modes(bot):
    """Registers are stored per motor; unsupported modes are refused (the group reports it)."""
    core = bot.core
    core.robot_set_motor_registers('single', 'waist', 'Goal_Current', 77)
    assert core.robot_get_motor_registers('single', 'waist', 'Goal_Current') == [77]
    assert core.robot_get_motor_registers('single', 'elbow', 'Goal_Current') == [0]
    assert core.robot_set_operating_modes('group', 'arm', 'linear_position') is False
    assert core.robot_get_robot_info('group', 'arm').mode == 'linear_position'  # as xs_sdk
    assert core.robot_set_operating_modes('group', 'arm', 'position', 'time', 1500, 250)
    assert core.robot_get_robot_info('group', 'arm').mode == 'position'
    assert core.robot_get_motor_registers('group', 'arm', 'Profile_Velocity') == [1500] * 4
    core.robot_set_operating_modes('single', 'gripper', 'pwm')
    core.robot_set_motor_pid_gains('group', 'arm', kp_pos=800)  # logged as not emulated
    bot.arm.set_trajectory_time(1.0, 0.2)
    bot.arm.set_trajectory_time(MOVING_TIME, ACCEL_TIME)


def test_torque_off_then_capture(bot):
    """Torque off (sim_driver service): the arm falls under gravity; capture_joint_positions."""
    bot.arm.go_to_home_pose()
    before = np.array(bot.arm.get_joint_positions())
    assert bot.core.robot_torque_enable('group', 'all', False) is True
    try:
        assert wait_until(lambda: np.max(np.abs(np.array(bot.arm.get_joint_positions())
                                                - before)) > 0.05, 5.0)
    finally:
        assert bot.core.robot_torque_enable('group', 'all', True) is True
    pause(bot, 0.3)
    bot.arm.capture_joint_positions()
    np.testing.assert_allclose(bot.arm.get_joint_commands(), bot.arm.get_joint_positions(),
                               atol=0.02)
    np.testing.assert_allclose(bot.arm.get_ee_pose_command(),
                               bot.core.model.fk(bot.arm.get_joint_commands()), atol=1e-12)
    bot.core.robot_reboot_motors('single', 'gripper', True)
    # after torque on, the arm moves again
    assert bot.arm.set_joint_positions([0, 0, 0, 0], moving_time=1.0)
    np.testing.assert_allclose(bot.arm.get_joint_positions(), [0] * 4, atol=0.005)
    bot.arm.set_trajectory_time(MOVING_TIME, ACCEL_TIME)


def test_raw_commands_and_trajectory(bot):
    """robot_write_commands / _joint_command / _trajectory move the arm (non-blocking)."""
    core = bot.core
    bot.arm.go_to_home_pose()
    core.robot_set_motor_registers('group', 'arm', 'Profile_Velocity', 600)
    core.robot_set_motor_registers('group', 'arm', 'Profile_Acceleration', 100)
    core.robot_write_commands('arm', [0.2, 0.1, 0.1, 0.1])
    assert wait_until(lambda: np.allclose(bot.arm.get_joint_positions(), [0.2, 0.1, 0.1, 0.1],
                                          atol=0.005), 5.0)
    core.robot_write_joint_command('waist', -0.2)
    assert wait_until(lambda: abs(bot.arm.get_joint_positions()[0] + 0.2) < 0.005, 5.0)
    core.robot_write_trajectory('group', 'arm', 'position', [
        {0.0: [-0.2, 0.1, 0.1, 0.1]}, {0.5: [0.0, 0.2, 0.0, 0.0]}, {1.0: [0.3, 0.0, 0.0, 0.0]}])
    assert wait_until(lambda: np.allclose(bot.arm.get_joint_positions(), [0.3, 0, 0, 0],
                                          atol=0.005), 4.0)
    core.robot_write_commands('arm', [0.0, 0.0])  # wrong size: logged, ignored
    single = core.robot_get_single_joint_state('waist')
    assert set(single) == {'position', 'velocity', 'effort'}
    assert single['position'] == pytest.approx(0.3, abs=0.005)
    js = core.robot_get_joint_states()
    assert list(js.name[:5]) == ['waist', 'shoulder', 'elbow', 'wrist_angle', 'gripper']
    assert len(js.velocity) == len(js.name) and len(js.effort) == len(js.name)
    bot.arm.capture_joint_positions()
    bot.arm.set_trajectory_time(MOVING_TIME, ACCEL_TIME)


def test_grasp_timing_from_the_xl430_figures_and_early_arm_move_warning(bot, capfd):
    """travel_time follows the XL430 figures; an arm move during closing warns, not after."""
    g = bot.gripper
    no_load = 57 * 2 * math.pi / 60  # XL430-W250, 11.1 V
    assert g.travel_time(250) == pytest.approx(g.horn_travel / (250 / 885 * no_load))
    assert 0.9 < g.travel_time(250) < 1.1 and g.travel_time(150) > g.travel_time(350)
    g.release(2.5)
    capfd.readouterr()
    g.grasp(0.2)  # far too short: the fingers are still closing
    # the warning reads the fingers' speed from joint_states: wait until this process has one
    # of the closing (about a third of the 1 s closing, at BOT_SPEED)
    assert wait_until(lambda: abs(g.get_gripper_velocity()) > 0.1, 3.0), \
        g.get_gripper_velocity()
    assert bot.arm.set_single_joint_position('waist', 0.2)
    err = capfd.readouterr().err
    assert 'still closing on nothing' in err and 'give grasp() a longer delay' in err, err
    assert bot.arm.last_error == ''  # a warning, the move went ahead
    g.release(2.5)
    g.grasp(2.5)  # closed by now: no warning
    capfd.readouterr()
    assert bot.arm.set_single_joint_position('waist', 0.0)
    assert 'still closing' not in capfd.readouterr().err
    g.release(2.5)


def _close_time(g, pressure: float) -> float:
    """Return the simulated time [s] the open fingers take to reach the closed limit."""
    def stamp() -> float:
        s = g.core.robot_get_joint_states().header.stamp
        return s.sec + 1e-9 * s.nanosec

    g.set_pressure(pressure)
    g.release(0.1)
    assert wait_until(lambda: g.get_finger_position() > UPPER - 5e-4, 6.0)
    assert wait_until(lambda: not g.gripper_moving, 1.0)
    t0 = stamp()
    g.grasp(0.0)
    assert wait_until(lambda: g.get_finger_position() < LOWER + 5e-4, 8.0)
    return stamp() - t0  # joint_states stamps: sim_driver's simulated clock


def test_measured_close_time_per_pressure(bot):
    """
    Open to closed on the simulated XL430: never faster than its no-load figure allows.

    Prints the measured times (README states the default pressure's figure).
    """
    g = bot.gripper
    try:
        times = {p: _close_time(g, p) for p in (0.0, 0.5, 1.0)}
    finally:
        g.set_pressure(0.5)
        g.release(0.1)
    print('close times [s]: ' + ', '.join(
        f'pressure {p} ({150 + 200 * p:.0f} PWM): {t:.2f} (XL430 no-load bound '
        f'{g.travel_time(150 + 200 * p):.2f})' for p, t in times.items()))
    for p, t in times.items():
        assert g.travel_time(150 + 200 * p) <= t < 3.0 * g.travel_time(150 + 200 * p), (p, t)
    assert times[0.0] > times[0.5] > times[1.0]


def test_interrupt_stops_moving_fingers_and_keeps_a_grasp(bot):
    """
    Ctrl-C (core.interrupt()) with the gripper driven in pwm mode.

    Fingers closing on nothing stop where they are (effort 0); fingers squeezing an object keep
    squeezing it (dropping it is not safe); the report line says which.
    """
    g = bot.gripper
    g.set_pressure(0.0)  # 150 PWM: slow enough to interrupt mid-way
    try:
        g.release(0.1)
        assert wait_until(lambda: g.get_finger_position() > UPPER - 5e-4, 6.0)
        assert wait_until(lambda: not g.gripper_moving, 1.0)
        g.grasp(0.0)
        assert wait_until(lambda: g.get_finger_position() < UPPER - 0.004, 3.0)
        report = bot.core.interrupt(settle=0.0)
        assert 'gripper stopped at' in report, report
        assert wait_until(lambda: abs(g.get_gripper_velocity()) < 0.01, 3.0), \
            g.get_gripper_velocity()
        pause(bot, 0.1)
        stopped = g.get_finger_position()
        pause(bot, 0.7)
        assert abs(g.get_finger_position() - stopped) < 3e-4
        assert LOWER + 0.002 < stopped < UPPER - 0.002, stopped
        assert abs(g.get_gripper_effort()) < 0.02
        # squeezing an object: it keeps the grasp
        assert bot.core.set_remote_parameters(sim_driver(bot), {'object_width': 0.040}) == ''
        g.release(0.1)
        assert wait_until(lambda: g.get_finger_position() > UPPER - 5e-4, 6.0)
        g.grasp(0.0)
        assert wait_until(lambda: abs(g.get_finger_width() - 0.040) < 1e-3, 8.0)
        pause(bot, 0.5)
        report = bot.core.interrupt(settle=0.0)
        assert 'gripper keeps squeezing an object' in report and '150 PWM' in report, report
        pause(bot, 0.5)
        assert g.get_finger_width() == pytest.approx(0.040, abs=1e-3)
        assert g.get_gripper_effort() == pytest.approx(-pwm_to_effort(150), abs=0.05)
    finally:
        bot.core.set_remote_parameters(sim_driver(bot), {'object_width': 0.0})
        g.set_pressure(0.5)
        g.release(0.1)
        wait_until(lambda: g.get_finger_position() > UPPER - 5e-4, 6.0)
