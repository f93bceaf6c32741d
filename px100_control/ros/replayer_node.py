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

Safety: when a live driver or trajectory_server runs in a namespace the bag replays into (see
:mod:`px100_control.ros.peers`), the replayer warns, naming them, and by default does not
re-send the bag's goals (``trajectory/goal``) and setpoints (``commands/joint_setpoints``):
they would move the live arm again. ``--send-commands`` (``send_commands=True``) sends them
anyway. Replayed ``joint_states`` beside a live driver are sent, with a warning.

Python: ``ReplayerNode(bag, rate=..., topics=..., remap=...)``, then ``start()``; ``done`` is
set when the replay ended.
"""
import sys
import threading
import time
from typing import Dict, List, Optional, Sequence, Tuple

from px100_control.bag.reader import BagReader
from px100_control.bag.replay import parse_remaps, ReplaySchedule, resolve_topic
from px100_control.errors import BagError, Px100Error
from px100_control.models.registry import read_robot_file
from px100_control.ros.common import (BAG_EXECUTOR, ignore_further_interrupts,
                                      install_stop_signals, keep_spinning, make_executor,
                                      parameter_descriptor, parse_cli, robot_node_kwargs,
                                      shutdown_executor, shutting_down)
from px100_control.ros.parameter_schema import COMMON, REPLAYER
from px100_control.ros.peers import has_unknown, live_peers
from px100_control.ros.recorder_node import message_class
import rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

PROGRESS_PERIOD_S = 0.25
#: topics (relative to a robot namespace) that move a live arm when replayed
COMMAND_TOPICS = ('trajectory/goal', 'commands/joint_setpoints')
#: how long [s] the graph is watched for live nodes before commands are replayed (the wait ends
#: as soon as one is seen; a loaded machine has taken more than 1 s to discover a bringup)
LIVE_CHECK_S = 3.0
#: after --wait-for-subscribers saw its subscribers, the time [s] given to their side of the match
SUBSCRIBER_SETTLE_S = 0.5
#: while commands are replayed, the graph is looked at again at most this often [s]
LIVE_RECHECK_S = 0.25


def publisher_qos(profiles: Sequence[dict]) -> QoSProfile:
    """Return the QoS to replay a topic with, from its recorded offered QoS profiles."""
    profiles = [p for p in profiles if isinstance(p, dict)]
    reliable = all(p.get('reliability', 'reliable') != 'best_effort' for p in profiles)
    latched = bool(profiles) and all(p.get('durability') == 'transient_local' for p in profiles)
    depth = max([int(p.get('depth') or 0) for p in profiles] + [0])
    if depth <= 0:
        depth = 1 if latched else 10
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


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
        super().__init__('replayer', **robot_node_kwargs('replayer', node_kwargs))
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
        try:
            self._setup(ns, rate, loop, topics, remap, start_offset)
        except BaseException:
            self.reader.close()
            raise
        self.delay = float(delay)
        self.wait_for_subscribers = float(wait_for_subscribers)
        self.min_subscribers = max(1, int(min_subscribers))
        self.progress = bool(progress)
        self.send_commands = bool(send_commands)
        #: bag topics left out because a live node would act on them
        self.withheld: List[str] = []
        self._commands: Dict[str, str] = {}
        self._next_live_check = 0.0
        self.published = 0
        self.passes = 0
        self.done = threading.Event()
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self.error = ''

    def _setup(self, ns, rate, loop, topics, remap, start_offset) -> None:
        reader = self.reader
        explicit = None
        if topics:
            explicit = reader.check_topics([resolve_topic(t, ns) for t in topics])
        remaps = parse_remaps(remap, ns)
        unknown = [src for src in remaps if src not in reader.topics]
        if unknown:
            raise BagError(f"{reader.path}: cannot remap {', '.join(unknown)}: not in the bag "
                           f"(it has: {', '.join(sorted(reader.topics))})")
        self.publishers_by_topic: Dict[str, object] = {}
        self.remaps = remaps
        for topic in (explicit or sorted(reader.topics)):
            type_name = reader.topics[topic]
            cls = message_class(type_name) if type_name else None
            if cls is None:
                reason = (f"{reader.path}: topic '{topic}' has type '{type_name or '?'}', which "
                          'is not installed here')
                if explicit is not None:
                    raise BagError(reason)
                self.get_logger().warning(reason + ': not replayed')
                continue
            out = remaps.get(topic, topic)
            self.publishers_by_topic[topic] = self.create_publisher(
                cls, out, publisher_qos(reader.qos.get(topic, [])))
        self.topics: List[str] = sorted(self.publishers_by_topic)
        if not self.topics:
            raise BagError(f'{reader.path}: no topic to replay (none with an installed type)')
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
            + (''.join(f', {a} -> {b}' for a, b in remaps.items())))

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
            if self.delay > 0 and not self._sleep_until(time.monotonic() + self.delay):
                return
            if self.wait_for_subscribers > 0:
                self._wait_for_subscribers()
            self._check_live_graph()
            if not self.topics:
                self.get_logger().warning('nothing left to replay')
                return
            self._play()
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

    def _command_topics(self) -> Dict[str, str]:
        """Return {bag topic: namespace} of the goal / setpoint topics being replayed."""
        out = {}
        for topic in self.topics:
            published_as = self.remaps.get(topic, topic)
            for suffix in COMMAND_TOPICS:
                if published_as.endswith('/' + suffix) or published_as == suffix:
                    out[topic] = published_as[:-len(suffix)].rstrip('/') or '/'
        return out

    def _live_nodes(self, namespaces) -> Tuple[Dict[str, List[str]], bool]:
        """Return ({namespace: live driver / server names}, whether a peer is still unknown)."""
        live, unknown = {}, False
        for ns in namespaces:
            peers = live_peers(self, ns)
            names = peers['drivers'] + peers['trajectory_servers']
            unknown = unknown or has_unknown(peers)
            if names:
                live[ns] = sorted(set(names))
        return live, unknown

    def _check_live_graph(self) -> None:
        """Warn about live drivers / trajectory servers; withhold commands from them."""
        commands = self._command_topics()
        if not commands or self.send_commands:
            return
        self._commands = commands
        namespaces = sorted(set(commands.values()))
        deadline = time.monotonic() + LIVE_CHECK_S
        live, unknown = self._live_nodes(namespaces)
        while (not live or unknown) and time.monotonic() < deadline and \
                not self._stop.is_set():
            time.sleep(0.05)
            live, unknown = self._live_nodes(namespaces)
        self._withhold(live)

    def _withhold(self, live: Dict[str, List[str]]) -> None:
        """Stop replaying the command topics of the namespaces with live nodes (with a warning)."""
        new = [t for t, ns in self._commands.items() if ns in live and t not in self.withheld]
        if not new:
            return
        self.withheld.extend(new)
        self.topics = [t for t in self.topics if t not in self.withheld]
        self.get_logger().warning(
            'live nodes would act on the replayed commands ('
            + '; '.join(f"{ns}: {', '.join(n)}" for ns, n in live.items())
            + f"): not replaying {', '.join(new)} (--send-commands replays them)")

    def _withheld_now(self, topic: str) -> bool:
        """
        Return True if topic is a command topic whose namespace has live nodes by now.

        Discovery can outlast the check before the replay (a loaded machine): the graph is looked
        at again, at most every LIVE_RECHECK_S, while commands are being replayed.
        """
        if topic in self.withheld:
            return True
        if topic not in self._commands:
            return False
        now = time.monotonic()
        if now >= self._next_live_check:
            self._next_live_check = now + LIVE_RECHECK_S
            self._withhold(self._live_nodes(sorted(set(self._commands.values())))[0])
        return topic in self.withheld

    def _wait_for_acks(self, timeout_s: float = 2.0) -> None:
        """Give reliable subscribers the time to acknowledge the last messages before exit."""
        from rclpy.duration import Duration
        if not self.context.ok():
            return
        for pub in self.publishers_by_topic.values():
            try:
                pub.wait_for_all_acked(Duration(seconds=timeout_s))
            except Exception:  # best effort publishers, shutdown in progress
                pass

    def _play(self) -> None:
        schedule = self.schedule
        t0 = time.monotonic()
        self._t0 = t0
        self._next_progress = 0.0
        pass_index = 0
        while not self._stop.is_set():
            for raw in self.reader.iter_raw(self.topics, start_ns=schedule.first_ns):
                if not self._sleep_until(t0 + schedule.due_s(raw.log_time_ns, pass_index)):
                    return
                if self._withheld_now(raw.topic):
                    continue
                self.publishers_by_topic[raw.topic].publish(raw.data)
                self.published += 1
                if self.progress and time.monotonic() >= self._next_progress:
                    self._show_progress()
            self.passes = pass_index + 1
            if not schedule.loop:
                return
            pass_index += 1

    def _show_progress(self, final: bool = False) -> None:
        t0 = getattr(self, '_t0', None)
        now = time.monotonic()
        elapsed = 0.0 if t0 is None else now - t0
        self._next_progress = now + PROGRESS_PERIOD_S
        s = self.schedule
        index, bag_t = s.bag_time_ns(elapsed)
        done_s = (bag_t - s.bag_start_ns) * 1e-9
        text = (f'[replay] {done_s:7.2f} / {s.bag_duration_s:.2f} s '
                f'({100.0 * s.progress(elapsed):3.0f} %)  {self.published} messages'
                + (f'  pass {index + 1}' if s.loop else ''))
        if final:
            text = (f'[replay] done: {self.published} messages in {elapsed:.2f} s'
                    + (f' ({self.passes} passes)' if s.loop else ''))
        end = '\n' if final or not sys.stderr.isatty() else ''
        print(('\r' if sys.stderr.isatty() else '') + text, end=end, file=sys.stderr,
              flush=True)

    def destroy_node(self):
        """Stop publishing, close the bag, destroy the node."""
        self.stop()
        self.reader.close()
        return super().destroy_node()


def _add_arguments(parser) -> None:
    parser.add_argument('bag', help='bag directory (or .mcap file)')
    parser.add_argument('-r', '--rate', type=float, default=1.0,
                        help='playback speed factor (default 1.0)')
    parser.add_argument('-l', '--loop', action='store_true', help='replay again and again')
    parser.add_argument('--topics', nargs='+', default=None, metavar='TOPIC',
                        help='topics to replay (default: all); relative names are under '
                             '/<robot_name>/')
    parser.add_argument('--remap', '-m', nargs='*', default=None, metavar='FROM:=TO',
                        help='publish topic FROM on TO')
    parser.add_argument('--start-offset', type=float, default=0.0,
                        help='skip this many seconds of the bag at the start')
    parser.add_argument('--delay', type=float, default=0.0,
                        help='wait this many seconds before publishing')
    parser.add_argument('--wait-for-subscribers', type=float, default=0.0, metavar='S',
                        help='wait up to S seconds for a subscriber on every topic')
    parser.add_argument('--min-subscribers', type=int, default=1, metavar='N',
                        help='with --wait-for-subscribers: wait for N subscribers per topic')
    parser.add_argument('--no-progress', action='store_true',
                        help='no progress line on stderr')
    parser.add_argument('--send-commands', action='store_true',
                        help='also replay goals and setpoints into a namespace where a live '
                             'driver or trajectory_server runs (default: skip them there)')


def extract_remaps(argv: Sequence[str]):
    """
    Return (argv without them, [from:=to, ...]) of the ``--remap``/``-m`` options.

    rcl would take a bare ``from:=to`` for a (deprecated) node remap rule, so the values are
    taken out of the command line before it reaches rclpy.
    """
    out, remaps, i = [], [], 0
    argv = list(argv)
    while i < len(argv):
        arg = argv[i]
        if arg == '--ros-args':
            out.extend(argv[i:])
            break
        if arg in ('--remap', '-m') or arg.startswith('--remap='):
            if arg.startswith('--remap='):
                remaps.append(arg.split('=', 1)[1])
            i += 1
            first = i
            while i < len(argv) and not argv[i].startswith('-') and (
                    ':=' in argv[i] or (i == first and not arg.startswith('--remap='))):
                remaps.append(argv[i])  # a value without ':=' is refused with a clear error
                i += 1
            continue
        out.append(arg)
        i += 1
    return out, remaps


def main(args=None) -> int:
    """Replay a bag; exit 0 when it is done (or interrupted), 1 with a clear error otherwise."""
    from rclpy.executors import ExternalShutdownException
    argv, remaps = extract_remaps(sys.argv if args is None else args)
    options, argv = parse_cli('Publish a recorded bag into the ROS graph with its timing.',
                              argv, _add_arguments, (REPLAYER,))
    options.remap = remaps
    install_stop_signals()
    rclpy.init(args=argv)
    node = None
    executor = None
    status = 0
    try:
        executor = make_executor(kind=BAG_EXECUTOR)   # before the node: see common.run_nodes
        node = ReplayerNode(options.bag, rate=options.rate, loop=options.loop,
                            topics=options.topics, remap=options.remap,
                            start_offset=options.start_offset, delay=options.delay,
                            wait_for_subscribers=options.wait_for_subscribers,
                            min_subscribers=options.min_subscribers,
                            progress=not options.no_progress,
                            send_commands=options.send_commands)
        node.start()
        executor.add_node(node)
        while keep_spinning() and not node.done.is_set():
            executor.spin_once(timeout_sec=0.1)
        if node.error:
            status = 1
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Px100Error as exc:  # BagError and a bad robot_model
        print(f'replay: error: {exc}', file=sys.stderr)
        status = 1
    except Exception:
        if not shutting_down():
            raise
    finally:
        shutdown_executor(executor)
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
        ignore_further_interrupts()
    return status


if __name__ == '__main__':
    sys.exit(main())
