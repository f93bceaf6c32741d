"""
Record topics to a rosbag2-compatible MCAP bag: ``ros2 run px100_control record``.

Command line (the options of ``ros2 bag record``, plus stop conditions)::

    record [TOPIC ...] [-a/--all] [--robot-only] [-o/--output DIR] [--duration S]
           [--max-messages N] [--idle-timeout S] [--no-tf] [--tf-rate HZ]
           [--compression zstd|lz4|none] [--flush-period S]
           [--ros-args -r __ns:=/px100 -p robot_name:=px100 -p robot_model:=px100]

The node ``recorder`` lives in the robot namespace (``/px100`` by default, see
:mod:`px100_control.ros.common`); topics without a leading ``/`` resolve in it
(``joint_states`` is ``/px100/joint_states``). ``-a`` records every topic of the graph, as
``ros2 bag record -a`` (hidden ``_`` topics excepted); with no topic, or with
``--robot-only``, it records the topics of the robot namespace plus ``/diagnostics``. Either
way it keeps scanning the graph for new topics. Messages
are recorded as the exact bytes received (raw subscriptions, no deserialisation) with the QoS
of their publishers (transient local for ``robot_description`` and ``trajectory/status``). From
``joint_states`` it also writes ``/tf`` (tf2_msgs/msg/TFMessage through the URDF: the recorded
``robot_description``, else the robot model's URDF with links prefixed ``<robot_name>/``) and,
when no robot_description is published, the model's URDF on ``/<robot_name>/robot_description``,
so Foxglove's 3D panel shows the arm. From ``world/markers`` (the simulated scene) it writes the
objects' frames to ``/tf``: ``<robot_name>/objects/<name>``, children of the markers' frame
``<robot_name>/base_link``. SIGINT and SIGTERM finalise the bag; after SIGKILL the
file is readable up to its last chunk (at most ``--flush-period`` s are lost) and
``bag_reindex`` rebuilds it.

Nothing lost at the start: the recorder subscribes at once to the contract's topics
(docs/ros_interfaces.md: it knows their names, types and QoS), before any publisher exists, and
to other topics as they appear. It is *ready* once every selected topic that has a publisher is
subscribed and matched with all its publishers (or after ``ready_timeout``, with a warning
naming the unmatched ones); it then publishes the bag directory on ``recorder/ready``
(std_msgs/String, transient local, under ``/<robot_name>/``), where the client waits for it
(``InterbotixManipulatorXS(..., recorder=True)`` or a Recorder instance), and logs ``ready``.
``with Recorder(dir):`` enters only when its recorder is ready.

Python API (the client and the demos record their runs with it)::

    from px100_control.ros.recorder_node import Recorder

    with Recorder('/tmp/my_run', robot_name='px100'):      # all topics of /px100 + /diagnostics
        ...                                                 # drive the robot
    # Recorder(out, all_topics=True): every topic of the graph
    # or: rec = Recorder(out, topics=['joint_states']).start(); ...; rec.stop()

    stop = record_in_process(node.context, '/tmp/my_run')  # on an existing rclpy context
    ...; stop()

``Recorder`` runs a :class:`RecorderNode` in its own executor thread (and its own rclpy context
unless one is given); ``stop()`` closes the bag and returns its metadata.yaml path. Options are
those of :class:`RecorderNode`. Times in the bag are the reception times (ns since the epoch).
"""
import importlib
import os
import threading
import time
from typing import Dict, List, Optional, Sequence
import weakref

from px100_control.bag import metadata as md
from px100_control.bag.replay import resolve_topic
from px100_control.bag.tf import encode_tf_message, TF_TYPE, TfTree
from px100_control.bag.world import MARKER_ARRAY_TYPE, markers_from_decoded, object_tf_entries
from px100_control.bag.writer import BagWriter
from px100_control.errors import BagError, Px100Error
from px100_control.models.registry import load_robot
from px100_control.models.registry import read_robot_file
from px100_control.models.urdf_prefix import prefix_urdf
from px100_control.models.urdf_writer import urdf_from_model
from px100_control.ros.common import (BAG_EXECUTOR, ignore_further_interrupts,
                                      install_stop_signals, keep_spinning, make_executor,
                                      parameter_descriptor, parse_cli, robot_name,
                                      robot_node_kwargs, shutdown_executor, shutting_down)
from px100_control.ros.parameter_schema import COMMON, RECORDER
from px100_control.wire.private_api import take_serialized
import rclpy
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile,
                       ReliabilityPolicy)

