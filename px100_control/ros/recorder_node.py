"""
Record topics to a rosbag2-compatible MCAP bag: ``ros2 run px100_control record``.

Command line (the options of ``ros2 bag record``, Jazzy, plus stop conditions)::

    record [TOPIC ...] [-a/--all] [--all-topics] [--all-services] [--all-actions]
           [--include-hidden-topics] [--robot-only] [-o/--output DIR] [--duration S]
           [--max-messages N] [--idle-timeout S] [--no-tf] [--tf-rate HZ]
           [--compression zstd|lz4|none] [--flush-period S]
           [--ros-args -r __ns:=/px100 -p robot_name:=px100 -p robot_model:=px100]

The node ``recorder`` lives in the robot namespace (``/px100`` by default); topics without a
leading ``/`` resolve in it (``joint_states`` is ``/px100/joint_states``). ``-a``: every topic
but hidden (``_``) ones and every service's calls (``<service>/_service_event``), as ``ros2 bag
record -a``, plus every action's topics (goal/cancel/result events, feedback, status: as
rosbag2 since Kilted). No topic, or ``--robot-only``: everything of the robot namespace
(service events and actions included), ``/diagnostics``, ``/tf``, ``/tf_static`` (rules:
:class:`~px100_control.bag.recording.TopicSelection`); new topics are picked up as they
appear. Messages are recorded as the exact bytes received (raw subscriptions) with their
publishers' QoS. A live ``/tf`` publisher (robot_state_publisher) is recorded as it is; while
the graph has none (older bringups), the recorder writes ``/tf`` itself from ``joint_states``
and ``world/markers`` (:mod:`px100_control.bag.tf_recording`), never both. When no
robot_description is published it writes the model's URDF there (for Foxglove's 3D panel).
SIGINT and SIGTERM finalise the bag; after SIGKILL it is readable up to its last chunk
(``--flush-period``); ``bag_reindex`` fixes it.

Nothing lost at the start: the recorder subscribes at once to the contract's topics
(docs/ros_interfaces.md: it knows their names, types and QoS), before any publisher exists, and
to other topics as they appear. It is *ready* once every selected topic that has a publisher is
subscribed and matched with all its publishers, for calls' topics on their side too (ros.
writer_match), or after ``ready_timeout`` with a warning naming the unmatched ones; it then
publishes the bag directory on ``recorder/ready`` (std_msgs/String, transient local), where the
client waits (client.recorder_wait), and logs ``ready``; ``with Recorder(dir):`` enters only
then. It lists itself in ros.recorder_registry: a client started just after it knows it is
coming before DDS discovery has found it.

Python API: :mod:`px100_control.ros.recorder`. Bag times: reception [ns since the epoch]. The
closing line counts the topics that got a message, of the 'ready' line's recorded topics.
"""
import os
import sys
import threading
import time
from typing import List, Optional, Sequence
import weakref

from px100_control.bag.recording import (check_positive, default_output_dir, StopConditions,
                                         TF_TOPIC, TopicSelection)
from px100_control.bag.tf_recording import TfRecording
from px100_control.bag.tool_options import add_record_arguments, record_selection
from px100_control.bag.writer import BagWriter
from px100_control.errors import BagError
from px100_control.models.registry import read_robot_file
from px100_control.parameters import COMMON, RECORDER
from px100_control.ros import cdr, recorder_registry
from px100_control.ros.bag_qos import SUBSCRIPTION_DEPTH
from px100_control.ros.bag_tool import run_bag_tool
from px100_control.ros.common import init_robot_node, LATCHED_QOS, parse_cli, robot_name
from px100_control.ros.message_types import joint_positions, string_data, world_markers
from px100_control.ros.parameter_schema import parameter_descriptor
from px100_control.ros.recorder_topics import RecorderTopics, take_next
from rclpy.node import Node
from std_msgs.msg import String

#: most queued messages taken in one callback (the other topics get their turn after that)
DRAIN_LIMIT = 200
#: the recorders of this process that are recording (for the client's Ctrl-C report)
_ACTIVE = weakref.WeakSet()


def active_recorders() -> List['RecorderNode']:
    """Return the RecorderNodes of this process still recording (the client waits for them)."""
    return [n for n in list(_ACTIVE) if not n.closed.is_set()]


