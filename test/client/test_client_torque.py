"""
Torque per joint, per group and for all, as the real SDK: only the addressed servos change.

Real in-process nodes (the ``bot`` fixture); sim_driver's ``torque_enable.<joint>`` parameters
carry it. A joint switched off falls under gravity while the others keep holding.
"""

from client_support import pause
import numpy as np
import pytest

pytestmark = pytest.mark.ros


def _torque(bot):
    node = bot.core.find_node('sim_driver')
    return {j: bot.core.get_remote_parameter(node, f'torque_enable.{j}')
            for j in ('waist', 'shoulder', 'elbow', 'wrist_angle', 'gripper')}


def _delta(bot, seconds):
    q0 = np.array(bot.arm.get_joint_positions())
    pause(bot, seconds)
    return np.abs(np.array(bot.arm.get_joint_positions()) - q0)


def test_single_group_and_all(bot):
    """Switch the gripper off (the arm holds); elbow off drops only the elbow; all on holds."""
    core, arm = bot.core, bot.arm
    try:
        assert arm.set_joint_positions([0.0, 0.0, 0.0, 0.0])
        assert core.robot_torque_enable('single', 'gripper', False) is True
        assert _torque(bot) == {'waist': True, 'shoulder': True, 'elbow': True,
                                'wrist_angle': True, 'gripper': False}
        assert np.max(_delta(bot, 1.0)) < 0.01  # the arm still holds
        finger = bot.gripper.get_finger_position()
        core.publish_setpoints(['gripper'], efforts=[0.4])  # drive ignored: torque off
        pause(bot, 0.5)
        assert abs(bot.gripper.get_finger_position() - finger) < 1e-3

        assert core.robot_torque_enable('single', 'elbow', False) is True
        d = _delta(bot, 0.5)
        assert d[2] > 0.05, d              # the elbow falls
        assert d[0] < 0.01 and d[1] < 0.05, d  # waist and shoulder hold

        assert core.robot_torque_enable('group', 'arm', False) is True
        assert _torque(bot)['shoulder'] is False and _torque(bot)['gripper'] is False
        assert core.robot_torque_enable('group', 'all', True) is True
        assert set(_torque(bot).values()) == {True}
        pause(bot, 0.3)
        assert np.max(_delta(bot, 0.5)) < 0.01  # all hold where they are
        arm.capture_joint_positions()
    finally:
        core.robot_torque_enable('group', 'all', True)
        core.robot_reset()
        pause(bot, 0.3)
        arm.capture_joint_positions()
