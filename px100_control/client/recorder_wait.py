"""
The client waits for the recorders that record it, so that a bag holds a script's first command.

Which recorders (the ``recorder`` argument of
:class:`~px100_control.client.core.InterbotixRobotXSCore`):

- None (default): every recorder found when the robot is constructed, with no change to the
  script: the Recorders running in this process (``with Recorder(dir):`` around the script)
  and the other recorders of this machine's domain that record this robot
  (:mod:`px100_control.ros.recorder_registry`: ``record -a`` started before the script, even
  when DDS discovery has not found it yet) or are nodes named ``recorder`` in the graph (looked
  for until the client is :func:`discovery_grace` s old), each for at most :data:`AUTO_WAIT` s;
- a :class:`~px100_control.ros.recorder.Recorder`: that one, up to connect_timeout;
- True (or env ``PX100_RECORDER=wait``): also a recorder that is still starting: up to
  connect_timeout for an announcement on ``recorder/ready``;
- False: none.

Waiting for a recorder means: it announced that it is ready (``recorder/ready``, std_msgs/String
with the bag directory, transient local, in the recorder's namespace), then each of this
client's command publishers (setpoints) is matched with the recorder's subscription, and the
recorder subscribes to the service event topics on which the servers publish this client's
calls (action goals, cancels and results, IK requests and replies). For a recorder of this
process both directions are checked (its subscription has matched this client's publisher,
and the servers' event publishers, whose processes confirmed their side too); for one in
another process this client's side is checked, and for each event topic the recorder
subscribes to (seen in the graph) the recorder's own word that it matched its publishers on
both sides (``recorder/matched``; at most
:data:`MATCH_WAIT` s, half that for a recorder of another namespace, which records this robot
only when it records every topic; a recorder announces ready once it matched the publishers
it knows). A recorder that is not
ready in time is named in a warning: the start of the run may then be missing from its bag; so
is a recorder of the robot's namespace that announces itself only later.
"""
import os
import sys
import threading
import time
from typing import Dict, List

from px100_control.bag.recording import MATCHED_TOPIC
from px100_control.ros import recorder_registry
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

#: [s] longest wait for each recorder found at startup (recorder=None)
AUTO_WAIT = 5.0
#: [s] longest wait for this client's publishers to match a recorder in another process
MATCH_WAIT = 3.0
#: [s] default of :func:`discovery_grace`
DISCOVERY_GRACE = 2.0
#: the recorder node's name (px100_control.ros.recorder_node)
RECORDER_NODE = 'recorder'
_LATCHED = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


def local_recorders() -> list:
    """Return the RecorderNodes of this process that are recording (none if never imported)."""
    module = sys.modules.get('px100_control.ros.recorder_node')
    return list(module.active_recorders()) if module is not None else []


def local_bag_dirs() -> List[str]:
    """Return the bag directories of the recorders of this process that are recording."""
    return sorted(n.output for n in local_recorders())


def discovery_grace() -> float:
    """
    Return how long [s] after its start a client looks for recorders (env PX100_RECORDER_GRACE).

    Two processes started together take a while to discover each other (about 1-2 s on a
    loaded machine): a recorder started with the script is seen only after that.
    """
    try:
        return max(0.0, float(os.environ.get('PX100_RECORDER_GRACE', DISCOVERY_GRACE)))
    except ValueError:
        return DISCOVERY_GRACE


def wanted(recorder) -> object:
    """Return the effective ``recorder`` argument (env PX100_RECORDER=wait means True)."""
    if recorder is None and os.environ.get('PX100_RECORDER', '').lower() in ('wait', '1'):
        return True
    return recorder


def graph_recorders(node, exclude: List[object] = ()) -> List[str]:
    """
    Return the namespaces of the recorder nodes in ``node``'s graph that are not in ``exclude``.

    :param exclude: in-process RecorderNodes (each one hides one graph node of its namespace)
    """
    counts: Dict[str, int] = {}
    for name, ns in node.get_node_names_and_namespaces():
        if name == RECORDER_NODE:
            counts[ns] = counts.get(ns, 0) + 1
    for rec in exclude:
        ns = rec.get_namespace()
        if counts.get(ns, 0) > 0:
            counts[ns] -= 1
    return sorted(ns for ns, n in counts.items() if n > 0)


