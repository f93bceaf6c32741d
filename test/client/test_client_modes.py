"""
Operating modes emulated as xs_sdk does, on real in-process nodes (the ``bot`` fixture).

velocity commands are rad/s, current commands mA (torque through the XL430 figures), pwm
commands PWM units; positions for a joint in another mode are refused, never executed as
something else; a mode the simulation cannot emulate is refused with the reason.
"""
import time

from client_support import pause, wait_until
import pytest

pytestmark = pytest.mark.ros


@pytest.fixture
def arm_at_sleep(bot):
    """Start at the sleep pose in position mode; put everything back afterwards."""
    bot.arm.go_to_sleep_pose()
    yield bot
    bot.core.robot_set_operating_modes('group', 'all', 'position')
    bot.core.robot_set_operating_modes('single', 'gripper', 'pwm')
    bot.core.robot_reset()
    pause(0.3)
    bot.arm.capture_joint_positions()


def _driver_mode(bot, joint):
    return bot.core.get_remote_parameter(bot.core.find_node('sim_driver'),
                                         f'operating_mode.{joint}')


def test_unknown_mode_is_refused_and_nothing_changes(arm_at_sleep, capfd):
    """'linear_position' on the arm: False, an error naming the mode, still position."""
    bot = arm_at_sleep
    assert bot.core.robot_set_operating_modes('group', 'arm', 'linear_position') is False
    assert "Operating mode 'linear_position' is not emulated" in capfd.readouterr().err
    assert bot.core.robot_get_robot_info('group', 'arm').mode == 'position'
    assert _driver_mode(bot, 'shoulder') == ''
    assert bot.arm.set_single_joint_position('waist', 0.3)


def test_velocity_mode_turns_at_the_commanded_speed(arm_at_sleep):
    """Waist in velocity mode: 0.5 rad/s for 1 s turns it ~0.5 rad; 0 stops it."""
    bot = arm_at_sleep
    q0 = bot.arm.get_joint_positions()[0]
    assert bot.core.robot_set_operating_modes('single', 'waist', 'velocity')
    assert _driver_mode(bot, 'waist') == 'velocity'
    bot.core.robot_write_joint_command('waist', 0.5)
    time.sleep(1.0)
    bot.core.robot_write_joint_command('waist', 0.0)
    assert wait_until(lambda: abs(bot.arm.get_joint_velocities()[0]) < 0.02, 1.0)
    turned = bot.arm.get_joint_positions()[0] - q0
    assert 0.35 < turned < 0.65, turned


def test_current_mode_is_torque_and_positions_are_refused(arm_at_sleep):
    """Waist in current mode: 150 mA turns it; a position command is refused, not executed."""
    bot = arm_at_sleep
    q0 = bot.arm.get_joint_positions()
    assert bot.core.robot_set_operating_modes('single', 'waist', 'current')
    assert _driver_mode(bot, 'waist') == 'torque'
    assert bot.arm.set_single_joint_position('waist', 1.0) is False
    assert 'not in a position mode' in bot.arm.last_error
    bot.core.robot_write_joint_command('waist', 1.0)  # 1 mA: far below friction
    pause(0.5)
    assert abs(bot.arm.get_joint_positions()[0] - q0[0]) < 0.02  # not 1 rad
    bot.core.robot_write_joint_command('waist', 150.0)  # 0.16 N*m > 0.1 N*m friction
    pause(0.8)
    bot.core.robot_write_joint_command('waist', 0.0)
    assert bot.arm.get_joint_positions()[0] - q0[0] > 0.05
    # beyond the XL430's stall current: refused, nothing sent
    bot.core.robot_write_joint_command('waist', 5000.0)
    assert bot.core.robot_set_operating_modes('single', 'waist', 'position')
    q = bot.arm.get_joint_positions()
    pause(0.5)
    assert abs(bot.arm.get_joint_positions()[0] - q[0]) < 0.02  # position mode holds


def test_pwm_mode_and_the_driver_refuses_positions(arm_at_sleep):
    """Waist in pwm mode turns with PWM 150; a raw position setpoint is refused by sim_driver."""
    bot = arm_at_sleep
    q0 = bot.arm.get_joint_positions()[0]
    assert bot.core.robot_set_operating_modes('single', 'waist', 'pwm')
    assert _driver_mode(bot, 'waist') == 'duty'
    bot.core.publish_setpoints(['waist'], positions=[1.0])  # as a confused script would
    pause(0.5)
    assert abs(bot.arm.get_joint_positions()[0] - q0) < 0.02
    bot.core.robot_write_joint_command('waist', 150)
    pause(0.8)
    bot.core.robot_write_joint_command('waist', 0)
    assert bot.arm.get_joint_positions()[0] - q0 > 0.2
