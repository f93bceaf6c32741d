"""The pure replay schedule: due times at a rate, from an offset, in loops; remaps; texts."""
from hypothesis import given, settings
from hypothesis import strategies as st
from px100_control.bag.replay import (command_topics, MIN_LOOP_PERIOD_S, not_replayed,
                                      parse_remaps, plan, progress_text, ReplaySchedule,
                                      resolve_topic, withheld_warning)
from px100_control.errors import BagError
import pytest

S = 1_000_000_000
T0 = 1_700_000_000 * S


def test_docstring_example():
    """Start 0, rate 2, a message at 1 s is due at 0.5 s."""
    assert ReplaySchedule(0, 2 * S, rate=2.0).due_s(1 * S) == 0.5


def test_rate_offset_and_skipping():
    """Messages before the offset are skipped; the rest keep their spacing divided by rate."""
    times = [T0 + k * S // 10 for k in range(21)]  # 0 .. 2 s every 0.1 s
    sched = ReplaySchedule(times[0], times[-1], rate=2.0, start_offset_s=0.5)
    p = plan(times, sched)
    assert [i for _, i, _ in p] == list(range(5, 21))
    dues = [d for _, _, d in p]
    assert dues[0] == pytest.approx(0.0)
    assert dues[-1] == pytest.approx(0.75)
    assert all(b - a == pytest.approx(0.05) for a, b in zip(dues, dues[1:]))
    assert sched.pass_duration_s == pytest.approx(0.75)


def test_loop_passes_follow_each_other():
    """Pass k starts k periods later; the period is the pass duration."""
    times = [T0, T0 + S, T0 + 2 * S]
    sched = ReplaySchedule(times[0], times[-1], loop=True)
    p = plan(times, sched, passes=3)
    assert [d for _, _, d in p] == pytest.approx([0, 1, 2, 2, 3, 4, 4, 5, 6])
    assert sched.bag_time_ns(2.5) == (1, T0 + S // 2)
    assert plan(times, ReplaySchedule(times[0], times[-1]), passes=3) == plan(
        times, ReplaySchedule(times[0], times[-1]))


def test_single_message_loop_does_not_spin():
    """A one-message bag in a loop repeats at most every MIN_LOOP_PERIOD_S."""
    sched = ReplaySchedule(T0, T0, loop=True)
    assert sched.due_s(T0, 1) == MIN_LOOP_PERIOD_S
    assert sched.progress(0.0) == 1.0


@pytest.mark.parametrize('kwargs, message', [
    ({'rate': 0.0}, 'rate must be'), ({'rate': -1.0}, 'rate must be'),
    ({'rate': float('nan')}, 'rate must be'), ({'rate': float('inf')}, 'rate must be'),
    ({'start_offset_s': -1.0}, 'start offset'), ({'start_offset_s': float('nan')}, 'offset'),
    ({'start_offset_s': 5.0}, 'beyond the end'),
])
def test_bad_options(kwargs, message):
    """Bad rates and offsets are refused with the reason."""
    with pytest.raises(ValueError, match=message):
        ReplaySchedule(T0, T0 + 2 * S, **kwargs)


@settings(max_examples=60, deadline=None)
@given(gaps=st.lists(st.integers(0, 5 * S), min_size=1, max_size=40),
       rate=st.floats(0.05, 20.0), offset_frac=st.floats(0.0, 1.0))
def test_due_times_keep_order_and_scale(gaps, rate, offset_frac):
    """Due times are non-decreasing, start at >= 0 and equal (log time - first) / rate."""
    times = [T0]
    for g in gaps:
        times.append(times[-1] + g)
    offset = (times[-1] - times[0]) * 1e-9 * offset_frac
    sched = ReplaySchedule(times[0], times[-1], rate=rate, start_offset_s=offset)
    p = plan(times, sched)
    dues = [d for _, _, d in p]
    assert p, 'the last message is always replayed'
    assert all(b >= a for a, b in zip(dues, dues[1:]))
    assert dues[0] >= -1e-9
    for _, i, d in p:
        assert d == pytest.approx((times[i] - sched.first_ns) * 1e-9 / rate, abs=1e-9)


def test_topic_names_and_remaps():
    """Relative names go under the robot namespace; from:=to pairs parse; bad ones are refused."""
    assert resolve_topic('joint_states', 'px100') == '/px100/joint_states'
    assert resolve_topic('/diagnostics', 'px100') == '/diagnostics'
    assert resolve_topic('x', '') == '/x'
    assert parse_remaps(['joint_states:=/other', '/a:=b'], 'px100') == {
        '/px100/joint_states': '/other', '/a': '/px100/b'}
    for bad in ['nosep', ':=/x', '/x:=', '']:
        with pytest.raises(BagError, match='from:=to'):
            parse_remaps([bad])
    with pytest.raises(BagError, match='remapped twice'):
        parse_remaps(['/a:=/b', '/a:=/c'])


def test_command_topics_follow_remaps():
    """Setpoints are commands in the namespace they are published into."""
    topics = ['/px100/trajectory/goal', '/px100/joint_states', '/px100/commands/joint_setpoints',
              '/commands/joint_setpoints']
    assert command_topics(topics, {}) == {'/px100/commands/joint_setpoints': '/px100',
                                          '/commands/joint_setpoints': '/'}
    sp = '/px100/commands/joint_setpoints'
    assert command_topics([sp], {sp: '/arm2/commands/joint_setpoints'}) == {sp: '/arm2'}
    assert command_topics([sp], {sp: '/px100/other'}) == {}


def test_retired_request_topics_are_never_replayed():
    """An older bag's goal and IK request topics are never re-sent, even with send_commands."""
    for topic in ('/px100/trajectory/goal', '/arm2/ik/request', '/px100/ik/path_request'):
        for send in (False, True):
            assert 'retired request topics' in not_replayed(topic, send), topic
    for topic in ('/px100/trajectory/status', '/px100/ik/solution', '/px100/joint_states',
                  '/px100/commands/joint_setpoints'):
        assert not_replayed(topic, False) == '', topic


def test_withheld_warning_names_the_live_nodes():
    """The warning names each namespace's live nodes and the topics not replayed."""
    text = withheld_warning({'/px100': ['/px100/sim_driver', '/px100/trajectory_actions']},
                            ['/px100/commands/joint_setpoints'])
    assert text == ('live nodes would act on the replayed commands (/px100: /px100/sim_driver, '
                    '/px100/trajectory_actions): not replaying /px100/commands/joint_setpoints '
                    '(--send-commands replays them)')


def test_progress_text():
    """The progress line: bag time, percent, messages, pass; the final line: the totals."""
    s = ReplaySchedule(T0, T0 + 4 * 10**9, rate=2.0)
    assert progress_text(s, 1.0, 7) == '[replay]    2.00 / 4.00 s ( 50 %)  7 messages'
    assert progress_text(s, 2.5, 9, passes=1, final=True) == \
        '[replay] done: 9 messages in 2.50 s'
    loop = ReplaySchedule(T0, T0 + 4 * 10**9, rate=2.0, loop=True)
    assert progress_text(loop, 3.0, 12).endswith('  pass 2')
    assert progress_text(loop, 5.0, 20, passes=2, final=True).endswith('(2 passes)')
