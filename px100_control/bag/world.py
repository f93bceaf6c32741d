"""
The simulated world in messages and bags: marker fields, object /tf frames, object paths, verdicts.

Pure (no rclpy): the sim_driver turns :func:`world_markers` into a
``visualization_msgs/MarkerArray`` (``px100_control.ros.world_msgs``), the recorder turns the
markers it receives into ``/tf`` entries with :func:`object_tf_entries`, ``inspect`` and the demo
read object paths back with :func:`extract_object_paths` and judge a pick and place with
:func:`placement_verdict`.

Frames and units: every pose is in the robot base frame ``<robot_name>/base_link`` [m], with
quaternions (x, y, z, w); times [s] or [ns] as named. Marker ``scale`` is the body's full extent
along its own x, y, z axes [m] (box: its size; cylinder: diameter, diameter, height; sphere:
the diameter three times), as RViz and Foxglove draw CUBE / CYLINDER / SPHERE markers.
"""
from dataclasses import dataclass, field
import math
from typing import Dict, Iterable, List, Mapping, Optional, Sequence, Tuple

import numpy as np
from px100_control.errors import InvalidInputError

#: Marker ``ns`` of each body kind
MARKER_NS = {'object': 'objects', 'fixture': 'fixtures', 'table': 'table'}
#: visualization_msgs/Marker type constants of each shape (CUBE, SPHERE, CYLINDER)
MARKER_TYPE = {'box': 1, 'sphere': 2, 'cylinder': 3}
SHAPE_OF_TYPE = {v: k for k, v in MARKER_TYPE.items()}
MARKER_ARRAY_TYPE = 'visualization_msgs/msg/MarkerArray'
#: an object counts as picked when it rose this much [m] above its start
LIFT_MIN = 0.01
#: default placement tolerance [m] (distance of the object's position from its target)
PLACE_TOLERANCE = 0.01


@dataclass(frozen=True)
class WorldMarker:
    """
    One body of the world as a marker: what a visualization_msgs/Marker of it carries.

    ``ns`` 'objects' | 'fixtures' | 'table'; ``id`` stable per body; ``name`` (the marker's
    ``text``); ``shape`` 'box' | 'cylinder' | 'sphere'; ``scale`` full extents [m]; ``rgba``
    0..1; ``position`` [m] and ``orientation`` (x, y, z, w) in the frame ``frame_id``.
    """

    ns: str
    id: int  # noqa: A003 - the Marker field's name
    name: str
    shape: str
    scale: Tuple[float, float, float]
    rgba: Tuple[float, float, float, float]
    position: Tuple[float, float, float]
    orientation: Tuple[float, float, float, float]
    frame_id: str = ''


def marker_scale(shape: str, size: Sequence[float]) -> Tuple[float, float, float]:
    """
    Return the marker scale (full extents x, y, z [m]) of a body's shape and size.

    ``size``: box (x, y, z) full extents; cylinder (radius, height); sphere (radius,).
    :raises InvalidInputError: unknown shape or a size of the wrong length
    """
    s = [float(v) for v in np.atleast_1d(np.asarray(size, dtype=float))]
    if shape == 'box' and len(s) == 3:
        return (s[0], s[1], s[2])
    if shape == 'cylinder' and len(s) == 2:
        return (2 * s[0], 2 * s[0], s[1])
    if shape == 'sphere' and len(s) == 1:
        return (2 * s[0],) * 3
    raise InvalidInputError(f'shape {shape!r} with size {s}: expected box (x, y, z), '
                            'cylinder (radius, height) or sphere (radius,)')


