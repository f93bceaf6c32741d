"""
The goal executor (px100_control.control.goal_executor) on its own: no ROS, no sleeps.

The clock is an argument: a rig advances it in 5 ms ticks and plays the driver (the measurement
is the last setpoint, stamped when it was sent, unless a test freezes a joint, offsets it, lies
about it or goes silent). What the trajectory server did over DDS with sleeps is checked here
tick by tick: success on time, refusals that change nothing, preemption from the current
setpoint, cancel to rest, pause and resume without a jump, the watchdog (steady clock, two
checks, 'noticed late'), tracking and settle aborts with the joint named, the held setpoint of a
joint measured outside its limits, and linear_max_step's one step per tick.
"""
import math

import numpy as np
from px100_control.control.goal_executor import (ABORTED, CANCELED, GOAL_TOLERANCE, GoalExecutor,
                                                 GoalRequest, PATH_TOLERANCE, Settings,
                                                 settings_error, SUCCEEDED)
from px100_control.errors import InvalidInputError
from px100_control.models.registry import load_robot
import pytest

MODEL = load_robot('px100')
ARM = list(MODEL.joint_names)
TICK = 5_000_000          # 200 Hz [ns]
SETTINGS = {'rate': 200.0, 'profile': 'trapezoidal', 'moving_time': 2.0, 'accel_time': 0.3,
            'max_joint_step': 0.01, 'state_timeout': 1.0, 'hold_after': 0.25,
            'path_tolerance': 0.2, 'path_window': 0.2, 'goal_tolerance': 0.002,
            'goal_time_tolerance': 1.0, 'stop_deceleration': 10.0, 'start_tolerance': 0.05}


def request(points, names=ARM, key=1, vel=None, **tolerances):
    """Return a GoalRequest of [(time [s], positions)] points (tolerances: GoalRequest's)."""
    return GoalRequest(key=key, label=f'goal{key}', names=names,
                       times=[t for t, _ in points], positions=[p for _, p in points],
                       velocities=vel or [[] for _ in points],
                       accelerations=[[] for _ in points], **tolerances)


