"""
Whether the publishers a node subscribes to have matched its subscriptions on their own side.

DDS matches two endpoints on each side separately. A subscription counts a publisher as soon as
its own participant has learnt of it; the publisher sends to the subscription only once the
publisher's participant has processed the subscription's announcement. On a loaded machine, or
after a lost discovery packet (resent at the next heartbeat, seconds later), that comes later,
and what the publisher sends meanwhile never reaches the subscription: a recorder that counted
itself ready could miss a script's first service call.

The announcements of one participant's endpoints reach another participant in the order they
were made. So an answer from a service of the publisher's process, to a client created after
the subscriptions, proves that the process knows every one of them. :class:`WriterSideCheck`
asks each publishing process (participant, from the publishers' GIDs) once through one of its
nodes' ``get_parameter_types`` (no names: nothing is read or changed), again after a new
subscription (:meth:`WriterSideCheck.reset`), and again every :data:`RETRY` s while unanswered
(an answer sent before its client was matched is lost). A process none of whose nodes has
parameter services (seen for :data:`UNASKABLE_GRACE` s) cannot be asked and is trusted; one
whose nodes the graph does not name yet (their list, ``ros_discovery_info``, comes apart from
the endpoints) is not: a server stopped or starved before it sent that list was trusted so.
"""
import time
from typing import Dict, Iterable, List, Optional, Tuple

from rcl_interfaces.srv import GetParameterTypes

#: [s] ask a process again after this long without an answer
RETRY = 0.5
#: [s] a process none of whose nodes shows a parameter service for this long is trusted
UNASKABLE_GRACE = 1.0
#: the graph topic every node publishes on: its publishers name the nodes of a participant
ROSOUT = '/rosout'
#: the node name the graph gives an endpoint whose participant's node list has not arrived
UNKNOWN_NODE = '_NODE_NAME_UNKNOWN_'


def participant_of(info) -> Tuple:
    """Return the key of a publisher's participant: its GID prefix, else its node's name."""
    gid = bytes(getattr(info, 'endpoint_gid', b'') or b'')
    return ('gid', gid[:12]) if len(gid) >= 12 and any(gid[:12]) else \
        ('node', info.node_namespace, info.node_name)


class WriterSideCheck:
    """
    Confirm that the processes of given publishers have matched this node's subscriptions.

    :param node: the subscribing node (its graph queries, its clients, its executor)
    """

    def __init__(self, node):
        self._node = node
        self._me = (node.get_namespace(), node.get_name())
        self._own: Optional[Tuple] = None
        #: participant key -> (client, service name)
        self._clients: Dict[Tuple, tuple] = {}
        #: participant key -> (future of the last call, monotonic time it was sent)
        self._calls: Dict[Tuple, tuple] = {}
        self._confirmed: set = set()
        #: participant key -> when it was first seen with no parameter service to ask [s]
        self._unaskable: Dict[Tuple, float] = {}

    def reset(self) -> None:
        """Forget the answers: a subscription was created after them (they do not cover it)."""
        for client, _ in self._clients.values():
            try:
                self._node.destroy_client(client)
            except Exception:  # noqa: B902 - the context is gone (SIGINT): nothing to free
                pass
        self._clients.clear()
        self._calls.clear()
        self._confirmed.clear()
        self._unaskable.clear()

    def unconfirmed(self, infos: Iterable) -> List[Tuple]:
        """
        Return the participant keys of ``infos`` (TopicEndpointInfo of publishers) not confirmed.

        Asks those not asked yet (or not answered for RETRY s); never blocks.
        """
        groups: Dict[Tuple, set] = {}
        for info in infos:
            key = participant_of(info)
            if (info.node_namespace, info.node_name) != self._me and key != self._own_key():
                groups.setdefault(key, set()).add((info.node_namespace, info.node_name))
        out = []
        for key, nodes in groups.items():
            if key in self._confirmed:
                continue
            if not self._ask(key, nodes):
                if not self._nodes_of(key, nodes):
                    out.append(key)   # the graph does not name its nodes yet
                    continue
                first = self._unaskable.setdefault(key, time.monotonic())
                if time.monotonic() - first < UNASKABLE_GRACE:
                    out.append(key)   # its services may not be discovered yet
                continue   # nothing to ask it with: trusted
            if key not in self._confirmed:
                out.append(key)
        return out

    def _own_key(self) -> Optional[Tuple]:
        """Return this node's participant key (matching within it is immediate: no question)."""
        if self._own is None:
            mine = [participant_of(i) for i in self._node.get_publishers_info_by_topic(ROSOUT)
                    if (i.node_namespace, i.node_name) == self._me]
            self._own = mine[0] if mine and mine[0][0] == 'gid' else None
        return self._own

    def _ask(self, key: Tuple, nodes: set) -> bool:
        """Send (or resend) the question to participant ``key``; False if it cannot be asked."""
        if key not in self._clients:
            service = self._service_of(key, nodes)
            if service is None:
                return False
            self._clients[key] = (self._node.create_client(GetParameterTypes, service), service)
        client, _ = self._clients[key]
        future, sent = self._calls.get(key, (None, 0.0))
        now = time.monotonic()
        if client.service_is_ready() and (future is None or now - sent > RETRY):
            future = client.call_async(GetParameterTypes.Request())
            self._calls[key] = (future, now)
            future.add_done_callback(lambda f, k=key: self._answered(k, f))
        return True

    def _answered(self, key: Tuple, future) -> None:
        if self._calls.get(key, (None,))[0] is future and future.result() is not None:
            self._confirmed.add(key)

    def _nodes_of(self, key: Tuple, nodes: set) -> List[Tuple[str, str]]:
        """
        Return the (namespace, name) the graph gives the nodes of participant ``key``.

        Until a participant's node list (``ros_discovery_info``) arrives, the graph names its
        endpoints' node ``_NODE_NAME_UNKNOWN_``: that names no node.
        """
        if key[0] == 'gid':   # every node of the participant that logs: more to choose from
            nodes = nodes | {(i.node_namespace, i.node_name) for i in
                             self._node.get_publishers_info_by_topic(ROSOUT)
                             if participant_of(i) == key}
        return sorted((ns, name) for ns, name in nodes if name != UNKNOWN_NODE)

    def _service_of(self, key: Tuple, nodes: set) -> Optional[str]:
        """Return the get_parameter_types service of a node of participant ``key``, if any."""
        for ns, name in self._nodes_of(key, nodes):
            wanted = f"{ns.rstrip('/')}/{name}/get_parameter_types"
            try:
                services = self._node.get_service_names_and_types_by_node(name, ns)
            except Exception:  # noqa: B902 - the node left the graph meanwhile
                continue
            if any(s == wanted for s, _ in services):
                return wanted
        return None

    def describe(self, key: Tuple) -> str:
        """Return what was asked of participant ``key``, for a log line."""
        entry = self._clients.get(key)
        return entry[1] if entry else str(key[1:])
