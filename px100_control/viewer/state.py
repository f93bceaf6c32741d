"""
What the viewer shows, as plain data: joints, world bodies, trail, trajectory, statuses.

No ROS and no viser here: messages arrive as plain values (or as duck-typed message objects
with the fields of visualization_msgs/Marker), and every method that depends on time takes it
as an argument [s]. Positions are in the robot's base frame [m]; quaternions are (x, y, z, w).
:class:`ViewerState` counts a version per part so the scene redraws only what changed.
"""
from collections import deque
from dataclasses import dataclass
import math
import re
import time
from typing import Callable, Dict, Iterable, List, Optional, Sequence, Tuple

#: visualization_msgs/Marker type -> shape name (CUBE, SPHERE, CYLINDER)
MARKER_SHAPES = {1: 'box', 2: 'sphere', 3: 'cylinder'}
#: visualization_msgs/Marker actions
MARKER_ADD, MARKER_DELETE, MARKER_DELETEALL = 0, 2, 3
#: action_msgs/GoalStatus codes -> names
GOAL_STATUS_NAMES = {0: 'UNKNOWN', 1: 'ACCEPTED', 2: 'EXECUTING', 3: 'CANCELING',
                     4: 'SUCCEEDED', 5: 'CANCELED', 6: 'ABORTED'}
TERMINAL_STATUSES = ('SUCCEEDED', 'CANCELED', 'ABORTED')
#: ASCII punctuation a backslash escapes in CommonMark, but , : ; / ? @ (never markup)
_MARKDOWN_SPECIAL = re.compile(r'[\\`*_{}\[\]<>()#+\-.!|~&"\'=^$%]')


@dataclass(frozen=True)
class Body:
    """
    One world body as the page draws it.

    :param shape: 'box' (size = full x, y, z extents), 'cylinder' (radius, height, axis z),
        'sphere' (radius); sizes [m]
    :param rgba: colour, 4 floats in 0..1
    :param position: xyz [m] in the base frame; quat_xyzw its orientation
    """

    name: str
    ns: str
    shape: str
    size: Tuple[float, ...]
    rgba: Tuple[float, float, float, float]
    position: Tuple[float, float, float]
    quat_xyzw: Tuple[float, float, float, float]


def body_from_marker(marker) -> Optional[Body]:
    """
    Return the Body of one visualization_msgs/Marker (any object with its fields), or None.

    None for shapes the viewer does not draw (anything but CUBE, SPHERE, CYLINDER). ``scale``
    is the full extent [m] (ROS Marker convention): a cylinder's radius is scale.x / 2.
    """
    shape = MARKER_SHAPES.get(int(marker.type))
    if shape is None:
        return None
    sx, sy, sz = float(marker.scale.x), float(marker.scale.y), float(marker.scale.z)
    if shape == 'box':
        size = (sx, sy, sz)
    elif shape == 'cylinder':
        size = (sx / 2.0, sz)
    else:
        size = (sx / 2.0,)
    p, q, c = marker.pose.position, marker.pose.orientation, marker.color
    quat = (float(q.x), float(q.y), float(q.z), float(q.w))
    if not any(quat):
        quat = (0.0, 0.0, 0.0, 1.0)
    name = str(marker.text) or f'{marker.ns}_{marker.id}'
    return Body(name=name, ns=str(marker.ns), shape=shape, size=size,
                rgba=(float(c.r), float(c.g), float(c.b), float(c.a)),
                position=(float(p.x), float(p.y), float(p.z)), quat_xyzw=quat)


def apply_markers(bodies: Dict[Tuple[str, int], Body], markers: Iterable) -> Dict:
    """
    Return the bodies after a MarkerArray's markers (ADD/MODIFY, DELETE, DELETEALL in order).

    Bodies are keyed by (ns, id), as ROS markers are.
    """
    out = dict(bodies)
    for m in markers:
        action = int(m.action)
        key = (str(m.ns), int(m.id))
        if action == MARKER_DELETEALL:
            out.clear()
        elif action == MARKER_DELETE:
            out.pop(key, None)
        else:
            body = body_from_marker(m)
            if body is not None:
                out[key] = body
    return out


