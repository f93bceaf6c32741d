"""
Properties of the pure trajectory code (px100_control.control.trajectory): no ROS here.

Profiles: endpoints, zero boundary velocity, peak velocity as stated (and within limits), time
monotonic and sampled consistently; waypoints: passes through every point at its time with
continuous velocity and no overshoot; the smooth stop; every validation reason.
"""
from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
from px100_control.control import trajectory as tj
from px100_control.errors import InvalidInputError
from px100_control.models.registry import load_robot
import pytest

MODEL = load_robot('px100')
NAMES = list(MODEL.joint_names)
LO, HI, VMAX = MODEL.lower, MODEL.upper, MODEL.velocity_limits


def _grid(T, n=2001):
    return np.linspace(0.0, T, n)


def _finite_diff_ok(traj, ts, tol):
    """Check that qd is the derivative of q and qdd of qd (central differences)."""
    q, qd, qdd = traj.sample_many(ts)
    dt = ts[1] - ts[0]
    num_qd = (q[2:] - q[:-2]) / (2 * dt)
    num_qdd = (qd[2:] - qd[:-2]) / (2 * dt)
    assert np.max(np.abs(num_qd - qd[1:-1])) < tol
    return np.abs(num_qdd - qdd[1:-1])


@pytest.mark.parametrize('profile', tj.PROFILES)
def test_point_to_point_endpoints_and_boundary_velocity(profile):
    """Every profile starts at q0, ends at q1; trapezoid/min-jerk start and end at rest."""
    q0 = np.array([0.0, -1.88, 1.5, 0.8])
    q1 = np.array([0.5, 0.1, -0.3, 0.2])
    traj = tj.plan_move(q0, q1, 2.0, profile, 0.3, max_joint_step=0.01, period=0.005)
    q, qd, _ = traj.sample(0.0)
    np.testing.assert_allclose(q, q0, atol=1e-12)
    q, qd_end, _ = traj.sample(traj.duration)
    np.testing.assert_allclose(q, q1, atol=1e-12)
    np.testing.assert_allclose(qd_end, 0.0, atol=1e-12)
    if profile != 'linear_max_step':
        np.testing.assert_allclose(traj.sample(0.0)[1], 0.0, atol=1e-12)
        np.testing.assert_allclose(traj.sample(traj.duration - 1e-9)[1], 0.0, atol=1e-6)
    # after the end: holds, zero velocity; before 0: the start
    np.testing.assert_allclose(traj.sample(traj.duration + 5.0)[0], q1, atol=1e-12)
    np.testing.assert_allclose(traj.sample(-1.0)[0], q0, atol=1e-12)


def test_trapezoidal_has_interbotix_time_based_semantics():
    """moving_time is the duration; accel_time ramps; cruise speed |dq|/(T-Ta); Ta <= T/2."""
    q0, q1 = np.zeros(4), np.array([1.0, -0.5, 0.25, 0.0])
    T, ta = 2.0, 0.3
    traj = tj.plan_move(q0, q1, T, 'trapezoidal', ta)
    assert traj.duration == pytest.approx(T)
    v_cruise = np.abs(q1 - q0) / (T - ta)
    for t in (ta, 1.0, T - ta):
        np.testing.assert_allclose(np.abs(traj.sample(t)[1]), v_cruise, atol=1e-12)
    np.testing.assert_allclose(np.abs(traj.sample(ta / 2)[1]), v_cruise / 2, atol=1e-12)
    np.testing.assert_allclose(traj.peak_velocity(), v_cruise, rtol=1e-9)
    # constant acceleration during the ramps, zero while cruising
    a = v_cruise / ta
    np.testing.assert_allclose(np.abs(traj.sample(0.1)[2]), a, rtol=1e-12)
    np.testing.assert_allclose(traj.sample(1.0)[2], 0.0, atol=1e-12)
    # accel_time above T/2 is clipped to T/2 (a triangle), as the servo does
    tri = tj.plan_move(q0, q1, T, 'trapezoidal', 5.0)
    np.testing.assert_allclose(tri.peak_velocity(), np.abs(q1 - q0) / (T / 2), rtol=1e-6)
    np.testing.assert_allclose(tri.sample(T / 2)[0], (q0 + q1) / 2, atol=1e-12)
    # accel_time 0: constant speed (a velocity step at both ends)
    lin = tj.plan_move(q0, q1, T, 'trapezoidal', 0.0)
    np.testing.assert_allclose(lin.sample(0.5)[0], q0 + 0.25 * (q1 - q0), atol=1e-12)


