"""
Replay a bag into the live graph with its original timing: ``ros2 run px100_control replay``.

Command line (the options of ``ros2 bag play``)::

    replay BAG [-r/--rate R] [-l/--loop] [--topics T ...] [--remap FROM:=TO ...]
               [--start-offset S] [--delay S] [--wait-for-subscribers S [--min-subscribers N]]
               [--no-progress]

Messages are published as the recorded bytes (no deserialisation) on publishers with the QoS
recorded for their topic (transient local stays transient local). Topic names without a leading
``/`` are taken under ``/<robot_name>/``. A progress line goes to stderr. Types that are not
installed here (e.g. ``/tf``'s tf2_msgs) are skipped with a warning unless asked for by
``--topics`` (then it is an error). A missing, empty, truncated or corrupt bag, an unknown
topic or type: one clear error line, exit status 1.

Safety: when a live driver or trajectory server runs in a namespace the bag replays into (see
:mod:`px100_control.ros.peers`), the replayer warns, naming them, and by default does not
re-send the bag's setpoints (``commands/joint_setpoints``): they would move the live arm again.
``--send-commands`` (``send_commands=True``) sends them anyway. Replayed ``joint_states``
beside a live driver are sent, with a warning. Recorded service calls
(``<service>/_service_event``, the actions' goal/cancel/result events included) and the
retired request topics of older bags (``trajectory/goal``, ``ik/request``,
``ik/path_request``) are never re-sent; an action's feedback and status and the Interbotix
commands (``commands/joint_group``, ``joint_single``, ``joint_trajectory``) only with
``--send-commands`` (:func:`px100_control.bag.replay.not_replayed`).

Python: ``ReplayerNode(bag, rate=..., topics=..., remap=...)``, then ``start()``; ``done`` is
set when the replay ended.
"""
import sys
import threading
import time
from typing import Dict, List, Optional, Sequence

from px100_control.bag.reader import BagReader
from px100_control.bag.replay import (command_topics, not_replayed, parse_remaps,
                                      progress_text, ReplaySchedule, resolve_topic)
from px100_control.bag.tool_options import add_replay_arguments, extract_remaps
from px100_control.errors import BagError
from px100_control.models.registry import read_robot_file
from px100_control.parameters import COMMON, REPLAYER
from px100_control.ros.bag_qos import publisher_qos
from px100_control.ros.bag_tool import run_bag_tool
from px100_control.ros.common import init_robot_node, parse_cli
from px100_control.ros.message_types import message_class
from px100_control.ros.parameter_schema import parameter_descriptor
from px100_control.ros.replay_guard import CommandGuard
from rclpy.duration import Duration
from rclpy.node import Node

PROGRESS_PERIOD_S = 0.25
#: after --wait-for-subscribers saw its subscribers, the time [s] given to their side of the match
SUBSCRIBER_SETTLE_S = 0.5