TF_TOPIC = '/tf'
#: QoS a tf2 broadcaster offers (recorded with the /tf we write)
TF_QOS = md.qos_profile('reliable', 'volatile', 'keep_last', 100)
DESCRIPTION_QOS = md.qos_profile('reliable', 'transient_local', 'keep_last', 1)
SUBSCRIPTION_DEPTH = 1000
#: most queued messages taken in one callback (the other topics get their turn after that)
DRAIN_LIMIT = 200
#: joint states kept for /tf while the URDF is being parsed at start-up
TF_BACKLOG = 20000
#: the contract's topics (docs/ros_interfaces.md), subscribed before any publisher appears:
#: name (relative to /<robot_name>/ unless absolute) -> (type, latched)
CONTRACT_TOPICS = {
    'joint_states': ('sensor_msgs/msg/JointState', False),
    'ee_pose': ('geometry_msgs/msg/PoseStamped', False),
    'robot_description': ('std_msgs/msg/String', True),
    'commands/joint_setpoints': ('sensor_msgs/msg/JointState', False),
    'ik/request': ('geometry_msgs/msg/PoseStamped', False),
    'ik/solution': ('sensor_msgs/msg/JointState', False),
    'ik/status': ('diagnostic_msgs/msg/DiagnosticStatus', False),
    'ik/path_request': ('geometry_msgs/msg/PoseArray', False),
    'ik/path_solution': ('trajectory_msgs/msg/JointTrajectory', False),
    'trajectory/goal': ('trajectory_msgs/msg/JointTrajectory', False),
    'trajectory/status': ('action_msgs/msg/GoalStatusArray', True),
    'trajectory/feedback': ('sensor_msgs/msg/JointState', False),
    'world/markers': ('visualization_msgs/msg/MarkerArray', True),
    'world/held_object': ('std_msgs/msg/String', True),
    '/diagnostics': ('diagnostic_msgs/msg/DiagnosticArray', False),
}
#: where a recorder announces that it is ready (relative to /<robot_name>/): the bag directory
READY_TOPIC = 'recorder/ready'
#: the recorders of this process that are recording (for the client's Ctrl-C report)
_ACTIVE = weakref.WeakSet()


def active_bag_dirs() -> List[str]:
    """Return the bag directories of the RecorderNodes of this process still recording."""
    return sorted(n.output for n in list(_ACTIVE) if not n.closed.is_set())


def default_output_dir() -> str:
    """Return ``rosbag2_YYYY_MM_DD-HH_MM_SS`` (what ros2 bag record uses) in the cwd."""
    return os.path.abspath(time.strftime('rosbag2_%Y_%m_%d-%H_%M_%S'))


def message_class(type_name: str):
    """Return the rclpy message class of ``pkg/msg/Name`` or None when it is not installed."""
    parts = type_name.split('/')
    if len(parts) != 3:
        return None
    try:
        return getattr(importlib.import_module(f'{parts[0]}.{parts[1]}'), parts[2])
    except (ImportError, AttributeError):
        return None


def _duration(d) -> dict:
    return md.duration_dict(d.nanoseconds)


def qos_to_dict(qos: QoSProfile) -> dict:
    """Return a rclpy QoSProfile as rosbag2's v9 QoS dict."""
    def name(policy, value) -> str:
        try:
            return policy(value).name.lower()
        except ValueError:
            return 'unknown'
    return {
        'history': name(HistoryPolicy, qos.history), 'depth': int(qos.depth),
        'reliability': name(ReliabilityPolicy, qos.reliability),
        'durability': name(DurabilityPolicy, qos.durability),
        'deadline': _duration(qos.deadline), 'lifespan': _duration(qos.lifespan),
        'liveliness': name(LivelinessPolicy, qos.liveliness),
        'liveliness_lease_duration': _duration(qos.liveliness_lease_duration),
        'avoid_ros_namespace_conventions': bool(qos.avoid_ros_namespace_conventions),
    }


def subscription_qos(offered: Sequence[QoSProfile]) -> QoSProfile:
    """
    Return a QoS that matches every publisher (as rosbag2 adapts it).

    Reliable if all publishers are reliable, else best effort; transient local if all are,
    else volatile; a deep keep-last queue so that bursts are not dropped.
    """
    reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered)
    latched = bool(offered) and all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL
                                    for q in offered)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=SUBSCRIPTION_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