class RecorderNode(Node):
    """
    Node 'recorder': subscribes raw to the selected topics and writes them to a bag.

    :param output: bag directory (must not exist or be empty); default rosbag2_<date>
    :param topics: topics to record (relative names under the node's namespace, the robot's);
        None = the robot's view (below)
    :param all_topics: record every topic of the graph (hidden ``_x`` topics excepted), and
        unless told otherwise every service's events and action (``-a``); also the default
        when no topic is given
    :param robot_only: only the robot's namespace plus ``/diagnostics``, ``/tf`` and
        ``/tf_static`` (None: True when nothing else was asked for)
    :param all_services: every ``<service>/_service_event`` (None: as all_topics)
    :param all_actions: every action's topics (None: as all_topics)
    :param include_hidden_topics: with all_topics, the hidden topics too
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
                 all_services: Optional[bool] = None, all_actions: Optional[bool] = None,
                 include_hidden_topics: bool = False, duration: Optional[float] = None,
                 max_messages: Optional[int] = None, idle_timeout: Optional[float] = None,
                 write_tf: bool = True, tf_rate: float = 50.0, write_description: bool = True,
                 compression: str = 'zstd', flush_period: float = 1.0,
                 rescan_period: float = 0.5, ready_timeout: float = 5.0, **node_kwargs):
        init_robot_node(self, 'recorder', node_kwargs)
        # the robot_model/robot_name parameters of declare_robot_parameters(), but the model
        # (URDF parsing, slow to import) is loaded in the background: recording starts at once
        model_name = str(self.declare_parameter(
            'robot_model', 'px100', parameter_descriptor(COMMON[0])).value)
        self.declare_parameter('robot_name', self.get_namespace().strip('/'),
                               parameter_descriptor(COMMON[1]))
        read_robot_file(model_name)  # fast check: raises UnknownRobotError for a bad name
        self.model_name = model_name
        self.robot_name = robot_name(self)
        check_positive(duration=duration, idle_timeout=idle_timeout,
                       flush_period=flush_period, tf_rate=tf_rate)
        self.stop_when = StopConditions(duration, max_messages, idle_timeout)
        self.output = os.path.abspath(output) if output else default_output_dir()
        #: the robot's namespace: relative topics resolve in it ('/' for none)
        self.namespace = self.get_namespace()
        self.selection = TopicSelection(self.namespace, topics, all_topics, robot_only,
                                        all_services, all_actions, include_hidden_topics)
        self.write_description = bool(write_description)
        self.ready = threading.Event()
        self.ready_timeout = float(ready_timeout)
        self._lock = threading.Lock()
        self._closing = False
        self._drain_on_close = True
        self.closed = threading.Event()
        self.stop_reason = ''
        self.metadata_path = ''
        self._last_message_at: Optional[float] = None
        self._dropped_writes = 0
        self.bag = BagWriter(self.output, compression=compression, flush_period_s=flush_period,
                             custom_data={'recorder': 'px100_control',
                                          'robot_name': self.robot_name,
                                          'robot_model': model_name})
        self.tf = TfRecording(self.bag, self.robot_name, model_name, int(1e9 / float(tf_rate)),
                              joint_positions, world_markers, string_data, self._log,
                              self.selection.prefix, enabled=write_tf,
                              encode_string=cdr.string_writer(),
                              live=lambda: self.count_publishers(TF_TOPIC) > 0)
        self.topics = RecorderTopics(self, self.bag, self._selected, self.selection.wanted,
                                     self._make_callback, self.selection.matched_topic)
        #: topic -> raw subscription (the client looks up what a Recorder subscribes here)
        self._subs = self.topics.subs
        try:
            self._start(duration, rescan_period, flush_period)
        except BaseException:
            self.finish()  # e.g. SIGINT during start-up: still leave a closed, valid bag
            raise

    def _start(self, duration, rescan_period: float, flush_period: float) -> None:
        self.started_at = time.monotonic()
        _ACTIVE.add(self)
        sel = self.selection  # announced at once: discovery by DDS can take seconds
        self._entry = recorder_registry.register(self.namespace, sel.all_topics, sel.all_topics
                                                 and not sel.robot_only, sel.wanted, self.output)
        self.topics.subscribe_contract(self.selection.contract_topics())
        self.tf.start_loading()
        self._scan_timer = self.create_timer(rescan_period, self.scan_graph)
        self._housekeeping_timer = self.create_timer(
            min(0.1, max(0.02, flush_period / 4)), self._housekeeping)
        self.get_logger().info(f'recording to {self.output}: ' + self.selection.describe()
                               + (f' (for {duration:g} s)' if duration else ''))
        self.scan_graph()
        self._check_ready()

    def _log(self, level: str, text: str) -> None:
        getattr(self.get_logger(), level)(text)

    def _selected(self, topic: str) -> bool:
        return self.selection.selected(topic)

    def records(self, topic: str) -> bool:
        """Return True if ``topic`` (absolute name) is one this recorder records."""
        return self._selected(topic)

    def _check_ready(self) -> None:
        """Announce readiness once subscribed and matched (see the module docstring)."""
        if self.ready.is_set() or self._closing:
            return
        unmatched = self.topics.unmatched()
        late = time.monotonic() - self.started_at > self.ready_timeout
        if unmatched and not late:
            return
        if unmatched:
            self.get_logger().warning(
                f'ready after {self.ready_timeout:g} s, but not matched with every publisher '
                f"of: {', '.join(unmatched)}")
        self._pub_ready = self.create_publisher(String, self.selection.ready_topic, LATCHED_QOS)
        self._pub_ready.publish(String(data=self.output))
        self.ready.set()
        self.get_logger().info(f'ready: recording {self._counted(self._subs)} to {self.output}'
                               ' (topics that appear later are added)')

    def scan_graph(self) -> None:
        """Subscribe to every selected topic that has a publisher and is not recorded yet."""
        if not self._closing:
            self.topics.scan()

    # -- messages ---------------------------------------------------------------------------
    def _make_callback(self, topic: str):
        subs = self._subs

        def callback(data: bytes, info: dict) -> None:
            if self._closing or not self._handle(topic, data, info):
                return
            # take what else is queued now: one executor wake-up per burst, not per message
            # (the executor's per-message overhead is what limits a Python recorder at 1 kHz)
            sub = subs.get(topic)
            for _ in range(DRAIN_LIMIT):
                if sub is None or self._closing:
                    break
                taken = take_next(sub)
                if taken is None or not self._handle(topic, *taken):
                    break
            self._last_message_at = time.monotonic()

        return callback

    def _handle(self, topic: str, data: bytes, info: dict) -> bool:
        """Record one received message; False when recording of this burst must end."""
        t = self._write(topic, data, info)
        if t is None:
            self._dropped_writes += 1  # closed under our feet (stop in progress)
            return False
        reason = self.stop_when.count_reason(self.bag.message_count)
        if reason:
            self._drain_on_close = False  # exactly max_messages
            self.request_stop(reason)
            return False
        self.tf.take(topic, data, t, time.monotonic())
        return True

    def _write(self, topic: str, data: bytes, info: dict) -> Optional[int]:
        """Write one message to the bag; return its log time [ns] (None: the bag refused it)."""
        t = info.get('received_timestamp') or time.time_ns()
        try:
            if topic not in self.bag.topics:
                self.topics.add_channel(topic)
            self.bag.write(topic, data, t, info.get('source_timestamp') or t)
        except BagError:
            return None
        return t

    # -- stop conditions --------------------------------------------------------------------
    def _housekeeping(self) -> None:
        if self._closing:
            return
        self.bag.flush_if_due()
        self.topics.note_matches()
        self._check_ready()
        now = time.monotonic()
        if (self.write_description and self.tf.description_due(now)
                and self.tf.description_topic not in self._subs
                and self._selected(self.tf.description_topic)):
            self.tf.write_model_description()
        reason = self.stop_when.time_reason(now, self.started_at, self._last_message_at)
        if reason:
            self.request_stop(reason)

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
        recorder_registry.unregister(getattr(self, '_entry', ''))
        try:
            if self._drain_on_close:
                self._drain_queues()
            self.tf.flush_backlog()
            self.topics.destroy_all()
            self.metadata_path = self.bag.close()
            if self.context.ok():  # after SIGINT the context (and /rosout) is gone already
                self.get_logger().info(f'bag closed: {self._summary()}')
        finally:
            self.closed.set()
        return self.metadata_path

    def _drain_queues(self) -> None:
        """Write what was received but not taken yet (also after SIGINT shut the context)."""
        for topic, sub in list(self._subs.items()):
            for _ in range(100 * SUBSCRIPTION_DEPTH):
                taken = take_next(sub)
                t = None if taken is None else self._write(topic, *taken)
                if t is None:
                    break
                self.tf.take(topic, taken[0], t, time.monotonic(), description=False)

    def _counted(self, topics) -> str:
        """Return 'N topics' of a topic set, saying so when this recorder computes /tf."""
        computed = self.tf.enabled and TF_TOPIC not in self._subs
        subscribed = len(set(topics) - {TF_TOPIC}) if computed else len(set(topics))
        return f'{subscribed + computed} topics' + (
            f' ({subscribed} subscribed + {TF_TOPIC} computed here)' if computed else '')

    def _summary(self) -> str:
        return (f'{self.bag.message_count} messages on {len(self.bag.topics)} of the '
                f'{self._counted(self._subs)} recorded in {self.output}'
                + (f' ({self.stop_reason})' if self.stop_reason else ''))

    @property
    def topics_recorded(self) -> List[str]:
        """Return the topics in the bag or subscribed and matched with a publisher."""
        return sorted(set(self.bag.topics) | self.topics.matched)

    def destroy_node(self):
        """Close the bag, then destroy the node."""
        self.finish()
        return super().destroy_node()


def _report(node: RecorderNode) -> None:
    node.finish()
    print(f'record: {node.bag.message_count} messages in {node.output}'
          + (f' ({node.stop_reason})' if node.stop_reason else ''), file=sys.stderr)


def main(args=None) -> int:
    """Run the recorder until SIGINT/SIGTERM or a stop condition; exit 0 with a closed bag."""
    options, argv = parse_cli('Record topics to a rosbag2-compatible MCAP bag.', args,
                              add_record_arguments, (RECORDER,))
    return run_bag_tool('record', argv, lambda: RecorderNode(
        output=options.output, **record_selection(options),
        duration=options.duration, max_messages=options.max_messages,
        idle_timeout=options.idle_timeout, write_tf=not options.no_tf,
        tf_rate=options.tf_rate, write_description=not options.no_robot_description,
        compression=options.compression, flush_period=options.flush_period),
        done=lambda node: node.closed.is_set(), close=_report)


if __name__ == '__main__':
    sys.exit(main())