class ReplayerNode(Node):
    """
    Node 'replayer': publishes a bag's messages with their recorded timing.

    :param bag: bag directory or .mcap file
    :param rate: speed factor (> 0)
    :param loop: replay again and again
    :param topics: topics to replay (default: all with an installed type)
    :param remap: ``from:=to`` topic remappings
    :param start_offset: bag time [s] to skip at the start
    :param delay: wait this long [s] before the first message
    :param wait_for_subscribers: wait up to this long [s] for every topic to have
        min_subscribers subscribers
    :param progress: write a progress line to stderr
    :param send_commands: replay goals and setpoints also into a namespace with a live driver
        or trajectory_server (default: skip them there, with a warning)
    :raises BagError: bad bag, unknown topic or type, bad option value
    """

    def __init__(self, bag: str, rate: float = 1.0, loop: bool = False,
                 topics: Optional[Sequence[str]] = None, remap: Optional[Sequence[str]] = None,
                 start_offset: float = 0.0, delay: float = 0.0,
                 wait_for_subscribers: float = 0.0, min_subscribers: int = 1,
                 progress: bool = True, send_commands: bool = False, **node_kwargs):
        init_robot_node(self, 'replayer', node_kwargs)
        # the robot_model/robot_name parameters of every node (the model itself is not needed)
        read_robot_file(str(self.declare_parameter(
            'robot_model', 'px100', parameter_descriptor(COMMON[0])).value))
        self.declare_parameter('robot_name', self.get_namespace().strip('/'),
                               parameter_descriptor(COMMON[1]))
        # the bag's topics keep their recorded (absolute) names; relative --topics / --remap
        # names resolve in the node's namespace, the robot's
        ns = self.get_namespace()
        for what, value in (('delay', delay), ('wait_for_subscribers', wait_for_subscribers)):
            if not (float(value) >= 0 and float(value) < float('inf')):
                raise BagError(f'{what} must be a number >= 0, got {value!r}')
        self.reader = BagReader(bag)
        self.send_commands = bool(send_commands)
        try:
            self._make_publishers(ns, topics, remap)
            self._make_schedule(rate, loop, start_offset)
        except BaseException:
            self.reader.close()
            raise
        self.delay = float(delay)
        self.wait_for_subscribers = float(wait_for_subscribers)
        self.min_subscribers = max(1, int(min_subscribers))
        self.progress = bool(progress)
        self.guard = CommandGuard(self, {}, threading.Event())
        self.published = 0
        self.passes = 0
        self.done = threading.Event()
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self.error = ''

    def _make_publishers(self, ns: str, topics, remap) -> None:
        reader = self.reader
        explicit = None
        if topics:
            explicit = reader.check_topics([resolve_topic(t, ns) for t in topics])
        self.remaps = parse_remaps(remap, ns)
        unknown = [src for src in self.remaps if src not in reader.topics]
        if unknown:
            raise BagError(f"{reader.path}: cannot remap {', '.join(unknown)}: not in the bag "
                           f"(it has: {', '.join(sorted(reader.topics))})")
        self.publishers_by_topic: Dict[str, object] = {}
        #: bag topics left out for good: topic -> why (service events, action topics, ...)
        self.not_replayed = {t: why for t in (explicit or reader.topics)
                             if (why := not_replayed(t, self.send_commands))}
        for why in sorted(set(self.not_replayed.values())):
            self.get_logger().info(f'not replayed ({why}): ' + ', '.join(
                sorted(t for t, w in self.not_replayed.items() if w == why)))
        for topic in (explicit or sorted(reader.topics)):
            if topic in self.not_replayed:
                continue
            type_name = reader.topics[topic]
            cls = message_class(type_name) if type_name else None
            if cls is None:
                reason = (f"{reader.path}: topic '{topic}' has type '{type_name or '?'}', which "
                          'is not installed here')
                if explicit is not None:
                    raise BagError(reason)
                self.get_logger().warning(reason + ': not replayed')
                continue
            self.publishers_by_topic[topic] = self.create_publisher(
                cls, self.remaps.get(topic, topic), publisher_qos(reader.qos.get(topic, [])))
        self.topics: List[str] = sorted(self.publishers_by_topic)
        if not self.topics:
            raise BagError(f'{reader.path}: no topic to replay (none with an installed type)')

    def _make_schedule(self, rate, loop, start_offset) -> None:
        reader = self.reader
        summary = reader.summary()
        counted = [summary.topics[t] for t in self.topics if summary.topics[t].message_count]
        if not counted:
            raise BagError(f'{reader.path}: the bag has no messages on '
                           f"{', '.join(self.topics)}")
        self.message_count = sum(t.message_count for t in counted)
        try:
            self.schedule = ReplaySchedule(min(t.first_ns for t in counted),
                                           max(t.last_ns for t in counted),
                                           rate=float(rate), start_offset_s=float(start_offset),
                                           loop=bool(loop))
        except (TypeError, ValueError) as exc:
            raise BagError(f'{reader.path}: {exc}') from None
        self.get_logger().info(
            f'replaying {self.message_count} messages of {len(self.topics)} topics from '
            f'{reader.path} ({self.schedule.bag_duration_s:.2f} s) at rate {rate:g}'
            + (' in a loop' if loop else '')
            + (''.join(f', {a} -> {b}' for a, b in self.remaps.items())))

    @property
    def withheld(self) -> List[str]:
        """Return the bag topics left out because a live node would act on them."""
        return self.guard.withheld

    # -- playback ---------------------------------------------------------------------------
    def start(self) -> 'ReplayerNode':
        """Start publishing in a background thread; return self."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name='px100_replay', daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        """Stop publishing and wait for the playback thread."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)

    def _sleep_until(self, deadline: float) -> bool:
        """Sleep until time.monotonic() >= deadline; return False if stopped meanwhile."""
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return not self._stop.is_set()
            if self._stop.wait(min(left, 0.1)):
                return False

    def _wait_for_subscribers(self) -> None:
        deadline = time.monotonic() + self.wait_for_subscribers
        while time.monotonic() < deadline and not self._stop.is_set():
            if all(p.get_subscription_count() >= self.min_subscribers
                   for p in self.publishers_by_topic.values()):
                # this side matched; the subscriber matches this publisher a moment later, and
                # takes only what it sees after that (a latched topic keeps one message)
                self._stop.wait(SUBSCRIBER_SETTLE_S)
                return
            time.sleep(0.05)
        missing = [t for t, p in self.publishers_by_topic.items()
                   if p.get_subscription_count() < self.min_subscribers]
        if missing:
            self.get_logger().warning(f"no subscriber on {', '.join(missing)} after "
                                      f'{self.wait_for_subscribers:g} s: replaying anyway')

    def _run(self) -> None:
        try:
            self._prepare_and_play()
        except BagError as exc:
            self.error = str(exc)
            self.get_logger().error(self.error)
        except Exception as exc:  # publishing after shutdown, etc.: end the replay cleanly
            if self.context.ok():
                self.error = f'{exc.__class__.__name__}: {exc}'
                self.get_logger().error(f'replay stopped: {self.error}')
        finally:
            self._wait_for_acks()
            if self.progress:
                self._show_progress(final=True)
            self.done.set()

    def _prepare_and_play(self) -> None:
        """Wait (delay, subscribers), withhold commands from live nodes, then play."""
        if self.delay > 0 and not self._sleep_until(time.monotonic() + self.delay):
            return
        if self.wait_for_subscribers > 0:
            self._wait_for_subscribers()
        commands = {} if self.send_commands else command_topics(self.topics, self.remaps)
        self.guard = CommandGuard(self, commands, self._stop)
        self.guard.check()
        self._drop_withheld()
        if not self.topics:
            self.get_logger().warning('nothing left to replay')
            return
        self._play()

    def _drop_withheld(self) -> None:
        self.topics = [t for t in self.topics if t not in self.guard.withheld]

    def _wait_for_acks(self, timeout_s: float = 2.0) -> None:
        """Give reliable subscribers the time to acknowledge the last messages before exit."""
        if not self.context.ok():
            return
        for pub in self.publishers_by_topic.values():
            try:
                pub.wait_for_all_acked(Duration(seconds=timeout_s))
            except Exception:  # best effort publishers, shutdown in progress
                pass

    def _play(self) -> None:
        schedule = self.schedule
        self._t0 = t0 = time.monotonic()
        self._next_progress = 0.0
        pass_index = 0
        while not self._stop.is_set():
            for raw in self.reader.iter_raw(self.topics, start_ns=schedule.first_ns):
                if not self._sleep_until(t0 + schedule.due_s(raw.log_time_ns, pass_index)):
                    return
                if self.guard.withheld_now(raw.topic):
                    continue
                self.publishers_by_topic[raw.topic].publish(raw.data)
                self.published += 1
                if self.progress and time.monotonic() >= self._next_progress:
                    self._show_progress()
            self.passes = pass_index + 1
            if not schedule.loop:
                return
            pass_index += 1
            self._drop_withheld()

    def _show_progress(self, final: bool = False) -> None:
        t0 = getattr(self, '_t0', None)
        now = time.monotonic()
        elapsed = 0.0 if t0 is None else now - t0
        self._next_progress = now + PROGRESS_PERIOD_S
        text = progress_text(self.schedule, elapsed, self.published, self.passes, final)
        end = '\n' if final or not sys.stderr.isatty() else ''
        print(('\r' if sys.stderr.isatty() else '') + text, end=end, file=sys.stderr,
              flush=True)

    def destroy_node(self):
        """Stop publishing, close the bag, destroy the node."""
        self.stop()
        self.reader.close()
        return super().destroy_node()


def main(args=None) -> int:
    """Replay a bag; exit 0 when it is done (or interrupted), 1 with a clear error otherwise."""
    argv, remaps = extract_remaps(sys.argv if args is None else args)
    options, argv = parse_cli('Publish a recorded bag into the ROS graph with its timing.',
                              argv, add_replay_arguments, (REPLAYER,), example_args='BAG')
    return run_bag_tool('replay', argv, lambda: ReplayerNode(
        options.bag, rate=options.rate, loop=options.loop, topics=options.topics,
        remap=remaps, start_offset=options.start_offset, delay=options.delay,
        wait_for_subscribers=options.wait_for_subscribers,
        min_subscribers=options.min_subscribers, progress=not options.no_progress,
        send_commands=options.send_commands).start(),
        done=lambda node: node.done.is_set(), status=lambda node: 1 if node.error else 0)


if __name__ == '__main__':
    sys.exit(main())
