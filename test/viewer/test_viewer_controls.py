"""The viewer's controls on plain values: settings, read-only beyond loopback, a move's goal."""
from px100_control.models.registry import load_robot
from px100_control.viewer.controls import (check_settings, forced_read_only, goal_move,
                                           SPEED_FRACTION)
import pytest

MODEL = load_robot('px100')


@pytest.mark.parametrize('rate, trail, port, words', [
    (0.5, 500, 8080, 'viewer rate must be within 1..60 Hz, not 0.5'),
    (30.0, 1, 8080, 'viewer trail_length must be within 2..100000, not 1'),
    (30.0, 500, 70000, 'viewer port must be within 1..65535, not 70000'),
])
def test_settings_out_of_range_are_named(rate, trail, port, words):
    with pytest.raises(ValueError, match=words):
        check_settings(rate, trail, port)


def test_settings_in_range_pass():
    check_settings(1.0, 2, 1)
    check_settings(60.0, 100000, 65535)


def test_controls_beyond_loopback_need_consent():
    assert not forced_read_only('127.0.0.1', False, False)
    assert not forced_read_only('::1', False, False)
    assert forced_read_only('0.0.0.0', False, False)
    assert not forced_read_only('0.0.0.0', True, False)       # read-only already
    assert not forced_read_only('0.0.0.0', False, True)       # allowed


def test_a_move_takes_moving_time_or_longer_for_a_far_joint():
    """Joints in model order; a joint that would exceed the speed share lengthens the move."""
    k = MODEL.joint_index('shoulder')
    vmax = float(MODEL.velocity_limits[k]) * SPEED_FRACTION
    names, target, t = goal_move(MODEL, {'shoulder': 0.5, 'waist': 0.1, 'nonsense': 1.0},
                                 {'waist': 0.1, 'shoulder': 0.0}, 0.5)
    assert names == ['waist', 'shoulder'] and target == [0.1, 0.5]
    assert t == pytest.approx(max(0.5, 0.5 / vmax))
    lo, hi = float(MODEL.lower[k]), float(MODEL.upper[k])
    _, _, t = goal_move(MODEL, {'shoulder': hi}, {'shoulder': lo}, 0.01)
    assert t == pytest.approx((hi - lo) / vmax) and t > 0.01
    _, _, t = goal_move(MODEL, {'elbow': 0.3}, {}, 0.7)        # no state yet: moving_time
    assert t == 0.7


def test_a_target_outside_the_limits_is_refused_by_name():
    k = MODEL.joint_index('elbow')
    with pytest.raises(ValueError, match=r'elbow = .* is outside its limits'):
        goal_move(MODEL, {'elbow': float(MODEL.upper[k]) + 0.1}, {}, 1.0)
