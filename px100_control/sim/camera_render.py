"""
Render a scene camera (:class:`~px100_control.perception.camera.CameraSpec`) with MuJoCo.

:func:`add_camera` puts the camera into a model spec before it is compiled (it changes no
physics); :class:`CameraRenderer` draws colour (uint8, H x W x 3) and depth (float32, H x W,
metres along the optical axis) of a model's current state offscreen. The OpenGL backend is
MuJoCo's: ``MUJOCO_GL=egl`` renders on the CPU without a display (software rasteriser) on a
machine without a GPU; ``osmesa`` works too where installed. Only visual geoms (groups 0-2)
are drawn, not the collision twins (group 3).
"""
import math
import os
import threading

import mujoco
import numpy as np
from px100_control.perception.camera import CameraSpec, checked
from px100_control.sim import mjcf


def mujoco_quaternion(spec: CameraSpec) -> np.ndarray:
    """Return the MuJoCo camera quaternion (w, x, y, z): MuJoCo looks along -z with y up."""
    optical = spec.optical_rotation()
    mj = np.column_stack([optical[:, 0], -optical[:, 1], -optical[:, 2]])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, mj.reshape(-1))
    return quat


def add_camera(model_spec, camera: CameraSpec) -> None:
    """Add ``camera`` to a MuJoCo MjSpec's world body and size the offscreen buffer for it."""
    checked(camera)
    model_spec.worldbody.add_camera(name=camera.name, pos=list(camera.position),
                                    quat=list(mujoco_quaternion(camera)),
                                    fovy=math.degrees(camera.fovy))
    if not model_spec.lights:
        # the room's light: a soft key light above the table (a scene without one renders dark)
        light = model_spec.worldbody.add_light(name='camera_room_light', pos=[0.2, 0.0, 1.5],
                                               dir=[0.0, 0.0, -1.0], castshadow=False)
        light.diffuse = [0.6, 0.6, 0.6]
        light.ambient = [0.3, 0.3, 0.3]
        light.specular = [0.1, 0.1, 0.1]
    glob = model_spec.visual.global_
    glob.offwidth = max(int(glob.offwidth), camera.width)
    glob.offheight = max(int(glob.offheight), camera.height)


class CameraRenderer:
    """
    Offscreen colour + depth renderer of one camera of a compiled model.

    One pass draws the scene; colour and depth are read from the same frame.
    """

    def __init__(self, model, camera: CameraSpec):
        self.camera = camera
        self.camera_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera.name)
        if self.camera_id < 0:
            raise ValueError(f"camera '{camera.name}' is not in the model (add_camera first)")
        glob = model.vis.global_
        if camera.width > glob.offwidth or camera.height > glob.offheight:
            raise ValueError(f'camera {camera.width} x {camera.height} px is larger than the '
                             f'offscreen buffer {glob.offwidth} x {glob.offheight} px '
                             '(add_camera sizes it)')
        self._model = model
        self._lock = threading.Lock()
        with self._lock:
            self._gl = mujoco.GLContext(camera.width, camera.height)
            self._gl.make_current()
            try:
                self._scene = mujoco.MjvScene(model, maxgeom=10000)
                self._context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
                mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
                self._context.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
            finally:
                _release_context()
        self._option = mujoco.MjvOption()          # visual groups 0-2, as MuJoCo's default
        self._view = mujoco.MjvCamera()
        self._view.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._view.fixedcamid = self.camera_id
        self._rect = mujoco.MjrRect(0, 0, camera.width, camera.height)
        self._rgb = np.empty((camera.height, camera.width, 3), dtype=np.uint8)
        self._z = np.empty((camera.height, camera.width), dtype=np.float32)
        # the depth buffer (reversed z, 0 at the far plane) to metres along the optical axis:
        # z_m = d / (z + c), the perspective matrix's terms in float32 as glFrustum makes them
        near = np.float32(model.vis.map.znear * model.stat.extent)
        far = np.float32(model.vis.map.zfar * model.stat.extent)
        self._c = np.float32(-0.5) * (-(far + near) / (far - near)) - np.float32(0.5)
        self._d = np.float32(-0.5) * (-(np.float32(2) * far * near) / (far - near))

    def render(self, data) -> tuple:
        """Return (colour uint8 H x W x 3, depth float32 H x W [m]) of ``data``'s state."""
        with self._lock:
            if self._context is None:
                raise RuntimeError('the camera renderer is closed')
            self._gl.make_current()
            try:
                mujoco.mjv_updateScene(self._model, data, self._option, None, self._view,
                                       mujoco.mjtCatBit.mjCAT_ALL, self._scene)
                mujoco.mjr_render(self._rect, self._scene, self._context)
                mujoco.mjr_readPixels(self._rgb, self._z, self._rect, self._context)
            finally:
                _release_context()
            # OpenGL's rows run bottom-up
            color = np.flipud(self._rgb).copy()
            depth = np.flipud(self._d / (self._z.astype(np.float64) + self._c))
        return color, depth.astype(np.float32)

    def close(self) -> None:
        """Free the OpenGL context (from any thread); closing twice is harmless."""
        with self._lock:
            if self._context is None:
                return
            self._gl.make_current()
            try:
                self._context.free()
            finally:
                _release_context()
            self._context = None
            self._gl.free()


def _release_context() -> None:
    """
    Leave no OpenGL context current on this thread.

    MuJoCo's Renderer keeps its context current on the thread that last drew, and an EGL
    context current on one thread cannot be made current on another (EGL_BAD_ACCESS): a
    multi-threaded executor renders and closes from different threads.
    """
    if os.environ.get('MUJOCO_GL', '').lower() != 'egl':
        return
    from OpenGL import EGL      # optional: only the EGL backend needs (and has) it
    display = EGL.eglGetCurrentDisplay()
    if display:
        EGL.eglMakeCurrent(display, EGL.EGL_NO_SURFACE, EGL.EGL_NO_SURFACE, EGL.EGL_NO_CONTEXT)


def posed_model(robot, scene, camera: CameraSpec, joints=None) -> tuple:
    """
    Return (model, data) of ``robot`` and ``scene`` with ``camera``, the arm at ``joints``.

    :param joints: arm joint positions [rad] in the robot's joint order (default: its sleep pose)
    """
    spec, _ = mjcf.build_spec(robot, scene)
    add_camera(spec, camera)
    model = spec.compile()
    data = mujoco.MjData(model)
    for name, q in zip(robot.joint_names, robot.sleep if joints is None else joints):
        joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        data.qpos[model.jnt_qposadr[joint]] = q
    mujoco.mj_forward(model, data)
    return model, data
