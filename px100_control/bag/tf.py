"""
The /tf tree of an arm from its joint states, through its URDF, as tf2_msgs/msg/TFMessage bytes.

:class:`TfTree` parses a URDF (yourdfpy, no meshes) and returns, for joint positions by name,
one transform per URDF joint (parent link -> child link: origin times the joint motion; mimic
joints follow their master; joints without a value sit at 0), split for a live publisher into
the fixed joints (``/tf_static``) and the movable ones that have a value (``/tf``). Frame names
are the URDF link names with ``frame_prefix`` in front (``'px100/'`` for an unprefixed URDF;
``''`` when the URDF's links already carry the robot namespace, as the published
robot_description does: :func:`description_tree` decides). The recorder writes its TFMessage
as CDR bytes (``wire.cdr.tf_message``, tf2_msgs need not be installed); the live
robot_state_publisher (``ros.state_publisher_node``) publishes the same entries.
Units: m, rad; stamps in integer ns.
"""
from dataclasses import dataclass
import math
from typing import Dict, List, Mapping, Optional, Tuple
import xml.etree.ElementTree as ET

import numpy as np
from px100_control.errors import Px100Error, RobotModelError
from px100_control.kinematics.rotations import matrix_to_quaternion
from px100_control.models.urdf_tree import load_urdf_tree
from px100_control.wire.cdr import tf_message

TF_TYPE = 'tf2_msgs/msg/TFMessage'