class RecorderWait:
    """
    Wait for the recorders of one client core (see the module docstring).

    :param core: the InterbotixRobotXSCore (its node, publishers, logger and bag_paths)
    :param publishers: the core's command publishers that must reach the bag
    :param event_topics: the servers' ``<service>/_service_event`` topics of its calls
    """

    def __init__(self, core, publishers: list, event_topics: List[str] = ()):
        self.core = core
        self.node = core.get_node()
        self.pubs = list(publishers)
        self.events = list(event_topics)
        self.topics = [p.topic_name for p in self.pubs] + self.events

    def run(self, recorder, timeout: float) -> bool:
        """Wait for the recorders ``recorder`` selects; return False if one was not ready."""
        recorder = wanted(recorder)
        if recorder is False:
            return True
        if recorder is not None and recorder is not True:
            node = getattr(recorder, 'node', None)
            self._note_bag(getattr(recorder, 'output_dir', ''))
            if node is None:
                return self._warn(f'the Recorder given ({recorder.output_dir}) is not started')
            return self._local(node, time.monotonic() + timeout)
        ok = True
        local, remote = self._find(recorder is None)
        if recorder is True and not remote and not local:
            remote = [self.core.ns or '/']  # not in the graph yet: wait for its announcement
        for rec in local:
            ok = self._local(rec, time.monotonic() + (timeout if recorder else AUTO_WAIT)) and ok
        for ns in remote:
            ok = self._remote(ns, timeout if recorder else AUTO_WAIT) and ok
        return ok

    def _find(self, grace: bool):
        """
        Return (in-process RecorderNodes recording us, namespaces of other recorders).

        :param grace: look until one is found or the core is :func:`discovery_grace` s old
        """
        end = self.core._started_at + (discovery_grace() if grace else 0.0)
        while True:
            local = [r for r in local_recorders() if self._records_us(r)]
            remote = sorted(set(graph_recorders(self.node, local_recorders())) | {
                e['namespace'] for e in recorder_registry.running(os.getpid())
                if any(recorder_registry.records(e, t) for t in self.topics)})
            if local or remote or time.monotonic() >= end:
                return local, remote
            time.sleep(0.05)

    # -- in this process ------------------------------------------------------------------
    def _records_us(self, rec) -> bool:
        return any(rec.records(t) for t in self.topics)

    def _local(self, rec, end: float) -> bool:
        """Wait until an in-process RecorderNode is ready and matched both ways with us."""
        self._note_bag(rec.output)
        if not rec.ready.wait(max(0.0, end - time.monotonic())):
            return self._warn(f'the recorder writing {rec.output} did not get ready')
        for pub in [p for p in self.pubs if rec.records(p.topic_name)]:
            while not self._local_matched(rec, pub):
                if time.monotonic() > end:
                    return self._warn(f'the recorder writing {rec.output} did not match '
                                      f'{pub.topic_name}')
                time.sleep(0.005)
        for topic in [t for t in self.events if rec.records(t)]:
            while not self._local_event_matched(rec, topic):
                if time.monotonic() > end:
                    return self._warn(f'the recorder writing {rec.output} did not match '
                                      f'{topic}')
                time.sleep(0.005)
        self.node.loginfo(f'Recorder ready and matched: recording to {rec.output}')
        return True

    def _local_matched(self, rec, pub) -> bool:
        topic = pub.topic_name
        sub = rec.topics.subs.get(topic)
        if sub is None or pub.get_subscription_count() < self.node.count_subscribers(topic):
            return False
        mine = (self.node.get_name(), self.node.get_namespace())
        theirs = rec.get_publishers_info_by_topic(topic)
        return any((i.node_name, i.node_namespace) == mine for i in theirs) and \
            sub.get_publisher_count() >= len(theirs) and any(
                i.node_name == RECORDER_NODE and i.node_namespace == rec.get_namespace()
                for i in self.node.get_subscriptions_info_by_topic(topic))

    def _local_event_matched(self, rec, topic: str) -> bool:
        """Return True when the event's publishers and the recorder matched, on both sides."""
        sub = rec.topics.subs.get(topic)
        return sub is not None and topic in rec.topics.matched and \
            sub.get_publisher_count() >= max(1, len(rec.get_publishers_info_by_topic(topic)))

    # -- in another process ---------------------------------------------------------------
    def _remote(self, ns: str, timeout: float) -> bool:
        """Wait for the recorder in namespace ``ns`` to announce ready, then match it."""
        topic = f"{ns.rstrip('/')}/recorder/ready"
        event = threading.Event()
        paths = []

        def on_ready(msg: String) -> None:
            self._note_bag(msg.data)
            paths.append(msg.data)
            event.set()

        sub = self.node.create_subscription(String, topic, on_ready, _LATCHED,
                                            callback_group=self.core._cbg)
        try:
            if not event.wait(timeout):
                return self._warn(f'no recorder announced ready on {topic} within '
                                  f'{timeout:.1f} s')
        finally:
            self.node.destroy_subscription(sub)
        # a recorder of another namespace records this robot only with -a (then it subscribes
        # once its graph scan sees our publishers): a shorter bound
        own = ns == (self.core.ns or '/')
        end = time.monotonic() + (MATCH_WAIT if own else MATCH_WAIT / 2.0)
        for pub in self.pubs:
            while time.monotonic() < end and not any(
                    i.node_name == RECORDER_NODE and i.node_namespace == ns
                    for i in self.node.get_subscriptions_info_by_topic(pub.topic_name)):
                time.sleep(0.01)
            self.core._await_matched(pub, max(0.0, end - time.monotonic()))
        self._await_recorder_matched(ns, end)
        self.node.loginfo(f"Recorder ready and matched: recording to {', '.join(paths)}")
        return True

    def _await_recorder_matched(self, ns: str, end: float) -> None:
        """Wait until the recorder says it matched the event topics it subscribes (by end)."""
        matched, changed = set(), threading.Event()

        def on_matched(msg: String) -> None:
            matched.update(msg.data.splitlines())
            changed.set()

        sub = self.node.create_subscription(String, f"{ns.rstrip('/')}/{MATCHED_TOPIC}",
                                            on_matched, _LATCHED, callback_group=self.core._cbg)
        try:
            for topic in self.events:
                while time.monotonic() < end and not any(
                        i.node_name == RECORDER_NODE and i.node_namespace == ns
                        for i in self.node.get_subscriptions_info_by_topic(topic)):
                    time.sleep(0.01)    # (a recorder that does not record it never subscribes)
                while time.monotonic() < end and topic not in matched and any(
                        i.node_name == RECORDER_NODE and i.node_namespace == ns
                        for i in self.node.get_subscriptions_info_by_topic(topic)):
                    changed.clear()
                    changed.wait(0.05)
        finally:
            self.node.destroy_subscription(sub)

    # -- helpers --------------------------------------------------------------------------
    def _note_bag(self, path: str) -> None:
        if path and path not in self.core.bag_paths:
            self.core.bag_paths.append(path)

    def _warn(self, what: str) -> bool:
        self.core.get_node().logwarn(f'Recorder: {what}: the start of this run may be missing '
                                     'from the bag.')
        return False
