"""
Read a serial chain from a URDF (with yourdfpy) into PoE form.

Walks the joints from ``base_frame`` to ``ee_frame``; the actuated ones (revolute, continuous,
prismatic) become screw axes in the base frame at q = 0. Units: m, rad.
"""
import io
from typing import Sequence

import numpy as np

from px100_control.errors import RobotModelError
from px100_control.kinematics.dh import tool_from_xyz_rpy

_ACTUATED = ('revolute', 'continuous', 'prismatic')


def load_urdf(urdf_xml: str):
    """Return a yourdfpy.URDF parsed from XML text (no meshes); raise RobotModelError."""
    import yourdfpy  # optional: with trimesh ~0.5 s to import, only URDF robots need it
    try:
        return yourdfpy.URDF.load(io.StringIO(urdf_xml), build_scene_graph=False,
                                  load_meshes=False, load_collision_meshes=False)
    except Exception as exc:  # yourdfpy raises many types
        raise RobotModelError(f'cannot parse URDF: {exc}') from exc


def chain_joints(urdf, base_frame: str, ee_frame: str):
    """Return the URDF joints from base_frame to ee_frame, in order."""
    by_child = {j.child: j for j in urdf.robot.joints}
    chain, link = [], ee_frame
    while link != base_frame:
        if link not in by_child:
            raise RobotModelError(f"no kinematic chain from '{base_frame}' to '{ee_frame}' "
                                  f"(stopped at '{link}')")
        joint = by_child[link]
        chain.append(joint)
        link = joint.parent
    return chain[::-1]


def _origin(joint) -> np.ndarray:
    return np.eye(4) if joint.origin is None else np.array(joint.origin, dtype=float)


def chain_to_poe(urdf, base_frame: str, ee_frame: str, arm_joints: Sequence[str]):
    """
    Return (S_list (6, n), M (4, 4), limits dict) for the arm joints of a URDF chain.

    :raises RobotModelError: when an arm joint is not an actuated joint of that chain
    """
    T = np.eye(4)
    axes = {}
    limits = {}
    for joint in chain_joints(urdf, base_frame, ee_frame):
        T = T @ _origin(joint)
        if joint.type in _ACTUATED:
            axis = np.array(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), float)
            axis /= np.linalg.norm(axis)
            w = T[:3, :3] @ axis
            p = T[:3, 3]
            if joint.type == 'prismatic':
                axes[joint.name] = np.concatenate([np.zeros(3), w])
            else:
                axes[joint.name] = np.concatenate([w, -np.cross(w, p)])
            lim = joint.limit
            unbounded = joint.type == 'continuous' or lim is None or lim.lower is None
            limits[joint.name] = (
                -np.pi if unbounded else float(lim.lower),
                np.pi if unbounded else float(lim.upper),
                float(lim.velocity) if lim is not None and lim.velocity else np.pi,
                float(lim.effort) if lim is not None and lim.effort else 1.0,
            )
    missing = [j for j in arm_joints if j not in axes]
    if missing:
        raise RobotModelError(f'arm joints {missing} are not actuated joints on the chain '
                              f"'{base_frame}' -> '{ee_frame}'")
    S_list = np.column_stack([axes[j] for j in arm_joints])
    return S_list, T, limits


__all__ = ['load_urdf', 'chain_joints', 'chain_to_poe', 'tool_from_xyz_rpy']
