"""
The service calls and action goals a bag holds, counted from their introspection events.

A service with introspection on publishes each call on ``<service>/_service_event``:
REQUEST_SENT / REQUEST_RECEIVED (client / server side, with the request) and RESPONSE_SENT /
RESPONSE_RECEIVED (with the response), each carrying the client's id and the request's
sequence number. An action's goals, cancels and result requests are calls of its three
services (``<action>/_action/send_goal`` ...). Events are paired into calls
(:func:`pair_events`): with a client id, one call per (client id, sequence number), however
many sides recorded it; without one (all zeros: the action servers' events, rclpy exposes no
client id to them), each request is a call of its own and a response answers the oldest
unanswered request of its sequence number, in stamp order, so two clients that share sequence
numbers are not merged. Counting reads only the ``info`` header of each event (plain CDR, no type
definition needed), so it works on any bag; :func:`read_calls` also names each call by its
request (a goal id, a target stamp). Times: ns since the epoch.
"""
from collections import deque
from dataclasses import dataclass, field
import struct
from typing import Callable, Dict, Iterable, List, Optional, Tuple

from px100_control.bag.ros_names import action_topic, service_event_topic
from px100_control.errors import BagError

REQUEST_EVENTS = (0, 1)    # service_msgs/ServiceEventInfo REQUEST_SENT, REQUEST_RECEIVED
RESPONSE_EVENTS = (2, 3)   # RESPONSE_SENT, RESPONSE_RECEIVED


def stamp_text(stamp) -> str:
    """Return a builtin_interfaces/Time as 'sec.nanosec' (nine digits): a request's name."""
    return f'{int(stamp.sec)}.{int(stamp.nanosec):09d}'


_ARM_ACTION = 'arm_controller/follow_joint_trajectory/_action/'
#: the calls a px100_control client makes, by kind -> (the service, relative to the robot
#: namespace, whose events hold them; request -> the name the client knows it by: goal id in
#: hex, target stamp)
CLIENT_CALLS = {
    'goals': (_ARM_ACTION + 'send_goal', lambda r: bytes(r.goal_id.uuid).hex()),
    'results': (_ARM_ACTION + 'get_result', lambda r: bytes(r.goal_id.uuid).hex()),
    'cancels': (_ARM_ACTION + 'cancel_goal', lambda r: bytes(r.goal_info.goal_id.uuid).hex()),
    'ik': ('compute_ik', lambda r: stamp_text(r.target.header.stamp)),
    'path': ('compute_cartesian_path', lambda r: stamp_text(r.waypoints.header.stamp)),
}


@dataclass(frozen=True)
class EventInfo:
    """The ``info`` of one service event: event type, stamp [ns], client id, sequence number."""

    event_type: int
    stamp_ns: int
    client_gid: bytes
    sequence_number: int


def event_info(data: bytes) -> EventInfo:
    """
    Return the ServiceEventInfo at the start of a serialized ``*_Event`` message.

    :raises BagError: too short, or not CDR
    """
    if len(data) < 44 or data[0] != 0 or data[1] not in (0, 1):
        raise BagError(f'not a CDR service event ({len(data)} bytes)')
    end = '<' if data[1] == 1 else '>'
    body = data[4:]
    sec, nanosec = struct.unpack_from(end + 'iI', body, 4)
    (seq,) = struct.unpack_from(end + 'q', body, 32)
    return EventInfo(body[0], sec * 1_000_000_000 + nanosec, bytes(body[12:28]), seq)


@dataclass
class Call:
    """
    One call: its client id and sequence number, when its request and response were seen.

    :param request_ns: the stamp [ns] of its first request event (None: no request recorded)
    :param response_ns: the stamp [ns] of its first response event (None: unanswered)
    :param key: what the request names (from :func:`read_calls`' key function), else None
    """

    client_gid: bytes
    sequence_number: int
    request_ns: Optional[int] = None
    response_ns: Optional[int] = None
    key: Optional[str] = None

    @property
    def answered(self) -> bool:
        """Return True if both the request and the response are in the bag."""
        return self.request_ns is not None and self.response_ns is not None