class RecorderNode(Node):
    """
    Node 'recorder': subscribes raw to the selected topics and writes them to a bag.

    :param output: bag directory (must not exist or be empty); default rosbag2_<date>
    :param topics: topics to record (relative names under the node's namespace, the robot's);
        None = the robot's view (below)
    :param all_topics: record every topic of the graph (hidden ``_x`` topics excepted), as
        ``ros2 bag record -a``; also the default when no topic is given
    :param robot_only: with all_topics, only the topics of the robot's namespace plus
        ``/diagnostics`` (None: True when neither topics nor all_topics were given)
    :param duration: stop after this many seconds [s] (None: until stopped)
    :param max_messages: stop after this many recorded messages (None: no limit)
    :param idle_timeout: stop when nothing arrived for this long [s] after the first message
    :param write_tf: write /tf from joint_states through the URDF
    :param tf_rate: highest /tf rate [Hz]
    :param write_description: write the model URDF as robot_description if none is published
        (when robot_description is one of the recorded topics)
    :param compression: chunk compression 'zstd', 'lz4' or 'none'
    :param flush_period: longest time [s] a message stays in memory (SIGKILL loses at most that)
    :param rescan_period: graph scan period [s] for new topics
    :param ready_timeout: [s] report ready after this long even if a publisher is not matched
    :raises BagError: the output directory is not usable
    """

    def __init__(self, output: Optional[str] = None, topics: Optional[Sequence[str]] = None,
                 all_topics: Optional[bool] = None, robot_only: Optional[bool] = None,
                 duration: Optional[float] = None,
                 max_messages: Optional[int] = None, idle_timeout: Optional[float] = None,
                 write_tf: bool = True, tf_rate: float = 50.0, write_description: bool = True,
                 compression: str = 'zstd', flush_period: float = 1.0,
                 rescan_period: float = 0.5, ready_timeout: float = 5.0, **node_kwargs):
        super().__init__('recorder', **robot_node_kwargs('recorder', node_kwargs))
        # the robot_model/robot_name parameters of declare_robot_parameters(), but the model
        # (URDF parsing, slow to import) is loaded in the background: recording starts at once
        model_name = str(self.declare_parameter(
            'robot_model', 'px100', parameter_descriptor(COMMON[0])).value)
        self.declare_parameter('robot_name', self.get_namespace().strip('/'),
                               parameter_descriptor(COMMON[1]))
        read_robot_file(model_name)  # fast check: raises UnknownRobotError for a bad name
        self.model_name = model_name
        self.robot_name = robot_name(self)
        for what, value in (('duration', duration), ('idle_timeout', idle_timeout),
                            ('flush_period', flush_period), ('tf_rate', tf_rate)):
            if value is not None and not (float(value) > 0 and float(value) < float('inf')):
                raise BagError(f'{what} must be a number > 0, got {value!r}')
        if max_messages is not None and int(max_messages) <= 0:
            raise BagError(f'max_messages must be > 0, got {max_messages!r}')
        self.output = os.path.abspath(output) if output else default_output_dir()
        #: the robot's namespace: relative topics resolve in it ('/' for none)
        self.namespace = self.get_namespace()
        explicit = [resolve_topic(t, self.namespace) for t in (topics or ())]
        self.robot_only = (not all_topics) if robot_only is None else bool(robot_only)
        self.all_topics = bool(all_topics) or not explicit
        self.wanted = set(explicit)
        self.duration = duration
        self.max_messages = None if max_messages is None else int(max_messages)
        self.idle_timeout = idle_timeout
        self.write_tf = bool(write_tf)
        self.tf_period_ns = int(1e9 / float(tf_rate))
        self.write_description = bool(write_description)
        ns = self.namespace.rstrip('/') + '/'
        self.js_topic = ns + 'joint_states'
        self.markers_topic = ns + 'world/markers'
        self._last_object_tf_ns = 0
        self.description_topic = ns + 'robot_description'
        self._subs: Dict[str, object] = {}
        #: contract topics subscribed ahead of their publishers: topic -> (type, latched)
        self._ahead: Dict[str, tuple] = {}
        #: subscribed-ahead topics already matched with a publisher (and logged as recorded)
        self._matched: set = set()
        #: the QoS of each subscribed-ahead topic's subscription
        self._ahead_qos: Dict[str, QoSProfile] = {}
        self.ready = threading.Event()
        self.ready_timeout = float(ready_timeout)
        self.ready_topic = ns + READY_TOPIC
        self._pub_ready = None
        self._skipped: Dict[str, str] = {}
        self._lock = threading.Lock()
        self._closing = False
        self._drain_on_close = True
        self.closed = threading.Event()
        self.stop_reason = ''
        self.metadata_path = ''
        self._last_message_at: Optional[float] = None
        self._tf_tree: Optional[TfTree] = None
        self._model_tf_tree: Optional[TfTree] = None
        self._model_urdf_xml: Optional[str] = None
        self._model_ready = threading.Event()
        self._last_tf_ns = 0
        self._tf_backlog: List[tuple] = []
        self._description_seen = False
        self._first_js_at: Optional[float] = None
        self._dropped_writes = 0
        self.bag = BagWriter(self.output, compression=compression, flush_period_s=flush_period,
                             custom_data={'recorder': 'px100_control',
                                          'robot_name': self.robot_name,
                                          'robot_model': model_name})
        try:
            self.started_at = time.monotonic()
            _ACTIVE.add(self)
            self._subscribe_contract(ns)
            threading.Thread(target=self._load_model, name='px100_recorder_model',
                             daemon=True).start()
            self._scan_timer = self.create_timer(rescan_period, self.scan_graph)
            self._housekeeping_timer = self.create_timer(
                min(0.1, max(0.02, flush_period / 4)), self._housekeeping)
            self.get_logger().info(
                f'recording to {self.output}: '
                + (('all topics of ' + ns + ' and /diagnostics' if self.robot_only
                    else 'all topics') if self.all_topics else ', '.join(sorted(self.wanted)))
                + (f' (for {duration:g} s)' if duration else ''))
            self.scan_graph()
            self._check_ready()
        except BaseException:
            self.finish()  # e.g. SIGINT during start-up: still leave a closed, valid bag
            raise

    def _load_model(self) -> None:
        """Load the robot model's URDF and its tf tree (background thread)."""
        try:
            model = load_robot(self.model_name)
            urdf = model.urdf_xml
            if not urdf:
                urdf = urdf_from_model(model)
            self._model_urdf_xml = urdf
            self._model_tf_tree = TfTree(urdf, f'{self.robot_name}/' if self.robot_name
                                         else '')
        except Exception as exc:  # no URDF for this model: record without /tf
            self.get_logger().warning(f'robot model {self.model_name}: no URDF for /tf ({exc})')
        finally:
            self._model_ready.set()

    # -- graph ------------------------------------------------------------------------------
    def _subscribe_contract(self, ns: str) -> None:
        """Subscribe to the selected contract topics now, before their publishers exist."""
        for name, (type_name, latched) in CONTRACT_TOPICS.items():
            topic = name if name.startswith('/') else ns + name
            if not self._selected(topic) or (self.write_tf and topic == TF_TOPIC):
                continue
            cls = message_class(type_name)
            if cls is None:
                continue  # e.g. visualization_msgs not installed: the scan decides later
            qos = QoSProfile(
                history=HistoryPolicy.KEEP_LAST, depth=SUBSCRIPTION_DEPTH,
                reliability=ReliabilityPolicy.RELIABLE,
                durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                            else DurabilityPolicy.VOLATILE))
            try:
                sub = self.create_subscription(cls, topic, self._make_callback(topic), qos,
                                               raw=True)
            except Exception as exc:  # e.g. this participant has the topic with another type
                self.get_logger().debug(f'{topic}: not subscribed ahead ({exc})')
                continue
            self._ahead[topic] = (type_name, latched)
            self._ahead_qos[topic] = qos
            self._subs[topic] = sub
            self.get_logger().debug(f'{topic} [{type_name}]: subscribed ahead')

    def _add_channel(self, topic: str) -> None:
        """Add a subscribed-ahead topic to the bag (at its first message: publishers' QoS)."""
        type_name, latched = self._ahead[topic]
        pubs = list(self.get_publishers_info_by_topic(topic))
        offered = [qos_to_dict(p.qos_profile) for p in pubs] or [qos_to_dict(QoSProfile(
            depth=1 if latched else 10, reliability=ReliabilityPolicy.RELIABLE,
            durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                        else DurabilityPolicy.VOLATILE)))]
        type_hash = getattr(pubs[0], 'topic_type_hash', '') if pubs else ''
        self.bag.add_topic(topic, type_name, offered,
                           type_description_hash=str(type_hash) if type_hash else None)

    def _revise_ahead(self, topic: str, type_name: str, pubs) -> None:
        """Re-subscribe a subscribed-ahead topic whose publishers its QoS or type cannot match."""
        ahead_type, latched = self._ahead[topic]
        type_name = getattr(pubs[0], 'topic_type', '') or type_name
        mine = self._ahead_qos[topic]
        reliable = all(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE for p in pubs)
        durable = all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
                      for p in pubs)
        fits = (reliable or mine.reliability == ReliabilityPolicy.BEST_EFFORT) and \
            (durable or mine.durability == DurabilityPolicy.VOLATILE)
        if type_name == ahead_type and fits:
            return
        if topic in self.bag.topics and type_name != ahead_type:
            self._skip(topic, f"published as '{type_name}', already recorded as '{ahead_type}'")
            return
        cls = message_class(type_name)
        if cls is None:
            return
        self.destroy_subscription(self._subs.pop(topic))
        self._ahead[topic] = (type_name, latched and durable)
        qos = subscription_qos([p.qos_profile for p in pubs])
        self._ahead_qos[topic] = qos
        self._subs[topic] = self.create_subscription(
            cls, topic, self._make_callback(topic), qos, raw=True)
        self.get_logger().info(f'{topic}: re-subscribed to match its publishers '
                               f'[{type_name}, {qos.reliability.name.lower()}, '
                               f'{qos.durability.name.lower()}]')

    def _note_matches(self) -> None:
        """Log 'recording <topic>' once a subscribed-ahead topic is matched with a publisher."""
        for topic, (type_name, latched) in list(self._ahead.items()):
            sub = self._subs.get(topic)
            if topic in self._matched or sub is None or sub.get_publisher_count() == 0:
                continue
            self._matched.add(topic)
            qos = self._ahead_qos[topic]
            self.get_logger().info(f'recording {topic} [{type_name}] '
                                   f'({qos.reliability.name.lower()}, '
                                   f'{qos.durability.name.lower()})')

    def _unmatched(self) -> List[str]:
        """Return the selected topics whose publishers are not all matched yet."""
        out = []
        for topic, _ in self.get_topic_names_and_types():
            if topic in self._skipped or not self._selected(topic) or topic == TF_TOPIC:
                continue
            n = self.count_publishers(topic)
            if n == 0:
                continue
            sub = self._subs.get(topic)
            if sub is None or sub.get_publisher_count() < n:
                out.append(topic)
        return out

    def _check_ready(self) -> None:
        """Announce readiness once subscribed and matched (see the module docstring)."""
        if self.ready.is_set() or self._closing:
            return
        unmatched = self._unmatched()
        late = time.monotonic() - self.started_at > self.ready_timeout
        if unmatched and not late:
            return
        if unmatched:
            self.get_logger().warning(
                f'ready after {self.ready_timeout:g} s, but not matched with every publisher '
                f"of: {', '.join(unmatched)}")
        from std_msgs.msg import String
        self._pub_ready = self.create_publisher(String, self.ready_topic, QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self._pub_ready.publish(String(data=self.output))
        self.ready.set()
        self.get_logger().info(f'ready: recording {len(self._subs)} topics to {self.output}')

    def _selected(self, topic: str) -> bool:
        if topic == getattr(self, 'ready_topic', None):
            return False
        if topic in self.wanted:
            return True
        if not self.all_topics:
            return False
        if self.write_tf and topic in (TF_TOPIC, '/tf_static'):
            return False
        if self.robot_only:
            prefix = self.namespace.rstrip('/') + '/'
            return topic.startswith(prefix) or topic == '/diagnostics'
        return not any(part.startswith('_') for part in topic.split('/'))

    def scan_graph(self) -> None:
        """Subscribe to every selected topic that has a publisher and is not recorded yet."""
        if self._closing:
            return
        for topic, types in self.get_topic_names_and_types():
            if topic in self._ahead and topic not in self._skipped:
                pubs = self.get_publishers_info_by_topic(topic)
                if pubs:
                    self._revise_ahead(topic, types[0], pubs)
                continue
            if topic in self._subs or topic in self._skipped or not self._selected(topic):
                continue
            if self.write_tf and topic == TF_TOPIC:
                self._skip(topic, '/tf is written by the recorder itself from joint_states')
                continue
            pubs = self.get_publishers_info_by_topic(topic)
            if not pubs:
                continue  # a subscriber only: wait for a publisher (its type and QoS)
            type_name = types[0]
            cls = message_class(type_name)
            if cls is None:
                self._skip(topic, f"type '{type_name}' is not installed")
                continue
            try:
                type_hash = getattr(pubs[0], 'topic_type_hash', '') or None
                self.bag.add_topic(topic, type_name, [qos_to_dict(p.qos_profile) for p in pubs],
                                   type_description_hash=str(type_hash) if type_hash else None)
            except BagError as exc:
                self._skip(topic, str(exc))
                continue
            qos = subscription_qos([p.qos_profile for p in pubs])
            self._subs[topic] = self.create_subscription(
                cls, topic, self._make_callback(topic), qos, raw=True)
            self.get_logger().info(f'recording {topic} [{type_name}] '
                                   f'({qos.reliability.name.lower()}, '
                                   f'{qos.durability.name.lower()})')

    def _skip(self, topic: str, reason: str) -> None:
        self._skipped[topic] = reason
        level = self.get_logger().warning if topic in self.wanted else self.get_logger().info
        level(f'not recording {topic}: {reason}')

    # -- messages ---------------------------------------------------------------------------
    def _make_callback(self, topic: str):
        write = self.bag.write
        is_js = topic == self.js_topic
        is_markers = topic == self.markers_topic
        is_description = topic == self.description_topic
        subs = self._subs

        def handle(data: bytes, info: dict) -> bool:
            t = info.get('received_timestamp') or time.time_ns()
            try:
                if topic not in self.bag.topics:
                    self._add_channel(topic)
                write(topic, data, t, info.get('source_timestamp') or t)
            except BagError:
                self._dropped_writes += 1  # closed under our feet (stop in progress)
                return False
            if self.max_messages is not None and self.bag.message_count >= self.max_messages:
                self._drain_on_close = False  # exactly max_messages
                self.request_stop(f'{self.max_messages} messages recorded')
                return False
            if is_js and self.write_tf:
                self._joint_states_to_tf(data, t)
            elif is_markers and self.write_tf:
                self._markers_to_tf(data, t)
            elif is_description:
                self._on_description(data)
            return True

        def callback(data: bytes, info: dict) -> None:
            if self._closing or not handle(data, info):
                return
            # take what else is queued now: one executor wake-up per burst, not per message
            # (the executor's per-message overhead is what limits a Python recorder at 1 kHz)
            sub = subs.get(topic)
            for _ in range(DRAIN_LIMIT):
                if sub is None or self._closing:
                    break
                try:
                    taken = take_serialized(sub)
                except Exception:  # destroyed meanwhile (stop in progress)
                    break
                if taken is None or not handle(*taken):
                    break
            self._last_message_at = time.monotonic()

        return callback

    def _on_description(self, data: bytes) -> None:
        from rclpy.serialization import deserialize_message
        from std_msgs.msg import String
        self._description_seen = True
        if not self.write_tf:
            return
        try:
            urdf = deserialize_message(data, String).data
        except Exception:  # not a String after all: /tf keeps using the robot model
            return
        # parsing a URDF can take a while (yourdfpy): never in the executor's thread
        threading.Thread(target=self._use_description, args=(urdf,), daemon=True,
                         name='px100_recorder_urdf').start()

    def _use_description(self, urdf: str) -> None:
        """Build the /tf tree from a published robot_description (background thread)."""
        try:
            tree = TfTree(urdf, '')
            if not tree.movable:
                raise ValueError('it has no movable joint')
            if self.robot_name and not tree.root.startswith(self.robot_name + '/'):
                tree = TfTree(urdf, self.robot_name + '/')
        except (Px100Error, ValueError, TypeError) as exc:
            self.get_logger().warning(f'robot_description is not a usable URDF ({exc}); '
                                      '/tf uses the robot model')
            return
        self._tf_tree = tree

    def _joint_states_to_tf(self, data: bytes, log_ns: int) -> None:
        if self._first_js_at is None:
            self._first_js_at = time.monotonic()
        if self._tf_tree is None:
            if not self._model_ready.is_set():
                # the URDF is still being parsed (first seconds): /tf of these joint states is
                # written as soon as it is ready
                if len(self._tf_backlog) < TF_BACKLOG:
                    self._tf_backlog.append((data, log_ns))
                return
            if self._model_tf_tree is None:
                self.write_tf = False
                return
            self._tf_tree = self._model_tf_tree
        if self._tf_backlog:
            backlog, self._tf_backlog = self._tf_backlog, []
            for old_data, old_ns in backlog:
                self._write_tf(old_data, old_ns)
        self._write_tf(data, log_ns)

    def _write_tf(self, data: bytes, log_ns: int) -> None:
        if log_ns - self._last_tf_ns < self.tf_period_ns:
            return
        from rclpy.serialization import deserialize_message
        from sensor_msgs.msg import JointState
        try:
            msg = deserialize_message(data, JointState)
        except Exception:  # a malformed message: recorded as is, no /tf from it
            return
        positions = dict(zip(msg.name, msg.position))
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        payload = encode_tf_message(self._tf_tree.tf_entries(positions), stamp or log_ns)
        try:
            if not self.bag.has_topic(TF_TOPIC):
                self.bag.add_topic(TF_TOPIC, TF_TYPE, [TF_QOS])
            self.bag.write(TF_TOPIC, payload, log_ns)
        except BagError:
            return
        self._last_tf_ns = log_ns

    def _markers_to_tf(self, data: bytes, log_ns: int) -> None:
        """Write the objects' /tf frames of one world/markers MarkerArray (at most tf_rate)."""
        if log_ns - self._last_object_tf_ns < self.tf_period_ns:
            return
        from rclpy.serialization import deserialize_message
        cls = message_class(MARKER_ARRAY_TYPE)
        try:
            msg = deserialize_message(data, cls)
        except Exception:  # a malformed message: recorded as is, no /tf from it
            return
        markers = markers_from_decoded(msg)
        entries = object_tf_entries(markers, self.robot_name)
        if not entries:
            return
        stamp = msg.markers[0].header.stamp
        stamp_ns = stamp.sec * 1_000_000_000 + stamp.nanosec
        try:
            if not self.bag.has_topic(TF_TOPIC):
                self.bag.add_topic(TF_TOPIC, TF_TYPE, [TF_QOS])
            self.bag.write(TF_TOPIC, encode_tf_message(entries, stamp_ns or log_ns), log_ns)
        except BagError:
            return
        self._last_object_tf_ns = log_ns

    def _flush_tf_backlog(self, timeout_s: float = 5.0) -> None:
        """At close: wait (a little) for the URDF, then write /tf of the waiting joint states."""
        if not (self.write_tf and self._tf_backlog):
            return
        if self._tf_tree is None:
            self._model_ready.wait(timeout_s)
            self._tf_tree = self._tf_tree or self._model_tf_tree
        if self._tf_tree is not None:
            backlog, self._tf_backlog = self._tf_backlog, []
            for data, log_ns in backlog:
                self._write_tf(data, log_ns)

    def _write_model_description(self) -> None:
        urdf = self._model_urdf_xml
        if urdf is None:
            return
        if self.robot_name:
            urdf = prefix_urdf(urdf, self.robot_name)
        # std_msgs/String CDR: encapsulation header, uint32 length (with NUL), bytes, NUL
        text = urdf.encode('utf-8') + b'\x00'
        payload = b'\x00\x01\x00\x00' + len(text).to_bytes(4, 'little') + text
        try:
            if not self.bag.has_topic(self.description_topic):
                self.bag.add_topic(self.description_topic, 'std_msgs/msg/String',
                                   [DESCRIPTION_QOS])
            self.bag.write(self.description_topic, payload, self.bag.start_ns or time.time_ns())
            self.get_logger().info(f'no robot_description published: wrote the '
                                   f'{self.model_name} model URDF to {self.description_topic}')
        except BagError:
            pass
        self._description_seen = True

    # -- stop conditions --------------------------------------------------------------------
    def _housekeeping(self) -> None:
        if self._closing:
            return
        self.bag.flush_if_due()
        self._note_matches()
        self._check_ready()
        now = time.monotonic()
        if (self.write_description and not self._description_seen
                and self._first_js_at is not None and now - self._first_js_at > 1.5
                and self.description_topic not in self._subs and self._model_ready.is_set()
                and self._selected(self.description_topic)):
            self._write_model_description()
        if self.duration is not None and now - self.started_at >= self.duration:
            self.request_stop(f'duration {self.duration:g} s reached')
        elif (self.idle_timeout is not None and self._last_message_at is not None
              and now - self._last_message_at >= self.idle_timeout):
            self.request_stop(f'no message for {self.idle_timeout:g} s')

    def request_stop(self, reason: str) -> None:
        """Finish the bag now (a stop condition was met); the node then has nothing to do."""
        if not self.stop_reason:
            self.stop_reason = reason
        self.finish()

    def finish(self) -> str:
        """Stop recording and close the bag (idempotent); return the metadata.yaml path."""
        with self._lock:
            if self._closing:
                self.closed.wait(10.0)
                return self.metadata_path
            self._closing = True
        try:
            if self._drain_on_close:
                self._drain_queues()
            self._flush_tf_backlog()
            for sub in list(self._subs.values()):
                try:
                    self.destroy_subscription(sub)
                except Exception:  # the context is already shut down (SIGINT): fine
                    pass
            self.metadata_path = self.bag.close()
            if self.context.ok():  # after SIGINT the context (and /rosout) is gone already
                self.get_logger().info(
                    f'bag closed: {self.bag.message_count} messages on '
                    f'{len(self.bag.topics)} topics in {self.output}'
                    + (f' ({self.stop_reason})' if self.stop_reason else ''))
        finally:
            self.closed.set()
        return self.metadata_path

    def _drain_queues(self) -> None:
        """Write what was received but not taken yet (also after SIGINT shut the context)."""
        for topic, sub in list(self._subs.items()):
            for _ in range(100 * SUBSCRIPTION_DEPTH):
                try:
                    taken = take_serialized(sub)
                except Exception:  # destroyed: nothing left to take
                    break
                if taken is None:
                    break
                data, info = taken
                t = info.get('received_timestamp') or time.time_ns()
                try:
                    if topic not in self.bag.topics:
                        self._add_channel(topic)
                    self.bag.write(topic, data, t, info.get('source_timestamp') or t)
                except BagError:
                    break
                if topic == self.js_topic and self.write_tf:
                    self._joint_states_to_tf(data, t)
                elif topic == self.markers_topic and self.write_tf:
                    self._markers_to_tf(data, t)

    @property
    def topics_recorded(self) -> List[str]:
        """Return the topics in the bag or subscribed and matched with a publisher."""
        return sorted(set(self.bag.topics) | self._matched)

    def destroy_node(self):
        """Close the bag, then destroy the node."""
        self.finish()
        return super().destroy_node()


class Recorder:
    """
    Record in-process from Python: a RecorderNode spun in its own thread.

    :param output_dir: bag directory to create
    :param topics: topics to record (None: all of /<robot_name>/ and /diagnostics)
    :param all_topics: record every topic of the graph (with topics: in addition to them)
    :param robot_only: with all_topics, only the robot's namespace and /diagnostics
    :param robot_name: namespace of the robot's topics (and the recorder node)
    :param robot_model: robot model (URDF for /tf)
    :param context: an initialised rclpy Context to join (default: a private one)
    :param options: further RecorderNode options (duration, max_messages, write_tf, ...)
    """

    def __init__(self, output_dir: str, topics: Optional[Sequence[str]] = None,
                 all_topics: bool = False, robot_name: str = 'px100',
                 robot_model: str = 'px100', context=None, robot_only: Optional[bool] = None,
                 **options):
        self.output_dir = os.path.abspath(output_dir)
        self._args = dict(output=self.output_dir, topics=topics,
                          all_topics=all_topics or not topics,
                          robot_only=(not all_topics) if robot_only is None else robot_only,
                          **options)
        self._params = [rclpy.parameter.Parameter('robot_name', value=robot_name),
                        rclpy.parameter.Parameter('robot_model', value=robot_model)]
        self._given_context = context
        self.context = None
        self.node: Optional[RecorderNode] = None
        self._executor = None
        self._thread: Optional[threading.Thread] = None
        self.metadata_path = ''

    def start(self, wait: bool = True) -> 'Recorder':
        """
        Create the node and start recording; return self.

        :param wait: return only once the recorder is ready (subscribed and matched, see the
            module docstring; at most ready_timeout + 5 s), else at once (see wait_ready)
        """
        if self.node is not None:
            return self
        if self._given_context is None:
            from rclpy.signals import SignalHandlerOptions
            self.context = rclpy.Context()
            # no rclpy signal handlers: Ctrl-C reaches the script (KeyboardInterrupt, or the
            # client's handler), and the with-block closes the bag on this context
            rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        else:
            self.context = self._given_context
        try:
            self.node = RecorderNode(context=self.context, parameter_overrides=self._params,
                                     **self._args)
        except Exception:
            if self._given_context is None:
                self.context.try_shutdown()
            raise
        self._executor = make_executor(context=self.context, kind=BAG_EXECUTOR)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name='px100_recorder', daemon=True)
        self._thread.start()
        if wait:
            self.wait_ready(self.node.ready_timeout + 5.0)
        return self

    def _spin(self) -> None:
        from rclpy.executors import ExternalShutdownException
        try:
            while self.context.ok() and not self.node.closed.is_set():
                self._executor.spin_once(timeout_sec=0.1)
        except (ExternalShutdownException, KeyboardInterrupt):
            pass
        except Exception as exc:  # keep the bag: it is closed in stop()
            self.node.get_logger().error(f'recorder executor stopped: {exc}')

    def wait_ready(self, timeout: Optional[float] = None) -> bool:
        """Wait until the recorder is subscribed and matched (module docstring); True if so."""
        return self.node is not None and self.node.ready.wait(timeout)

    @property
    def finished(self) -> bool:
        """Return True once the bag is closed (stop() or a stop condition)."""
        return self.node is not None and self.node.closed.is_set()

    def wait(self, timeout: Optional[float] = None) -> bool:
        """Wait until a stop condition closed the bag; return True if it did."""
        return self.node is not None and self.node.closed.wait(timeout)

    def stop(self) -> str:
        """Close the bag, stop the node (and the private context); return metadata.yaml path."""
        if self.node is None:
            return self.metadata_path
        self.metadata_path = self.node.finish()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self._executor.remove_node(self.node)
        self._executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        if self._given_context is None:
            self.context.try_shutdown()
        self.node = None
        return self.metadata_path

    __call__ = stop

    def __enter__(self):
        """Start recording; return once the recorder is ready (at most ready_timeout + 5 s)."""
        return self.start(wait=True)

    def __exit__(self, *exc):
        """Stop recording and close the bag."""
        self.stop()


