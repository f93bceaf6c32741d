"""
Scenes as files: a table, static fixtures and movable objects around the robot.

A scene is a YAML file ``config/scenes/<name>.yaml`` (see ``config/scenes/pick_place.yaml``)::

    name: pick_place
    table: {size: [0.60, 0.70, 0.03], position: [0.15, 0.0, -0.015], rgba: [...]}
    fixtures:                      # static bodies (pedestals, walls of a box with a hole)
      - {name: pedestal, shape: cylinder, size: [0.025, 0.04], position: [...]}
    objects:                       # movable bodies, grasped by contact only
      - {name: red_cube, shape: box, size: [0.028, 0.028, 0.028], mass: 0.03,
         friction: 1.0, rgba: [0.85, 0.15, 0.15, 1.0], position: [0.17, -0.05, 0.014],
         rpy: [0.0, 0.0, 0.0]}

Frames and units: positions are body centres in the ROBOT BASE frame [m], ``rpy`` roll, pitch,
yaw [rad] (fixed axes x, y, z); sizes [m]: box = full x, y, z extents, cylinder = radius,
height (axis along the body's z), sphere = radius; mass [kg]; friction = sliding coefficient;
rgba 4 floats in 0..1. ``table`` is optional and is always a box.

``camera`` (optional) is the scene's RGB-D camera (:class:`~px100_control.perception.camera.
CameraSpec`): ``position`` and ``look_at`` [m] in the base frame, ``width`` / ``height`` [px],
``fovy`` [rad], ``rate`` [Hz], ``depth_range`` [min, max] [m], ``subpixel`` [px], ``baseline``
[m]; a key left out takes the D415 default. The camera node uses it.

:func:`load_scene` validates everything and raises
:class:`~px100_control.errors.InvalidInputError` naming the file and every wrong field (one line
each): unknown keys,
missing or non-numeric values, NaN/inf, non-positive sizes or masses, duplicate names,
overlapping bodies (bounding boxes, 0.1 mm tolerance so resting contact is allowed), and, with
``robot`` given, objects out of the robot's reach (:func:`check_reach`).
"""
from dataclasses import dataclass
import functools
import math
import os
import re
from typing import Any, Callable, List, Optional, Sequence, Tuple

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.kinematics.iterative import chain, fk_batch
from px100_control.kinematics.rotations import euler_sxyz_to_matrix
from px100_control.paths import data_path
from px100_control.perception.camera import camera_error, CameraSpec
import yaml

SHAPES = {'box': 3, 'cylinder': 2, 'sphere': 1}    # shape -> number of size values
KINDS = ('object', 'fixture', 'table')
DEFAULT_SCENE = 'pick_place'
#: touching bodies may interpenetrate this much [m] before they count as overlapping
OVERLAP_TOLERANCE = 1e-4
_NAME = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')
_BODY_KEYS = {'name', 'shape', 'size', 'mass', 'friction', 'rgba', 'position', 'rpy'}
_TOP_KEYS = {'name', 'description', 'table', 'fixtures', 'objects', 'camera'}
#: the camera block's keys: number of values (None: one integer)
_CAMERA_KEYS = {'position': 3, 'look_at': 3, 'width': None, 'height': None, 'fovy': 1,
                'rate': 1, 'depth_range': 2, 'subpixel': 1, 'baseline': 1}
_DEFAULT_RGBA = {'object': (0.8, 0.3, 0.2, 1.0), 'fixture': (0.45, 0.45, 0.5, 1.0),
                 'table': (0.76, 0.65, 0.5, 1.0)}


@dataclass(frozen=True)
class SceneBody:
    """
    One body of a scene (see the module docstring for frames and units).

    :param kind: 'object' (movable), 'fixture' (static) or 'table' (static box)
    :param size: box (x, y, z) full extents; cylinder (radius, height); sphere (radius,) [m]
    :param mass: [kg] (objects; static bodies keep 0)
    :param position: centre in the robot base frame [m]; rpy: orientation [rad]
    """

    name: str
    kind: str
    shape: str
    size: Tuple[float, ...]
    mass: float
    friction: float
    rgba: Tuple[float, float, float, float]
    position: Tuple[float, float, float]
    rpy: Tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def quaternion_xyzw(self) -> Tuple[float, float, float, float]:
        """Return the initial orientation as a unit quaternion (x, y, z, w)."""
        return rpy_to_quaternion_xyzw(self.rpy)

    def half_extents(self) -> np.ndarray:
        """Return the half extents (3,) of the body's axis-aligned bounding box [m]."""
        if self.shape == 'box':
            local = 0.5 * np.array(self.size)
        elif self.shape == 'cylinder':
            local = np.array([self.size[0], self.size[0], 0.5 * self.size[1]])
        else:
            return np.full(3, self.size[0])
        R = euler_sxyz_to_matrix(*self.rpy)
        return np.abs(R) @ local


