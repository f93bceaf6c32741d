"""XsDriver (control/xs_driver.py): xs_sdk's semantics without ROS, time as an argument."""
import math

from px100_control.control.xs_driver import (profile_times, rad_to_ticks, ticks_to_rad,
                                             VELOCITY_UNIT, XsDriver, XsError)
from px100_control.models.registry import load_robot
import pytest

JS = ['waist', 'shoulder', 'elbow', 'wrist_angle', 'gripper', 'left_finger', 'right_finger']
SLEEP = {'waist': 0.0, 'shoulder': -1.88, 'elbow': 1.5, 'wrist_angle': 0.8, 'gripper': 0.0}


def driver(name='px100'):
    model = load_robot(name)
    return XsDriver(model, model.extra.get('xs_driver'), JS)


def test_time_profile_is_the_servo_trapezoid():
    """Profile_Velocity 2000 ms, Profile_Acceleration 300 ms: ramps 0.3 s, arrives at 2 s."""
    d = driver()
    assert d.group_command('arm', [0.0, 0.0, 0.0, 0.0], 10.0, SLEEP) == {}
    peak = 1.88 / (2.0 - 0.3)
    q, qd = d.references(11.0)['shoulder']
    assert q == pytest.approx(-0.94) and qd == pytest.approx(peak)
    assert d.references(10.15)['shoulder'][1] == pytest.approx(peak / 2)
    assert d.references(12.0)['shoulder'] == (0.0, 0.0)
    assert not d.active and d.references(12.1) == {}


def test_new_goal_mid_move_keeps_the_velocity():
    d = driver()
    d.single_command('waist', 1.0, 0.0, SLEEP)
    q, qd = d.references(1.0)['waist']
    d.single_command('waist', -1.0, 1.0, dict(SLEEP, waist=q))
    q2, qd2 = d.references(1.0)['waist']
    assert (q2, qd2) == pytest.approx((q, qd))


def test_velocity_profile_times():
    """Velocity-based profile: 0.229 rpm and 214.577 rev/min^2 units; triangle when short."""
    T, ta = profile_times('velocity', 131, 0, 1.0)
    assert T == pytest.approx(1.0 / (131 * VELOCITY_UNIT)) and ta == 0.0
    T, ta = profile_times('velocity', 131, 10, 0.01)
    assert ta == pytest.approx(T / 2)
    assert profile_times('velocity', 0, 0, 1.0) == (0.0, 0.0)
    assert profile_times('time', 1000, 800, 1.0) == (1.0, 0.5)


def test_modes_units_and_refusals():
    d = driver()
    assert d.single_command('gripper', 250.0, 0.0, SLEEP) == {'gripper': ('duty', 250 / 885)}
    d.set_operating_modes('single', 'waist', 'velocity', 'velocity', 0, 0)
    assert d.single_command('waist', 0.5, 0.0, SLEEP) == {'waist': ('velocity', 0.5)}
    with pytest.raises(XsError, match="joint 'waist' is in velocity mode but group 'arm'"):
        d.group_command('arm', [0.0] * 4, 0.0, SLEEP)
    with pytest.raises(XsError, match='no current sensing'):
        d.set_operating_modes('single', 'elbow', 'current_based_position', 'time', 0, 0)
    with pytest.raises(XsError, match=r'Number of commands \(3\)'):
        d.group_command('arm', [0.0] * 3, 0.0, SLEEP)
    with pytest.raises(XsError, match='NaN'):
        d.single_command('elbow', math.nan, 0.0, SLEEP)
    with pytest.raises(XsError, match="register 'Goal_Current'"):
        d.set_register('group', 'arm', 'Goal_Current', 1)
    with pytest.raises(XsError, match="'cmd_type' while setting motor registers"):
        d.set_register('grp', 'arm', 'Profile_Velocity', 1)
    assert not d.active


def test_current_mode_on_xm430():
    """wx250s: the elbow's two XM430-W350 take mA -> N*m through their torque constant."""
    model = load_robot('wx250s')
    d = XsDriver(model, model.extra['xs_driver'], list(model.joint_names) + JS[4:])
    d.set_operating_modes('single', 'elbow', 'current', 'velocity', 0, 0)
    kind, torque = d.single_command('elbow', 1000.0, 0.0, {})['elbow']
    assert model.extra['servos']['elbow'] == '2x XM430-W350'
    assert kind == 'torque' and torque == pytest.approx(2 * 4.1 / 2.3)