def test_minimum_jerk_peak_and_zero_acceleration_at_ends():
    """The quintic peaks at 1.875 |dq| / T in the middle, with zero end accelerations."""
    q0, q1 = np.zeros(4), np.array([0.8, -0.4, 0.2, 1.0])
    traj = tj.plan_move(q0, q1, 1.6, 'minimum_jerk')
    np.testing.assert_allclose(traj.sample(0.8)[1], 1.875 * (q1 - q0) / 1.6, rtol=1e-12)
    np.testing.assert_allclose(traj.sample(0.0)[2], 0.0, atol=1e-12)
    np.testing.assert_allclose(traj.sample(1.6 - 1e-12)[2], 0.0, atol=1e-6)
    np.testing.assert_allclose(traj.peak_velocity(), 1.875 * np.abs(q1 - q0) / 1.6, rtol=1e-6)


@pytest.mark.parametrize('profile', tj.PROFILES)
def test_derivatives_are_consistent(profile):
    """Velocity and acceleration are the derivatives of q (finite differences), v0 != 0."""
    traj = tj.plan_move(np.zeros(4), np.array([1.0, -1.0, 0.5, 0.2]), 1.5, profile, 0.4,
                        v_start=np.array([0.3, 0.0, -0.2, 0.1]), max_joint_step=0.01,
                        period=0.005)
    ts = _grid(traj.duration, 3001)
    err_qdd = _finite_diff_ok(traj, ts, tol=2e-3)  # velocity kinks (ramps) cost O(a dt)
    if profile == 'minimum_jerk':
        assert np.max(err_qdd) < 1e-3


def test_start_velocity_blends_continuously():
    """A move started at velocity v0 (preemption) has qd(0) = v0 and still ends at rest."""
    v0 = np.array([0.5, -0.2, 0.0, 0.1])
    traj = tj.plan_move(np.zeros(4), np.ones(4) * 0.3, 1.0, 'minimum_jerk', v_start=v0)
    np.testing.assert_allclose(traj.sample(0.0)[1], v0, atol=1e-12)
    np.testing.assert_allclose(traj.sample(1.0 - 1e-9)[1], 0.0, atol=1e-6)
    np.testing.assert_allclose(traj.end, np.ones(4) * 0.3)


def test_time_is_monotonic_and_samples_agree():
    """sample_many equals sample at each time; the check grid is increasing and covers [0, T]."""
    traj = tj.plan_waypoints(np.zeros(4), [0.5, 1.2, 2.0],
                             [[0.2, 0.1, 0, 0], [0.4, -0.2, 0.1, 0], [0.1, 0.0, 0.3, 0.2]])
    ts = traj.check_times(0.01)
    assert ts[0] == 0.0 and ts[-1] == pytest.approx(traj.duration)
    assert np.all(np.diff(ts) > 0)
    q, qd, qdd = traj.sample_many(ts)
    for k in (0, 7, 55, len(ts) - 1):
        one = traj.sample(ts[k])
        np.testing.assert_allclose(one[0], q[k], atol=1e-12)
        np.testing.assert_allclose(one[1], qd[k], atol=1e-12)


@pytest.mark.parametrize('profile', tj.PROFILES)
def test_peak_velocity_within_limits_when_validated(profile):
    """check_trajectory accepts a move within the URDF speeds and names the joint otherwise."""
    q0 = MODEL.sleep.copy()
    q1 = np.array([1.0, 0.0, 0.0, 0.0])
    slow = tj.plan_move(q0, q1, 2.0, profile, 0.3, max_joint_step=0.05, period=0.005)
    assert tj.check_trajectory(slow, NAMES, LO, HI, VMAX) == ''
    assert np.all(slow.peak_velocity() <= VMAX)
    fast = tj.plan_move(q0, q1, 0.3, profile, 0.1, max_joint_step=0.05, period=0.005)
    reason = tj.check_trajectory(fast, NAMES, LO, HI, VMAX)
    assert "joint 'shoulder'" in reason and 'velocity limit' in reason


