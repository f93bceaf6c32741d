"""
The recorder's subscriptions: the contract's topics at once, the other topics as they appear.

Raw subscriptions (the received bytes go to the bag as they are). A contract topic is subscribed
*ahead*, before any publisher exists, with the QoS the contract gives it; when its publishers
turn up with a type or QoS that subscription cannot match, it is re-subscribed to match them.
Any other selected topic is subscribed once the graph shows a publisher, with a QoS every
publisher matches, and added to the bag with the QoS profiles they offer.
"""
from typing import Callable, Dict, Iterable, List

from px100_control.bag.ros_names import kind_of
from px100_control.bag.writer import BagWriter
from px100_control.errors import BagError
from px100_control.ros.bag_qos import (ahead_qos, all_latched, assumed_offer, describe,
                                       matches_all, qos_to_dict, subscription_qos)
from px100_control.ros.common import LATCHED_QOS
from px100_control.ros.message_types import message_class
from px100_control.ros.writer_match import participant_of, WriterSideCheck
from px100_control.wire.private_api import take_serialized
from rclpy.node import Node
from std_msgs.msg import String


def take_next(sub):
    """Return the next queued (bytes, info) of a raw subscription; None if none or destroyed."""
    try:
        return take_serialized(sub)
    except Exception:  # destroyed meanwhile (stop in progress)
        return None


