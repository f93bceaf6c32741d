"""
Message definitions for bags: ``.msg`` texts, rosbag2's concatenated ``ros2msg`` schemas, RIHS01.

A schema in a rosbag2 MCAP file is the root ``.msg`` text followed by every dependency, each
preceded by a line of 80 ``=`` and ``MSG: <pkg>/<Name>`` (dependencies in sorted order, depth
first, each once), exactly as rosbag2's ``LocalMessageDefinitionSource`` builds it from the
installed ``share/<pkg>/msg/<Name>.msg`` files. Texts come from the installed ROS share
directories (found through the ament index, or next to the python package of the messages);
``tf2_msgs/msg/TFMessage`` and its dependencies are shipped here for machines without them.

Type hashes (``RIHS01_<sha256>``, rosbag2's ``type_description_hash``) come from the installed
``<Name>.json`` type descriptions, or are computed from them (TFMessage).
No rclpy and no ``*_msgs`` imports here.
"""
import functools
import hashlib
import importlib.util
import json
import os
import re
from typing import Dict, List, Optional, Tuple

from px100_control.errors import BagError

SEPARATOR = '=' * 80

PRIMITIVE_TYPES = frozenset((
    'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16', 'int32',
    'uint32', 'int64', 'uint64', 'string', 'wstring'))

#: .msg texts shipped with the package (used when the share directory does not have them).
HANDWRITTEN_MSGS: Dict[str, str] = {
    'tf2_msgs/msg/TFMessage': 'geometry_msgs/TransformStamped[] transforms\n',
    'geometry_msgs/msg/TransformStamped': (
        '# This expresses a transform from coordinate frame header.frame_id\n'
        '# to the coordinate frame child_frame_id at the time of header.stamp\n'
        'std_msgs/Header header\n'
        'string child_frame_id\n'
        'Transform transform\n'),
    'geometry_msgs/msg/Transform': (
        '# This represents the transform between two coordinate frames in free space.\n'
        'Vector3 translation\n'
        'Quaternion rotation\n'),
    'geometry_msgs/msg/Vector3': 'float64 x\nfloat64 y\nfloat64 z\n',
    'geometry_msgs/msg/Quaternion': ('float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n'),
    'std_msgs/msg/Header': 'builtin_interfaces/Time stamp\nstring frame_id\n',
    'builtin_interfaces/msg/Time': 'int32 sec\nuint32 nanosec\n',
}

# rosidl type ids of the type description (type_description_interfaces/FieldType)
_NESTED_UNBOUNDED_SEQUENCE = 145

_NAME = r'[A-Za-z][A-Za-z0-9_]*'
_TYPE_RE = re.compile(rf'^({_NAME})/(?:({_NAME})/)?({_NAME})$')


class MessageTypeError(BagError):
    """A message type name is malformed or its definition cannot be found."""


def normalize_type(type_name: str) -> str:
    """
    Return the full ``pkg/msg/Name`` form of ``pkg/Name`` or ``pkg/msg/Name``.

    :raises MessageTypeError: not a ROS 2 message type name
    """
    match = _TYPE_RE.match(str(type_name).strip())
    if match is None:
        raise MessageTypeError(f"'{type_name}' is not a ROS 2 message type name (pkg/msg/Name)")
    pkg, ns, name = match.groups()
    return f'{pkg}/{ns or "msg"}/{name}'


def _share_dir_candidates(package: str) -> List[str]:
    dirs = []
    try:
        from ament_index_python.packages import get_package_share_directory  # optional: ROS
        dirs.append(get_package_share_directory(package))
    except Exception:  # not in the index, or no ament_index_python at all
        pass
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError):
        spec = None
    if spec is not None and spec.origin:
        # <prefix>/lib/pythonX.Y/site-packages/<pkg>/__init__.py -> <prefix>/share/<pkg>
        path = os.path.dirname(os.path.abspath(spec.origin))
        for _ in range(6):
            path = os.path.dirname(path)
            cand = os.path.join(path, 'share', package)
            if os.path.isdir(cand):
                dirs.append(cand)
                break
    return dirs


def _interface_file(type_name: str, extension: str) -> Optional[str]:
    pkg, ns, name = normalize_type(type_name).split('/')
    for share in _share_dir_candidates(pkg):
        path = os.path.join(share, ns, name + extension)
        if os.path.isfile(path):
            return path
    return None


@functools.lru_cache(maxsize=None)
def msg_text(type_name: str) -> str:
    """
    Return the ``.msg`` text of one type (installed file, else the shipped text).

    :raises MessageTypeError: neither installed nor shipped
    """
    full = normalize_type(type_name)
    path = _interface_file(full, '.msg')
    if path is not None:
        with open(path, encoding='utf-8') as f:
            return f.read()
    if full in HANDWRITTEN_MSGS:
        return HANDWRITTEN_MSGS[full]
    raise MessageTypeError(f"no message definition for '{full}': its package is not installed "
                           '(no share/<pkg>/msg/<Name>.msg found)')