def pair_events(events: Iterable[Tuple[EventInfo, Optional[str]]]) -> List[Call]:
    """
    Return the calls of one service's events (info, key of its request or None), by stamp.

    A client id of zeros names no client: such requests are never merged, and each response
    answers the oldest open request of its sequence number (one left without a request
    becomes a call of its own).
    """
    calls: List[Call] = []
    by_client: Dict[Tuple[bytes, int], Call] = {}
    waiting: Dict[int, deque] = {}
    for info, key in sorted(events, key=lambda e: e[0].stamp_ns):
        request = info.event_type in REQUEST_EVENTS
        if not request and info.event_type not in RESPONSE_EVENTS:
            continue
        ident = (info.client_gid, info.sequence_number)
        if any(info.client_gid):
            call = by_client.get(ident)
            if call is None:
                call = by_client[ident] = Call(*ident)
                calls.append(call)
        elif request:
            call = Call(*ident)
            calls.append(call)
            waiting.setdefault(info.sequence_number, deque()).append(call)
        else:
            queue = waiting.get(info.sequence_number)
            call = queue.popleft() if queue else None
            if call is None:
                call = Call(*ident)
                calls.append(call)
        if request and call.request_ns is None:
            call.request_ns, call.key = info.stamp_ns, key if key is not None else call.key
        elif not request and call.response_ns is None:
            call.response_ns = info.stamp_ns
    return calls


def read_calls(reader, topic: str,
               key: Optional[Callable[[object], str]] = None) -> List[Call]:
    """
    Return the calls on one ``_service_event`` topic of a bag (a BagReader).

    :param key: function(decoded request) -> its name (e.g. the goal id in hex); requests are
        decoded only with it (the bag's type definition is then needed)
    :raises BagError: unknown topic, an unreadable event, or (with key) no usable definition
    """
    events = []
    for raw in reader.iter_raw([topic]):
        info = event_info(raw.data)
        name = None
        if key is not None and info.event_type in REQUEST_EVENTS:
            msg = reader.decode(raw)
            name = key(msg.request[0]) if len(msg.request) else None
        events.append((info, name))
    return pair_events(events)


@dataclass
class CallSummary:
    """
    The calls of one service or action in a bag.

    :param name: the service or action name
    :param kind: 'service' or 'action'
    :param counts: per part ('call' of a service; 'goal', 'cancel', 'result' of an action):
        (requests, responses), each call counted once
    :param messages: per action topic ('feedback', 'status'): messages recorded
    :param unreadable: events whose info could not be read
    """

    name: str
    kind: str
    counts: Dict[str, Tuple[int, int]] = field(default_factory=dict)
    messages: Dict[str, int] = field(default_factory=dict)
    unreadable: int = 0


def _part(topic: str):
    """Return (name, kind, part) of a call topic, None for other topics."""
    action = action_topic(topic)
    if action is not None:
        return action[0], 'action', action[1]
    service = service_event_topic(topic)
    return None if service is None else (service, 'service', 'call')


def summarise_calls(reader) -> List[CallSummary]:
    """Return the calls of every service and action in a bag (a BagReader), by name."""
    parts = {t: _part(t) for t in reader.topics}
    parts = {t: p for t, p in parts.items() if p is not None}
    if not parts:
        return []
    out: Dict[str, CallSummary] = {}
    events: Dict[Tuple[str, str], list] = {}
    for raw in reader.iter_raw(sorted(parts)):
        name, kind, part = parts[raw.topic]
        summary = out.setdefault(name, CallSummary(name, kind))
        if part in ('feedback', 'status'):
            summary.messages[part] = summary.messages.get(part, 0) + 1
            continue
        try:
            info = event_info(raw.data)
        except BagError:
            summary.unreadable += 1
            continue
        events.setdefault((name, part), []).append((info, None))
    for (name, part), these in events.items():
        calls = pair_events(these)
        out[name].counts[part] = (sum(c.request_ns is not None for c in calls),
                                  sum(c.response_ns is not None for c in calls))
    return [out[n] for n in sorted(out)]


_WORDS = {'call': ('request', 'response'), 'goal': ('goal', 'goal reply'),
          'cancel': ('cancel', 'cancel reply'), 'result': ('result request', 'result')}


def _plural(n: int, word: str) -> str:
    if n == 1:
        return f'{n} {word}'
    return f'{n} {word[:-1]}ies' if word.endswith('y') else f'{n} {word}s'


def format_calls(summaries: Iterable[CallSummary]) -> str:
    """Return the printable table of calls ('' when there are none)."""
    summaries = list(summaries)
    if not summaries:
        return ''
    width = max(len(s.name) for s in summaries)
    lines = ['calls:      (from service introspection events; each call counted once)']
    for s in summaries:
        words = []
        for part in ('call', 'goal', 'cancel', 'result'):
            if part in s.counts:
                req, res = s.counts[part]
                words += [_plural(req, _WORDS[part][0]), _plural(res, _WORDS[part][1])]
        words += [f'{n} {part}' for part, n in sorted(s.messages.items())]
        if s.unreadable:
            words.append(f'{s.unreadable} unreadable events')
        lines.append(f"  {s.name:<{width}}  {s.kind:<7}  {', '.join(words)}")
    return '\n'.join(lines)
