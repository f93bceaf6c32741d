"""
The MuJoCo model of a robot and its scene, built in code with ``mujoco.MjSpec``.

One source of truth: the robot's URDF (``RobotModel.urdf_xml``: the file of a URDF robot or
the URDF generated for a table robot) is imported by MuJoCo with
``<compiler discardvisual="false" fusestatic="false"/>`` (visuals and link names kept). On top
of it :func:`build_spec` adds, generated from the URDF and never edited per robot:

- collision geometry: every visual primitive of a moving link (box, cylinder, sphere) gets a
  collision twin (group 3); the finger links get no twin but a finger PAD each: a box on the
  finger face that looks at the other finger, standing ``PAD_PROUD`` [m] proud of it (the
  PX100 URDF faces cannot close below a 30 mm gap; with 4 mm pads the gap closes to 22 mm and
  opens to 66 mm), ``condim`` 4 (sliding + torsional friction);
- the gripper: the horn joint (URDF ``gripper``) is welded; the left finger slide is the
  gripper's degree of freedom (the horn angle follows from the linkage, see
  :class:`~px100_control.control.gripper.GripperLinkage`) and the URDF ``<mimic>`` (a soft
  equality on import) is made stiff;
- placeholder inertias (a radius of gyration above 0.5 m, e.g. the Interbotix 1 g dummy links
  with 0.001 kg*m^2) become point masses, as the hand-written dynamics did;
- contact physics measured on this machine (MuJoCo 4.0, PX100 URDF): elliptic friction cones,
  ``impratio`` 10, friction 1, contact and joint-limit ``solref`` time constant 0.002 s;
- sleeping enabled: a body at rest (an object on the table, the arm with torque off) sleeps
  until something touches it, pushes it or moves it, so idle objects cost nothing per step;
- the scene (:mod:`.scene`): the table and fixtures as static bodies, objects as free bodies.

Collision filter (contype/conaffinity bits): robot geoms 1/0 (never collide with each other),
static scene geoms 2/1, objects 2/3 (collide with the robot, the statics and each other).
World frame = the robot's base frame (the URDF root link sits at the origin). Units: SI.
"""
from dataclasses import dataclass
import math
import re
from typing import Dict, Optional, Tuple

import mujoco
import numpy as np
from px100_control.errors import RobotModelError
from px100_control.sim.scene import rpy_to_quaternion_xyzw

#: finger pads stand this far proud of the URDF finger faces [m]
PAD_PROUD = 0.004
#: pad overlap into the finger body [m] (so pad and finger are one solid)
PAD_EMBED = 0.001
#: contact and joint-limit constraint time constant [s] and damping ratio
STIFF_SOLREF = (0.002, 1.0)
#: constraint impedance of limits and the finger mimic (stiff: 0.99 .. 0.999)
STIFF_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
#: sliding, torsional, rolling friction of pads and objects
CONTACT_FRICTION = (1.0, 0.005, 0.0001)
#: a placeholder inertia has a radius of gyration above this [m] (replaced by a point mass)
MAX_GYRATION_RADIUS = 0.5
GRAVITY = 9.81
ROBOT_CONTYPE, ROBOT_CONAFFINITY = 1, 0
STATIC_CONTYPE, STATIC_CONAFFINITY = 2, 1
OBJECT_CONTYPE, OBJECT_CONAFFINITY = 2, 3
COLLISION_GROUP = 3
SCENE_PREFIX = 'scene/'


@dataclass(frozen=True)
class BuiltModel:
    """
    A compiled MuJoCo model and where the robot's parts are in it.

    :param arm_qpos/arm_dof: qpos / dof address of each arm joint (model.joint_names order)
    :param finger_qpos/finger_dof: left and right finger slide addresses (None: no gripper)
    :param pad_geoms: geom ids of the left and right finger pads
    :param bodies: {scene body name: MuJoCo body id}; object_qpos: {object: qpos address}
    """

    model: 'mujoco.MjModel'
    arm_qpos: Tuple[int, ...]
    arm_dof: Tuple[int, ...]
    finger_qpos: Optional[Tuple[int, int]]
    finger_dof: Optional[Tuple[int, int]]
    pad_geoms: Tuple[int, ...]
    ee_body: int
    bodies: Dict[str, int]
    object_qpos: Dict[str, int]
    object_dof: Dict[str, int]
    notes: Tuple[str, ...]


def _mujoco_urdf(urdf_xml: str) -> str:
    """Return the URDF text with the MuJoCo compiler options that keep visuals and links."""
    tag = '<mujoco><compiler discardvisual="false" fusestatic="false"/></mujoco>'
    match = re.search(r'<robot\b[^>]*>', urdf_xml)
    if match is None:
        raise RobotModelError('the robot description is not a URDF (no <robot> element)')
    return urdf_xml[:match.end()] + tag + urdf_xml[match.end():]