@dataclass(frozen=True)
class _Joint:
    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    mimic: Optional[Tuple[str, float, float]]


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    c, s = np.cos(angle), np.sin(angle)
    C = 1.0 - c
    return np.array([[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
                     [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
                     [z * x * C - y * s, z * y * C + x * s, c + z * z * C]])


class TfTree:
    """
    The kinematic tree of a URDF: joint transforms and link poses from joint positions.

    :param urdf_xml: URDF text
    :param frame_prefix: prepended to every link name to form the tf frame names
    :raises RobotModelError: the URDF cannot be parsed or is not a tree
    """

    def __init__(self, urdf_xml: str, frame_prefix: str = ''):
        urdf = load_urdf_tree(urdf_xml)
        self.frame_prefix = frame_prefix
        joints = []
        for j in urdf.robot.joints:
            axis = np.array(j.axis if j.axis is not None else (1.0, 0.0, 0.0), dtype=float)
            norm = float(np.linalg.norm(axis))
            axis = axis / norm if norm > 0 else np.array([1.0, 0.0, 0.0])
            origin = np.eye(4) if j.origin is None else np.array(j.origin, dtype=float)
            mimic = None
            if j.mimic is not None:
                mimic = (j.mimic.joint, float(j.mimic.multiplier if j.mimic.multiplier
                                              is not None else 1.0),
                         float(j.mimic.offset or 0.0))
            joints.append(_Joint(j.name, j.type, j.parent, j.child, origin, axis, mimic))
        children = {j.child for j in joints}
        roots = sorted({j.parent for j in joints} - children)
        if joints and len(roots) != 1:
            raise RobotModelError(f'URDF is not a tree with one root link (roots: {roots})')
        self.root = roots[0] if roots else (urdf.robot.links[0].name if urdf.robot.links else '')
        # order joints root-first so that link poses can be chained in one pass
        by_parent: Dict[str, List[_Joint]] = {}
        for j in joints:
            by_parent.setdefault(j.parent, []).append(j)
        ordered, stack = [], [self.root]
        while stack:
            link = stack.pop()
            for j in by_parent.get(link, ()):
                ordered.append(j)
                stack.append(j.child)
        self.joints: List[_Joint] = ordered
        self.links: List[str] = [self.root] + [j.child for j in ordered]
        self.movable = [j.name for j in ordered if j.kind != 'fixed']
        self._entries = []
        for j in ordered:
            q0 = tuple(float(v) for v in matrix_to_quaternion(j.origin[:3, :3]))
            t0 = tuple(float(v) for v in j.origin[:3, 3])
            self._entries.append((j, self.frame(j.parent), self.frame(j.child), t0, q0,
                                  j.origin[:3, :3].copy()))

    def frame(self, link: str) -> str:
        """Return the tf frame name of a link."""
        return self.frame_prefix + link

    def joint_values(self, positions: Mapping[str, float], missing: Optional[float] = 0.0
                     ) -> Dict[str, Optional[float]]:
        """
        Return the value of every movable joint [rad or m] (mimics resolved).

        A joint is looked up by its URDF name, then by the name without a namespace prefix; a
        joint without a finite value (nor a master with one) gets ``missing``.
        """
        def lookup(name):
            if name in positions:
                v = float(positions[name])
            else:
                short = name.rsplit('/', 1)[-1]
                v = float(positions[short]) if short in positions else None
            return v if v is None or math.isfinite(v) else None

        values = {}
        for j in self.joints:
            if j.kind == 'fixed':
                continue
            v = lookup(j.name)
            if v is None and j.mimic is not None:
                master = lookup(j.mimic[0])
                if master is None:
                    master = values.get(j.mimic[0])
                if master is not None:
                    v = j.mimic[1] * master + j.mimic[2]
            values[j.name] = missing if v is None else v
        return values

    def joint_transforms(self, positions: Mapping[str, float]
                         ) -> List[Tuple[str, str, np.ndarray]]:
        """Return [(parent frame, child frame, (4, 4) T_parent_child)] for every URDF joint."""
        values = self.joint_values(positions)
        out = []
        for j in self.joints:
            T = j.origin.copy()
            if j.kind in ('revolute', 'continuous'):
                M = np.eye(4)
                M[:3, :3] = _rotation(j.axis, values[j.name])
                T = T @ M
            elif j.kind == 'prismatic':
                M = np.eye(4)
                M[:3, 3] = j.axis * values[j.name]
                T = T @ M
            out.append((self.frame(j.parent), self.frame(j.child), T))
        return out

    def tf_entries(self, positions: Mapping[str, float]) -> List[tuple]:
        """
        Return [(parent frame, child frame, (x, y, z), (qx, qy, qz, qw))] for every URDF joint.

        The fast path of :meth:`joint_transforms` for /tf (plain floats, quaternions composed
        directly).
        """
        values = self.joint_values(positions)
        return [self._entry(e, values.get(e[0].name, 0.0)) for e in self._entries]

    def static_entries(self) -> List[tuple]:
        """Return the :meth:`tf_entries` of the fixed joints (``/tf_static``)."""
        return [self._entry(e, 0.0) for e in self._entries if e[0].kind == 'fixed']

    def moving_entries(self, positions: Mapping[str, float]) -> List[tuple]:
        """
        Return the :meth:`tf_entries` of the movable joints that have a finite value.

        As robot_state_publisher: a joint absent from ``positions`` (and a mimic joint whose
        master is absent) gets no transform, rather than one at 0.
        """
        values = self.joint_values(positions, missing=None)
        return [self._entry(e, values[e[0].name]) for e in self._entries
                if values.get(e[0].name) is not None]

    @staticmethod
    def _entry(entry, value: float) -> tuple:
        """Return the /tf entry of one joint at ``value`` [rad or m]."""
        j, parent, child, t0, q0, R0 = entry
        if j.kind in ('revolute', 'continuous'):
            half = 0.5 * value
            s = math.sin(half)
            return parent, child, t0, _qmul(q0, (j.axis[0] * s, j.axis[1] * s, j.axis[2] * s,
                                                 math.cos(half)))
        if j.kind == 'prismatic':
            d = R0 @ (j.axis * value)
            return parent, child, (t0[0] + d[0], t0[1] + d[1], t0[2] + d[2]), q0
        return parent, child, t0, q0

    def link_poses(self, positions: Mapping[str, float]) -> Dict[str, np.ndarray]:
        """Return {link name: (4, 4) pose in the root link frame}."""
        poses = {self.root: np.eye(4)}
        for (_, _, T), j in zip(self.joint_transforms(positions), self.joints):
            poses[j.child] = poses[j.parent] @ T
        return poses

    def edges(self) -> List[Tuple[str, str]]:
        """Return [(parent link, child link)] of every joint, root first."""
        return [(j.parent, j.child) for j in self.joints]


def _qmul(a, b):
    """Return the Hamilton product a * b of quaternions (x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def description_tree(urdf_xml: str, robot_name: str) -> TfTree:
    """
    Return the TfTree of a published robot_description, its frames ``<robot_name>/<link>``.

    Links already named ``<robot_name>/...`` (as sim_driver publishes them) are kept; an
    unprefixed URDF gets the prefix.

    :raises RobotModelError: not a URDF, not a tree, or no movable joint; the reason in one line
    """
    try:
        root = ET.fromstring(urdf_xml)
    except (ET.ParseError, TypeError) as exc:
        raise RobotModelError(f'not valid XML ({" ".join(str(exc).split())})') from None
    if root.tag != 'robot':
        raise RobotModelError(f'the root element is <{root.tag}>, not <robot>')
    try:
        tree = TfTree(urdf_xml, '')
        if not tree.movable:
            raise RobotModelError('it has no movable joint')
        if robot_name and not tree.root.startswith(robot_name + '/'):
            tree = TfTree(urdf_xml, robot_name + '/')
    except (Px100Error, ValueError, TypeError, AttributeError) as exc:
        raise RobotModelError(' '.join(str(exc).split()) or type(exc).__name__) from None
    return tree


def encode_tf_message(transforms: List[tuple], stamp_ns: int) -> bytes:
    """
    Return the CDR bytes (little endian, with encapsulation header) of a tf2_msgs/TFMessage.

    :param transforms: [(parent frame, child frame, (4, 4) T)] or the
        [(parent, child, (x, y, z), (qx, qy, qz, qw))] of :meth:`TfTree.tf_entries`
    :param stamp_ns: header stamp of every transform [ns since the epoch]
    """
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    entries = []
    for entry in transforms:
        if len(entry) == 3:
            parent, child, T = entry
            T = np.asarray(T, dtype=float)
            entry = (parent, child, (T[0, 3], T[1, 3], T[2, 3]), matrix_to_quaternion(T[:3, :3]))
        entries.append(entry)
    return tf_message(entries, sec, nanosec)
