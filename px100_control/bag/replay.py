"""
The replay schedule: when each recorded message is due, at a rate, from an offset, in loops.

Pure time arithmetic (no clock is read here): log times are integer ns since the epoch, due times
are float seconds from the start of the replay. With ``rate`` r and ``start_offset_s`` o the
first replayed log time is ``t0 = bag_start + o``; a message logged at t is due at
``(t - t0) / r`` in the first pass and one ``period_s`` later in each following pass (``loop``).
Topic selection and ``from:=to`` remapping are parsed here too, and the replay's safety and
progress texts are worded here: which replayed topics are commands to a live arm, what the
warning about live nodes says, the progress line.
"""
from dataclasses import dataclass
import math
from typing import Dict, Iterable, List, Mapping, Optional, Sequence, Tuple

from px100_control.bag.ros_names import action_topic, is_call_record, is_xs_command
from px100_control.errors import BagError

#: shortest wall time of one loop pass [s] (a one-message bag must not loop at 100 % CPU)
MIN_LOOP_PERIOD_S = 0.01
#: topics (relative to a robot namespace) that move a live arm when replayed
COMMAND_TOPICS = ('commands/joint_setpoints',)
#: request topics of bags recorded before goals and IK became actions and services: no node
#: takes them any more, so they are never re-sent
RETIRED_REQUESTS = ('trajectory/goal', 'ik/request', 'ik/path_request')


