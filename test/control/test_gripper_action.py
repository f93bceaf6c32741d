"""The gripper_cmd engine (px100_control.control.gripper_action): targets, reach, stall."""
import math

from px100_control.control.gripper import GripperLinkage
from px100_control.control.gripper_action import (ABORTED, closing_torque,
                                                  DEFAULT_GRASP_TORQUE, gripper_target,
                                                  GripperGoalMonitor, GripperSettings,
                                                  STALL_TORQUE, SUCCEEDED)
from px100_control.errors import InvalidInputError
import pytest

LINK = GripperLinkage()
S = GripperSettings(goal_tolerance=0.002, stall_velocity_threshold=0.001, stall_timeout=1.0,
                    allow_stalling=True)
MS = 1_000_000


def test_target_is_the_servo_angle_of_the_finger_position():
    assert gripper_target(LINK, 0.015, 0.0) == pytest.approx(LINK.angle_lower)
    assert LINK.finger_position(gripper_target(LINK, 0.025, 5.0)) == pytest.approx(0.025)


@pytest.mark.parametrize('position, effort, words', [
    (0.05, 0.0, 'outside the finger limits'), (0.01, 0.0, 'outside the finger limits'),
    (math.nan, 0.0, 'outside'), (0.02, -1.0, 'max_effort'), (0.02, math.inf, 'max_effort')])
def test_bad_goals_are_refused_with_the_reason(position, effort, words):
    with pytest.raises(InvalidInputError, match=words):
        gripper_target(LINK, position, effort)


def test_reached_within_tolerance():
    m = GripperGoalMonitor(0.02, S, 0)
    assert m.update(0.03, -0.05, 100 * MS) is None
    status, reached, stalled, _ = m.update(0.0215, -0.01, 200 * MS)
    assert (status, reached, stalled) == (SUCCEEDED, True, False)


def test_stall_after_stall_timeout_of_no_motion_short_of_the_goal():
    m = GripperGoalMonitor(0.015, S, 0)
    assert m.update(0.02, -0.05, 100 * MS) is None        # moving
    assert m.update(0.018, 0.0, 600 * MS) is None          # stopped 0.5 s
    assert m.update(0.018, 0.0, 1090 * MS) is None         # 0.99 s
    status, reached, stalled, words = m.update(0.018, 0.0, 1200 * MS)
    assert (status, reached, stalled) == (SUCCEEDED, False, True) and 'stalled' in words
    strict = GripperGoalMonitor(0.015, GripperSettings(0.002, 0.001, 1.0, False), 0)
    assert strict.update(0.018, 0.0, 1100 * MS)[:3] == (ABORTED, False, True)


def test_closing_torque_from_finger_force():
    assert closing_torque(LINK, 0.0, 0.5) == DEFAULT_GRASP_TORQUE
    assert closing_torque(LINK, 10.0, 0.0) == pytest.approx(2 * 10.0 * LINK.finger_rate(0.0))
    assert closing_torque(LINK, 1e6, 0.0) == STALL_TORQUE
