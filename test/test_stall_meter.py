"""StallMeter: late periodic checks are reported with the longest noted part (no ROS)."""
from px100_control.tools.stall import StallMeter
import pytest

MS = 1_000_000


def test_on_time_checks_report_nothing():
    """Checks every period: no stall, the worst gap is the period."""
    m = StallMeter(0.02, 0.25)
    for k in range(50):
        m.note('tick', 3 * MS)
        assert m.check(k * 20 * MS) is None
    assert m.stalls == 0
    assert m.worst_gap_s == pytest.approx(0.02)


def test_late_check_names_the_longest_part():
    """A check 2 s late is a stall of 2 s naming the part that took longest since the last one."""
    m = StallMeter(0.02, 0.25)
    assert m.check(0) is None
    m.note('publishing a setpoint', 5 * MS)
    m.note('publishing a setpoint', 1990 * MS)
    m.note('a setpoint tick', 1995 * MS)
    stall = m.check(2000 * MS)
    assert stall is not None and m.stalls == 1
    assert stall.gap_s == pytest.approx(2.0)
    assert stall.longest == {'publishing a setpoint': pytest.approx(1.99),
                             'a setpoint tick': pytest.approx(1.995)}
    text = stall.describe()
    assert text.startswith('not scheduled for 2.00 s (checks every 0.02 s)')
    assert stall.counts == {'publishing a setpoint': 2, 'a setpoint tick': 1}
    assert text.index('a setpoint tick 1.995 s (x1)') < \
        text.index('publishing a setpoint 1.990 s (x2)')
    # the parts are per interval: the next, on-time interval starts empty
    m.note('a setpoint tick', 1 * MS)
    assert m.check(2020 * MS) is None
    stall = m.check(2400 * MS)
    assert stall.longest == {} and 'no noted part ran' in stall.describe()


def test_parts_that_kept_running_are_counted():
    """A late check after 400 short ticks: the process ran, only the check was not called."""
    m = StallMeter(0.02, 0.25)
    m.check(0)
    for _ in range(400):
        m.note('a setpoint tick', MS // 2)
    stall = m.check(2000 * MS)
    assert stall.counts == {'a setpoint tick': 400}
    assert 'a setpoint tick 0.001 s (x400)' in stall.describe()


def test_gap_at_the_threshold_is_no_stall():
    """Exactly warn_after is tolerated; one nanosecond more is a stall."""
    m = StallMeter(0.02, 0.25)
    m.check(0)
    assert m.check(250 * MS) is None
    assert m.check(500 * MS + 1) is not None


@pytest.mark.parametrize('period, warn', [(0.0, 0.25), (0.02, 0.02), (-1.0, 1.0)])
def test_bad_settings_are_refused(period, warn):
    """The threshold must exceed a positive period."""
    with pytest.raises(ValueError, match='period_s'):
        StallMeter(period, warn)