def world_markers(objects: Iterable, poses: Mapping[str, tuple],
                  frame_id: str = '') -> List[WorldMarker]:
    """
    Return one WorldMarker per body, ids = the body's index in ``objects`` (stable per scene).

    :param objects: ObjectInfo-like items (name, kind, shape, size, rgba) as
        ``ArmSimulator.objects()`` returns them
    :param poses: name -> (position xyz [m], quaternion xyzw), as ``object_poses()``; a body
        without a pose (a static one the simulator does not report) gets its pose from the
        item's ``pose`` attribute if it has one, else the identity
    :param frame_id: the frame of the poses (``'<robot_name>/base_link'``)
    """
    out = []
    for index, info in enumerate(objects):
        pose = poses.get(info.name)
        if pose is None:
            pose = getattr(info, 'pose', None) or ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        position, quat = pose
        out.append(WorldMarker(
            ns=MARKER_NS.get(info.kind, str(info.kind)), id=index, name=str(info.name),
            shape=str(info.shape), scale=marker_scale(info.shape, info.size),
            rgba=tuple(float(c) for c in info.rgba),
            position=tuple(float(v) for v in position),
            orientation=tuple(float(v) for v in quat), frame_id=frame_id))
    return out


def object_frame(robot_name: str, name: str) -> str:
    """Return the tf frame of a movable object: ``'<robot_name>/objects/<name>'``."""
    ns = robot_name.strip('/')
    return f'{ns}/objects/{name}' if ns else f'objects/{name}'


def object_tf_entries(markers: Iterable[WorldMarker], robot_name: str,
                      base_frame: str = 'base_link') -> List[tuple]:
    """
    Return the /tf entries [(parent, child, (x, y, z), (qx, qy, qz, qw))] of the movable objects.

    Child frames are ``'<robot_name>/objects/<name>'``; the parent is the marker's frame
    (``'<robot_name>/base_link'`` when the marker has none). Fixtures and the table get no
    frame (they do not move; their markers place them).
    """
    ns = robot_name.strip('/')
    default_parent = f'{ns}/{base_frame}' if ns else base_frame
    return [(m.frame_id or default_parent, object_frame(robot_name, m.name),
             tuple(m.position), tuple(m.orientation))
            for m in markers if m.ns == MARKER_NS['object']]