def record_in_process(context, output_dir: str, topics: Optional[Sequence[str]] = None,
                      robot_name: str = 'px100', **options) -> Recorder:
    """
    Start recording on an existing rclpy context; return the Recorder (call it to stop).

    Example: ``stop = record_in_process(node.context, '/tmp/run'); ...; stop()``
    """
    return Recorder(output_dir, topics=topics, robot_name=robot_name, context=context,
                    **options).start()


def _add_arguments(parser) -> None:
    parser.add_argument('topics', nargs='*', metavar='TOPIC',
                        help='topics to record (relative names are under the robot namespace, '
                             '/<robot_name>/)')
    parser.add_argument('-a', '--all', action='store_true',
                        help='record every topic of the graph, as ros2 bag record -a '
                             '(hidden _topics excepted)')
    parser.add_argument('--robot-only', action='store_true', default=None,
                        help='only the topics of the robot namespace and /diagnostics (the '
                             'default when neither TOPIC nor -a is given)')
    parser.add_argument('-o', '--output', default=None,
                        help='bag directory to create (default rosbag2_<date>-<time>)')
    parser.add_argument('--duration', type=float, default=None,
                        help='stop after this many seconds')
    parser.add_argument('--max-messages', type=int, default=None,
                        help='stop after this many messages')
    parser.add_argument('--idle-timeout', type=float, default=None,
                        help='stop when no message arrived for this many seconds')
    parser.add_argument('--no-tf', action='store_true',
                        help='do not write /tf from joint_states')
    parser.add_argument('--tf-rate', type=float, default=50.0, help='highest /tf rate [Hz]')
    parser.add_argument('--no-robot-description', action='store_true',
                        help='do not write the model URDF when no robot_description is '
                             'published')
    parser.add_argument('--compression', choices=('zstd', 'lz4', 'none'), default='zstd',
                        help='chunk compression (default zstd)')
    parser.add_argument('--flush-period', type=float, default=1.0,
                        help='write a chunk at least this often [s]: what a SIGKILL can lose')


