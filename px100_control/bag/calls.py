"""
The service calls and action goals a bag holds, counted from their introspection events.

A service with introspection on publishes each call on ``<service>/_service_event``:
REQUEST_SENT / REQUEST_RECEIVED (client / server side, with the request) and RESPONSE_SENT /
RESPONSE_RECEIVED (with the response), each carrying the client's id and the request's
sequence number. An action's goals, cancels and result requests are calls of its three
services (``<action>/_action/send_goal`` ...). A call is counted once per (client id,
sequence number), however many sides recorded it. Only the ``info`` header of each event is
read (plain CDR, no type definition needed), so this works on any bag. Times: ns since the
epoch.
"""
from dataclasses import dataclass, field
import struct
from typing import Dict, Iterable, List, Set, Tuple

from px100_control.bag.ros_names import action_topic, service_event_topic
from px100_control.errors import BagError

REQUEST_EVENTS = (0, 1)    # service_msgs/ServiceEventInfo REQUEST_SENT, REQUEST_RECEIVED
RESPONSE_EVENTS = (2, 3)   # RESPONSE_SENT, RESPONSE_RECEIVED


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
class _Calls:
    requests: Set[Tuple[bytes, int]] = field(default_factory=set)
    responses: Set[Tuple[bytes, int]] = field(default_factory=set)

    def add(self, info: EventInfo) -> None:
        key = (info.client_gid, info.sequence_number)
        if info.event_type in REQUEST_EVENTS:
            self.requests.add(key)
        elif info.event_type in RESPONSE_EVENTS:
            self.responses.add(key)


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
    calls: Dict[Tuple[str, str], _Calls] = {}
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
        calls.setdefault((name, part), _Calls()).add(info)
    for (name, part), c in calls.items():
        out[name].counts[part] = (len(c.requests), len(c.responses))
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
