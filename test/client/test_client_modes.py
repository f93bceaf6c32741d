"""
Operating modes emulated as xs_sdk does, on real in-process nodes (the ``bot`` fixture).

velocity commands are rad/s, current commands mA (torque through the px100's XL430 figures), pwm
commands PWM units; positions for a joint in another mode are refused, never executed as
something else; a mode the simulation cannot emulate is refused with the reason, and so are
the commands of those joints until a supported mode is set. The core's position writes last
the Profile_Velocity register, stretched to the velocity limits when it is too short (0 = no
profile).
"""
import time

from client_support import ACCEL_TIME, MOVING_TIME, pause, wait_until
import numpy as np
import pytest

pytestmark = pytest.mark.ros


@pytest.fixture
def arm_at_sleep(bot):
    """Start at the sleep pose in position mode; put everything back afterwards."""
    bot.arm.go_to_sleep_pose()
    yield bot
    bot.arm.set_trajectory_time(MOVING_TIME, ACCEL_TIME)
    bot.core.robot_set_operating_modes('group', 'all', 'position')
    bot.core.robot_set_operating_modes('single', 'gripper', 'pwm')
    bot.core.robot_reset()
    pause(bot, 0.3)
    bot.arm.capture_joint_positions()


def _driver_mode(bot, joint):
    return bot.core.get_remote_parameter(bot.core.find_node('sim_driver'),
                                         f'operating_mode.{joint}')


def _still(bot, seconds: float = 0.8) -> float:
    """Return how far [rad] any arm joint moved during ``seconds``."""
    q0 = np.array(bot.arm.get_joint_positions())
    pause(bot, seconds)
    return float(np.max(np.abs(np.array(bot.arm.get_joint_positions()) - q0)))


def test_refused_mode_blocks_the_group_until_a_valid_mode(arm_at_sleep, capfd):
    """
    'linear_position' on the arm: False with the reason; then no command of the arm runs.

    As xs_sdk's group: its mode is the refused one, so robot_write_commands, single-joint
    commands, trajectories and the arm interface's moves are refused with a reason naming it
    (never executed as positions); sim_driver keeps its mode. 'position' lifts the block.
    """
    bot = arm_at_sleep
    assert bot.core.robot_set_operating_modes('group', 'arm', 'linear_position') is False
    err = capfd.readouterr().err
    assert "Operating mode 'linear_position' is not emulated" in err and 'refused' in err
    assert bot.core.robot_get_robot_info('group', 'arm').mode == 'linear_position'
    assert _driver_mode(bot, 'shoulder') == ''
    bot.core.robot_write_commands('arm', [0.0, 1.0, 1.0, 0.0])
    bot.core.robot_write_joint_command('waist', 0.5)
    bot.core.robot_write_trajectory('group', 'arm', 'position',
                                    [{0.0: [0.0] * 4}, {1.0: [0.5, 0.0, 0.0, 0.0]}])
    assert _still(bot) < 0.01
    err = capfd.readouterr().err
    assert err.count("operating mode 'linear_position' of waist") >= 3, err
    assert 'Will not execute' in err
    assert bot.arm.set_single_joint_position('waist', 0.3) is False
    assert "'linear_position'" in bot.arm.last_error and 'refused' in bot.arm.last_error
    assert _still(bot, 0.3) < 0.01
    # an unknown name on one motor blocks that motor only
    assert bot.core.robot_set_operating_modes('group', 'arm', 'position')
    assert bot.core.robot_set_operating_modes('single', 'elbow', 'torque') is False
    bot.core.robot_write_joint_command('elbow', 1.0)
    assert _still(bot) < 0.01
    assert "operating mode 'torque' of elbow was refused" in capfd.readouterr().err
    assert bot.core.robot_set_operating_modes('single', 'elbow', 'position')
    bot.core.robot_write_commands('arm', [0.3, -1.0, 1.0, 0.5])
    assert wait_until(lambda: abs(bot.arm.get_joint_positions()[0] - 0.3) < 0.02, 5.0)


def test_velocity_mode_turns_at_the_commanded_speed(arm_at_sleep):
    """Waist in velocity mode: 0.5 rad/s for 1 s turns it ~0.5 rad; 0 stops it."""
    bot = arm_at_sleep
    q0 = bot.arm.get_joint_positions()[0]
    assert bot.core.robot_set_operating_modes('single', 'waist', 'velocity')
    assert _driver_mode(bot, 'waist') == 'velocity'
    bot.core.robot_write_joint_command('waist', 0.5)
    speed = []
    assert wait_until(lambda: speed.append(bot.arm.get_joint_velocities()[0]) or
                      abs(speed[-1] - 0.5) < 0.03, 3.0), speed[-20:]
    pause(bot, 1.0)
    bot.core.robot_write_joint_command('waist', 0.0)
    assert wait_until(lambda: abs(bot.arm.get_joint_velocities()[0]) < 0.02, 1.0)
    # about 0.5 rad; the commands' wall-time delays count BOT_SPEED times over in this window
    turned = bot.arm.get_joint_positions()[0] - q0
    assert 0.4 < turned < 1.0, turned


