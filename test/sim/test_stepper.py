"""The sim_driver's time keeping (Stepper) on a real ArmSimulator, with clocks given (no ROS)."""
import math

from px100_control.models.registry import load_robot
from px100_control.sim.simulator import ArmSimulator
from px100_control.sim.stepper import MAX_CHUNK, MAX_PHYSICS_LOAD, Stepper
import pytest

MS = 1_000_000


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


class FakeWall:
    """A monotonic wall clock [s] that advances ``step`` per reading."""

    def __init__(self, step=1e-4):
        self.t = 1000.0
        self.step = step

    def __call__(self):
        self.t += self.step
        return self.t


def stepper(px100, master=False, rtf=1.0, publish_rate=100.0, clock_rate=250.0, wall=None,
            warnings=None):
    return Stepper(ArmSimulator(px100, scene=None), 1000.0, publish_rate, clock_rate, rtf,
                   master, warn=None if warnings is None else warnings.append,
                   wall=wall or FakeWall())


@pytest.mark.parametrize('rtf, expect_fast', [(0.0, True), (float('inf'), True), (1.0, False),
                                              (3.0, False)])
def test_own_clock_is_not_tied_to_the_wall(px100, rtf, expect_fast):
    """As fast as possible ignores wall time; a finite factor follows it (0.1 ms per reading)."""
    wall = FakeWall()
    s = stepper(px100, master=True, rtf=rtf, wall=wall)
    s.set_rtf(rtf)
    wall0, sim0 = wall.t, s.sim_ns
    for _ in range(5):
        s.master_tick(lambda ns: None, lambda ns: None)
    elapsed = wall.t - wall0
    sim = (s.sim_ns - sim0) * 1e-9
    if expect_fast:
        assert sim > 3.0 * elapsed, (sim, elapsed)
    else:
        assert sim == pytest.approx(rtf * elapsed, abs=2e-3), (sim, elapsed)
    assert not math.isnan(s.achieved_rtf)


def test_own_clock_hands_out_clock_ticks_and_samples_on_their_grids(px100):
    """/clock every 4 ms and samples every 10 ms of simulated time, each once, in order."""
    s = stepper(px100, master=True, rtf=0.0, wall=FakeWall(step=1e-3))
    clocks, samples = [], []
    while s.sim_ns < 200 * MS:
        s.master_tick(clocks.append, samples.append)
    assert clocks[:5] == [4 * MS, 8 * MS, 12 * MS, 16 * MS, 20 * MS]
    assert samples[:3] == [10 * MS, 20 * MS, 30 * MS]
    assert all(b - a == 4 * MS for a, b in zip(clocks, clocks[1:]))
    assert all(b - a == 10 * MS for a, b in zip(samples, samples[1:]))
    assert s.stamp_ns == s.sim_ns       # own clock: stamps are simulated time


def test_following_a_clock_integrates_exactly_the_elapsed_time(px100):
    """The first reading sets the origin; then the physics follows the clock in whole steps."""
    s = stepper(px100)
    s.advance_to(5_000 * MS)
    assert (s.start_ns, s.sim_ns) == (5_000 * MS, 0)
    s.advance_to(5_250 * MS + 400_000)          # 250.4 ms later: 250 steps of 1 ms
    assert s.sim_ns == 250 * MS
    assert s.stamp_ns == 5_250 * MS
    s.advance_to(5_100 * MS)                    # the clock went back: re-anchored, no physics
    assert s.sim_ns == 250 * MS and s.start_ns == 4_850 * MS


def test_a_far_behind_clock_drops_time_and_says_so(px100):
    """Behind by more than a publish period + MAX_CHUNK: that much integrated, the rest dropped."""
    warnings = []
    s = stepper(px100, warnings=warnings)
    s.advance_to(1_000 * MS)
    s.advance_to(11_000 * MS)                   # 10 s behind
    assert s.sim_ns == int((MAX_CHUNK + 0.01) * 1e9)        # + one publish period (100 Hz)
    assert s.start_ns == 11_000 * MS - s.sim_ns  # the stamp is the clock's now
    assert warnings == ['simulation fell 10.000 s behind the clock; skipping ahead']


def test_a_slow_publish_rate_widens_the_chunk(px100):
    """At 0.5 Hz one sample period (2 s) is integrated without dropping time."""
    s = stepper(px100, publish_rate=0.5, warnings=[])
    s.advance_to(1_000 * MS)
    assert s.advance_to_sample(3_000 * MS) == 3_000 * MS
    assert s.sim_ns == 2_000 * MS and s.start_ns == 1_000 * MS


def test_a_late_sample_at_a_slow_rate_drops_no_time(px100):
    """At 1 Hz a sample 0.3 s late integrates the whole 1.3 s (a CI run dropped 1 ms here)."""
    warnings = []
    s = stepper(px100, publish_rate=1.0, warnings=warnings)
    s.advance_to(1_000 * MS)
    assert s.advance_to_sample(2_300 * MS) == 2_300 * MS
    assert s.sim_ns == 1_300 * MS and s.start_ns == 1_000 * MS and not warnings


def test_step_cost_and_the_load_check(px100):
    """The measured step cost bounds control_rate when following a clock, not on its own."""
    s = stepper(px100)
    assert s.step_cost is None and s.load_error(1e5) is None
    s.advance(20)
    assert 0.0 < s.step_cost < 0.01
    s.step_cost = 50e-6
    assert s.load_error(MAX_PHYSICS_LOAD / 50e-6 * 0.9) is None
    error = s.load_error(100000.0)
    assert 'control_rate 100000 Hz: one physics step takes 50 us here' in error
    assert f'at most {MAX_PHYSICS_LOAD / 50e-6:.0f} Hz' in error
    s.master = True
    assert s.load_error(100000.0) is None


def test_control_rate_changes_the_step(px100):
    s = stepper(px100)
    s.set_control_rate(2000.0)
    assert s.dt_ns == 500_000 and s.sim.dt == pytest.approx(5e-4)
    s.advance(4)
    assert s.sim_ns == 2 * MS
    assert math.isnan(stepper(px100).achieved_rtf)