@dataclass(frozen=True)
class ReplaySchedule:
    """
    Due times of recorded messages.

    :param bag_start_ns: first log time of the replayed topics
    :param bag_end_ns: last log time of the replayed topics
    :param rate: playback speed factor (> 0; 2 = twice as fast)
    :param start_offset_s: bag time [s] skipped at the start (>= 0)
    :param loop: replay again and again
    :raises ValueError: rate not > 0, offset < 0 or beyond the bag, NaN/inf, end < start
    """

    bag_start_ns: int
    bag_end_ns: int
    rate: float = 1.0
    start_offset_s: float = 0.0
    loop: bool = False

    def __post_init__(self):
        if not (isinstance(self.rate, (int, float)) and math.isfinite(self.rate)
                and self.rate > 0):
            raise ValueError(f'rate must be a finite number > 0, got {self.rate!r}')
        if not (math.isfinite(self.start_offset_s) and self.start_offset_s >= 0):
            raise ValueError(f'start offset must be a finite number >= 0 s, '
                             f'got {self.start_offset_s!r}')
        if self.bag_end_ns < self.bag_start_ns:
            raise ValueError('bag end time is before its start time')
        if self.first_ns > self.bag_end_ns:
            raise ValueError(f'start offset {self.start_offset_s:g} s is beyond the end of the '
                             f'bag ({self.bag_duration_s:.3f} s long)')

    @property
    def bag_duration_s(self) -> float:
        """Bag time from the first to the last message [s]."""
        return (self.bag_end_ns - self.bag_start_ns) * 1e-9

    @property
    def first_ns(self) -> int:
        """First log time that is replayed."""
        return self.bag_start_ns + int(round(self.start_offset_s * 1e9))

    @property
    def pass_duration_s(self) -> float:
        """Wall time [s] of one pass from the first to the last replayed message."""
        return (self.bag_end_ns - self.first_ns) * 1e-9 / self.rate

    @property
    def period_s(self) -> float:
        """Wall time [s] between the starts of two loop passes."""
        return max(self.pass_duration_s, MIN_LOOP_PERIOD_S)

    def includes(self, log_time_ns: int) -> bool:
        """Return True if a message logged at this time is replayed."""
        return self.first_ns <= log_time_ns <= self.bag_end_ns

    def due_s(self, log_time_ns: int, pass_index: int = 0) -> float:
        """
        Return when [s from the replay start] a message logged at log_time_ns is due.

        Example Input: start 0, rate 2.0, log time 1e9 ns, pass 0. Output: 0.5
        """
        return pass_index * self.period_s + (log_time_ns - self.first_ns) * 1e-9 / self.rate

    def bag_time_ns(self, elapsed_s: float) -> Tuple[int, int]:
        """Return (pass index, bag log time [ns]) reached after elapsed_s of replay."""
        if elapsed_s <= 0:
            return 0, self.first_ns
        index = int(elapsed_s // self.period_s) if self.loop else 0
        within = elapsed_s - index * self.period_s
        t = self.first_ns + int(min(within * self.rate, (self.bag_end_ns - self.first_ns) * 1e-9)
                                * 1e9)
        return index, t

    def progress(self, elapsed_s: float) -> float:
        """Return the fraction [0, 1] of the current pass replayed after elapsed_s."""
        if self.pass_duration_s <= 0:
            return 1.0
        _, t = self.bag_time_ns(elapsed_s)
        return min(1.0, max(0.0, (t - self.first_ns) * 1e-9 / self.rate / self.pass_duration_s))


def plan(log_times_ns: Sequence[int], schedule: ReplaySchedule,
         passes: int = 1) -> List[Tuple[int, int, float]]:
    """
    Return [(pass, message index, due [s])] of a bag's log times in replay order.

    Messages logged before the start offset are skipped; log times must be sorted.
    """
    out = []
    for p in range(passes if schedule.loop else 1):
        for i, t in enumerate(log_times_ns):
            if schedule.includes(t):
                out.append((p, i, schedule.due_s(t, p)))
    return out


def resolve_topic(name: str, namespace: str = '') -> str:
    """Return an absolute topic name: ``/x`` as is, ``x`` under ``/<namespace>/`` (or ``/x``)."""
    name = str(name).strip()
    if not name:
        raise BagError('empty topic name')
    if name.startswith('/'):
        return name
    ns = namespace.strip('/')
    return f'/{ns}/{name}' if ns else f'/{name}'


def parse_remaps(items: Optional[Iterable[str]], namespace: str = '') -> Dict[str, str]:
    """
    Return {from topic: to topic} of ``from:=to`` items (names resolved as resolve_topic).

    :raises BagError: an item without ``:=``, an empty side, or a topic remapped twice
    """
    remaps: Dict[str, str] = {}
    for item in items or ():
        src, sep, dst = str(item).partition(':=')
        if not sep or not src.strip() or not dst.strip():
            raise BagError(f"remap '{item}' is not of the form from:=to")
        src, dst = resolve_topic(src, namespace), resolve_topic(dst, namespace)
        if src in remaps and remaps[src] != dst:
            raise BagError(f"topic '{src}' is remapped twice ({remaps[src]} and {dst})")
        remaps[src] = dst
    return remaps


def command_topics(topics: Iterable[str], remaps: Mapping[str, str]) -> Dict[str, str]:
    """Return {bag topic: namespace it is published into} of the setpoint topics."""
    out = {}
    for topic in topics:
        published_as = remaps.get(topic, topic)
        for suffix in COMMAND_TOPICS:
            if published_as.endswith('/' + suffix) or published_as == suffix:
                out[topic] = published_as[:-len(suffix)].rstrip('/') or '/'
    return out


def not_replayed(topic: str, send_commands: bool) -> str:
    """
    Return why a bag topic is never replayed ('' when it may be).

    Service events (the actions' goal/cancel/result ones included) record calls that were
    made: they are never re-sent, nor are the retired request topics of older bags
    (``trajectory/goal``, ``ik/request``, ``ik/path_request``: no node takes them). An action's
    feedback and status and the Interbotix driver's commands (``commands/joint_group`` ...) are
    re-sent only with ``send_commands``.
    """
    if is_call_record(topic):
        return 'recorded service calls are never re-sent'
    if any(topic.endswith('/' + t) or topic == t for t in RETIRED_REQUESTS):
        return 'retired request topics are never re-sent (goals and IK are actions and services)'
    if not send_commands and action_topic(topic) is not None:
        return 'action topics are re-sent only with --send-commands'
    if not send_commands and is_xs_command(topic):
        return 'driver commands are re-sent only with --send-commands'
    return ''


def withheld_warning(live: Mapping[str, Sequence[str]], topics: Sequence[str]) -> str:
    """Return the warning about commands not replayed ({namespace: live node names})."""
    return ('live nodes would act on the replayed commands ('
            + '; '.join(f"{ns}: {', '.join(n)}" for ns, n in live.items())
            + f"): not replaying {', '.join(topics)} (--send-commands replays them)")


def progress_text(schedule: ReplaySchedule, elapsed_s: float, published: int,
                  passes: int = 0, final: bool = False) -> str:
    """Return the progress line after ``elapsed_s`` [s] of replay (``final``: the last one)."""
    if final:
        return (f'[replay] done: {published} messages in {elapsed_s:.2f} s'
                + (f' ({passes} passes)' if schedule.loop else ''))
    index, bag_t = schedule.bag_time_ns(elapsed_s)
    done_s = (bag_t - schedule.bag_start_ns) * 1e-9
    return (f'[replay] {done_s:7.2f} / {schedule.bag_duration_s:.2f} s '
            f'({100.0 * schedule.progress(elapsed_s):3.0f} %)  {published} messages'
            + (f'  pass {index + 1}' if schedule.loop else ''))
