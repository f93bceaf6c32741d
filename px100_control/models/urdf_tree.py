"""
The parts of a URDF this package reads, parsed once per URDF text and kept in a cache file.

:func:`load_urdf_tree` returns the joints (type, parent and child links, origin, axis, limit,
dynamics, mimic) and the links (inertial) of a URDF as yourdfpy parses them, in plain frozen
dataclasses with yourdfpy's field names, under ``.robot`` as yourdfpy's ``URDF.robot``. A
cache miss parses with yourdfpy; a hit reads a JSON file and imports neither yourdfpy nor
trimesh, about 0.9 s of CPU that every node process spent on start before. Units as in the
URDF: m, rad, kg, kg*m^2; ``origin`` is the 4x4 transform of the child (joint) or of the
inertial frame in the parent link, ``axis`` a unit vector in the joint frame.

Cache folder: env ``PX100_CACHE_DIR`` (empty: no cache), else ``$XDG_CACHE_HOME/px100_control``
or ``~/.cache/px100_control``. A file is named by the SHA-256 of the URDF text, this module's
source and yourdfpy's version, written atomically, and read only if it holds that same key; a
folder that cannot be written, or a broken file, only costs the parse.
"""
from dataclasses import dataclass
import functools
import hashlib
from importlib import metadata
import json
import os
import tempfile
from typing import Optional, Tuple

import numpy as np
from px100_control.models.urdf_chain import load_urdf

#: bump when the stored layout changes (the module's source is in the key as well)
CACHE_FORMAT = 1


@dataclass(frozen=True)
class Limit:
    """A joint's ``<limit>``: effort [N*m or N], velocity [rad/s or m/s], lower/upper."""

    effort: Optional[float]
    velocity: Optional[float]
    lower: Optional[float]
    upper: Optional[float]


@dataclass(frozen=True)
class Dynamics:
    """A joint's ``<dynamics>`` as yourdfpy keeps it (the attribute text or None)."""

    damping: object
    friction: object


@dataclass(frozen=True)
class Mimic:
    """A joint's ``<mimic>``: value = multiplier * value(joint) + offset."""

    joint: str
    multiplier: Optional[float]
    offset: Optional[float]


@dataclass(frozen=True)
class Joint:
    """A URDF joint (``origin`` 4x4 or None, ``axis`` (3,) or None)."""

    name: str
    type: str  # noqa: A003 - yourdfpy's (and URDF's) name of the field
    parent: str
    child: str
    origin: Optional[np.ndarray]
    axis: Optional[np.ndarray]
    dynamics: Optional[Dynamics]
    limit: Optional[Limit]
    mimic: Optional[Mimic]


@dataclass(frozen=True)
class Inertial:
    """A link's ``<inertial>``: origin 4x4 (or None), mass [kg], inertia 3x3 [kg*m^2]."""

    origin: Optional[np.ndarray]
    mass: Optional[float]
    inertia: Optional[np.ndarray]


@dataclass(frozen=True)
class Link:
    """A URDF link (its inertial only: this package draws meshes through viser)."""

    name: str
    inertial: Optional[Inertial]


@dataclass(frozen=True)
class Robot:
    """The robot element: name, links and joints in file order."""

    name: str
    links: Tuple[Link, ...]
    joints: Tuple[Joint, ...]


@dataclass(frozen=True)
class UrdfTree:
    """A parsed URDF; ``robot`` as yourdfpy's ``URDF.robot``."""

    robot: Robot


def cache_dir() -> str:
    """Return the cache folder ('' when ``PX100_CACHE_DIR`` is set empty: no cache)."""
    env = os.environ.get('PX100_CACHE_DIR')
    if env is not None:
        return env
    base = os.environ.get('XDG_CACHE_HOME') or os.path.join(os.path.expanduser('~'), '.cache')
    return os.path.join(base, 'px100_control')


@functools.lru_cache(maxsize=1)
def _code_key() -> str:
    """Return the part of the key that changes with this module or yourdfpy."""
    try:
        version = metadata.version('yourdfpy')
    except metadata.PackageNotFoundError:
        version = 'none'
    with open(__file__, 'rb') as f:
        source = hashlib.sha256(f.read()).hexdigest()
    return f'{CACHE_FORMAT}/{source}/{version}'


