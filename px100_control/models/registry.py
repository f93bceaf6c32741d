"""
Robot registry: robots are data files in ``config/robots/<name>.yaml``.

A robot file gives either a ``urdf`` (a file in ``urdf/``; kinematics and limits come from it)
or a ``kinematics`` table (``convention: dh | mdh | poe``, one entry per joint with limits).
Optional ``alternative_models`` hold the same robot in other conventions (tests prove that
they agree). See ``config/robots/px100.yaml`` for the schema.

A table robot has no URDF file: ``model_from_spec`` generates one (``models/urdf_writer.py``:
exact kinematics, approximate inertials, primitive visuals), so every robot publishes one on
``robot_description``. Its optional ``inertial: {rod_mass_per_m, motor_mass}`` section tunes
those approximate inertials (see urdf_writer). Table examples: ``config/robots/rrrp.yaml``
(mdh), ``rrrr.yaml`` (dh), ``myarm300pi.yaml`` and ``px150.yaml`` (poe).
"""
import dataclasses
import functools
import os
from typing import Dict, List

import numpy as np
from px100_control.errors import RobotModelError, UnknownRobotError
from px100_control.kinematics.dh import dh_to_screws, DHRow, tool_from_xyz_rpy
from px100_control.kinematics.se3 import screw_axis
from px100_control.models.robot_model import GripperSpec, RobotModel
from px100_control.models.urdf_chain import chain_to_poe
from px100_control.models.urdf_tree import load_urdf_tree
from px100_control.models.urdf_writer import urdf_from_model
from px100_control.paths import data_path
import yaml


def robots_dir() -> str:
    """Return the folder of robot description files."""
    return data_path('config', 'robots')


def available_robots() -> List[str]:
    """Return the names of every registered robot model."""
    return sorted(f[:-5] for f in os.listdir(robots_dir()) if f.endswith('.yaml'))


def read_robot_file(name_or_path: str) -> dict:
    """Return the parsed YAML of a robot by registered name or file path."""
    path = name_or_path if name_or_path.endswith('.yaml') else os.path.join(
        robots_dir(), name_or_path + '.yaml')
    if not os.path.isfile(path):
        raise UnknownRobotError(f"unknown robot_model '{name_or_path}' "
                                f"(available: {', '.join(available_robots())})")
    with open(path, encoding='utf-8') as f:
        spec = yaml.safe_load(f)
    if not isinstance(spec, dict) or 'name' not in spec:
        raise RobotModelError(f'{path}: not a robot description (no name)')
    spec['_path'] = path
    return spec


def _matrix(entry) -> np.ndarray:
    """Parse a transform given as a 4x4 list or {xyz, rpy}."""
    if entry is None:
        return np.eye(4)
    if isinstance(entry, dict):
        return tool_from_xyz_rpy(entry.get('xyz', (0, 0, 0)), entry.get('rpy', (0, 0, 0)))
    T = np.array(entry, dtype=float)
    if T.shape != (4, 4):
        raise RobotModelError(f'a transform must be 4x4 or {{xyz, rpy}}, got {entry!r}')
    return T


def table_to_poe(kin: dict):
    """
    Return (S_list, M, joints) from a ``kinematics`` table (dh, mdh or poe).

    dh/mdh joints: {name, type, a, alpha, d, theta}; poe joints: {name, type, omega, point}
    (or ``v`` for prismatic). ``base`` and ``tool`` are optional transforms; poe takes ``M``.
    """
    convention = kin.get('convention')
    joints = kin['joints']
    if convention in ('dh', 'mdh'):
        rows = [DHRow(float(j.get('a', 0)), float(j.get('alpha', 0)), float(j.get('d', 0)),
                      float(j.get('theta', 0)), j.get('type', 'revolute')) for j in joints]
        S, M = dh_to_screws(rows, _matrix(kin.get('base')), _matrix(kin.get('tool')),
                            modified=convention == 'mdh')
        return S, M, joints
    if convention == 'poe':
        cols = []
        for j in joints:
            if j.get('type', 'revolute') == 'prismatic':
                cols.append(np.concatenate([np.zeros(3), np.array(j['v'], float)]))
            else:
                cols.append(screw_axis(j['omega'], j.get('point', (0, 0, 0))))
        return np.column_stack(cols), _matrix(kin.get('M')), joints
    raise RobotModelError(f'kinematics convention must be dh, mdh or poe, not {convention!r}')


