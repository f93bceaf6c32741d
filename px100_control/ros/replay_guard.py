"""
Replay safety: a bag's setpoints are not re-sent to a live arm.

When a live driver or trajectory server runs in a namespace the bag's
``commands/joint_setpoints`` are replayed into (:mod:`px100_control.ros.peers`), they are
withheld, with a warning naming the live nodes. The graph is watched up to LIVE_CHECK_S
before the replay (the wait ends once a live node is seen, named, and no other has appeared
for SETTLE_S: one process's endpoints are discovered one by one; a name still unknown, or a
set still growing, is waited for up to NAME_WAIT_S more) and looked at again, at most
every LIVE_RECHECK_S, while commands are replayed: discovery can outlast the first look on a
loaded machine. Times are ``time.monotonic()`` seconds.
"""
import threading
import time
from typing import Dict, List, Tuple

from px100_control.bag.replay import withheld_warning
from px100_control.ros.peers import DISCOVERY_BOUND_S, has_unknown, live_peers
from rclpy.node import Node

#: how long [s] the graph is watched for live nodes before commands are replayed: until a
#: participant missed by the first DDS announcements has been announced again
LIVE_CHECK_S = DISCOVERY_BOUND_S
#: how much longer [s] a live node seen but not yet named is waited for (its name arrives
#: after its endpoints; CI once saw only '(a node not identified yet)' at 3 s)
NAME_WAIT_S = 1.0
#: how long [s] the live nodes found must stay the same before they are named (CI once named
#: only sim_driver of a bringup: its action status publisher was discovered after joint_states';
#: a fresh-clone run at load 7 did again with 0.5 s)
SETTLE_S = 1.0
#: while commands are replayed, the graph is looked at again at most this often [s]
LIVE_RECHECK_S = 0.25


class CommandGuard:
    """
    Withhold replayed command topics from namespaces with live nodes.

    :param node: the replaying node (its graph and logger)
    :param commands: {bag topic: namespace it is published into} of the command topics
        (:func:`px100_control.bag.replay.command_topics`)
    :param stop: set when the replay is stopped (ends the first wait early)
    """

    def __init__(self, node: Node, commands: Dict[str, str], stop: threading.Event):
        self.node, self.commands, self._stop = node, dict(commands), stop
        self._namespaces = sorted(set(self.commands.values()))
        #: bag topics left out because a live node would act on them
        self.withheld: List[str] = []
        self._next_check = 0.0

    def _live_nodes(self) -> Tuple[Dict[str, List[str]], bool]:
        """Return ({namespace: live driver / server names}, whether a peer is still unknown)."""
        live, unknown = {}, False
        for ns in self._namespaces:
            peers = live_peers(self.node, ns)
            names = peers['drivers'] + peers['trajectory_servers']
            unknown = unknown or has_unknown(peers)
            if names:
                live[ns] = sorted(set(names))
        return live, unknown

    def check(self) -> None:
        """Before the replay: watch the graph (up to LIVE_CHECK_S) and withhold what is live."""
        if not self.commands:
            return
        deadline = time.monotonic() + LIVE_CHECK_S
        live, unknown = self._live_nodes()
        while (not live or unknown) and time.monotonic() < deadline and \
                not self._stop.is_set():
            time.sleep(0.05)
            live, unknown = self._live_nodes()
        deadline = time.monotonic() + NAME_WAIT_S
        settled = time.monotonic() + SETTLE_S
        while live and (unknown or time.monotonic() < settled) and \
                time.monotonic() < deadline and not self._stop.is_set():
            time.sleep(0.05)
            seen, unknown = self._live_nodes()
            if seen != live:
                live, settled = seen, time.monotonic() + SETTLE_S
        self._withhold(live)

    def _withhold(self, live: Dict[str, List[str]]) -> None:
        new = [t for t, ns in self.commands.items() if ns in live and t not in self.withheld]
        if new:
            self.withheld.extend(new)
            self.node.get_logger().warning(withheld_warning(live, new))

    def withheld_now(self, topic: str) -> bool:
        """Return True if topic is a command topic whose namespace has live nodes by now."""
        if topic in self.withheld:
            return True
        if topic not in self.commands:
            return False
        now = time.monotonic()
        if now >= self._next_check:
            self._next_check = now + LIVE_RECHECK_S
            self._withhold(self._live_nodes()[0])
        return topic in self.withheld