def test_linear_position_and_trajectory():
    d = driver()
    d.set_operating_modes('single', 'gripper', 'linear_position', 'time', 500, 100)
    d.single_command('gripper', 0.06, 0.0, SLEEP)
    q, _ = d.references(1.0)['gripper']
    assert d.linkage.finger_position(q) == pytest.approx(0.03)
    with pytest.raises(XsError, match='fewer than 2 points'):
        d.trajectory_command('group', 'arm', [0.0], [[0.0] * 4], 'position', 0.0)
    d.trajectory_command('group', 'arm', [0.0, 0.5], [[0.0] * 4, [0.1] * 4], 'position', 2.0)
    with pytest.raises(XsError, match='still moving'):
        d.trajectory_command('group', 'arm', [0.0, 0.5], [[0.0] * 4] * 2, 'position', 2.0)
    assert d.due_points(2.4, SLEEP) == {} and 'waist' not in d.motions
    d.due_points(2.5, SLEEP)
    assert 'waist' in d.motions and d.trajectory is None


def test_robot_info_and_ticks():
    info = driver().robot_info('single', 'gripper')
    assert info.joint_names == ['left_finger'] and info.joint_state_indices == [5]
    assert rad_to_ticks(0.0) == 2048 and ticks_to_rad(3072) == pytest.approx(math.pi / 2)


def test_motion_floats_equal_the_trajectory_segment():
    """Motion samples its plan_move segment in floats: the same values as segment.sample."""
    from px100_control.control.trajectory import plan_move
    from px100_control.control.xs_driver import Motion
    for v0 in (None, [0.7]):
        seg = plan_move([0.2], [-0.4], 1.3, accel_time=0.4, v_start=v0).segments[0]
        motion = Motion(5.0, seg)
        for tl in (0.0, 0.1, 0.4, 0.65, 1.0, 1.29):
            q, qd, done = motion.sample(5.0 + tl)
            ref_q, ref_qd, _ = seg.sample(tl)
            assert (q, qd) == pytest.approx((ref_q[0], ref_qd[0]), abs=1e-12) and not done
        assert motion.sample(6.31) == (-0.4, 0.0, True)


def test_follows_the_simulator_modes_set_from_outside():
    """operating_mode parameters set by ros2 param or the client: the driver reports them."""
    d = driver()
    assert d.follow_sim_modes({'waist': 'velocity', 'gripper': ''}) == ['waist']
    assert d.state['waist'].mode == 'velocity' and d.state['gripper'].mode == 'pwm'
    assert d.robot_info('group', 'arm').mode == 'position'      # members differ: kept
    assert d.follow_sim_modes(dict.fromkeys(d.groups['arm'], 'duty')) == d.groups['arm']
    assert d.robot_info('group', 'arm').mode == 'pwm'
    assert d.follow_sim_modes({'waist': '', 'gripper': 'position'}) == ['waist', 'gripper']
    assert d.state['gripper'].mode == 'position'


def test_stop_and_clock_going_back_drop_moves_and_trajectories():
    d = driver()
    d.trajectory_command('group', 'arm', [0.0, 0.5], [[0.0] * 4, [0.1] * 4], 'position', 2.0)
    d.single_command('gripper', 0.0, 2.0, SLEEP)
    d.stop(['waist'])
    assert d.trajectory is None
    d.set_operating_modes('single', 'gripper', 'position', 'time', 1000, 0)
    d.single_command('gripper', 0.5, 2.0, SLEEP)
    d.trajectory_command('group', 'arm', [0.0, 0.5], [[0.0] * 4, [0.1] * 4], 'position', 2.0)
    assert d.references(1.0) == {} and not d.active     # a new simulator starts at 0 s


def test_velocity_trajectory_points_are_written_at_their_times():
    d = driver()
    d.set_operating_modes('group', 'arm', 'velocity', 'velocity', 0, 0)
    with pytest.raises(XsError, match='a position trajectory is refused'):
        d.trajectory_command('group', 'arm', [0.0, 1.0], [[0.0] * 4] * 2, 'position', 0.0)
    with pytest.raises(XsError, match='above its limit'):
        d.trajectory_command('group', 'arm', [0.0, 1.0], [[0.0] * 4, [9.0] * 4], 'velocity', 0)
    d.trajectory_command('group', 'arm', [0.0, 0.5, 1.0], [[0.0] * 4, [0.2] * 4, [0.0] * 4],
                         'velocity', 3.0)
    assert d.due_points(3.4, SLEEP) == {}
    assert d.due_points(3.5, SLEEP) == {j: ('velocity', 0.2) for j in d.groups['arm']}
    assert d.due_points(4.0, SLEEP)['elbow'] == ('velocity', 0.0) and not d.active