def test_linear_max_step_never_steps_more_than_the_maximum():
    """Seed 001: N = ceil(max|dq| / step) steps; sampled every period no step is larger."""
    steps = tj.linear_steps([0.0, 0.0], [0.25, -0.1], 0.1)
    assert steps.shape == (4, 2)
    assert np.max(np.abs(np.diff(steps, axis=0))) <= 0.1 + 1e-12
    q0, q1 = np.zeros(4), np.array([1.0, -0.5, 0.2, 0.0])
    period, step = 0.005, 0.004
    traj = tj.plan_move(q0, q1, 0.5, 'linear_max_step', max_joint_step=step, period=period)
    assert traj.duration == pytest.approx(250 * period)  # 1.0 / 0.004 steps, longer than 0.5
    q = traj.sample_many(np.arange(0.0, traj.duration + period, period))[0]
    assert np.max(np.abs(np.diff(q, axis=0))) <= step + 1e-12
    np.testing.assert_allclose(q[-1], q1)
    long = tj.plan_move(q0, q1, 3.0, 'linear_max_step', max_joint_step=step, period=period)
    assert long.duration == pytest.approx(3.0)  # slow enough already: moving_time kept


def test_waypoints_pass_through_points_with_continuous_velocity():
    """A spline through waypoints hits each at its time; velocity is continuous; ends at rest."""
    times = [0.6, 1.4, 2.0, 3.0]
    pts = np.array([[0.3, -1.0, 1.0, 0.5], [0.6, -0.5, 0.6, 0.2], [0.2, -0.4, 0.3, 0.2],
                    [0.0, -0.2, 0.1, 0.0]])
    q0 = MODEL.sleep.copy()
    traj = tj.plan_waypoints(q0, times, pts)
    for t, p in zip(times, pts):
        np.testing.assert_allclose(traj.sample(t - 1e-12)[0], p, atol=1e-9)
    for t in times[:-1]:
        np.testing.assert_allclose(traj.sample(t - 1e-9)[1], traj.sample(t + 1e-9)[1],
                                   atol=1e-6)
    np.testing.assert_allclose(traj.sample(3.0 - 1e-9)[1], 0.0, atol=1e-6)
    np.testing.assert_allclose(traj.sample(0.0)[1], 0.0, atol=1e-12)
    # shape preserving: between two knots every joint stays within their range
    knots_t = np.concatenate([[0.0], times])
    knots_q = np.vstack([q0, pts])
    for i in range(len(times)):
        ts = np.linspace(knots_t[i], knots_t[i + 1], 200)
        q = traj.sample_many(ts)[0]
        lo = np.minimum(knots_q[i], knots_q[i + 1]) - 1e-9
        hi = np.maximum(knots_q[i], knots_q[i + 1]) + 1e-9
        assert np.all(q >= lo) and np.all(q <= hi)
    assert tj.check_trajectory(traj, NAMES, LO, HI, VMAX) == ''


def test_waypoints_with_given_velocities_and_accelerations():
    """Given velocities (cubic) and accelerations (quintic) are met at the waypoints."""
    times = [1.0, 2.0]
    pts = np.array([[0.5, 0.0], [1.0, 0.5]])
    vel = np.array([[0.4, 0.3], [0.0, 0.0]])
    acc = np.array([[0.1, -0.2], [0.0, 0.0]])
    cubic = tj.plan_waypoints(np.zeros(2), times, pts, vel)
    np.testing.assert_allclose(cubic.sample(1.0)[1], vel[0], atol=1e-9)
    quintic = tj.plan_waypoints(np.zeros(2), times, pts, vel, acc)
    q, qd, qdd = quintic.sample(1.0)
    np.testing.assert_allclose(q, pts[0], atol=1e-9)
    np.testing.assert_allclose(qd, vel[0], atol=1e-9)
    np.testing.assert_allclose(qdd, acc[0], atol=1e-9)
    np.testing.assert_allclose(quintic.sample(2.0 - 1e-12)[0], pts[1], atol=1e-9)
    _finite_diff_ok(quintic, _grid(2.0, 4001), tol=1e-4)


def test_linear_waypoints_are_piecewise_linear():
    """With interpolation 'linear' each segment has constant velocity (seed 001)."""
    traj = tj.plan_waypoints(np.zeros(1), [1.0, 2.0], [[1.0], [0.0]], interpolation='linear')
    np.testing.assert_allclose(traj.sample(0.5)[0], [0.5])
    np.testing.assert_allclose(traj.sample(1.5)[1], [-1.0])


@settings(max_examples=60, deadline=None)
@given(v=st.lists(st.floats(-3.0, 3.0), min_size=4, max_size=4),
       a_max=st.floats(0.5, 50.0))