class Trail:
    """
    A bounded end-effector trail: at most ``max_points`` points, one per ``min_step`` [m] moved.

    :param max_points: the oldest points drop out beyond this (memory and drawing stay bounded)
    """

    def __init__(self, max_points: int = 500, min_step: float = 0.002):
        if max_points < 2:
            raise ValueError(f'trail max_points must be at least 2, not {max_points}')
        self.points = deque(maxlen=int(max_points))
        self.min_step = float(min_step)

    def add(self, xyz: Sequence[float]) -> bool:
        """Append a point if it is min_step away from the last one; return True if added."""
        p = tuple(float(v) for v in xyz)
        if self.points and math.dist(self.points[-1], p) < self.min_step:
            return False
        self.points.append(p)
        return True

    def clear(self) -> None:
        """Forget every point."""
        self.points.clear()


class Throttle:
    """Allow an action at most once per ``period`` [s] (time is an argument)."""

    def __init__(self, period: float):
        self.period = float(period)
        self.last = -math.inf

    def due(self, now: float) -> bool:
        """Return True if the period has passed since the last :meth:`mark`."""
        return now - self.last >= self.period

    def mark(self, now: float) -> None:
        """Record that the action happened at now."""
        self.last = now


class RateLimit:
    """
    Allow actions at ``rate`` [1/s] on average, each as soon as a credit is there.

    Unlike :class:`Throttle` no tick is waited for: with joint_states at 50 Hz and a page rate
    of 30 Hz, 3 of every 5 messages are drawn the moment they arrive (intervals of 20 and
    40 ms), none later. Credit builds up to ``burst`` while idle (time is an argument [s]).
    """

    def __init__(self, rate: float, burst: float = 2.0):
        self.rate = float(rate)
        self.burst = max(1.0, float(burst))
        self.credit = self.burst
        self.last: Optional[float] = None

    def _refill(self, now: float) -> None:
        if self.last is not None:
            self.credit = min(self.burst, self.credit + (now - self.last) * self.rate)
        self.last = now

    def due(self, now: float) -> bool:
        """Return True if an action may happen at now."""
        self._refill(now)
        return self.credit >= 1.0

    def mark(self, now: float) -> None:
        """Record that the action happened at now (spends one credit)."""
        self._refill(now)
        self.credit -= 1.0


def interpolate_joint_path(start: Dict[str, float], names: Sequence[str],
                           points: Sequence[Sequence[float]],
                           samples_per_segment: int = 12) -> List[Dict[str, float]]:
    """
    Return joint configurations along a trajectory goal, from ``start`` through its points.

    Joints not in ``names`` keep their start value. Linear in joint space: every profile of
    trajectory_server (trapezoidal, minimum jerk, linear) follows this geometric path and only
    times it differently.
    """
    current = dict(start)
    out = [dict(current)]
    for pt in points:
        target = dict(current)
        target.update({n: float(v) for n, v in zip(names, pt)})
        for k in range(1, samples_per_segment + 1):
            s = k / samples_per_segment
            out.append({n: current[n] + s * (target[n] - current[n]) if n in target else v
                        for n, v in current.items()})
        current = target
    return out


def markdown_literal(text: str) -> str:
    """
    Return text escaped for Markdown (CommonMark + GFM) so it renders as written.

    Names and error texts reach the status panel verbatim; unescaped, ``<lambda>`` would be
    raw HTML that swallows the lines after it and ``wrist_angle ... shoulder_x`` italics.
    """
    one_line = ' '.join(str(text).split())     # a newline would start a block (list, code)
    return _MARKDOWN_SPECIAL.sub(r'\\\g<0>', one_line)