@dataclass(frozen=True)
class Scene:
    """A validated scene: name, source path, and its bodies (table, fixtures, objects)."""

    name: str
    path: str
    bodies: Tuple[SceneBody, ...]
    description: str = ''
    camera: Optional[CameraSpec] = None

    @property
    def objects(self) -> Tuple[SceneBody, ...]:
        """Return the movable bodies."""
        return tuple(b for b in self.bodies if b.kind == 'object')

    @property
    def statics(self) -> Tuple[SceneBody, ...]:
        """Return the table and the fixtures."""
        return tuple(b for b in self.bodies if b.kind != 'object')

    def body(self, name: str) -> SceneBody:
        """Return the body called ``name``; raise InvalidInputError if there is none."""
        for b in self.bodies:
            if b.name == name:
                return b
        raise InvalidInputError(f"scene '{self.name}' has no body '{name}' (bodies: "
                                f"{', '.join(b.name for b in self.bodies)})")


def rpy_to_quaternion_xyzw(rpy: Sequence[float]) -> Tuple[float, float, float, float]:
    """Return the unit quaternion (x, y, z, w) of roll, pitch, yaw [rad] (fixed x, y, z)."""
    r, p, y = (0.5 * float(a) for a in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), \
        math.cos(y), math.sin(y)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def scenes_dir() -> str:
    """Return the folder of scene files."""
    return data_path('config', 'scenes')


def available_scenes():
    """Return the names of the scene files in :func:`scenes_dir`."""
    folder = scenes_dir()
    if not os.path.isdir(folder):
        return []
    return sorted(f[:-5] for f in os.listdir(folder) if f.endswith('.yaml'))


def scene_path(name_or_path: str) -> str:
    """
    Return the file of a scene given by name (config/scenes/<name>.yaml) or path.

    :raises InvalidInputError: no such file
    """
    text = str(name_or_path)
    if text.endswith(('.yaml', '.yml')) or os.sep in text:
        path = text
    else:
        path = os.path.join(scenes_dir(), text + '.yaml')
    if not os.path.isfile(path):
        raise InvalidInputError(f"unknown scene '{text}': no file {path} (available: "
                                f"{', '.join(available_scenes()) or 'none'})")
    return path


def _numbers(where: str, value, count: Optional[int] = None) -> Tuple[float, ...]:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = [value]
    if not isinstance(value, (list, tuple)):
        raise InvalidInputError(f'{where} must be a list of numbers, not {value!r}')
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InvalidInputError(f'{where} must be numbers, not {value!r}')
        if not math.isfinite(float(v)):
            raise InvalidInputError(f'{where} contains NaN or inf: {value!r}')
        out.append(float(v))
    if count is not None and len(out) != count:
        raise InvalidInputError(f'{where} needs {count} values, got {len(out)}: {value!r}')
    return tuple(out)


def _unknown_keys(where: str, raw: dict, allowed: set) -> Optional[str]:
    """Return the problem of keys not in ``allowed`` (None when there are none)."""
    unknown = sorted(set(raw) - allowed)
    if unknown:
        return f'{where}: unknown key(s) {unknown} (allowed: {sorted(allowed)})'
    return None


def _field(problems: List[str], check: Callable[[], Any]) -> Any:
    """Return ``check()``; on InvalidInputError add its text to ``problems`` and return None."""
    try:
        return check()
    except InvalidInputError as exc:
        problems.append(str(exc))
        return None


def _positive(where: str, values: Tuple[float, ...], what: str) -> Tuple[float, ...]:
    if any(v <= 0.0 for v in values):
        shown = list(values) if len(values) > 1 else values[0]
        raise InvalidInputError(f'{where}.{what} must be positive, not {shown}')
    return values


def _required(where: str, raw: dict, key: str):
    if key not in raw:
        raise InvalidInputError(f'{where}.{key} is missing')
    return raw[key]


def _mass(where: str, raw: dict, kind: str) -> float:
    if kind != 'object':
        if 'mass' in raw:
            raise InvalidInputError(f'{where}.mass: a {kind} is static and has no mass')
        return 0.0
    return _positive(where, _numbers(f'{where}.mass', _required(where, raw, 'mass'), 1),
                     'mass')[0]