def _from_table(spec: dict) -> Dict:
    S, M, joints = table_to_poe(spec['kinematics'])
    return {
        'S_list': S, 'M': M,
        'joint_names': tuple(j['name'] for j in joints),
        'joint_types': tuple(j.get('type', 'revolute') for j in joints),
        'lower': np.array([float(j.get('lower', -np.pi)) for j in joints]),
        'upper': np.array([float(j.get('upper', np.pi)) for j in joints]),
        'velocity_limits': np.array([float(j.get('velocity', np.pi)) for j in joints]),
        'effort_limits': np.array([float(j.get('effort', 1.0)) for j in joints]),
    }


def _from_urdf(spec: dict, urdf_xml: str) -> Dict:
    urdf = load_urdf_tree(urdf_xml)
    names = tuple(spec['arm_joints'])
    S, M, limits = chain_to_poe(urdf, spec.get('base_frame', 'base_link'),
                                spec.get('ee_frame', 'ee_gripper_link'), names)
    types = {j.name: j.type for j in urdf.robot.joints}
    return {
        'S_list': S, 'M': M, 'joint_names': names,
        'joint_types': tuple('prismatic' if types[n] == 'prismatic' else 'revolute'
                             for n in names),
        'lower': np.array([limits[n][0] for n in names]),
        'upper': np.array([limits[n][1] for n in names]),
        'velocity_limits': np.array([limits[n][2] for n in names]),
        'effort_limits': np.array([limits[n][3] for n in names]),
    }


def model_from_spec(spec: dict) -> RobotModel:
    """Build a RobotModel from a parsed robot description (see module docstring)."""
    urdf_xml = None
    if spec.get('urdf'):
        with open(data_path('urdf', spec['urdf']), encoding='utf-8') as f:
            urdf_xml = f.read()
        fields = _from_urdf(spec, urdf_xml)
    elif spec.get('kinematics'):
        fields = _from_table(spec)
    else:
        raise RobotModelError(f"robot '{spec['name']}' has neither urdf nor kinematics")
    n = len(fields['joint_names'])
    gripper = None
    if spec.get('gripper'):
        g = dict(spec['gripper'])
        lo, hi = g.pop('finger_limits', (0.015, 0.037))
        g['fingers'] = tuple(g.get('fingers', ('left_finger', 'right_finger')))
        gripper = GripperSpec(finger_lower=float(lo), finger_upper=float(hi), **g)
    home = np.array(spec.get('home', [0.0] * n), dtype=float)
    sleep = np.array(spec.get('sleep', home), dtype=float)
    if home.size != n or sleep.size != n:
        raise RobotModelError(f"robot '{spec['name']}': home/sleep need {n} values")
    model = RobotModel(
        name=spec['name'], home=home, sleep=sleep,
        base_frame=spec.get('base_frame', 'base_link'),
        ee_frame=spec.get('ee_frame', 'ee_gripper_link'),
        urdf_xml=urdf_xml, gripper=gripper,
        analytic_ik=(spec.get('ik') or {}).get('analytic'),
        description=spec.get('description', ''),
        extra={k: v for k, v in spec.items() if k not in ('name',)},
        **fields)
    if urdf_xml is None:
        # table robots publish a generated URDF (exact kinematics, approximate inertials)
        model = dataclasses.replace(model, urdf_xml=urdf_from_model(model))
    return model


@functools.lru_cache(maxsize=None)
def load_robot(name: str = 'px100') -> RobotModel:
    """
    Return the RobotModel registered under ``name`` (cached; models are immutable).

    :raises UnknownRobotError: no such robot; RobotModelError: its description is broken
    """
    return model_from_spec(read_robot_file(name))
