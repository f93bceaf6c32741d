"""
Generate a URDF from a RobotModel (for robots described by a DH, MDH or PoE table).

Geometry: joint i's frame sits on its axis (the point of the axis closest to the previous joint
frame's origin; a prismatic joint keeps the previous origin) and is parallel to the base frame
at q = 0, so every joint origin is a pure translation (rpy 0) and its ``axis`` is the screw
axis direction (omega, or v for a prismatic joint). A fixed joint to ``model.ee_frame`` carries
M. With T(q) = prod_i Tr(p_i - p_(i-1)) Rot(omega_i, q_i) . Tr(-p_n) M this is exactly the
product of exponentials of the model (tests check 1e-12 agreement).

Inertials are APPROXIMATE (the tables carry no mass data): each moving link is a slender rod
from its joint origin to the next one (or to the end effector) of ``rod_mass_per_m`` [kg/m]
(default 0.5) plus a motor of ``motor_mass`` [kg] (default 0.08, a small servo) at its distal end
(the actuator of the next joint, or the tool/gripper for the last link), a solid sphere of radius
2 cm; rod radius 1.5 cm for its axial inertia. A robot file may override both numbers in an
``inertial: {rod_mass_per_m, motor_mass}`` section. Visuals are primitives (a cylinder per link,
a sphere per joint) so that RViz/Foxglove can draw the arm. Models with a gripper get the
Interbotix-style gripper joints (continuous servo ``gripper`` and prismatic fingers, the right
one mimicking the left with multiplier -1) as branches off the end-effector frame.
"""
from typing import List
from xml.sax.saxutils import escape

import numpy as np

from px100_control.kinematics.rotations import matrix_to_euler_sxyz
from px100_control.models.robot_model import RobotModel

ROD_MASS_PER_M = 0.5
MOTOR_MASS = 0.08
_ROD_RADIUS = 0.015
_MOTOR_RADIUS = 0.02
_TINY_MASS = 0.001


def _f(x: float) -> str:
    """Format a float so that it parses back exactly."""
    return repr(float(x))


def _vec(v) -> str:
    return ' '.join(_f(x) for x in v)


