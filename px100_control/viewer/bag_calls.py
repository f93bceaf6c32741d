"""
The goals, their statuses, the IK targets and the errors a bag holds, for the bag viewer.

Two protocols are read, as the live viewer shows them:

- the trajectory action and the IK service (their introspection events,
  docs/ros_interfaces.md): each goal request of
  ``arm_controller/follow_joint_trajectory/_action/send_goal/_service_event`` (its
  JointTrajectory; the goal is named by the request event's stamp, as the live viewer names
  it), a refused goal (its response ``accepted`` false), the action's ``_action/status``;
  ``compute_ik/_service_event``: each request's PoseStamped target, each refusal's message;
- bags recorded before: ``trajectory/goal`` (named by its header stamp), ``trajectory/status``
  (read only when the bag has no ``_action/status``), ``ik/request`` and ``ik/status``.

``/diagnostics`` errors become the last error as in the live viewer. Times are seconds from the
bag's first message; goal ids are stamps [s]; positions in the base frame [m].
"""
import bisect
from collections import deque
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Sequence, Tuple

from px100_control.viewer.state import (GOAL_STATUS_NAMES, stamp_seconds, TERMINAL_STATUSES,
                                        ViewerState)

ACTION = 'arm_controller/follow_joint_trajectory/_action/'
#: topic (relative to the robot namespace unless absolute) -> what it carries
TOPICS = {
    ACTION + 'send_goal/_service_event': 'goal_event',
    ACTION + 'status': 'action_status',
    'compute_ik/_service_event': 'ik_event',
    'trajectory/goal': 'goal',
    'trajectory/status': 'status',
    'ik/request': 'ik_request',
    'ik/status': 'ik_status',
    '/diagnostics': 'diagnostics',
}
REQUEST_RECEIVED, RESPONSE_SENT = 1, 2
DIAGNOSTIC_ERROR = 2
REJECTED = 'REJECTED'
TERMINAL = TERMINAL_STATUSES + (REJECTED,)


@dataclass(frozen=True)
class BagGoal:
    """One trajectory goal: its id (stamp [s]), joint names and the points' positions."""

    goal_id: float
    names: Tuple[str, ...]
    points: Tuple[Tuple[float, ...], ...]


def _series():
    return field(default_factory=list)