def test_stop_comes_to_rest_within_the_deceleration(v, a_max):
    """plan_stop: continuous velocity, |qdd| <= a_max, monotone slowdown, rest at the end."""
    q = np.array([0.1, -0.2, 0.3, 0.4])
    v = np.array(v)
    traj = tj.plan_stop(q, v, a_max)
    q0, qd0, _ = traj.sample(0.0)
    np.testing.assert_allclose(q0, q)
    np.testing.assert_allclose(qd0, v)
    if traj.duration == 0.0:
        assert not np.any(v)
        return
    ts = _grid(traj.duration, 501)
    qs, qds, qdds = traj.sample_many(ts)
    assert np.max(np.abs(qdds)) <= a_max * (1 + 1e-9)
    speed = np.abs(qds)
    assert np.all(np.diff(speed, axis=0) <= 1e-12)
    np.testing.assert_allclose(traj.sample(traj.duration)[1], 0.0, atol=1e-12)
    np.testing.assert_allclose(traj.end, q + v * traj.duration / 3.0)


@pytest.mark.parametrize('case, expected', [
    ({'names': ['waist', 'bogus'], 'times': [1.0], 'pos': [[0.0, 0.0]]}, 'unknown joint'),
    ({'names': ['waist', 'waist'], 'times': [1.0], 'pos': [[0.0, 0.0]]}, 'duplicate'),
    ({'names': [], 'times': [1.0], 'pos': [[]]}, 'no joint names'),
    ({'names': ['waist'], 'times': [], 'pos': []}, 'no points'),
    ({'names': ['waist'], 'times': [1.0], 'pos': [[float('nan')]]}, 'NaN'),
    ({'names': ['waist'], 'times': [float('inf')], 'pos': [[0.0]]}, 'time_from_start'),
    ({'names': ['waist'], 'times': [1.0], 'pos': [[0.0, 1.0]]}, '2 positions for 1 joints'),
    ({'names': ['shoulder'], 'times': [1.0], 'pos': [[2.5]]}, 'outside its limits'),
    ({'names': ['waist'], 'times': [1.0, 1.0], 'pos': [[0.0], [0.1]]}, 'strictly increasing'),
    ({'names': ['waist'], 'times': [2.0, 1.0], 'pos': [[0.0], [0.1]]}, 'strictly increasing'),
    ({'names': ['waist'], 'times': [-1.0], 'pos': [[0.0]]}, 'negative'),
    ({'names': ['waist'], 'times': [1.0], 'pos': [[0.0]], 'vel': [[9.0]]}, 'above its limit'),
    ({'names': ['waist'], 'times': [1.0], 'pos': [[0.0]], 'vel': [[1.0, 2.0]]}, 'velocities'),
    ({'names': ['waist'], 'times': [1.0], 'pos': [[0.0]], 'vel': [[float('nan')]]}, 'NaN'),
])
def test_validation_names_the_reason(case, expected):
    """Every invalid-goal class gets a reason that says what is wrong."""
    reason = tj.validate_points(NAMES, case['names'], case['times'], case['pos'],
                                case.get('vel'), None, LO, HI, VMAX)
    assert expected in reason, reason


def test_validation_accepts_a_good_goal():
    """A subset of joints in any order with increasing times is valid."""
    assert tj.validate_points(NAMES, ['elbow', 'waist'], [0.0, 0.5, 1.0],
                              [[0.1, 0.0], [0.2, 0.1], [0.3, 0.2]],
                              [[], [], []], [[], [], []], LO, HI, VMAX) == ''


class _LengthOnly:
    """A huge array whose values must not be read (reading them is what stalled the node)."""

    def __init__(self, n):
        self.n = n

    def __len__(self):
        return self.n

    def __iter__(self):
        raise AssertionError('values of a wrongly sized array were read')

    __getitem__ = __iter__


@pytest.mark.parametrize('field', ['pos', 'vel', 'acc'])
def test_validation_rejects_huge_rows_by_length_alone(field):
    """A 10M-entry row is refused on its length, before any of its values is touched."""
    rows = {'pos': [[0.0]] * 3, 'vel': [[]] * 3, 'acc': [[]] * 3}
    rows[field] = rows[field][:2] + [_LengthOnly(10 ** 7)]
    reason = tj.validate_points(NAMES, ['waist'], [0.5, 1.0, 1.5], rows['pos'], rows['vel'],
                                rows['acc'], LO, HI, VMAX)
    assert reason.startswith('point 2: 10000000 '), reason


def test_validation_reasons_stay_short_for_huge_name_lists():
    """7,000 unknown or duplicate names: a reason of a few hundred characters, with the count."""
    many = [f'j{i}' for i in range(7000)]
    for names, expected in ((many, 'unknown joint'), (many + many, 'duplicate')):
        reason = tj.validate_points(NAMES, names, [1.0], [[0.0] * len(names)])
        assert expected in reason and '(7000 in all)' in reason and len(reason) < 400, reason