# -- object paths --------------------------------------------------------------------------------
@dataclass
class ObjectPaths:
    """
    Paths of the world's bodies in a bag or a live run.

    ``paths[name] = (t [s] (N,), xyz [m] (N, 3))`` in the base frame; ``kinds[name]`` the marker
    ns; ``rgba[name]`` its last colour (4 floats 0..1); ``shapes[name] = (shape, scale)`` its
    marker shape and full extents [m]; ``held = (t [s], names)`` the held_object samples ('' when
    nothing is held).
    """

    paths: Dict[str, Tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    kinds: Dict[str, str] = field(default_factory=dict)
    rgba: Dict[str, Tuple[float, float, float, float]] = field(default_factory=dict)
    shapes: Dict[str, Tuple[str, Tuple[float, float, float]]] = field(default_factory=dict)
    held: Tuple[np.ndarray, List[str]] = field(
        default_factory=lambda: (np.zeros(0), []))

    def objects(self) -> List[str]:
        """Return the movable objects' names (ns 'objects'), sorted."""
        return sorted(n for n, k in self.kinds.items() if k == MARKER_NS['object'])


class PathBuilder:
    """Collect marker samples into :class:`ObjectPaths` (times relative to ``t0_ns``)."""

    def __init__(self, t0_ns: int = 0):
        self.t0_ns = int(t0_ns)
        self._t: Dict[str, list] = {}
        self._xyz: Dict[str, list] = {}
        self._kinds: Dict[str, str] = {}
        self._rgba: Dict[str, tuple] = {}
        self._shapes: Dict[str, tuple] = {}
        self._held_t: list = []
        self._held: List[str] = []

    def add_markers(self, t_ns: int, markers: Iterable[WorldMarker]) -> None:
        """Add one MarkerArray's bodies at time t_ns [ns]."""
        t = (int(t_ns) - self.t0_ns) * 1e-9
        for m in markers:
            self._kinds[m.name] = m.ns
            self._rgba[m.name] = tuple(float(c) for c in m.rgba)
            self._shapes[m.name] = (m.shape, tuple(float(v) for v in m.scale))
            self._t.setdefault(m.name, []).append(t)
            self._xyz.setdefault(m.name, []).append(m.position)

    def add_held(self, t_ns: int, name: str) -> None:
        """Add one held_object sample ('' = nothing held)."""
        self._held_t.append((int(t_ns) - self.t0_ns) * 1e-9)
        self._held.append(str(name))

    def result(self) -> ObjectPaths:
        """Return the collected paths."""
        return ObjectPaths(
            paths={n: (np.array(self._t[n]), np.array(self._xyz[n], dtype=float).reshape(-1, 3))
                   for n in self._t},
            kinds=dict(self._kinds), rgba=dict(self._rgba), shapes=dict(self._shapes),
            held=(np.array(self._held_t), list(self._held)))


def markers_from_decoded(msg) -> List[WorldMarker]:
    """
    Return the WorldMarkers of a decoded MarkerArray (any object with the message's fields).

    Works on rclpy messages and on the dynamic messages of mcap-ros2-support; markers whose
    action is not ADD/MODIFY (0) are left out.
    """
    out = []
    for m in msg.markers:
        if int(getattr(m, 'action', 0)) != 0:
            continue
        p, o, s, c = m.pose.position, m.pose.orientation, m.scale, m.color
        out.append(WorldMarker(
            ns=str(m.ns), id=int(m.id), name=str(m.text) or f'{m.ns}_{m.id}',
            shape=SHAPE_OF_TYPE.get(int(m.type), str(m.type)),
            scale=(float(s.x), float(s.y), float(s.z)),
            rgba=(float(c.r), float(c.g), float(c.b), float(c.a)),
            position=(float(p.x), float(p.y), float(p.z)),
            orientation=(float(o.x), float(o.y), float(o.z), float(o.w)),
            frame_id=str(m.header.frame_id)))
    return out


def extract_object_paths(reader, namespace: str, t0_ns: Optional[int] = None) -> ObjectPaths:
    """
    Return the object paths recorded in a bag (``<namespace>/world/markers`` and ``held_object``).

    :param reader: a :class:`px100_control.bag.reader.BagReader`
    :param namespace: the robot namespace, e.g. '/px100'
    :param t0_ns: time origin [ns] (default: the bag's first message)
    """
    ns = '/' + namespace.strip('/') if namespace.strip('/') else ''
    markers_topic, held_topic = f'{ns}/world/markers', f'{ns}/world/held_object'
    present = [t for t in (markers_topic, held_topic) if t in reader.topics]
    if t0_ns is None:
        summary = reader.summary()
        t0_ns = summary.start_ns
    builder = PathBuilder(t0_ns)
    for raw, msg in reader.iter_decoded(present):
        if raw.topic == markers_topic:
            builder.add_markers(raw.log_time_ns, markers_from_decoded(msg))
        else:
            builder.add_held(raw.log_time_ns, msg.data)
    return builder.result()


# -- held object as published -------------------------------------------------------------------
#: a grasp counts as lost once the contact test has not found it for this long [s]
HELD_GRACE = 0.2


class HeldFilter:
    """
    The held object as ``world/held_object`` reports it: picked when lifted, held until released.

    The simulator's contact test is instantaneous. A name is taken once both pads touch the
    object off its support (lifted). It stays held while both pads still touch it, on its
    support or not: the squeeze at a grasp can lift a cube a fraction of a millimetre and let
    it settle again before the arm lifts it (measured: 'blue_cylinder', '' 0.6 s later, the name
    again at the lift), and a placed object rests on the table before the fingers open. It is
    lost (``''``, or another lifted name) only after ``grace`` [s] without both pads on it:
    carrying a cylinder one pad can lose contact for a few steps (measured: 60 ms mid-carry).
    """

    def __init__(self, grace: float = HELD_GRACE):
        self.grace_ns = int(round(1e9 * float(grace)))
        self.held = ''
        self._lost_ns: Optional[int] = None

    def reset(self) -> None:
        """Forget the held object (a new scene or a reset)."""
        self.held, self._lost_ns = '', None

    def update(self, name: str, stamp_ns: int, gripped: Iterable[str] = ()) -> str:
        """
        Take the contact test's answer at stamp_ns [ns]; return the held object to report.

        :param name: the object both pads touch off its support ('' for none)
        :param gripped: every object both pads touch (on its support too)
        """
        name = str(name or '')
        if not self.held or name == self.held or self.held in gripped:
            if not self.held:
                self.held = name
            self._lost_ns = None
            return self.held
        if self._lost_ns is None or stamp_ns < self._lost_ns:
            self._lost_ns = int(stamp_ns)
        if stamp_ns - self._lost_ns >= self.grace_ns:
            self.held, self._lost_ns = name, None
        return self.held


# -- verdicts ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Placement:
    """
    The outcome of moving one object: where it ended and how far from its target.

    ``verdict``: 'placed' (final position within ``tolerance`` of the target), 'dropped' (it was
    picked, i.e. lifted by at least LIFT_MIN, but ended elsewhere) or 'not picked' (it never
    rose LIFT_MIN above its start). ``error`` = |final - target| [m], ``error_xy`` its
    horizontal part, ``lift`` the highest rise above the start [m].
    """

    name: str
    verdict: str
    final: Tuple[float, float, float]
    target: Tuple[float, float, float]
    error: float
    error_xy: float
    lift: float


def placement_verdict(name: str, start, final, target, heights: Optional[Iterable[float]] = None,
                      tolerance: float = PLACE_TOLERANCE) -> Placement:
    """
    Judge one object: placed / dropped / not picked.

    :param start: its position [m] before the run
    :param final: its position [m] after the run
    :param target: where it should have ended [m] (its position resting at the target)
    :param heights: its z [m] during the run (for the lift); default start and final only
    :param tolerance: largest distance [m] of final from target that counts as placed
    """
    start, final, target = (np.asarray(v, dtype=float).reshape(3) for v in (start, final, target))
    if not (np.all(np.isfinite(start)) and np.all(np.isfinite(final))
            and np.all(np.isfinite(target))):
        raise InvalidInputError(f'{name}: non-finite position (start {start}, final {final}, '
                                f'target {target})')
    zs = np.asarray(list(heights) if heights is not None else [], dtype=float)
    zs = np.concatenate([zs[np.isfinite(zs)], [start[2], final[2]]])
    lift = float(np.max(zs) - start[2])
    error = float(np.linalg.norm(final - target))
    error_xy = float(math.hypot(*(final[:2] - target[:2])))
    if error <= tolerance:
        verdict = 'placed'
    elif lift >= LIFT_MIN:
        verdict = 'dropped'
    else:
        verdict = 'not picked'
    return Placement(name, verdict, tuple(float(v) for v in final),
                     tuple(float(v) for v in target), error, error_xy, lift)


def format_placements(placements: Sequence[Placement]) -> str:
    """Return the demo's per-object table (positions and errors in mm)."""
    rows = [(p.name, '({:.1f}, {:.1f}, {:.1f})'.format(*(1000 * v for v in p.final)),
             '({:.1f}, {:.1f}, {:.1f})'.format(*(1000 * v for v in p.target)),
             f'{1000 * p.error:.1f}', p.verdict) for p in placements]
    head = ('object', 'ended at [mm] (x, y, z)', 'target [mm]', 'error [mm]', 'verdict')
    widths = [max(len(r[k]) for r in rows + [head]) for k in range(4)]
    return '\n'.join(f'{r[0]:<{widths[0]}}  {r[1]:<{widths[1]}}  {r[2]:<{widths[2]}}  '
                     f'{r[3]:>{widths[3]}}  {r[4]}' for r in [head] + rows)