@dataclass
class CallTimeline:
    """Goals, statuses, IK targets and errors of a bag, each a time-sorted series."""

    goal_times: List[float] = _series()
    goals: List[BagGoal] = _series()
    status_times: List[float] = _series()
    statuses: List[Tuple[float, str]] = _series()
    ik_times: List[float] = _series()
    ik_targets: List[Tuple[Tuple[float, ...], Tuple[float, ...]]] = _series()
    error_times: List[float] = _series()
    errors: List[str] = _series()
    _uuids: Dict[bytes, float] = field(default_factory=dict)
    _pending: Dict[int, deque] = field(default_factory=dict)
    _action_status: List[Tuple[float, list]] = _series()
    _old_status: List[Tuple[float, list]] = _series()

    @staticmethod
    def topics(namespace: str, bag_topics) -> Dict[str, str]:
        """Return {bag topic: kind} of the topics this reads that the bag has."""
        out = {}
        for name, kind in TOPICS.items():
            topic = name if name.startswith('/') else f'/{namespace}/{name}'.replace('//', '/')
            if topic in bag_topics:
                out[topic] = kind
        return out

    def add(self, kind: str, t: float, msg) -> None:
        """Take one message of a topic of :meth:`topics` logged at t [s]."""
        getattr(self, '_on_' + kind)(t, msg)

    def _add_goal(self, t: float, goal_id: float, traj) -> None:
        self.goal_times.append(t)
        self.goals.append(BagGoal(goal_id, tuple(str(n) for n in traj.joint_names),
                                  tuple(tuple(float(v) for v in p.positions)
                                        for p in traj.points)))

    def _on_goal_event(self, t: float, msg) -> None:
        seq = int(msg.info.sequence_number)
        if msg.info.event_type == REQUEST_RECEIVED and len(msg.request):
            goal_id = stamp_seconds(msg.info.stamp)
            self._uuids[bytes(msg.request[0].goal_id.uuid)] = goal_id
            self._pending.setdefault(seq, deque()).append(goal_id)
            self._add_goal(t, goal_id, msg.request[0].goal.trajectory)
        elif msg.info.event_type == RESPONSE_SENT and len(msg.response):
            waiting = self._pending.get(seq)    # the oldest unanswered request of that number
            goal_id = waiting.popleft() if waiting else None
            if goal_id is not None and not msg.response[0].accepted:
                self.status_times.append(t)
                self.statuses.append((goal_id, REJECTED))
                self._error(t, f'goal {self.number(goal_id)}: not accepted by the action '
                               'server')

    def _on_goal(self, t: float, msg) -> None:
        self._add_goal(t, stamp_seconds(msg.header.stamp), msg)

    def _on_action_status(self, t: float, msg) -> None:
        self._action_status.append((t, list(msg.status_list)))

    def _on_status(self, t: float, msg) -> None:
        self._old_status.append((t, list(msg.status_list)))

    def _on_ik_event(self, t: float, msg) -> None:
        if msg.info.event_type == REQUEST_RECEIVED and len(msg.request):
            self._ik(t, msg.request[0].target)
        elif msg.info.event_type == RESPONSE_SENT and len(msg.response) and \
                not msg.response[0].success:
            self._error(t, f'ik: {msg.response[0].message}')

    def _on_ik_request(self, t: float, msg) -> None:
        self._ik(t, msg)

    def _on_ik_status(self, t: float, msg) -> None:
        if msg.level >= DIAGNOSTIC_ERROR:
            self._error(t, f'ik: {msg.message}')

    def _on_diagnostics(self, t: float, msg) -> None:
        errors = [s for s in msg.status if s.level >= DIAGNOSTIC_ERROR]
        if errors:
            self._error(t, f'{errors[-1].name}: {errors[-1].message}')

    def _ik(self, t: float, pose_stamped) -> None:
        p, q = pose_stamped.pose.position, pose_stamped.pose.orientation
        self.ik_times.append(t)
        self.ik_targets.append(((float(p.x), float(p.y), float(p.z)),
                                (float(q.x), float(q.y), float(q.z), float(q.w))))

    def _error(self, t: float, text: str) -> None:
        self.error_times.append(t)
        self.errors.append(text)

    def number(self, goal_id: float) -> int:
        """Return the goal's place in the bag (1, 2, ...; 0 for an unknown id)."""
        ids = [g.goal_id for g in self.goals]
        return ids.index(goal_id) + 1 if goal_id in ids else 0

    def finish(self) -> None:
        """Resolve the statuses (after every message): the latest goal of each status array."""
        arrays = self._action_status or self._old_status
        for t, status_list in arrays:
            if not status_list:
                continue
            latest = max(status_list, key=lambda s: stamp_seconds(s.goal_info.stamp))
            goal_id = self._uuids.get(bytes(latest.goal_info.goal_id.uuid),
                                      stamp_seconds(latest.goal_info.stamp))
            self.status_times.append(t)
            self.statuses.append((goal_id, GOAL_STATUS_NAMES.get(int(latest.status),
                                                                 str(latest.status))))
        order = sorted(range(len(self.status_times)), key=self.status_times.__getitem__)
        self.status_times = [self.status_times[i] for i in order]
        self.statuses = [self.statuses[i] for i in order]
        self._action_status, self._old_status, self._pending = [], [], {}

    def apply(self, state: ViewerState, t: float,
              joints_at: Callable[[float], Dict[str, float]]) -> None:
        """
        Set the state's goal path, goal status, IK target and last error to the bag's at t [s].

        :param joints_at: the recorded joints {name: value} at a time [s] (a goal's path starts
            where the arm was when the goal came)
        """
        state.goal_numbers = {round(g.goal_id, 9): i + 1 for i, g in enumerate(self.goals)}
        g, s = _last(self.goal_times, t), _last(self.status_times, t)
        goal = self.goals[g] if g >= 0 else None
        status = self.statuses[s] if s >= 0 else None
        state.show_goal_status(f'goal {state.goal_number(status[0])}: {status[1]}'
                               if status else '')
        ended = goal is not None and any(
            st[0] == goal.goal_id and st[1] in TERMINAL for st in self.statuses[:s + 1])
        if goal is None or ended:
            state.clear_path()
        elif state.path_goal != goal.goal_id or not state.path:
            state.set_goal(goal.goal_id, goal.names, goal.points,
                           start=joints_at(self.goal_times[g]))
        i = _last(self.ik_times, t)
        state.show_ik_target(self.ik_targets[i] if i >= 0 else None)
        e = _last(self.error_times, t)
        state.set_error(self.errors[e] if e >= 0 else '')


def _last(times: Sequence[float], t: float) -> int:
    return bisect.bisect_right(times, t) - 1