def clock_text(stamp: float) -> str:
    """
    Return a stamp [s] as the user reads it: local clock time, or simulated seconds.

    Stamps after 1 Jan 2001 are wall-clock time ('10:34:00.712'); smaller ones come from a
    simulated clock that started at 0 ('sim time 12.35 s').
    """
    if stamp < 978307200.0:
        return f'sim time {stamp:.2f} s'
    whole = time.localtime(stamp)
    return time.strftime('%H:%M:%S', whole) + f'.{int(1000 * (stamp % 1.0)):03d}'


def stamp_seconds(stamp) -> float:
    """Return a builtin_interfaces/Time-like object (sec, nanosec) as float seconds."""
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


class ViewerState:
    """
    Everything the page shows, with a version counter per part.

    Parts: 'robot' (urdf_xml), 'joints', 'world' (bodies, held), 'trail', 'path' (the active
    trajectory's end-effector path and target), 'ik' (last IK target), 'status' (texts).
    :param fk: function(joint dict) -> (xyz, quat_xyzw) of the end effector, or None until a
        robot is loaded (set by the scene)
    """

    PARTS = ('robot', 'joints', 'world', 'trail', 'path', 'ik', 'status')

    def __init__(self, trail_points: int = 500, trail_step: float = 0.002):
        self.version = dict.fromkeys(self.PARTS, 0)
        self.urdf_xml = ''
        self.robot_error = ''
        self.joints: Dict[str, float] = {}
        self.stamp = 0.0
        self.first_stamp: Optional[float] = None
        self.goal_numbers: Dict[float, int] = {}
        self.bodies: Dict[Tuple[str, int], Body] = {}
        self.held = ''
        self.trail = Trail(trail_points, trail_step)
        self.path: List[Tuple[float, float, float]] = []
        self.target: Optional[Tuple[float, float, float]] = None
        self.path_goal: Optional[float] = None
        self.ik_target: Optional[Tuple[Tuple[float, ...], Tuple[float, ...]]] = None
        self.goal_status = ''
        self.last_error = ''
        self.note = ''
        self.fk: Optional[Callable] = None
        self._ee = (-1, None)

    def _bump(self, *parts: str) -> None:
        for p in parts:
            self.version[p] += 1

    def set_robot(self, urdf_xml: str) -> None:
        """Take a new robot description (the trail and path are cleared)."""
        if urdf_xml == self.urdf_xml:
            return
        self.urdf_xml = urdf_xml
        self.trail.clear()
        self.path, self.target = [], None
        self._bump('robot', 'joints', 'trail', 'path')

    def set_joints(self, names: Sequence[str], positions: Sequence[float],
                   stamp: float) -> None:
        """Take a joint_states sample (rad or m) at stamp [s] (the trail: update_trail)."""
        for n, v in zip(names, positions):
            v = float(v)
            if math.isfinite(v):
                self.joints[str(n)] = v
        self.stamp = float(stamp)
        if self.first_stamp is None or self.stamp < self.first_stamp:
            self.first_stamp = self.stamp      # the start (or a clock that went back)
        self._bump('joints', 'status')

    def ee_pose(self):
        """Return the end effector's (xyz, quat_xyzw) at the current joints, or None."""
        if self.fk is None or not self.joints:
            return None
        key = self.version['joints']
        if self._ee[0] != key or self._ee[1] is None:
            self._ee = (key, self.fk(self.joints))
        return self._ee[1]

    def update_trail(self) -> bool:
        """
        Extend the trail to the end effector at the current joints; return True if it grew.

        The page calls this when it draws (the kinematics run once per drawn state, never
        while no browser is connected), not once per joint_states message.
        """
        pose = self.ee_pose()
        if pose is not None and self.trail.add(pose[0]):
            self._bump('trail')
            return True
        return False

    def set_markers(self, markers: Iterable) -> None:
        """Apply a world/markers MarkerArray's markers."""
        bodies = apply_markers(self.bodies, markers)
        if bodies != self.bodies:
            self.bodies = bodies
            self._bump('world', 'status')

    def set_held(self, name: str) -> None:
        """Set the held body's name (world/held_object), '' for none."""
        if name != self.held:
            self.held = str(name)
            self._bump('world', 'status')

    def set_goal(self, goal_id: float, names: Sequence[str],
                 points: Sequence[Sequence[float]],
                 start: Optional[Dict[str, float]] = None) -> None:
        """
        Show a trajectory goal's end-effector path and target (through fk).

        :param start: the joints the path starts from (None: the current ones)
        """
        if self.fk is None:
            return
        self.goal_number(goal_id)
        configs = interpolate_joint_path(self.joints if start is None else start, names,
                                         points)
        poses = [self.fk(q) for q in configs]
        self.path = [tuple(p[0]) for p in poses if p is not None]
        self.target = self.path[-1] if self.path else None
        self.path_goal = goal_id
        self._bump('path')

    def goal_number(self, goal_id: float) -> int:
        """Return the goal's number on this page: 1, 2, ... in the order goals were seen."""
        key = round(float(goal_id), 9)
        if key not in self.goal_numbers:
            self.goal_numbers[key] = len(self.goal_numbers) + 1
        return self.goal_numbers[key]

    def set_goal_status(self, goal_id: float, status: str) -> None:
        """Set the latest goal's status; a terminal one ends the path display of that goal."""
        text = f'goal {self.goal_number(goal_id)}: {status}'
        if text != self.goal_status:
            self.goal_status = text
            self._bump('status')
        if status in TERMINAL_STATUSES and self.path_goal is not None and \
                abs(goal_id - self.path_goal) < 1e-9 and self.path:
            self.path = []
            self._bump('path')

    def clear_path(self) -> None:
        """Show no goal path."""
        if self.path or self.target is not None or self.path_goal is not None:
            self.path, self.target, self.path_goal = [], None, None
            self._bump('path')

    def show_goal_status(self, text: str) -> None:
        """Set the trajectory status line's text as it is ('' = no goal yet)."""
        if text != self.goal_status:
            self.goal_status = text
            self._bump('status')

    def show_ik_target(self, target) -> None:
        """Set the IK target to (xyz, quat_xyzw), or None for none."""
        if target != self.ik_target:
            self.ik_target = None if target is None else (
                tuple(float(v) for v in target[0]), tuple(float(v) for v in target[1]))
            self._bump('ik')

    def set_ik_target(self, xyz: Sequence[float], quat_xyzw: Sequence[float]) -> None:
        """Set the last ik/request's target pose (quat all zero = orientation free)."""
        self.ik_target = (tuple(float(v) for v in xyz), tuple(float(v) for v in quat_xyzw))
        self._bump('ik')

    def set_error(self, text: str) -> None:
        """Set the last error, in words."""
        if text != self.last_error:
            self.last_error = str(text)
            self._bump('status')

    def set_note(self, text: str) -> None:
        """Set a short line about the viewer's own last action (e.g. 'torque off: done')."""
        if text != self.note:
            self.note = str(text)
            self._bump('status')

    def status_lines(self) -> List[str]:
        """
        Return the status panel's lines (the joint_states time first).

        'state t = 12.35 s at 10:34:00.712': seconds since the first joint_states this page
        saw, and the stamp as clock time (or simulated time). Goals are numbered in the order
        they were seen (their ROS id is their stamp).
        """
        if self.first_stamp is None:
            lines = ['state: no joint_states yet']
        else:
            lines = [f'state t = {self.stamp - self.first_stamp:.2f} s at '
                     f'{clock_text(self.stamp)}']
        if self.robot_error:
            lines.append(f'robot: {self.robot_error}')
        lines.append(f'trajectory: {self.goal_status or "no goal yet"}')
        lines.append(f'world: {len(self.bodies)} bodies')
        lines.append(f'holding: {self.held or "nothing"}')
        lines.append(f'last error: {self.last_error or "none"}')
        if self.note:
            lines.append(f'viewer: {self.note}')
        return lines
