"""
Who else is in the robot's namespace: a second driver or trajectory server, found in the graph.

Two ``sim_driver`` (or a real driver beside one) in one namespace publish competing
``joint_states`` and command the same joints; two trajectory servers both serve the goals of
their action. Both show up as tracking aborts, so the nodes and the client look for them by name:

- drivers: the nodes publishing ``<ns>/joint_states`` (a ``replayer`` is named separately);
- trajectory servers: the nodes serving the action ``<ns>/arm_controller/follow_joint_trajectory``
  (publishing its ``_action/status``; the trajectory_server serves it from its helper node
  ``trajectory_actions``, which the graph names).

Names are ``/<namespace>/<node>`` as the graph reports them; two nodes of the same name count
twice (one endpoint each).
"""
from typing import Dict, List

#: node names that subscribe or publish the contract's topics without being a driver / server
PASSIVE_NODES = ('recorder', 'replayer', 'viewer')
#: the topic every server of the arm's FollowJointTrajectory action publishes (relative to ns)
ARM_ACTION_STATUS = 'arm_controller/follow_joint_trajectory/_action/status'


#: what the graph reports for an endpoint whose node is not discovered yet
UNKNOWN = '_NODE_NAME_UNKNOWN_'

#: [s] after which a new participant has seen every running one: Fast DDS announces a
#: participant 5 times 0.1 s apart at start, then every 3 s, so one whose first announcements
#: crossed unseen (measured here: 3 of 6 starts beside a running bringup) appears after 3 s
DISCOVERY_BOUND_S = 3.5


def _full(info) -> str:
    if info.node_name == UNKNOWN:
        return '(a node not identified yet)'
    return f"{info.node_namespace.rstrip('/')}/{info.node_name}"


def has_unknown(peers: Dict[str, List[str]]) -> bool:
    """Return True when some endpoint's node is not identified yet (ask again shortly)."""
    return any(n.startswith('(') for names in peers.values() for n in names)


def _is_passive(name: str) -> bool:
    return any(name == p or name.startswith(p + '_') for p in PASSIVE_NODES)


def live_peers(node, ns: str) -> Dict[str, List[str]]:
    """
    Return {'drivers': [...], 'trajectory_servers': [...], 'replayers': [...]} under ``ns``.

    :param node: any rclpy node (its graph cache is used)
    :param ns: the robot namespace, '/px100' ('' or '/' for the root)
    """
    prefix = ns.rstrip('/') + '/'
    drivers, replayers = [], []
    for info in node.get_publishers_info_by_topic(prefix + 'joint_states'):
        name = _full(info)
        if info.node_name.startswith('replayer'):
            replayers.append(name)
        elif not _is_passive(info.node_name):
            drivers.append(name)  # two nodes may share one name: count endpoints
    servers = [_full(info)
               for info in node.get_publishers_info_by_topic(prefix + ARM_ACTION_STATUS)]
    return {'drivers': sorted(drivers), 'trajectory_servers': sorted(servers),
            'replayers': sorted(set(replayers))}


def duplicates_message(peers: Dict[str, List[str]], ns: str) -> str:
    """Return a sentence naming a second driver / trajectory_server under ``ns`` ('' if none)."""
    parts = []
    for key, what in (('drivers', 'drivers publish joint_states'),
                      ('trajectory_servers',
                       'nodes serve arm_controller/follow_joint_trajectory')):
        names = peers.get(key, [])
        if len(names) > 1:
            shown = [n if names.count(n) == 1 else f'{n} (x{names.count(n)}, same name)'
                     for n in sorted(set(names))]
            parts.append(f"{len(names)} {what} under '{ns or '/'}': {', '.join(shown)}")
    if not parts:
        return ''
    return ('; '.join(parts) + ': they fight over the same joints (moves abort, the arm '
            'jitters); stop all but one (e.g. an in-process bringup beside a running bringup).')


def new_duplicates(node, kind: str, ns: str, last: str) -> str:
    """
    Return the sentence naming duplicates of ``kind`` ('drivers' | 'trajectory_servers') under ns.

    Logs it as an error when it is new (differs from ``last``); returns ``last`` unchanged while
    a node of the graph is still being discovered (named on the next check).
    """
    peers = live_peers(node, ns)
    if has_unknown(peers):
        return last
    message = duplicates_message({kind: peers[kind]}, ns)
    if message and message != last:
        node.get_logger().error(message)
    return message