def cache_key(urdf_xml: str) -> str:
    """Return the SHA-256 (hex) naming the cache file of a URDF text."""
    return hashlib.sha256(f'{_code_key()}\n{urdf_xml}'.encode('utf-8')).hexdigest()


@functools.lru_cache(maxsize=16)
def load_urdf_tree(urdf_xml: str) -> UrdfTree:
    """
    Return the :class:`UrdfTree` of a URDF text: from the cache, else parsed (and stored).

    :raises RobotModelError: yourdfpy cannot parse it (nothing is stored)
    """
    folder = cache_dir()
    key = cache_key(urdf_xml)
    path = os.path.join(folder, 'urdf', key + '.json') if folder else ''
    if path:
        tree = _read(path, key)
        if tree is not None:
            return tree
    data = _distil(load_urdf(urdf_xml))
    if path:
        _write(path, key, data)
    return _tree(data)


def _array(value) -> Optional[np.ndarray]:
    """Return a read-only float array (trees are shared by every caller), or None."""
    if value is None:
        return None
    out = np.array(value, dtype=float)
    out.flags.writeable = False
    return out


def _list(value):
    return None if value is None else np.asarray(value, dtype=float).tolist()


def _scalar(value):
    """Keep what yourdfpy holds (a float, the attribute's text, None) as JSON keeps it."""
    if value is None or isinstance(value, str):
        return value
    return float(value)


def _distil(urdf) -> dict:
    """Return the JSON-ready data of a yourdfpy URDF."""
    joints = []
    for j in urdf.robot.joints:
        lim, dyn, mim = j.limit, j.dynamics, j.mimic
        joints.append({
            'name': j.name, 'type': j.type, 'parent': j.parent, 'child': j.child,
            'origin': _list(j.origin), 'axis': _list(j.axis),
            'dynamics': None if dyn is None else [_scalar(dyn.damping),
                                                  _scalar(dyn.friction)],
            'limit': None if lim is None else [_scalar(lim.effort), _scalar(lim.velocity),
                                               _scalar(lim.lower), _scalar(lim.upper)],
            'mimic': None if mim is None else [mim.joint, _scalar(mim.multiplier),
                                               _scalar(mim.offset)]})
    links = []
    for link in urdf.robot.links:
        i = link.inertial
        links.append({'name': link.name, 'inertial': None if i is None else
                      [_list(i.origin), _scalar(i.mass), _list(i.inertia)]})
    return {'name': urdf.robot.name, 'links': links, 'joints': joints}


def _tree(data: dict) -> UrdfTree:
    joints = tuple(Joint(
        j['name'], j['type'], j['parent'], j['child'], _array(j['origin']), _array(j['axis']),
        None if j['dynamics'] is None else Dynamics(*j['dynamics']),
        None if j['limit'] is None else Limit(*j['limit']),
        None if j['mimic'] is None else Mimic(*j['mimic'])) for j in data['joints'])
    links = tuple(Link(k['name'], None if k['inertial'] is None else Inertial(
        _array(k['inertial'][0]), k['inertial'][1], _array(k['inertial'][2])))
        for k in data['links'])
    return UrdfTree(Robot(data['name'], links, joints))


def _read(path: str, key: str) -> Optional[UrdfTree]:
    """Return the tree stored at path under key, or None (no file, another key, broken)."""
    try:
        with open(path, encoding='utf-8') as f:
            stored = json.load(f)
        if stored.get('key') != key:
            return None
        return _tree(stored['urdf'])
    except (OSError, ValueError, KeyError, TypeError, AttributeError, IndexError):
        return None


def _write(path: str, key: str, data: dict) -> None:
    """Store data under key at path atomically; a folder that cannot be written is skipped."""
    folder = os.path.dirname(path)
    try:
        os.makedirs(folder, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix='.urdf_', suffix='.tmp')
        try:
            with os.fdopen(fd, 'w', encoding='utf-8') as f:
                json.dump({'key': key, 'urdf': data}, f)
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise
    except OSError:
        pass