class Rig:
    """An executor, a clock and a driver that follows the setpoints."""

    def __init__(self, q0=(0.0, -0.9, 0.9, 0.3), **settings):
        self.ex = GoalExecutor(ARM, MODEL.lower, MODEL.upper, MODEL.velocity_limits,
                               Settings(**dict(SETTINGS, **settings)))
        self.now = 1_000_000_000
        self.steady = 5_000_000_000
        self.q = np.array(q0, dtype=float)
        self.frozen, self.offset, self.silent = set(), np.zeros(4), False
        self.sent, self.notes = [], []
        self.measure()

    def measure(self, q=None):
        """Report q (default: the driver's position) stamped now."""
        q = self.q + self.offset if q is None else np.asarray(q, float)
        return self.ex.measure(enumerate(q.tolist()), self.steady, self.now)

    def start(self, req):
        return self.ex.start(req, self.now, self.steady)

    def step(self, clock=True):
        """One tick (and a watchdog check every 4th): return the finished tuple or None."""
        self.now += TICK if clock else 0
        self.steady += TICK
        out = self.ex.tick(self.now, self.steady)
        if (self.steady // TICK) % 4 == 0:
            wd = self.ex.watchdog(self.steady)
            out.finished = out.finished or wd.finished
        self.notes += out.notes
        self.code = out.code or getattr(self, 'code', '')
        for q, qd in out.sends:
            self.sent.append((self.now, q, qd))
            keep = [ARM.index(j) for j in self.frozen]
            new = q.copy()
            new[keep] = self.q[keep]
            self.q = new
        if not self.silent:
            self.measure()
        return out.finished

    def run(self, seconds, **kw):
        """Tick for up to ``seconds``; return (status, reason, elapsed [s]) or None."""
        t0 = self.now
        for _ in range(int(round(seconds * 1e9 / TICK))):
            fin = self.step(**kw)
            if fin is not None:
                return fin[1], fin[2], (self.now - t0) * 1e-9
        return None

    def qs(self, since=0):
        return np.array([q for _, q, _ in self.sent[since:]])


def test_one_point_move_succeeds_on_time_without_a_big_step():
    rig = Rig()
    goal, old = rig.start(request([(1.0, [0.5, -0.9, 0.9, 0.3])]))
    assert old is None and goal.info['kind'].startswith('one-point trapezoidal')
    status, reason, elapsed = rig.run(3.0)
    assert status == SUCCEEDED and 'reached within' in reason, reason
    assert 1.0 <= elapsed <= 1.05
    q = rig.qs()
    assert np.abs(np.diff(q, axis=0)).max() < 0.01
    np.testing.assert_allclose(q[-1], [0.5, -0.9, 0.9, 0.3], atol=1e-12)
    assert rig.ex.active is None


def test_unnamed_joints_hold_and_moving_time_applies():
    rig = Rig(moving_time=0.5)
    rig.start(request([(0.0, [0.4])], names=['waist']))
    status, _, elapsed = rig.run(2.0)
    assert status == SUCCEEDED and 0.5 <= elapsed <= 0.55
    assert np.ptp(rig.qs()[:, 1:], axis=0).max() == 0.0


@pytest.mark.parametrize('req, words', [
    (request([(1.0, [0.1])], names=['wrist']), 'wrist'),
    (request([(1.0, [math.nan, 0, 0, 0])]), 'NaN'),
    (request([(1.0, [9.0, 0, 0, 0])]), 'limit'),
    (request([(1.0, [0.1, 0, 0, 0]), (0.5, [0.2, 0, 0, 0])]), 'increasing'),
    (request([(0.0, [1.0, -0.9, 0.9, 0.3]), (1.0, [0.2, -0.9, 0.9, 0.3])]), 'start_tolerance'),
])
def test_invalid_goal_changes_nothing(req, words):
    """An invalid goal raises with its reason; the running goal goes on undisturbed."""
    rig = Rig()
    running, _ = rig.start(request([(1.0, [0.5, -0.9, 0.9, 0.3])], key=7))
    rig.run(0.2)
    with pytest.raises(InvalidInputError, match=words):
        rig.start(req)
    assert rig.ex.active is running
    assert rig.run(3.0)[0] == SUCCEEDED


def test_no_measurement_or_stale_measurement_refuses_a_goal_until_fresh():
    ex = GoalExecutor(ARM, MODEL.lower, MODEL.upper, MODEL.velocity_limits,
                      Settings(**SETTINGS))
    with pytest.raises(InvalidInputError, match='no joint_states'):
        ex.start(request([(1.0, [0.1, 0, 0, 0])]), 0, 0)
    ex.measure(enumerate([0.0, -0.9, 0.9, 0.3]), 0, 0)
    with pytest.raises(InvalidInputError, match='old .*sim_driver'):
        ex.start(request([(1.0, [0.1, -0.9, 0.9, 0.3])]), 2_000_000_000, 2_000_000_000)
    ex.measure(enumerate([0.0, -0.9, 0.9, 0.3]), 2_000_000_000, 2_000_000_000)
    ex.start(request([(1.0, [0.1, -0.9, 0.9, 0.3])]), 2_000_000_000, 2_000_000_000)
    assert ex.active is not None


def test_non_finite_measurement_is_ignored():
    rig = Rig()
    assert not rig.measure([math.nan, 0.0, math.inf, 0.0])
    np.testing.assert_allclose(rig.ex.meas, [0.0, -0.9, 0.9, 0.3])


def test_preemption_continues_from_the_current_setpoint_and_velocity():
    rig = Rig()
    first, _ = rig.start(request([(1.0, [0.8, -0.9, 0.9, 0.3])], key=1))
    rig.run(0.5)
    k = len(rig.sent)
    second, old = rig.start(request([(1.0, [-0.2, -0.9, 0.9, 0.3])], key=2))
    assert old is first and rig.ex.active is second
    status, _, _ = rig.run(3.0)
    assert status == SUCCEEDED
    q = rig.qs()
    # no jump in position, and the velocity carried over (no reversal at the switch)
    assert np.abs(np.diff(q[k - 3:k + 3, 0])).max() < 0.01
    assert rig.sent[k][2][0] > 0.0


def test_cancel_decelerates_to_rest_where_it_is():
    rig = Rig()
    rig.start(request([(1.2, [1.0, -0.9, 0.9, 0.3])]))
    rig.run(0.6)
    goal = rig.ex.cancel(rig.now)
    assert goal.phase == 'canceling' and rig.ex.cancel(rig.now) is goal
    status, reason, elapsed = rig.run(2.0)
    assert status == CANCELED and reason.startswith('canceled: at rest at')
    q = rig.qs()
    assert 0.05 < q[-1, 0] < 1.0 - 0.05
    np.testing.assert_allclose(rig.sent[-1][2], 0.0, atol=1e-9)
    assert np.abs(np.diff(q[:, 0])).max() < 0.01


def test_silent_driver_pauses_the_goal_which_resumes_without_a_jump():
    """Measurements stop for 0.6 s: no setpoints after hold_after; then on from where it was."""
    rig = Rig(hold_after=0.25, state_timeout=1.0)
    rig.start(request([(3.0, [0.9])], names=['waist']))
    rig.run(1.0)
    k = len(rig.sent)
    rig.silent = True
    assert rig.run(0.6) is None
    paused = len(rig.sent) - k
    assert 48 <= paused <= 52                    # hold_after (0.25 s) of setpoints, then none
    assert [n for n in rig.notes if 'paused: no joint_states' in n[1]]
    rig.silent = False
    rig.measure()
    k2 = len(rig.sent)
    status, _, elapsed = rig.run(5.0)
    assert status == SUCCEEDED
    assert [n for n in rig.notes if 'resumed after a 0.3' in n[1]], rig.notes
    q = rig.qs()
    assert abs(q[k2, 0] - q[k2 - 1, 0]) < 0.01          # resumed where it paused
    assert 2.0 - 0.75 + 0.3 <= elapsed + 0.0 <= 2.0 + 0.1   # the rest of the move, delayed


def test_a_sample_stamped_before_a_pause_and_read_after_it_is_no_tracking_error():
    """
    The goal's clock stood still while paused: a late sample is placed before the pause.

    A starved driver publishes the samples of the time it catches up, stamped then; one stamped
    before a 0.45 s pause and read once the goal resumed showed the arm 0.45 s ahead of its
    setpoints (at 1 rad/s: over path_tolerance 0.2 rad) when its stamp was taken as that far
    back on the goal's time (test_namespaces: ABORTED under load, 0.2001 rad, "0.191 s before").
    """
    rig = Rig(hold_after=0.25, state_timeout=2.0)
    rig.start(request([(1.5, [1.2])], names=['waist']))     # 1 rad/s after a 0.3 s ramp
    rig.run(0.5)
    late_stamp, late_q = rig.now, rig.q.copy()
    rig.silent = True
    assert rig.run(0.7) is None
    assert [n for n in rig.notes if 'paused: no joint_states' in n[1]]
    rig.ex.measure(enumerate(late_q.tolist()), rig.steady, late_stamp)   # read only now
    assert rig.step() is None, rig.notes
    assert [n for n in rig.notes if 'resumed after a 0.4' in n[1]], rig.notes
    rig.silent = False
    status, reason, _ = rig.run(3.0)
    assert status == SUCCEEDED, reason


def test_a_server_not_scheduled_goes_on_from_where_it_was():
    """
    No tick for 0.5 s (the server's process starved) while the driver held the last setpoint.

    The goal's clock pauses over the gap: the next setpoint follows the last one, no tracking
    error against setpoints never sent (test_viewer_browser, load ~10: 'tracking error of joint
    shoulder is 0.6451 rad' with the arm at the setpoint of the stall's start).
    """
    rig = Rig(hold_after=0.25, state_timeout=2.0)
    rig.start(request([(1.5, [1.2])], names=['waist']))     # 1 rad/s after a 0.3 s ramp
    rig.run(0.5)
    last = rig.qs()[-1].copy()
    for _ in range(100):                      # 0.5 s: the driver holds, publishes; no tick
        rig.now += TICK
        rig.steady += TICK
        rig.measure()
    assert rig.step() is None, rig.notes
    assert [n for n in rig.notes if 'no tick for 0.51 s' in n[1]], rig.notes
    assert abs(rig.qs()[-1][0] - last[0]) < 0.01             # on from where it was
    status, reason, elapsed = rig.run(3.0)
    assert status == SUCCEEDED, reason
    assert elapsed >= 1.0 - 0.05                             # the rest of the move, not skipped


def test_a_stall_that_leaves_the_states_unread_counts_whole():
    """
    The server's process starved 1.1 s: no tick and no joint_states read meanwhile.

    The first tick after it finds the states stale and pauses the goal; the stall before that
    tick is a pause too, or the goal's clock jumps 1.1 s ahead of the setpoints sent
    (test_viewer_browser, load 7: 'not scheduled for 1.13 s', 'resumed after a 0.11 s pause',
    then 'tracking error of joint shoulder is 0.4874 rad').
    """
    rig = Rig(hold_after=0.25, state_timeout=2.0)
    rig.start(request([(1.5, [1.2])], names=['waist']))     # 1 rad/s after a 0.3 s ramp
    rig.run(0.5)
    last = rig.qs()[-1].copy()
    rig.now += 1_100_000_000                  # starved: nothing ran, the driver held `last`
    rig.steady += 1_100_000_000
    rig.silent = True
    assert rig.step() is None, rig.notes      # the states are 1.1 s old: paused
    assert [n for n in rig.notes if 'paused: no joint_states' in n[1]], rig.notes
    rig.measure()                             # the queued states, read now
    rig.silent = False
    assert rig.step() is None, rig.notes
    assert abs(rig.qs()[-1][0] - last[0]) < 0.01, (rig.qs()[-1], last)   # on from where it was
    status, reason, elapsed = rig.run(3.0)
    assert status == SUCCEEDED, reason
    assert elapsed >= 1.0 - 0.05                             # the rest of the move, not skipped


def test_watchdog_aborts_after_two_stale_checks_on_the_steady_clock():
    """A stopped goal clock (sim time) does not hide a silent driver: steady time decides."""
    rig = Rig(state_timeout=0.5, hold_after=0.25)
    rig.start(request([(3.0, [0.9])], names=['waist']))
    rig.run(0.2)
    rig.silent = True
    status, reason, _ = rig.run(2.0, clock=False)
    assert status == ABORTED and 'driver not publishing joint_states' in reason
    age = float(reason.split('none for ')[1].split(' s')[0])
    assert 0.5 < age <= 0.5 + 2 * 0.02 + 1e-9


def test_watchdog_says_when_the_abort_was_noticed_late():
    rig = Rig(state_timeout=0.5)
    rig.start(request([(3.0, [0.9])], names=['waist']))
    rig.steady += 2_000_000_000
    assert rig.ex.watchdog(rig.steady).finished is None
    out = rig.ex.watchdog(rig.steady + 20_000_000, rig.steady, 'not scheduled for 1.9 s')
    assert out.finished[1] == ABORTED
    assert out.finished[2].endswith('noticed late: this node was not scheduled for 1.9 s')


def test_blocked_joint_aborts_with_its_name_and_holds_where_measured():
    rig = Rig()
    rig.frozen.add('elbow')
    rig.start(request([(1.5, [0.0, -0.9, -0.6, 0.3])]))
    status, reason, _ = rig.run(3.0)
    assert status == ABORTED and "tracking error of joint 'elbow'" in reason, reason
    np.testing.assert_allclose(rig.sent[-1][1], rig.ex.meas)
    np.testing.assert_allclose(rig.sent[-1][2], 0.0)


def test_out_of_limit_measurement_never_becomes_a_setpoint():
    """A lying 100 rad waist aborts the move; the waist holds its last setpoint."""
    rig = Rig()
    rig.start(request([(2.0, [0.5])], names=['waist']))
    rig.run(0.3)
    last = rig.sent[-1][1][0]
    rig.silent = True
    rig.measure([100.0] + rig.q[1:].tolist())
    status, reason, _ = rig.run(0.1)
    assert status == ABORTED and 'tracking error' in reason
    held = rig.sent[-1][1]
    assert held[0] == pytest.approx(last, abs=0.01) and 0.0 <= held[0] <= 0.5
    assert [n for n in rig.notes if 'holding the last setpoint' in n[1]]


def test_goal_that_never_settles_aborts_after_the_settle_time():
    rig = Rig()
    rig.offset[3] = 0.01                          # within path tolerance, beyond goal tolerance
    rig.start(request([(0.5, [0.1])], names=['waist']))
    status, reason, elapsed = rig.run(5.0)
    assert status == ABORTED and "'wrist_angle' did not settle" in reason
    assert 0.5 + 1.0 < elapsed <= 0.5 + 1.0 + 0.01


def test_linear_max_step_advances_one_step_per_tick_however_late():
    rig = Rig(profile='linear_max_step', max_joint_step=0.004)
    goal, _ = rig.start(request([(0.5, [0.8, -0.9, 0.9, 0.3])]))
    assert goal.stepped
    for k in range(40):                           # ticks arriving late (3 periods apart)
        rig.now += 2 * TICK
        rig.step()
    status, _, _ = rig.run(5.0)
    assert status == SUCCEEDED
    q = rig.qs()
    assert np.abs(np.diff(q, axis=0)).max() <= 0.004 + 1e-9 and len(q) >= 200


def test_waypoints_pass_through_their_points():
    rig = Rig()
    pts = [(0.6, [0.3, -0.7, 0.8, 0.3]), (1.2, [0.5, -0.5, 0.5, 0.2]),
           (1.8, [0.2, -0.6, 0.6, 0.1])]
    t0 = rig.now
    goal, _ = rig.start(request(pts))
    assert goal.info['kind'] == '3-waypoint spline trajectory'
    assert rig.run(5.0)[0] == SUCCEEDED
    times = np.array([t for t, _, _ in rig.sent])
    for tw, p in pts:
        k = int(np.argmin(np.abs(times - (t0 + tw * 1e9))))
        np.testing.assert_allclose(rig.sent[k][1], p, atol=1e-9)


@pytest.mark.parametrize('name, value, words', [
    ('hold_after', 0.01, '>= 0.05'), ('hold_after', math.nan, 'hold_after must be >= 0.05'),
    ('profile', 'wobbly', 'profile must be one of'), ('accel_time', -1.0, '>= 0'),
    ('stop_deceleration', 0.0, '> 0'), ('rate', math.inf, '> 0')])
def test_settings_errors_name_the_problem(name, value, words):
    assert words in settings_error(name, value)
    assert settings_error(name, SETTINGS.get(name, 50)) == ''


def test_settings_ranges_are_the_schemas():
    """Every number setting is refused just outside the schema's range and taken at its ends."""
    from px100_control.parameters import TRAJECTORY_SERVER
    numbers = [s for s in TRAJECTORY_SERVER.params if s.kind in ('double', 'integer')]
    assert len(numbers) >= 12
    for spec in numbers:
        step = 1 if spec.kind == 'integer' else 1e-9
        assert settings_error(spec.name, spec.default) == ''
        below = spec.low if spec.above_low else spec.low - step
        assert spec.name in settings_error(spec.name, below)
        assert settings_error(spec.name, True)          # a bool is not a number
        if spec.high is not None:
            assert settings_error(spec.name, spec.high) == ''
            assert spec.name in settings_error(spec.name, spec.high + step)


def test_path_tolerance_per_joint_codes_and_none():
    """A blocked elbow: PATH_TOLERANCE by default; with its path tolerance -1, GOAL_TOLERANCE."""
    rig = Rig()
    rig.frozen.add('elbow')
    rig.start(request([(1.5, [0.0, -0.9, -0.6, 0.3])]))
    status, reason, _ = rig.run(3.0)
    assert (status, rig.code) == (ABORTED, PATH_TOLERANCE) and "'elbow'" in reason
    rig = Rig()
    rig.frozen.add('elbow')
    rig.start(request([(1.5, [0.0, -0.9, -0.6, 0.3])], path_tolerance={'elbow': -1.0},
                      goal_time_tolerance=0.5))
    status, reason, elapsed = rig.run(5.0)
    assert (status, rig.code) == (ABORTED, GOAL_TOLERANCE), reason
    assert "joint 'elbow' did not settle" in reason and 1.5 + 0.5 < elapsed <= 2.01


@pytest.mark.parametrize('tol, status', [({'wrist_angle': 0.02}, SUCCEEDED),
                                         ({'wrist_angle': 0.0}, ABORTED),
                                         ({'wrist_angle': -1.0}, SUCCEEDED)])
def test_goal_tolerance_per_joint(tol, status):
    """An offset of 10 mrad: within a 20 mrad or no tolerance; 0 = the default 2 mrad."""
    rig = Rig()
    rig.offset[3] = 0.01
    rig.start(request([(0.5, [0.1])], names=['waist'], goal_tolerance=tol,
                      goal_time_tolerance=0.3))
    got, reason, _ = rig.run(3.0)
    assert got == status, reason
    assert rig.code == ('' if status == SUCCEEDED else GOAL_TOLERANCE)


@pytest.mark.parametrize('kw, words', [
    ({'path_tolerance': {'nope': 0.1}}, "names joint 'nope'"),
    ({'goal_tolerance': {'waist': math.nan}}, "goal_tolerance of joint 'waist'"),
    ({'goal_time_tolerance': -1.0}, 'goal_time_tolerance'),
])
def test_bad_tolerances_are_refused_and_change_nothing(kw, words):
    rig = Rig()
    with pytest.raises(InvalidInputError, match=words):
        rig.start(request([(1.0, [0.1])], names=['waist'], **kw))
    assert rig.ex.active is None
