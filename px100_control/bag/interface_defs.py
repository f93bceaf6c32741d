"""
Bag schemas of the types generated from services and actions (``pkg/srv/X_Event``, ...).

A service event topic carries ``<pkg>/srv/<Name>_Event`` (``info``, ``request[<=1]``,
``response[<=1]``); an action's topics and service events carry ``<pkg>/action/<Name>_...``
types (``_SendGoal_Event``, ``_GetResult_Event``, ``_FeedbackMessage``). No ``.msg`` file
defines them: rosidl builds them from the ``.srv``/``.action``. rosbag2 (Jazzy) stores the raw
``.srv`` text for a service event (a ``SRV:`` section, which rosbags and mcap-ros2-support cannot
parse, ros2/rosbag2#2365) and nothing for action types. Here they get a ``ros2idl`` schema in
rosbag2's concatenated form (each struct after 80 ``=`` and ``IDL: pkg/ns/Name``, the root
first), built from the installed type description (``share/<pkg>/<ns>/<Name>.json``, which
lists every struct with its fields); the ``.msg`` types they use get their installed ``.idl``
files. No ``#include`` lines: every struct is in the schema, and rosbags (0.11) cannot parse
them. rosbags decodes these schemas and finds the same RIHS01 hash. No rclpy here.
"""
import functools
import json
from typing import Dict, List, Optional, Tuple

from px100_control.bag.msgdefs import (_interface_file, message_definition, MessageTypeError,
                                       normalize_type, SEPARATOR, type_hash)

#: IDL names of the type_description_interfaces/FieldType ids (plain types, 1..22)
_IDL_TYPES = {2: 'int8', 3: 'uint8', 4: 'int16', 5: 'uint16', 6: 'int32', 7: 'uint32',
              8: 'int64', 9: 'uint64', 10: 'float', 11: 'double', 12: 'long double',
              13: 'char', 14: 'wchar', 15: 'boolean', 16: 'octet', 17: 'string',
              18: 'wstring', 19: 'string', 20: 'wstring', 21: 'string', 22: 'wstring'}
_NESTED, _ARRAY, _BOUNDED, _UNBOUNDED = 1, 48, 96, 144


def is_generated(type_name: str) -> bool:
    """Return True for a type made by rosidl from a .srv or .action (``pkg/srv/..``, ...)."""
    return normalize_type(type_name).split('/')[1] in ('srv', 'action')


@functools.lru_cache(maxsize=None)
def _interface_description(type_name: str) -> Optional[dict]:
    """Return the installed type description JSON of the .srv/.action that made a type."""
    pkg, ns, name = normalize_type(type_name).split('/')
    path = _interface_file(f'{pkg}/{ns}/{name.split("_")[0]}', '.json')
    if path is None:
        return None
    try:
        with open(path, encoding='utf-8') as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def _descriptions(type_name: str) -> Dict[str, dict]:
    full = normalize_type(type_name)
    doc = _interface_description(full)
    if doc is None:
        raise MessageTypeError(f"no definition for '{full}': its package is not installed "
                               '(no share/<pkg>/<srv|action>/<Name>.json found)')
    msg = doc['type_description_msg']
    out = {d['type_name']: d for d in msg['referenced_type_descriptions']}
    out[msg['type_description']['type_name']] = msg['type_description']
    if full not in out:
        raise MessageTypeError(f"no definition for '{full}' in its interface's description")
    return out


def _idl_type(field_type: dict, typedefs: List[str], field_name: str) -> Tuple[str, str]:
    """Return (IDL type, declarator) of a field; array typedefs are appended to typedefs."""
    tid = field_type['type_id']
    base_id = tid % _ARRAY or _ARRAY
    kind = tid - base_id
    if base_id == _NESTED:
        base = field_type['nested_type_name'].replace('/', '::')
    else:
        base = _IDL_TYPES[base_id]
        if base_id in (19, 20, 21, 22) and field_type['string_capacity']:
            base = f"{base}<{field_type['string_capacity']}>"
    capacity = field_type['capacity']
    if kind == _ARRAY:
        alias = f"{base.replace('::', '__').replace('<', '').replace('>', '')}__{capacity}"
        typedefs.append(f'typedef {base} {alias}[{capacity}];')
        return alias, field_name
    if kind == _BOUNDED:
        return f'sequence<{base}, {capacity}>', field_name
    if kind == _UNBOUNDED:
        return f'sequence<{base}>', field_name
    return base, field_name


def struct_idl(description: dict) -> str:
    """Return the IDL text of one struct of a type description (fields only, no constants)."""
    pkg, ns, name = description['type_name'].split('/')
    typedefs, members = [], []
    for field in description['fields']:
        typ, decl = _idl_type(field['type'], typedefs, field['name'])
        members.append(f'      {typ} {decl};')
    lines = [
        f'module {pkg} {{', f'  module {ns} {{'] + [f'    {t}' for t in typedefs] + [
        f'    struct {name} {{'] + members + ['    };', '  };', '};']
    return '\n'.join(lines) + '\n'


def _reachable(root: str, descriptions: Dict[str, dict]) -> List[str]:
    """Return the types a struct uses, directly or not, sorted (the root excluded)."""
    seen, todo = set(), [root]
    while todo:
        for field in descriptions[todo.pop()]['fields']:
            nested = field['type']['nested_type_name']
            if nested and nested not in seen:
                seen.add(nested)
                todo.append(nested)
    seen.discard(root)
    return sorted(seen)


@functools.lru_cache(maxsize=None)
def generated_definition(type_name: str) -> str:
    """
    Return rosbag2's concatenated ``ros2idl`` schema of a service/action generated type.

    :raises MessageTypeError: its interface package is not installed
    """
    full = normalize_type(type_name)
    descriptions = _descriptions(full)
    parts = []
    for name in [full] + _reachable(full, descriptions):
        path = None if is_generated(name) else _interface_file(name, '.idl')
        if path is not None:
            with open(path, encoding='utf-8') as f:
                text = ''.join(line for line in f if not line.startswith('#include'))
        else:
            text = struct_idl(descriptions[name])
        parts.append(f'{SEPARATOR}\nIDL: {name}\n{text}')
    return '\n'.join(parts)


def schema(type_name: str) -> Tuple[str, str]:
    """
    Return (schema encoding, concatenated definition) of any type for a bag's schema record.

    ``ros2msg`` for ``.msg`` types (:func:`message_definition`), ``ros2idl`` for the types made
    from services and actions (:func:`generated_definition`).
    :raises MessageTypeError: malformed name, or the definition is not installed
    """
    if is_generated(type_name):
        return 'ros2idl', generated_definition(type_name)
    return 'ros2msg', message_definition(type_name)


@functools.lru_cache(maxsize=None)
def any_type_hash(type_name: str) -> str:
    """Return the RIHS01 hash of a type (also service/action generated ones; '' if unknown)."""
    full = normalize_type(type_name)
    if not is_generated(full):
        return type_hash(full)
    doc = _interface_description(full)
    for entry in (doc or {}).get('type_hashes', ()):
        if entry.get('type_name') == full:
            return entry.get('hash_string', '')
    return ''