def _fix_placeholder_inertias(spec) -> list:
    notes = []
    for body in spec.bodies:
        if body.name == 'world' or body.mass <= 0.0:
            continue
        full = np.array(body.fullinertia, float)
        inertia = full[:3] if body.explicitinertial and np.all(np.isfinite(full)) \
            else np.array(body.inertia, float)
        if math.sqrt(max(float(inertia.sum()), 0.0) / (2.0 * body.mass)) > MAX_GYRATION_RADIUS:
            notes.append(f"link '{body.name}': placeholder inertia {inertia.tolist()} on "
                         f'{body.mass} kg replaced by a point mass')
            body.fullinertia = [math.nan, 0.0, 0.0, 0.0, 0.0, 0.0]
            body.inertia = [0.0, 0.0, 0.0]
    return notes


def _finger_pad(body, outward: np.ndarray, name: str):
    """Add the pad on the inner face of a finger's largest visual box; return the geom."""
    boxes = [g for g in body.geoms if g.type == mujoco.mjtGeom.mjGEOM_BOX]
    if not boxes:
        return None
    box = max(boxes, key=lambda g: float(np.prod(g.size[:3])))
    q = np.array(box.quat, float)
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, q / np.linalg.norm(q))
    R = R.reshape(3, 3)
    half = np.array(box.size[:3], float)
    local_out = R.T @ outward                 # outward direction in the box's axes
    k = int(np.argmax(np.abs(local_out)))
    sign = 1.0 if local_out[k] > 0 else -1.0
    face = np.array(box.pos, float) - R[:, k] * sign * half[k]   # inner face centre
    thickness = PAD_PROUD + PAD_EMBED
    centre = face - R[:, k] * sign * (0.5 * thickness - PAD_EMBED)
    size = half.copy()
    size[k] = 0.5 * thickness
    pad = body.add_geom()
    pad.name = name
    pad.type = mujoco.mjtGeom.mjGEOM_BOX
    pad.size = size
    pad.pos = centre
    pad.quat = box.quat
    pad.rgba = [0.1, 0.1, 0.1, 1.0]
    return pad


def _contact_params(geom, condim: int = 4, friction=CONTACT_FRICTION) -> None:
    geom.condim = condim
    geom.friction = list(friction)
    geom.solref = list(STIFF_SOLREF)


def build_spec(robot, scene=None, timestep: float = 0.001):
    """
    Return (spec, notes): the MjSpec of a robot (RobotModel) and an optional Scene.

    :param timestep: physics step [s] (the control period)
    :raises RobotModelError: the robot has no URDF or MuJoCo cannot import it
    """
    if not robot.urdf_xml:
        raise RobotModelError(f"robot '{robot.name}' has no URDF to build a MuJoCo model from")
    try:
        spec = mujoco.MjSpec.from_string(_mujoco_urdf(robot.urdf_xml))
    except ValueError as exc:
        raise RobotModelError(f"MuJoCo cannot import the URDF of '{robot.name}': {exc}") from exc
    spec.modelname = robot.name
    opt = spec.option
    opt.timestep = float(timestep)
    opt.gravity = [0.0, 0.0, -GRAVITY]
    opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    opt.impratio = 10.0
    opt.integrator = mujoco.mjtIntegrator.mjINT_EULER      # implicit joint damping
    # bodies at rest sleep (objects on the table cost nothing until touched); a tree wakes on
    # contact with an awake one, on applied forces (the servos' torques) and on a written qpos
    opt.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    notes = _fix_placeholder_inertias(spec)
    gripper = robot.gripper
    finger_names = tuple(gripper.fingers) if gripper is not None else ()
    # joint limits stiff; the horn joint welded (the fingers carry the gripper's motion)
    for joint in list(spec.joints):
        joint.solref_limit = list(STIFF_SOLREF)
        joint.solimp_limit = list(STIFF_SOLIMP)
        joint.solref_friction = list(STIFF_SOLREF)     # Coulomb friction close to stiction
        joint.solimp_friction = list(STIFF_SOLIMP)
        if gripper is not None and joint.name == gripper.joint:
            spec.delete(joint)
    for eq in spec.equalities:
        eq.solref = list(STIFF_SOLREF)
        eq.solimp = list(STIFF_SOLIMP)
    # collision twins of the visual primitives (not on the fingers: they get pads)
    finger_bodies = {}
    for joint in spec.joints:
        if joint.name in finger_names:
            finger_bodies[joint.name] = joint
    finger_body_names = {j.parent.name for j in finger_bodies.values()}
    shapes = (mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_CYLINDER,
              mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_CAPSULE)
    for body in list(spec.bodies):
        if body.name == 'world' or body.name in finger_body_names:
            continue
        for g in list(body.geoms):
            if g.type not in shapes or g.contype != 0:
                continue
            twin = body.add_geom()
            twin.type = g.type
            twin.size = g.size
            twin.pos = g.pos
            twin.quat = g.quat
            twin.group = COLLISION_GROUP
            twin.rgba = [0.5, 0.5, 0.5, 0.0]
            twin.contype, twin.conaffinity = ROBOT_CONTYPE, ROBOT_CONAFFINITY
            twin.mass = 0.0
            twin.density = 0.0
            _contact_params(twin, condim=3)
    for i, name in enumerate(finger_names[:2]):
        joint = finger_bodies.get(name)
        if joint is None:
            continue
        axis = np.array(joint.axis, float)
        axis /= np.linalg.norm(axis)
        lo, hi = joint.range
        outward = axis if (lo + hi) >= 0.0 else -axis     # direction that opens the finger
        pad = _finger_pad(joint.parent, outward, f'{name}_pad')
        if pad is not None:
            pad.group = COLLISION_GROUP
            pad.contype, pad.conaffinity = ROBOT_CONTYPE, ROBOT_CONAFFINITY
            pad.mass = 0.0
            pad.density = 0.0
            _contact_params(pad)
    if scene is not None:
        _add_scene(spec, scene)
    return spec, notes