def _rgba(where: str, raw: dict, kind: str) -> Tuple[float, ...]:
    rgba = _numbers(f'{where}.rgba', raw.get('rgba', _DEFAULT_RGBA[kind]), 4)
    if any(c < 0.0 or c > 1.0 for c in rgba):
        raise InvalidInputError(f'{where}.rgba values must be in 0..1, not {list(rgba)}')
    return rgba


def _body(where: str, raw, kind: str, problems: List[str]) -> Optional[SceneBody]:
    """Return the body of ``raw``, or None after adding every wrong field to ``problems``."""
    if not isinstance(raw, dict):
        problems.append(f'{where} must be a mapping, not {raw!r}')
        return None
    count = len(problems)
    problems += [p for p in [_unknown_keys(where, raw, _BODY_KEYS)] if p]
    name = raw.get('name', 'table' if kind == 'table' else None)
    if not isinstance(name, str) or not _NAME.match(name):
        problems.append(f'{where}.name must be an identifier (letters, digits, _), '
                        f'not {name!r}')
    else:
        where = f'{where} ({name})'
    shape = raw.get('shape', 'box')
    size = None
    if shape not in SHAPES or (kind == 'table' and shape != 'box'):
        allowed = ['box'] if kind == 'table' else list(SHAPES)
        problems.append(f'{where}.shape must be one of {allowed}, not {shape!r}')
    else:
        size = _field(problems, lambda: _positive(where, _numbers(
            f'{where}.size', _required(where, raw, 'size'), SHAPES[shape]), 'size'))
    mass = _field(problems, lambda: _mass(where, raw, kind))
    friction = _field(problems, lambda: _positive(where, _numbers(
        f'{where}.friction', raw.get('friction', 1.0), 1), 'friction'))
    rgba = _field(problems, lambda: _rgba(where, raw, kind))
    position = _field(problems, lambda: _numbers(
        f'{where}.position', _required(where, raw, 'position'), 3))
    rpy = _field(problems, lambda: _numbers(f'{where}.rpy', raw.get('rpy', (0.0, 0.0, 0.0)), 3))
    if len(problems) > count:
        return None
    return SceneBody(name, kind, shape, size, mass, friction[0], rgba, position, rpy)


def _camera(where: str, raw, problems: List[str]) -> Optional[CameraSpec]:
    """Return the CameraSpec of a scene's ``camera`` block, or None after adding its problems."""
    if not isinstance(raw, dict):
        problems.append(f'{where} must be a mapping, not {raw!r}')
        return None
    unknown = _unknown_keys(where, raw, set(_CAMERA_KEYS))
    values, wrong = {}, []
    for key, count in _CAMERA_KEYS.items():
        if key not in raw:
            continue
        if count is None:
            if isinstance(raw[key], bool) or not isinstance(raw[key], int):
                wrong.append(f'{key} must be an integer, not {raw[key]!r}')
            else:
                values[key] = raw[key]
            continue
        try:
            got = _numbers(f'{key}', raw[key], count)
        except InvalidInputError as exc:
            wrong.append(str(exc))
            continue
        values[key] = got[0] if count == 1 else got
    if unknown:
        problems.append(unknown)
    error = camera_error(CameraSpec(**values))   # the fields that parsed, checked together
    if wrong or error:          # one line for the block: every wrong field of it named
        problems.append(f"{where}: {'; '.join(wrong + ([error] if error else []))}")
    return None if (unknown or wrong or error) else CameraSpec(**values)


def _overlaps(label: str, bodies: Sequence[SceneBody]) -> List[str]:
    """Return one problem per pair of bodies (one of them an object) that interpenetrate."""
    problems = []
    boxes = [(b, np.array(b.position), b.half_extents()) for b in bodies]
    for i, (a, pa, ha) in enumerate(boxes):
        for b, pb, hb in boxes[i + 1:]:
            if a.kind != 'object' and b.kind != 'object':
                continue        # static parts may touch or interlock (walls on a table)
            depth = (ha + hb) - np.abs(pa - pb)
            if np.all(depth > OVERLAP_TOLERANCE):
                problems.append(
                    f"{label}: bodies '{a.name}' and '{b.name}' overlap (bounding boxes "
                    f'interpenetrate by {1000 * float(depth.min()):.1f} mm); move '
                    f"'{b.name if b.kind == 'object' else a.name}'.position")
    return problems