class RecorderTopics:
    """
    Subscribe a recorder node to what it records, and add the topics to its bag.

    :param node: the recorder node (its graph queries, subscriptions and logger)
    :param bag: the bag being written
    :param selected: selected(topic) -> True if the topic is recorded
    :param wanted: the topics asked for by name (not recording one of them is a warning)
    :param callback_for: callback_for(topic) -> the raw subscription's callback
    :param matched_topic: where the subscribed-ahead topics matched so far are announced
        (latched std_msgs/String, one topic per line, again at each new match): a client in
        another process waits for its calls' event topics there, since seeing the recorder's
        subscription in its own graph does not mean the recorder has matched the publisher
    """

    def __init__(self, node: Node, bag: BagWriter, selected: Callable[[str], bool],
                 wanted: Iterable[str], callback_for: Callable[[str], Callable],
                 matched_topic: str = ''):
        self.node, self.bag = node, bag
        self._pub_matched = node.create_publisher(String, matched_topic, LATCHED_QOS) \
            if matched_topic else None
        self._selected = selected
        self._wanted, self._callback_for = set(wanted), callback_for
        self._log = node.get_logger()
        #: topic -> its raw subscription
        self.subs: Dict[str, object] = {}
        #: contract topics subscribed ahead of their publishers: topic -> (type, latched)
        self.ahead: Dict[str, tuple] = {}
        #: subscribed topics already matched with a publisher (calls: on both sides)
        self.matched: set = set()
        #: the QoS of each subscribed-ahead topic's subscription
        self.ahead_qos: Dict[str, object] = {}
        #: topic -> why it is not recorded
        self.skipped: Dict[str, str] = {}
        #: whether the publishers' processes have matched the subscriptions on their side
        self.writer_side = WriterSideCheck(node)

    def _subscribe(self, cls, topic: str, qos):
        sub = self.node.create_subscription(cls, topic, self._callback_for(topic), qos, raw=True)
        self.subs[topic] = sub
        self.writer_side.reset()
        return sub

    def subscribe_contract(self, contract: Iterable[tuple]) -> None:
        """Subscribe to the selected (topic, type, latched) now, before their publishers exist."""
        for topic, type_name, latched in contract:
            if not self._selected(topic):
                continue
            cls = message_class(type_name)
            if cls is None:
                continue  # e.g. visualization_msgs not installed: the scan decides later
            qos = ahead_qos(latched)
            try:
                self._subscribe(cls, topic, qos)
            except Exception as exc:  # e.g. this participant has the topic with another type
                self._log.debug(f'{topic}: not subscribed ahead ({exc})')
                continue
            self.ahead[topic] = (type_name, latched)
            self.ahead_qos[topic] = qos
            self._log.debug(f'{topic} [{type_name}]: subscribed ahead')

    def _add_to_bag(self, topic: str, type_name: str, pubs, offered=None) -> None:
        type_hash = getattr(pubs[0], 'topic_type_hash', '') if pubs else ''
        self.bag.add_topic(topic, type_name,
                           offered or [qos_to_dict(p.qos_profile) for p in pubs],
                           type_description_hash=str(type_hash) if type_hash else None)

    def add_channel(self, topic: str) -> None:
        """Add a subscribed-ahead topic to the bag (at its first message: publishers' QoS)."""
        type_name, latched = self.ahead[topic]
        pubs = list(self.node.get_publishers_info_by_topic(topic))
        self._add_to_bag(topic, type_name, pubs,
                         [qos_to_dict(p.qos_profile) for p in pubs] or [assumed_offer(latched)])

    def revise_ahead(self, topic: str, type_name: str, pubs) -> None:
        """Re-subscribe a subscribed-ahead topic whose publishers its QoS or type cannot match."""
        ahead_type, latched = self.ahead[topic]
        type_name = getattr(pubs[0], 'topic_type', '') or type_name
        offered = [p.qos_profile for p in pubs]
        if type_name == ahead_type and matches_all(self.ahead_qos[topic], offered):
            return
        if topic in self.bag.topics and type_name != ahead_type:
            self.skip(topic, f"published as '{type_name}', already recorded as '{ahead_type}'")
            return
        cls = message_class(type_name)
        if cls is None:
            return
        self.node.destroy_subscription(self.subs.pop(topic))
        self.ahead[topic] = (type_name, latched and all_latched(offered))
        qos = subscription_qos(offered)
        self.ahead_qos[topic] = qos
        self._subscribe(cls, topic, qos)
        self._log.info(f'{topic}: re-subscribed to match its publishers '
                       f'[{type_name}, {describe(qos)}]')

    def note_matches(self) -> None:
        """
        Note the topics newly matched with a publisher (log the subscribed-ahead ones).

        A call's topic (a service event, an action's) counts once its publishers' processes
        have also confirmed their side (:mod:`px100_control.ros.writer_match`): clients wait for
        these topics before their first call, and a recorder that got ready before it knew the
        servers (started with the script) would otherwise be trusted on its side alone.
        """
        known = len(self.matched)
        for topic, sub in list(self.subs.items()):
            if topic in self.matched or sub.get_publisher_count() == 0:
                continue
            if kind_of(topic) != 'topic' and self.writer_side.unconfirmed(
                    self.node.get_publishers_info_by_topic(topic)):
                continue
            self.matched.add(topic)
            if topic in self.ahead:
                self._log.info(f'recording {topic} [{self.ahead[topic][0]}] '
                               f'({describe(self.ahead_qos[topic])})')
        if self._pub_matched is not None and len(self.matched) > known:
            self._pub_matched.publish(String(data='\n'.join(sorted(self.matched))))

    def unmatched(self) -> List[str]:
        """
        Return the selected topics whose publishers are not all matched yet, on either side.

        This side: the subscription counts every publisher of the graph. Theirs, for the
        topics of calls (service events, actions: their servers spin, so they can answer):
        each publisher's process answered a question asked after the subscriptions were made
        (:mod:`px100_control.ros.writer_match`).
        """
        out, infos = [], {}
        for topic, _ in self.node.get_topic_names_and_types():
            if topic in self.skipped or not self._selected(topic):
                continue
            n = self.node.count_publishers(topic)
            if n == 0:
                continue
            sub = self.subs.get(topic)
            if sub is None or sub.get_publisher_count() < n:
                out.append(topic)
            elif not out and kind_of(topic) != 'topic':
                infos[topic] = self.node.get_publishers_info_by_topic(topic)
        if out:
            return out
        waiting = set(self.writer_side.unconfirmed(i for pubs in infos.values() for i in pubs))
        for topic, pubs in infos.items():
            nodes = sorted({f"{i.node_namespace.rstrip('/')}/{i.node_name}" for i in pubs
                            if participant_of(i) in waiting})
            if nodes:
                out.append(f"{topic} (the process of {', '.join(nodes)} has not confirmed "
                           'its side yet)')
        return out

    def scan(self) -> None:
        """Subscribe to every selected topic that has a publisher and is not recorded yet."""
        for topic, types in self.node.get_topic_names_and_types():
            if topic in self.ahead and topic not in self.skipped:
                pubs = self.node.get_publishers_info_by_topic(topic)
                if pubs:
                    self.revise_ahead(topic, types[0], pubs)
            elif topic not in self.subs and topic not in self.skipped and self._selected(topic):
                self._add_published(topic, types[0])

    def _add_published(self, topic: str, type_name: str) -> None:
        pubs = self.node.get_publishers_info_by_topic(topic)
        if not pubs:
            return  # a subscriber only: wait for a publisher (its type and QoS)
        cls = message_class(type_name)
        if cls is None:
            self.skip(topic, f"type '{type_name}' is not installed")
            return
        try:
            self._add_to_bag(topic, type_name, pubs)
        except BagError as exc:
            self.skip(topic, str(exc))
            return
        qos = subscription_qos([p.qos_profile for p in pubs])
        self._subscribe(cls, topic, qos)
        self._log.info(f'recording {topic} [{type_name}] ({describe(qos)})')

    def skip(self, topic: str, reason: str) -> None:
        """Leave a topic out, with a log line (a warning if it was asked for by name)."""
        self.skipped[topic] = reason
        level = self._log.warning if topic in self._wanted else self._log.info
        level(f'not recording {topic}: {reason}')

    def destroy_all(self) -> None:
        """Destroy every subscription (also after SIGINT shut the context down)."""
        for sub in list(self.subs.values()):
            try:
                self.node.destroy_subscription(sub)
            except Exception:  # the context is already shut down (SIGINT): fine
                pass