def _closest_point_on_axis(omega: np.ndarray, v: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Return the point of the line {omega, v = -omega x p} closest to ref."""
    w = omega / np.linalg.norm(omega)
    p0 = np.cross(w, v) / float(omega @ omega)  # the point of the axis closest to the origin
    return p0 + w * float((ref - p0) @ w)


def joint_origins(model: RobotModel) -> np.ndarray:
    """Return (n, 3) joint frame origins [m] in the base frame at q = 0 (see module doc)."""
    pts = []
    ref = np.zeros(3)
    for i, jtype in enumerate(model.joint_types):
        S = model.S_list[:, i]
        if jtype == 'prismatic':
            p = ref.copy()
        else:
            p = _closest_point_on_axis(S[:3], S[3:], ref)
            p[np.abs(p) < 1e-15] = 0.0
        pts.append(p)
        ref = p
    return np.array(pts).reshape(-1, 3)


def _rod_inertial(start: np.ndarray, end: np.ndarray, rod_mass_per_m: float,
                  motor_mass: float):
    """Return (mass, com (3,), inertia (3, 3)) of a rod start->end plus a motor at end."""
    d = end - start
    length = float(np.linalg.norm(d))
    parts = []  # (mass, centre, inertia about centre)
    if length > 1e-9:
        m_rod = rod_mass_per_m * length
        u = d / length
        I_rod = (m_rod * length ** 2 / 12.0) * (np.eye(3) - np.outer(u, u)) \
            + (0.5 * m_rod * _ROD_RADIUS ** 2) * np.outer(u, u)
        parts.append((m_rod, (start + end) / 2.0, I_rod))
    m_mot = max(motor_mass, _TINY_MASS)
    parts.append((m_mot, end.copy(), 0.4 * m_mot * _MOTOR_RADIUS ** 2 * np.eye(3)))
    mass = sum(m for m, _, _ in parts)
    com = sum(m * c for m, c, _ in parts) / mass
    inertia = np.zeros((3, 3))
    for m, c, I_c in parts:
        r = c - com
        inertia += I_c + m * ((r @ r) * np.eye(3) - np.outer(r, r))
    return mass, com, inertia


def _inertial_xml(mass: float, com, inertia: np.ndarray, indent: str) -> List[str]:
    In = inertia
    return [
        f'{indent}<inertial>',
        f'{indent}  <origin xyz="{_vec(com)}" rpy="0 0 0"/>',
        f'{indent}  <mass value="{_f(mass)}"/>',
        f'{indent}  <inertia ixx="{_f(In[0, 0])}" ixy="{_f(In[0, 1])}" ixz="{_f(In[0, 2])}" '
        f'iyy="{_f(In[1, 1])}" iyz="{_f(In[1, 2])}" izz="{_f(In[2, 2])}"/>',
        f'{indent}</inertial>',
    ]


def _cylinder_visual(start: np.ndarray, end: np.ndarray, radius: float, material: str,
                     indent: str) -> List[str]:
    d = end - start
    length = float(np.linalg.norm(d))
    if length < 1e-6:
        return []
    u = d / length
    # rotation taking z to u: about axis z x u by angle acos(u_z)
    axis = np.cross([0.0, 0.0, 1.0], u)
    s, c = float(np.linalg.norm(axis)), float(u[2])
    if s < 1e-12:
        R = np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    else:
        k = axis / s
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        R = np.eye(3) + s * K + (1.0 - c) * (K @ K)
    return [
        f'{indent}<visual>',
        f'{indent}  <origin xyz="{_vec((start + end) / 2.0)}" '
        f'rpy="{_vec(matrix_to_euler_sxyz(R))}"/>',
        f'{indent}  <geometry><cylinder radius="{_f(radius)}" length="{_f(length)}"/></geometry>',
        f'{indent}  <material name="{material}"/>',
        f'{indent}</visual>',
    ]


def _sphere_visual(center, radius: float, material: str, indent: str) -> List[str]:
    return [
        f'{indent}<visual>',
        f'{indent}  <origin xyz="{_vec(center)}" rpy="0 0 0"/>',
        f'{indent}  <geometry><sphere radius="{_f(radius)}"/></geometry>',
        f'{indent}  <material name="{material}"/>',
        f'{indent}</visual>',
    ]


def link_name(joint_name: str) -> str:
    """Return the generated name of the link a joint moves."""
    return f'{joint_name}_link'


def urdf_from_model(model: RobotModel) -> str:
    """
    Return a URDF (XML text) of the model's arm, end-effector frame and gripper, if any.

    Frames: ``model.base_frame`` is the root; ``model.ee_frame`` is at M for q = 0.
    """
    hints = (model.extra or {}).get('inertial') or {}
    rho = float(hints.get('rod_mass_per_m', ROD_MASS_PER_M))
    motor = float(hints.get('motor_mass', MOTOR_MASS))
    origins = joint_origins(model)
    M = np.asarray(model.M, dtype=float)
    ends = list(origins[1:]) + [M[:3, 3]]
    out = ['<?xml version="1.0"?>',
           f'<!-- Generated by px100_control.models.urdf_writer from robot model '
           f"'{escape(model.name)}'. Kinematics exact, inertials approximate. -->",
           f'<robot name="{escape(model.name)}">',
           '  <material name="arm_grey"><color rgba="0.6 0.6 0.65 1"/></material>',
           '  <material name="joint_black"><color rgba="0.1 0.1 0.1 1"/></material>',
           '  <material name="tool_orange"><color rgba="1.0 0.5 0.1 1"/></material>',
           f'  <link name="{model.base_frame}">']
    out += _cylinder_visual(np.array([0.0, 0.0, -0.02]), np.array([0.0, 0.0, 0.0]), 0.05,
                            'joint_black', '    ')
    out.append('  </link>')
    parent, parent_origin = model.base_frame, np.zeros(3)
    for i, name in enumerate(model.joint_names):
        S = model.S_list[:, i]
        prismatic = model.joint_types[i] == 'prismatic'
        axis = S[3:] if prismatic else S[:3]
        axis = axis / np.linalg.norm(axis)
        child = link_name(name)
        lo, hi = float(model.lower[i]), float(model.upper[i])
        jtype = 'prismatic' if prismatic else 'revolute'
        out += [f'  <joint name="{escape(name)}" type="{jtype}">',
                f'    <parent link="{parent}"/>',
                f'    <child link="{child}"/>',
                f'    <origin xyz="{_vec(origins[i] - parent_origin)}" rpy="0 0 0"/>',
                f'    <axis xyz="{_vec(axis)}"/>',
                f'    <limit lower="{_f(lo)}" upper="{_f(hi)}" '
                f'velocity="{_f(model.velocity_limits[i])}" '
                f'effort="{_f(model.effort_limits[i])}"/>',
                '    <dynamics damping="0.1" friction="0.1"/>',
                '  </joint>']
        # link geometry in the link frame (origin at the joint, base-aligned at q = 0)
        start, end = np.zeros(3), ends[i] - origins[i]
        if prismatic:
            # the moving part is the slider along the axis; draw it from the joint backwards
            start = -axis * 0.05
        mass, com, inertia = _rod_inertial(np.zeros(3), end, rho, motor)
        out.append(f'  <link name="{child}">')
        out += _sphere_visual(np.zeros(3), 0.025, 'joint_black', '    ')
        out += _cylinder_visual(start, end, 0.015, 'arm_grey', '    ')
        out += _inertial_xml(mass, com, inertia, '    ')
        out.append('  </link>')
        parent, parent_origin = child, origins[i]
    ee_offset = M[:3, 3] - parent_origin
    out += ['  <joint name="ee_fixed" type="fixed">',
            f'    <parent link="{parent}"/>',
            f'    <child link="{model.ee_frame}"/>',
            f'    <origin xyz="{_vec(ee_offset)}" rpy="{_vec(matrix_to_euler_sxyz(M[:3, :3]))}"/>',
            '  </joint>',
            f'  <link name="{model.ee_frame}">']
    out += _sphere_visual(np.zeros(3), 0.01, 'tool_orange', '    ')
    out += _inertial_xml(_TINY_MASS, np.zeros(3), 1e-7 * np.eye(3), '    ')
    out.append('  </link>')
    if model.gripper is not None:
        out += _gripper_xml(model)
    out.append('</robot>')
    return '\n'.join(out) + '\n'


def _gripper_xml(model: RobotModel) -> List[str]:
    """Return the gripper servo and finger joints hanging off the end-effector frame."""
    g = model.gripper
    ee = model.ee_frame
    left, right = (tuple(g.fingers) + ('right_finger',))[:2]
    lines = [f'  <joint name="{escape(g.joint)}" type="continuous">',
             f'    <parent link="{ee}"/>',
             '    <child link="gripper_prop_link"/>',
             '    <origin xyz="-0.05 0 0" rpy="0 0 0"/>',
             '    <axis xyz="1 0 0"/>',
             '    <limit effort="1" velocity="3.141592653589793"/>',
             '    <dynamics damping="0.1" friction="0.1"/>',
             '  </joint>',
             '  <link name="gripper_prop_link">']
    lines += _sphere_visual(np.zeros(3), 0.012, 'joint_black', '    ')
    lines += _inertial_xml(0.005, np.zeros(3), 1e-6 * np.eye(3), '    ')
    lines += ['  </link>',
              '  <joint name="fingers_fixed" type="fixed">',
              f'    <parent link="{ee}"/>',
              '    <child link="fingers_link"/>',
              '    <origin xyz="-0.027575 0 0" rpy="0 0 0"/>',
              '  </joint>',
              '  <link name="fingers_link">']
    lines += _inertial_xml(_TINY_MASS, np.zeros(3), 1e-7 * np.eye(3), '    ')
    lines.append('  </link>')
    lo, hi = float(g.finger_lower), float(g.finger_upper)
    for name, sign in ((left, 1.0), (right, -1.0)):
        flo, fhi = (lo, hi) if sign > 0 else (-hi, -lo)
        lines += [f'  <joint name="{escape(name)}" type="prismatic">',
                  '    <parent link="fingers_link"/>',
                  f'    <child link="{escape(name)}_link"/>',
                  '    <origin xyz="0 0 0" rpy="0 0 0"/>',
                  '    <axis xyz="0 1 0"/>',
                  f'    <limit lower="{_f(flo)}" upper="{_f(fhi)}" velocity="1" effort="5"/>']
        if sign < 0:
            lines.append(f'    <mimic joint="{escape(left)}" multiplier="-1" offset="0"/>')
        lines += ['  </joint>', f'  <link name="{escape(name)}_link">']
        lines += [
            '    <visual>',
            '      <origin xyz="0.01 0 0" rpy="0 0 0"/>',
            '      <geometry><box size="0.04 0.008 0.02"/></geometry>',
            '      <material name="tool_orange"/>',
            '    </visual>']
        lines += _inertial_xml(0.016, np.array([0.01, 0.0, 0.0]), 2e-6 * np.eye(3), '    ')
        lines.append('  </link>')
    return lines


__all__ = ['urdf_from_model', 'joint_origins', 'link_name',
           'ROD_MASS_PER_M', 'MOTOR_MASS']