def _add_scene(spec, scene) -> None:
    kinds = {'box': mujoco.mjtGeom.mjGEOM_BOX, 'cylinder': mujoco.mjtGeom.mjGEOM_CYLINDER,
             'sphere': mujoco.mjtGeom.mjGEOM_SPHERE}
    for b in scene.bodies:
        body = spec.worldbody.add_body()
        body.name = SCENE_PREFIX + b.name
        body.pos = list(b.position)
        x, y, z, w = rpy_to_quaternion_xyzw(b.rpy)
        body.quat = [w, x, y, z]
        geom = body.add_geom()
        geom.name = SCENE_PREFIX + b.name
        geom.type = kinds[b.shape]
        if b.shape == 'box':
            geom.size = [0.5 * s for s in b.size]
        elif b.shape == 'cylinder':
            geom.size = [b.size[0], 0.5 * b.size[1], 0.0]
        else:
            geom.size = [b.size[0], 0.0, 0.0]
        geom.rgba = list(b.rgba)
        _contact_params(geom, 4, (b.friction, CONTACT_FRICTION[1], CONTACT_FRICTION[2]))
        if b.kind == 'object':
            body.add_freejoint().name = SCENE_PREFIX + b.name
            geom.mass = b.mass
            geom.contype, geom.conaffinity = OBJECT_CONTYPE, OBJECT_CONAFFINITY
        else:
            geom.contype, geom.conaffinity = STATIC_CONTYPE, STATIC_CONAFFINITY


def build_model(robot, scene=None, timestep: float = 0.001) -> BuiltModel:
    """
    Return the compiled BuiltModel of a robot (RobotModel) and an optional Scene.

    :raises RobotModelError: MuJoCo cannot build it, or an arm joint is missing
    """
    spec, notes = build_spec(robot, scene, timestep)
    try:
        model = spec.compile()
    except ValueError as exc:
        raise RobotModelError(f"MuJoCo cannot compile the model of '{robot.name}': {exc}") \
            from exc

    def joint(name):
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if jid < 0:
            raise RobotModelError(f"joint '{name}' of '{robot.name}' is not in its URDF")
        return jid

    arm = [joint(n) for n in robot.joint_names]
    finger_qpos = finger_dof = None
    pads = ()
    if robot.gripper is not None:
        fingers = [joint(n) for n in robot.gripper.fingers[:2]]
        finger_qpos = tuple(int(model.jnt_qposadr[j]) for j in fingers)
        finger_dof = tuple(int(model.jnt_dofadr[j]) for j in fingers)
        pads = tuple(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f'{n}_pad')
                     for n in robot.gripper.fingers[:2])
    ee = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, robot.ee_frame)
    bodies, qadr, dadr = {}, {}, {}
    if scene is not None:
        for b in scene.bodies:
            bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, SCENE_PREFIX + b.name)
            bodies[b.name] = bid
            if b.kind == 'object':
                jid = int(model.body_jntadr[bid])
                qadr[b.name] = int(model.jnt_qposadr[jid])
                dadr[b.name] = int(model.jnt_dofadr[jid])
    return BuiltModel(model=model, arm_qpos=tuple(int(model.jnt_qposadr[j]) for j in arm),
                      arm_dof=tuple(int(model.jnt_dofadr[j]) for j in arm),
                      finger_qpos=finger_qpos, finger_dof=finger_dof, pad_geoms=pads,
                      ee_body=ee, bodies=bodies, object_qpos=qadr, object_dof=dadr,
                      notes=tuple(notes))