def main(args=None) -> int:
    """Run the recorder until SIGINT/SIGTERM or a stop condition; exit 0 with a closed bag."""
    import sys

    from rclpy.executors import ExternalShutdownException
    options, argv = parse_cli('Record topics to a rosbag2-compatible MCAP bag.', args,
                              _add_arguments, (RECORDER,))
    install_stop_signals()
    rclpy.init(args=argv)
    node = None
    executor = None
    try:
        executor = make_executor(kind=BAG_EXECUTOR)   # before the node: see common.run_nodes
        node = RecorderNode(
            output=options.output, topics=options.topics, all_topics=options.all,
            robot_only=options.robot_only,
            duration=options.duration, max_messages=options.max_messages,
            idle_timeout=options.idle_timeout, write_tf=not options.no_tf,
            tf_rate=options.tf_rate, write_description=not options.no_robot_description,
            compression=options.compression, flush_period=options.flush_period)
        executor.add_node(node)
        while keep_spinning() and not node.closed.is_set():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (BagError, Px100Error) as exc:
        print(f'record: error: {exc}', file=sys.stderr)
        rclpy.try_shutdown()
        return 1
    except Exception:
        if not shutting_down():
            raise
        # SIGINT/SIGTERM shut the context down while the node was being built: not an error
    finally:
        shutdown_executor(executor)
        if node is not None:
            node.finish()
            print(f'record: {node.bag.message_count} messages in {node.output}'
                  + (f' ({node.stop_reason})' if node.stop_reason else ''), file=sys.stderr)
            node.destroy_node()
        rclpy.try_shutdown()
        ignore_further_interrupts()
    return 0


if __name__ == '__main__':
    import sys
    sys.exit(main())
