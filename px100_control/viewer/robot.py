"""
The robot of a URDF text as the viewer needs it: arm joints, limits, forward kinematics.

Whatever robot the ``robot_description`` topic carries (any registered robot, any namespace):
the arm joints are the actuated joints on the chain from the root link to the end-effector link,
in chain order; their limits come from the URDF. Forward kinematics is a product of 4x4
matrices (numpy, no scene graph), cheap enough for every page update. Frames: poses are in the
URDF's root link (the scene root); units m, rad.
"""
from dataclasses import dataclass
import io
import math
from typing import Dict, Optional, Sequence, Tuple

import numpy as np
from px100_control.kinematics.rotations import matrix_to_quaternion

#: end-effector link names tried in order (suffix match after the robot-name prefix)
EE_LINKS = ('ee_gripper_link', 'ee_arm_link', 'ee_link', 'tool0')
_MOVING = ('revolute', 'continuous', 'prismatic')


@dataclass(frozen=True)
class UrdfJoint:
    """
    One non-fixed URDF joint.

    :param origin: (4, 4) parent link -> joint frame at q = 0
    :param axis: unit axis in the joint frame; mimic: (master joint, multiplier, offset) or None
    """

    name: str
    kind: str
    origin: np.ndarray
    axis: np.ndarray
    mimic: Optional[Tuple[str, float, float]]


@dataclass(frozen=True)
class ArmJoints:
    """
    The arm joints a page's sliders and goals use, with their limits.

    Same attribute names as :class:`~px100_control.models.robot_model.RobotModel`'s, so the
    goal of a control (:func:`px100_control.viewer.controls.goal_move`) takes either.
    :param lower/upper: position limits [rad or m]; velocity_limits [rad/s or m/s]
    """

    joint_names: Tuple[str, ...]
    lower: Tuple[float, ...]
    upper: Tuple[float, ...]
    velocity_limits: Tuple[float, ...]

    def joint_index(self, name: str) -> int:
        """Return the index of a joint in joint_names (ValueError if absent)."""
        return self.joint_names.index(name)


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return np.array([[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                     [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                     [t * x * z - s * y, t * y * z + s * x, t * z * z + c]])


def _quat_wxyz(rot: np.ndarray) -> Tuple[float, float, float, float]:
    """Return the unit quaternion (w, x, y, z) of a 3x3 rotation matrix (viser's order)."""
    x, y, z, w = matrix_to_quaternion(rot)
    return w, x, y, z


class UrdfRobot:
    """
    A URDF text's joints, arm and forward kinematics.

    :param urdf_xml: the robot description (links may carry a robot-name prefix)
    :raises ValueError: not a loadable URDF, or one without a link
    """

    def __init__(self, urdf_xml: str):
        import yourdfpy  # optional: with trimesh ~0.5 s to import, loaded with a URDF
        try:
            urdf = yourdfpy.URDF.load(io.BytesIO(urdf_xml.encode('utf-8')),
                                      build_scene_graph=False, load_meshes=False,
                                      load_collision_meshes=False)
        except Exception as exc:  # noqa: B902 - yourdfpy/lxml raise many kinds
            raise ValueError(f'robot_description is not a usable URDF: {exc}') from None
        joints = list(urdf.robot.joints)
        children = {j.child for j in joints}
        roots = [lk.name for lk in urdf.robot.links if lk.name not in children]
        if not roots:
            raise ValueError('robot_description is not a usable URDF: it has no root link')
        self.base = roots[0]
        links = [lk.name for lk in urdf.robot.links]
        self.ee = next((lk for suffix in EE_LINKS for lk in links
                        if lk == suffix or lk.endswith('/' + suffix)), links[-1])
        self.joints: Dict[str, UrdfJoint] = {}
        for j in joints:
            if j.type in _MOVING:
                axis = np.array(j.axis if j.axis is not None else (1.0, 0.0, 0.0), float)
                mimic = (j.mimic.joint, float(j.mimic.multiplier or 1.0),
                         float(j.mimic.offset or 0.0)) if j.mimic is not None else None
                self.joints[j.name] = UrdfJoint(
                    j.name, j.type, np.eye(4) if j.origin is None else np.array(j.origin, float),
                    axis / (np.linalg.norm(axis) or 1.0), mimic)
        by_child = {j.child: j for j in joints}
        chain, link = [], self.ee
        while link in by_child and link != self.base:
            chain.append(by_child[link])
            link = by_child[link].parent
        self.chain = [(j.name, np.eye(4) if j.origin is None else np.array(j.origin, float))
                      for j in reversed(chain)]
        #: actuated joints (not mimic), the names joint_states carries
        self.actuated = {n for n, j in self.joints.items() if j.mimic is None}
        self.arm = self._arm([j for j in reversed(chain)
                              if j.name in self.joints and j.name in self.actuated])

    @staticmethod
    def _arm(chain) -> ArmJoints:
        lower, upper, vel = [], [], []
        for j in chain:
            lim = j.limit
            bounded = j.type != 'continuous' and lim is not None and lim.lower is not None \
                and lim.upper is not None
            lower.append(float(lim.lower) if bounded else -math.pi)
            upper.append(float(lim.upper) if bounded else math.pi)
            vel.append(float(lim.velocity) if lim is not None and lim.velocity else math.pi)
        return ArmJoints(tuple(j.name for j in chain), tuple(lower), tuple(upper), tuple(vel))

    def value(self, name: str, q: Dict[str, float]) -> Optional[float]:
        """Return joint name's position in q (a mimic joint follows its master), or None."""
        joint = self.joints[name]
        if joint.mimic is None:
            return q.get(name)
        master = q.get(joint.mimic[0])
        return None if master is None else master * joint.mimic[1] + joint.mimic[2]

    def motion(self, name: str, value: float) -> np.ndarray:
        """Return the (4, 4) parent link -> child link transform of a joint at value."""
        joint = self.joints[name]
        move = np.eye(4)
        if joint.kind == 'prismatic':
            move[:3, 3] = joint.axis * value
        else:
            move[:3, :3] = _rotation(joint.axis, value)
        return joint.origin @ move

    def local_pose(self, name: str, value: float):
        """Return a joint's child link pose in its parent link: (xyz [m], wxyz)."""
        T = self.motion(name, value)
        return tuple(float(v) for v in T[:3, 3]), _quat_wxyz(T[:3, :3])

    def ee_transform(self, q: Dict[str, float]) -> np.ndarray:
        """Return the (4, 4) end-effector pose in the root link (joints missing from q: 0)."""
        T = np.eye(4)
        for name, origin in self.chain:
            if name in self.joints:
                value = self.value(name, q)
                T = T @ self.motion(name, 0.0 if value is None else float(value))
            else:
                T = T @ origin
        return T

    def ee_pose(self, q: Dict[str, float]):
        """Return the end effector's (xyz [m], quat_xyzw) in the root link at joints q."""
        T = self.ee_transform(q)
        return tuple(float(v) for v in T[:3, 3]), matrix_to_quaternion(T[:3, :3])


def clip_pose(arm: ArmJoints, values: Sequence[float]) -> Tuple[float, ...]:
    """Return values (one per arm joint) clipped into the arm's limits."""
    return tuple(min(max(float(v), lo), hi) for v, lo, hi in zip(values, arm.lower, arm.upper))