def test_current_mode_is_torque_and_positions_are_refused(arm_at_sleep):
    """Waist in current mode: 150 mA turns it; a position command is refused, not executed."""
    bot = arm_at_sleep
    q0 = bot.arm.get_joint_positions()
    assert bot.core.robot_set_operating_modes('single', 'waist', 'current')
    assert _driver_mode(bot, 'waist') == 'torque'
    assert bot.arm.set_single_joint_position('waist', 1.0) is False
    assert 'not in a position mode' in bot.arm.last_error
    bot.core.robot_write_joint_command('waist', 1.0)  # 1 mA: far below friction
    pause(bot, 0.5)
    assert abs(bot.arm.get_joint_positions()[0] - q0[0]) < 0.02  # not 1 rad
    bot.core.robot_write_joint_command('waist', 150.0)  # 0.16 N*m > 0.1 N*m friction
    pause(bot, 0.8)
    bot.core.robot_write_joint_command('waist', 0.0)
    assert bot.arm.get_joint_positions()[0] - q0[0] > 0.05
    # beyond the XL430's stall current: refused, nothing sent
    bot.core.robot_write_joint_command('waist', 5000.0)
    assert bot.core.robot_set_operating_modes('single', 'waist', 'position')
    q = bot.arm.get_joint_positions()
    pause(bot, 0.5)
    assert abs(bot.arm.get_joint_positions()[0] - q[0]) < 0.02  # position mode holds


def test_pwm_mode_and_the_driver_refuses_positions(arm_at_sleep):
    """Waist in pwm mode turns with PWM 150; a raw position setpoint is refused by sim_driver."""
    bot = arm_at_sleep
    q0 = bot.arm.get_joint_positions()[0]
    assert bot.core.robot_set_operating_modes('single', 'waist', 'pwm')
    assert _driver_mode(bot, 'waist') == 'duty'
    bot.core.publish_setpoints(['waist'], positions=[1.0])  # as a confused script would
    pause(bot, 0.5)
    assert abs(bot.arm.get_joint_positions()[0] - q0) < 0.02
    bot.core.robot_write_joint_command('waist', 150)
    pause(bot, 0.8)
    bot.core.robot_write_joint_command('waist', 0)
    assert bot.arm.get_joint_positions()[0] - q0 > 0.2


def test_core_position_writes_with_profile_velocity_zero(arm_at_sleep, capfd):
    """
    set_trajectory_time(0) then robot_write_commands: a move at the velocity limits.

    Profile_Velocity 0 is the servos' "no profile"; a too short profile is stretched with a
    warning; positions outside the limits are refused with an error and nothing moves.
    """
    bot = arm_at_sleep
    bot.arm.set_trajectory_time(0.0, 0.0)
    assert bot.core.robot_get_motor_registers('group', 'arm', 'Profile_Velocity') == [0] * 4
    capfd.readouterr()
    t0 = time.monotonic()
    bot.core.robot_write_commands('arm', [0.6, -1.0, 1.0, 0.5])
    assert wait_until(lambda: abs(bot.arm.get_joint_positions()[0] - 0.6) < 0.02, 3.0)
    assert time.monotonic() - t0 < 5.0  # a hang; 0.88 rad at pi rad/s: ~0.35 s + settling
    bot.core.robot_write_joint_command('waist', -0.4)
    assert wait_until(lambda: abs(bot.arm.get_joint_positions()[0] + 0.4) < 0.02, 3.0)
    assert '[ERROR]' not in capfd.readouterr().err
    bot.arm.set_trajectory_time(0.1, 0.05)  # 100 ms for 2 rad: stretched
    bot.core.robot_write_joint_command('waist', 1.6)
    assert wait_until(lambda: abs(bot.arm.get_joint_positions()[0] - 1.6) < 0.02, 4.0)
    assert 'exceeds the joint velocity limits' in capfd.readouterr().err
    # at rest first (within 0.02 rad above, the last move may still settle), then nothing moves
    assert wait_until(lambda: _still(bot, 0.2) < 0.002, 5.0)
    bot.core.robot_write_commands('arm', [0.0, -3.0, 1.0, 0.5])  # shoulder beyond -1.94
    assert _still(bot) < 0.01
    assert "for 'shoulder' is outside its limits" in capfd.readouterr().err