def test_bad_planner_input_raises():
    """Planners refuse malformed input with InvalidInputError (never a silent trajectory)."""
    with pytest.raises(InvalidInputError):
        tj.plan_move(np.zeros(4), np.zeros(3), 1.0)
    with pytest.raises(InvalidInputError):
        tj.plan_move(np.zeros(4), np.zeros(4), 0.0)
    with pytest.raises(InvalidInputError):
        tj.plan_move(np.zeros(4), np.full(4, np.nan), 1.0)
    with pytest.raises(InvalidInputError):
        tj.plan_move(np.zeros(4), np.zeros(4), 1.0, 'bogus')
    with pytest.raises(InvalidInputError):
        tj.plan_waypoints(np.zeros(2), [1.0, 0.5], [[0, 0], [1, 1]])
    with pytest.raises(InvalidInputError):
        tj.plan_stop(np.zeros(2), np.zeros(2), 0.0)
    with pytest.raises(InvalidInputError):
        tj.plan_move(np.zeros(4), np.ones(4), 1.0).sample(float('nan'))


@pytest.mark.parametrize('names, lengths, expected', [
    (['waist', 'bogus'], [(2, 0, 0, 0)], 'unknown joint'),
    (['waist', 'waist'], [(2, 0, 0, 0)], 'duplicate'),
    ([], [(0, 0, 0, 0)], 'no joint names'),
    (['waist'], [(1, 0, 0, 0), (2, 0, 0, 0)], 'point 1: 2 positions for 1 joints'),
    (['waist', 'elbow'], [(2, 3, 0, 0)], 'point 0: 3 velocities for 2 joints'),
    (['waist', 'elbow'], [(2, 2, 1, 0)], 'point 0: 1 accelerations for 2 joints'),
])
def test_shape_validation_names_the_reason(names, lengths, expected):
    """validate_shape (names and lengths only) refuses with validate_points' reason."""
    assert expected in tj.validate_shape(NAMES, names, lengths)
    rows = [[0.0] * p for p, _, _, _ in lengths]
    vels = [[0.0] * v for _, v, _, _ in lengths]
    accs = [[0.0] * a for _, _, a, _ in lengths]
    assert expected in tj.validate_points(NAMES, names, [0.5 * (k + 1) for k in range(len(rows))],
                                          rows, vels, accs)


def test_shape_validation_passes_what_only_values_make_invalid():
    """Right names and lengths pass validate_shape (effort counts are not checked)."""
    assert tj.validate_shape(NAMES, ['elbow', 'waist'], [(2, 0, 0, 0), (2, 2, 2, 7)]) == ''


@pytest.mark.parametrize('v0', [np.pi, -np.pi, 1.0, 0.0])
@pytest.mark.parametrize('accel_time', [0.05, 0.3])
def test_shortest_move_time_is_the_first_the_velocity_check_accepts(v0, accel_time):
    """A move sent while the joint moves: the duration found passes, 5 % less does not."""
    lim = np.array([np.pi, np.pi])
    q0, q1, v = np.zeros(2), np.array([0.45, -0.2]), np.array([v0, 0.0])
    travel = 0.45 / np.pi + 0.05
    T = tj.shortest_move_time(q0, q1, lim, accel_time, v_start=v, at_least=travel)
    assert T >= travel

    def reason(duration):
        traj = tj.plan_move(q0, q1, duration, 'trapezoidal', accel_time, v_start=v)
        return tj.check_trajectory(traj, ['a', 'b'], velocity_limits=lim)
    assert reason(T) == ''
    if T > travel:
        assert 'velocity limit' in reason(T / 1.05)


def test_shortest_move_time_names_a_move_no_duration_makes_feasible():
    """accel_time 0 at the velocity limit: a velocity step on top of it, never feasible."""
    with pytest.raises(InvalidInputError, match='velocity limits'):
        tj.shortest_move_time([0.0], [0.45], [np.pi], 0.0, v_start=[np.pi], at_least=0.2)


@pytest.mark.parametrize('field', ['q_goal', 'v_start'])
def test_shortest_move_time_names_nan_input(field):
    """A NaN goal or start velocity is refused with the field named, not searched."""
    args = {'q_goal': [0.45], 'v_start': [0.5]}
    args[field] = [float('nan')]
    with pytest.raises(InvalidInputError, match=field):
        tj.shortest_move_time([0.0], args['q_goal'], [np.pi], 0.05, v_start=args['v_start'],
                              at_least=0.2)
