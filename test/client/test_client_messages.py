"""
Refused calls name the bad argument, return False, move nothing; last_error is per call.

On real in-process nodes (the ``bot`` fixture). Also: a target given in mm gets a units hint,
``moving_time=0`` moves as fast as the limits allow without an ERROR log, and no numpy
RuntimeWarning leaks out of the bad-input paths.
"""
import math
import time
import warnings

from client_support import wait_until
import numpy as np
import pytest

pytestmark = pytest.mark.ros

NAN, INF = float('nan'), float('inf')


def _still(bot, seconds=0.3):
    """Return the largest joint change [rad] over ``seconds``."""
    q0 = np.array(bot.arm.get_joint_positions())
    bot.core.sleep(seconds)
    return float(np.max(np.abs(np.array(bot.arm.get_joint_positions()) - q0)))


def test_bad_arguments_are_named_refused_and_nothing_moves(bot):
    """Refuse NaN, inf, wrong shapes, mm targets: False, the argument named, no move."""
    arm = bot.arm
    assert arm.set_joint_positions([0.0, -0.5, 0.5, 0.0])
    commands = arm.get_joint_commands()
    cases = [
        (lambda: arm.set_ee_pose_components(x=NAN, z=0.2), 'x is NaN'),
        (lambda: arm.set_ee_pose_components(x=0.2, z=0.2, pitch=INF), 'pitch is inf'),
        (lambda: arm.set_ee_pose_components(x='a', z=0.2), "x is not a number: 'a'"),
        (lambda: arm.set_ee_pose_matrix(np.where(np.eye(4) > 0, 1.0, 0.0) + np.array(
            [[0, 0, 0, 0], [0, 0, 0, INF], [0, 0, 0, 0], [0, 0, 0, 0]])), 'T_sd[1][3] is inf'),
        (lambda: arm.set_ee_pose_matrix(np.eye(3)), 'T_sd must be a 4x4 matrix'),
        (lambda: arm.set_ee_pose_components(x=250.0, z=193.0),
         'given in mm? the API takes metres'),
        (lambda: arm.set_ee_cartesian_trajectory(z=-50.0), 'the API takes metres'),
        (lambda: arm.set_joint_positions([NAN, 0.0, 0.0, 0.0]), "joint 'waist' is nan"),
        (lambda: arm.set_joint_positions([0.1, 0.0, 0.0, 0.0], moving_time=-1.0),
         'moving_time is -1.0'),
        (lambda: arm.set_joint_positions([0.1, 0.0, 0.0, 0.0], accel_time=NAN),
         'accel_time is NaN'),
        (lambda: arm.set_single_joint_position('waist', NAN), "position of 'waist' is NaN"),
        (lambda: arm.set_single_joint_position('wrist', 0.1), "'wrist' is not in group"),
        (lambda: arm.set_ee_cartesian_trajectory(x=NAN), 'x is NaN'),
    ]
    with warnings.catch_warnings():
        warnings.simplefilter('error')  # a numpy RuntimeWarning would fail the call
        for call, text in cases:
            result = call()
            ok = result[1] if isinstance(result, tuple) else result
            assert ok is False, (text, result)
            assert text in arm.last_error, (text, arm.last_error)
    assert _still(bot) < 0.01
    assert arm.get_joint_commands() == commands


def test_last_error_is_cleared_by_a_successful_call(bot):
    """A refused call sets last_error; the next successful call empties it."""
    arm = bot.arm
    assert arm.set_ee_pose_components(x=NAN)[1] is False
    assert arm.last_error
    assert arm.set_joint_positions([0.0, -0.5, 0.5, 0.0])
    assert arm.last_error == ''
    assert arm.set_single_joint_position('waist', NAN) is False
    assert arm.last_error
    arm.go_to_home_pose()
    assert arm.last_error == ''


def test_moving_time_zero_while_the_arm_moves_is_accepted(bot, capfd):
    """moving_time=0 sent while the waist is at speed: planned for that speed, not refused."""
    arm = bot.arm
    assert arm.set_joint_positions([0.0, -0.5, 0.5, 0.0], moving_time=1.0)
    assert arm.set_joint_positions([0.8, -0.5, 0.5, 0.0], moving_time=0, blocking=False)
    assert wait_until(lambda: arm.get_joint_positions()[0] > 0.4, 2.0), \
        arm.get_joint_positions()
    capfd.readouterr()
    speed = arm.get_joint_velocities()[0]
    assert arm.set_joint_positions([1.2, -0.5, 0.5, 0.0], moving_time=0) is True, \
        (arm.last_error, speed)
    err = capfd.readouterr().err
    assert 'velocity limit' not in err and '[ERROR]' not in err, err
    assert wait_until(lambda: abs(arm.get_joint_positions()[0] - 1.2) < 0.02, 2.0)


def test_moving_time_zero_moves_fast_without_an_error_log(bot, capfd):
    """moving_time=0: the servos' no-profile move, at the velocity limits; no ERROR logged."""
    arm = bot.arm
    assert arm.set_joint_positions([0.0, -0.5, 0.5, 0.0], moving_time=1.0)
    capfd.readouterr()
    t0 = time.monotonic()
    assert arm.set_single_joint_position('waist', 0.6, moving_time=0) is True
    elapsed = time.monotonic() - t0
    assert wait_until(lambda: abs(arm.get_joint_positions()[0] - 0.6) < 0.02, 2.0)
    assert elapsed < 5.0  # a hang; 0.6 rad at pi rad/s is about 0.3 s plus settling
    assert arm.set_joint_positions([0.0, -0.5, 0.5, 0.0], moving_time=0) is True
    err = capfd.readouterr().err
    assert '[ERROR]' not in err, err
    assert arm.last_error == ''
    arm.set_trajectory_time(1.0, 0.3)
    assert arm.moving_time == 1.0 and not math.isnan(arm.accel_time)
