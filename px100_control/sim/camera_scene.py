"""
What a simulated camera sees: the robot, the world's bodies and the ArmTag, in a MuJoCo model.

The camera node's own model, apart from the physics: the robot from its URDF (the visual geoms
of :func:`px100_control.sim.mjcf.build_spec`; the node passes the ``robot_description`` it
receives), every body of ``world/markers`` as a mocap body
(moved each frame, never simulated), the ArmTag (:mod:`px100_control.perception.armtag`) as a
textured plate on its link, and the camera (:func:`~px100_control.sim.camera_render.add_camera`).
:meth:`CameraScene.set_state` poses it from joint positions [rad, m] and the bodies' poses (base
frame, quaternion x, y, z, w); :meth:`CameraScene.render` returns colour and depth. The model is
rebuilt (:func:`needs_rebuild`) when the set of bodies changes. World frame = the robot base.
"""
from dataclasses import dataclass, replace
from typing import Dict, Mapping, Optional, Sequence, Tuple

import mujoco
import numpy as np
from px100_control.perception import armtag
from px100_control.perception.camera import CameraSpec
from px100_control.sim import mjcf
from px100_control.sim.camera_render import add_camera, CameraRenderer

#: the tag plate's thickness [m] (its printed face is the ar_tag_link's z = 0 plane)
TAG_THICKNESS = 0.001
TAG_BODY = 'ar_tag_link'


@dataclass(frozen=True)
class Body:
    """One rendered body: shape 'box' | 'cylinder' | 'sphere', full extents [m], rgba 0..1."""

    name: str
    shape: str
    scale: Tuple[float, float, float]
    rgba: Tuple[float, float, float, float]


def _geom_size(shape: str, scale: Sequence[float]):
    if shape == 'box':
        return [0.5 * float(s) for s in scale]
    if shape == 'cylinder':
        return [0.5 * float(scale[0]), 0.5 * float(scale[2]), 0.0]
    return [0.5 * float(scale[0]), 0.0, 0.0]


def _add_bodies(spec, bodies: Sequence[Body]) -> None:
    kinds = {'box': mujoco.mjtGeom.mjGEOM_BOX, 'cylinder': mujoco.mjtGeom.mjGEOM_CYLINDER,
             'sphere': mujoco.mjtGeom.mjGEOM_SPHERE}
    for b in bodies:
        body = spec.worldbody.add_body(name=mjcf.SCENE_PREFIX + b.name, mocap=True)
        geom = body.add_geom(type=kinds[b.shape], size=_geom_size(b.shape, b.scale))
        geom.rgba = list(b.rgba)
        geom.contype = geom.conaffinity = 0


def _add_armtag(spec, tag_id: int, prefix: str) -> bool:
    """Add the tag plate on its parent link (if the robot has it); return True if added."""
    parent = spec.body(prefix + armtag.PARENT_LINK)
    if parent is None:
        return False
    image = np.repeat(armtag.tag_image(tag_id)[:, :, None], 3, axis=2)
    texture = spec.add_texture(name='armtag', type=mujoco.mjtTexture.mjTEXTURE_2D,
                               width=image.shape[1], height=image.shape[0], nchannel=3)
    texture.data = np.ascontiguousarray(image).tobytes()
    material = spec.add_material(name='armtag')
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = 'armtag'
    material.specular = 0.0
    material.shininess = 0.0
    body = parent.add_body(name=TAG_BODY, pos=list(armtag.OFFSET))
    half = 0.5 * armtag.TAG_SIZE * 10.0 / 8.0             # the white border is one cell wide
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[half, half, 0.5 * TAG_THICKNESS],
                  pos=[0.0, 0.0, -0.5 * TAG_THICKNESS], material='armtag',
                  contype=0, conaffinity=0)
    return True


class CameraScene:
    """
    A renderable model of the robot, the bodies and the ArmTag, and one camera.

    :param robot: the RobotModel (its URDF gives the geometry)
    :param camera: the CameraSpec (checked)
    :param bodies: the world's bodies (:class:`Body`)
    :param tag_id: the ArmTag id (None: no tag)
    :param urdf: a URDF to draw instead of the robot's own (e.g. its ``robot_description``,
        links named ``<prefix><link>``; joint names bare)
    :param prefix: the link name prefix of ``urdf`` (``'px100/'``)
    """

    def __init__(self, robot, camera: CameraSpec, bodies: Sequence[Body] = (),
                 tag_id: Optional[int] = armtag.TAG_ID, urdf: Optional[str] = None,
                 prefix: str = ''):
        self.urdf = urdf
        spec, _ = mjcf.build_spec(robot if urdf is None else replace(robot, urdf_xml=urdf))
        spec.option.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
        _add_bodies(spec, bodies)
        self.tag_id = tag_id
        self.has_tag = tag_id is not None and _add_armtag(spec, tag_id, prefix)
        add_camera(spec, camera)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.bodies = tuple(bodies)
        self.camera = camera
        m = self.model
        self._joint_qpos: Dict[str, int] = {}
        for j in range(m.njnt):
            if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                      int(mujoco.mjtJoint.mjJNT_SLIDE)):
                self._joint_qpos[mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)] = \
                    int(m.jnt_qposadr[j])
        self._mocap = {b.name: int(m.body_mocapid[mujoco.mj_name2id(
            m, mujoco.mjtObj.mjOBJ_BODY, mjcf.SCENE_PREFIX + b.name)]) for b in bodies}
        self._renderer = CameraRenderer(m, camera)
        mujoco.mj_kinematics(m, self.data)

    def set_state(self, joints: Mapping[str, float],
                  poses: Mapping[str, Tuple[Sequence[float], Sequence[float]]]) -> None:
        """Set joint positions {name: rad or m} and body poses {name: (xyz, xyzw)}."""
        qpos = self.data.qpos
        for name, value in joints.items():
            adr = self._joint_qpos.get(name)
            if adr is not None:
                qpos[adr] = value
        for name, (position, q) in poses.items():
            k = self._mocap.get(name)
            if k is not None:
                self.data.mocap_pos[k] = position
                self.data.mocap_quat[k] = (q[3], q[0], q[1], q[2])
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def render(self) -> Tuple[np.ndarray, np.ndarray]:
        """Return (colour uint8 H x W x 3, depth float32 H x W [m] along the optical axis)."""
        return self._renderer.render(self.data)

    def link_pose(self, link: str) -> np.ndarray:
        """Return the 4x4 pose of a link (MuJoCo body) in the base frame, at the last state."""
        bid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, link)
        if bid < 0:
            raise KeyError(f"no link '{link}' in the camera's model")
        T = np.eye(4)
        T[:3, :3] = self.data.xmat[bid].reshape(3, 3)
        T[:3, 3] = self.data.xpos[bid]
        return T

    def close(self) -> None:
        """Free the renderer's OpenGL context."""
        self._renderer.close()


def needs_rebuild(scene: Optional[CameraScene], camera: CameraSpec, bodies: Sequence[Body],
                  tag_id: Optional[int], urdf: Optional[str] = None) -> bool:
    """Return True when ``scene`` cannot show this URDF, ``bodies`` and tag through ``camera``."""
    return (scene is None or scene.camera != camera or scene.bodies != tuple(bodies)
            or scene.tag_id != tag_id or scene.urdf != urdf)