def parse_scene(data, path: str = '<scene>', robot=None) -> Scene:
    """
    Return the Scene of already-parsed YAML data (see :func:`load_scene`).

    Every wrong field of the file is found, not only the first: the error holds one line per
    problem (the first line alone when there is one).

    :raises InvalidInputError: naming each field that is wrong
    """
    label = os.path.basename(path)
    if not isinstance(data, dict):
        raise InvalidInputError(f'{label}: a scene file must be a mapping, not {type(data)}')
    problems = [p for p in [_unknown_keys(label, data, _TOP_KEYS)] if p]
    name = data.get('name', os.path.splitext(label)[0])
    if not isinstance(name, str) or not name:
        problems.append(f'{label}: name must be a string, not {name!r}')
    bodies = []
    if data.get('table') is not None:
        bodies.append(_body(f'{label}: table', data['table'], 'table', problems))
    for key, kind in (('fixtures', 'fixture'), ('objects', 'object')):
        items = data.get(key) or []
        if not isinstance(items, list):
            problems.append(f'{label}: {key} must be a list, not {items!r}')
            continue
        bodies += [_body(f'{label}: {key}[{i}]', raw, kind, problems)
                   for i, raw in enumerate(items)]
    bodies = [b for b in bodies if b is not None]
    names = [b.name for b in bodies]
    problems += [f"{label}: duplicate body name '{n}'"
                 for n in sorted({n for n in names if names.count(n) > 1})]
    problems += _overlaps(label, bodies)
    camera = (_camera(f'{label}: camera', data['camera'], problems)
              if data.get('camera') is not None else None)
    scene = Scene(name=name, path=path, bodies=tuple(bodies),
                  description=str(data.get('description', '')), camera=camera)
    if robot is not None and not problems:
        problems += reach_problems(scene, robot)
    if problems:
        raise InvalidInputError(_summary(path, problems))
    return scene


def _summary(path: str, problems: List[str]) -> str:
    """Return one line for one problem, else a count line and one indented line per problem."""
    if len(problems) == 1:
        return problems[0]
    return f'scene {path}: {len(problems)} problems:\n' + '\n'.join(
        f'  {p}' for p in problems)


def load_scene(name_or_path: str, robot=None) -> Scene:
    """
    Return the validated Scene of a name in config/scenes or a path to a .yaml file.

    :param robot: a RobotModel; if given, every object must be within its reach
    :raises InvalidInputError: unknown file, unreadable YAML, or the wrong fields (each named)
    """
    path = scene_path(name_or_path)
    try:
        with open(path, encoding='utf-8') as f:
            data = yaml.safe_load(f)
    except yaml.YAMLError as exc:
        mark = getattr(exc, 'problem_mark', None)
        where = f' at line {mark.line + 1}, column {mark.column + 1}' if mark else ''
        what = getattr(exc, 'problem', None) or str(exc).splitlines()[0]
        raise InvalidInputError(f'{path}: not valid YAML{where}: {what}') from exc
    return parse_scene(data, path, robot)


@functools.lru_cache(maxsize=32)
def _workspace(model) -> np.ndarray:
    """Return (k, 3) end-effector positions of random in-limit configurations (cached)."""
    return fk_batch(chain(model), model.random_configurations(4000, rng=7))[:, :3, 3]


def reach_margin(model, position: Sequence[float], band: float = 0.04) -> float:
    """
    Return how far [m] a point lies inside (+) or outside (-) the robot's horizontal reach.

    The reach at a height is the largest horizontal distance from the base z axis of sampled
    end-effector positions within ``band`` [m] of that height (4000 random in-limit poses).
    """
    ws = _workspace(model)
    near = ws[np.abs(ws[:, 2] - float(position[2])) < band]
    if near.size == 0:
        return -math.inf
    reach = float(np.max(np.hypot(near[:, 0], near[:, 1])))
    return reach - math.hypot(float(position[0]), float(position[1]))


def reach_problems(scene: Scene, model, margin: float = 0.01) -> List[str]:
    """
    Return one problem per object of the scene out of the robot's reach.

    :param margin: [m] an object's centre must lie this far inside the reach
    """
    problems = []
    for b in scene.objects:
        m = reach_margin(model, b.position)
        if m < margin:
            problems.append(
                f"scene '{scene.name}': object '{b.name}'.position {list(b.position)} is out "
                f"of reach of robot '{model.name}' ({-m * 1000:.0f} mm beyond its reach at "
                f'that height, margin {margin * 1000:.0f} mm)')
    return problems


def check_reach(scene: Scene, model, margin: float = 0.01) -> None:
    """Raise InvalidInputError naming every object of the scene out of the robot's reach."""
    problems = reach_problems(scene, model, margin)
    if problems:
        raise InvalidInputError(_summary(scene.path, problems))