def msg_dependencies(text: str, package: str) -> List[str]:
    """
    Return the message types a ``.msg`` text refers to, as written (``pkg/Name``), sorted.

    Relative names are taken in ``package``; primitive types and constants are skipped.
    """
    deps = set()
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith('#'):
            continue
        ftype = line.split()[0]
        ftype = ftype.split('[', 1)[0].split('<', 1)[0]
        if ftype in PRIMITIVE_TYPES:
            continue
        if ftype == 'Header':
            ftype = 'std_msgs/Header'
        elif '/' not in ftype:
            ftype = f'{package}/{ftype}'
        deps.add(ftype)
    return sorted(deps)


@functools.lru_cache(maxsize=None)
def message_definition(type_name: str) -> str:
    """
    Return the concatenated ``ros2msg`` schema text of a type and all its dependencies.

    Example Input: ``'std_msgs/msg/String'`` Output: the text of String.msg.
    :raises MessageTypeError: the type or one of its dependencies has no definition
    """
    full = normalize_type(type_name)
    seen = set()

    def append(name: str, depth: int) -> str:
        if depth > 50:
            raise MessageTypeError(f"'{full}': message definitions nest too deep")
        text = msg_text(name)
        out = text
        for dep in msg_dependencies(text, normalize_type(name).split('/')[0]):
            if dep not in seen:
                seen.add(dep)
                out += '\n' + SEPARATOR + '\nMSG: ' + dep + '\n' + append(dep, depth + 1)
        return out

    return append(full, 0)


def split_definition(schema_text: str) -> List[Tuple[str, str]]:
    """Return [(type name or '' for the root, .msg text)] of a concatenated schema."""
    parts = []
    for i, chunk in enumerate(re.split(r'^={80}\n', schema_text, flags=re.MULTILINE)):
        if i == 0:
            parts.append(('', chunk))
            continue
        first, _, rest = chunk.partition('\n')
        parts.append((first[len('MSG: '):].strip() if first.startswith('MSG: ') else '', rest))
    return parts


def _hashable(description: dict) -> dict:
    return {
        'type_name': description['type_name'],
        'fields': [{'name': f['name'], 'type': f['type']} for f in description['fields']],
    }


def rihs01(type_description_msg: dict) -> str:
    """
    Return the RIHS01 hash of a type description (``{type_description, referenced_...}``).

    The ROS 2 type hash: sha256 of the compact JSON of the description without default values,
    referenced types sorted by name (REP 2011).
    """
    refs = sorted(type_description_msg['referenced_type_descriptions'],
                  key=lambda d: d['type_name'])
    data = {
        'type_description': _hashable(type_description_msg['type_description']),
        'referenced_type_descriptions': [_hashable(r) for r in refs],
    }
    text = json.dumps(data, skipkeys=False, ensure_ascii=True, check_circular=True,
                      allow_nan=False, indent=None, separators=(', ', ': '), sort_keys=False)
    return 'RIHS01_' + hashlib.sha256(text.encode('utf-8')).hexdigest()


@functools.lru_cache(maxsize=None)
def type_description(type_name: str) -> Optional[dict]:
    """Return the installed type description JSON of a type (None when not installed)."""
    full = normalize_type(type_name)
    if full == 'tf2_msgs/msg/TFMessage':
        stamped = type_description('geometry_msgs/msg/TransformStamped')
        if stamped is None:
            return None
        td = stamped['type_description_msg']
        refs = [td['type_description']] + list(td['referenced_type_descriptions'])
        field = {'name': 'transforms', 'default_value': '', 'type': {
            'type_id': _NESTED_UNBOUNDED_SEQUENCE, 'capacity': 0, 'string_capacity': 0,
            'nested_type_name': 'geometry_msgs/msg/TransformStamped'}}
        msg = {'type_description': {'type_name': full, 'fields': [field]},
               'referenced_type_descriptions': sorted(refs, key=lambda d: d['type_name'])}
        return {'type_description_msg': msg, 'type_hashes': [{'type_name': full,
                                                             'hash_string': rihs01(msg)}]}
    path = _interface_file(full, '.json')
    if path is None:
        return None
    try:
        with open(path, encoding='utf-8') as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


@functools.lru_cache(maxsize=None)
def type_hash(type_name: str) -> str:
    """Return the ``RIHS01_...`` hash of a type, or '' when its description is not installed."""
    full = normalize_type(type_name)
    desc = type_description(full)
    if not desc:
        return ''
    for entry in desc.get('type_hashes', ()):
        if entry.get('type_name') == full:
            return entry.get('hash_string', '')
    return rihs01(desc['type_description_msg'])
