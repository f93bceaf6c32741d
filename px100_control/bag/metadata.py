"""
rosbag2 ``metadata.yaml`` (version 9, as ROS 2 Jazzy writes it) and QoS profile records.

A QoS profile is a plain dict in rosbag2's v9 form: ``history``/``reliability``/``durability``/
``liveliness`` as lower-case names (``keep_last``, ``reliable``, ``transient_local``,
``automatic``...), ``depth``, and ``deadline``/``lifespan``/``liveliness_lease_duration`` as
``{sec, nsec}`` (infinite = ``{sec: 9223372036, nsec: 854775807}``). Times are integer ns.
"""
from dataclasses import dataclass, field
import os
from typing import Dict, List, Optional

from px100_control.errors import BagError
import yaml

METADATA_FILE = 'metadata.yaml'
#: rosbag2 metadata version of ROS 2 Jazzy
METADATA_VERSION = 9
ROS_DISTRO = 'jazzy'
INFINITE = {'sec': 9223372036, 'nsec': 854775807}


def qos_profile(reliability: str = 'reliable', durability: str = 'volatile',
                history: str = 'keep_last', depth: int = 10) -> dict:
    """Return a v9 QoS profile dict with infinite deadline, lifespan and lease duration."""
    return {
        'history': history, 'depth': int(depth), 'reliability': reliability,
        'durability': durability, 'deadline': dict(INFINITE), 'lifespan': dict(INFINITE),
        'liveliness': 'automatic', 'liveliness_lease_duration': dict(INFINITE),
        'avoid_ros_namespace_conventions': False,
    }


def duration_dict(ns: int) -> dict:
    """Return ``{sec, nsec}`` of a duration in ns (ROS 'infinite' for >= 2**63 - 1)."""
    ns = int(ns)
    if ns >= 2 ** 63 - 1:
        return dict(INFINITE)
    return {'sec': ns // 1_000_000_000, 'nsec': ns % 1_000_000_000}


def qos_to_yaml(profiles: List[dict]) -> str:
    """Return the YAML text of a list of QoS profiles (the MCAP channel metadata value)."""
    if not profiles:
        return ''
    return yaml.safe_dump(list(profiles), default_flow_style=False, sort_keys=False).strip()


def qos_from_yaml(text) -> List[dict]:
    """Return the QoS profile list of a channel metadata value or a v9 metadata entry."""
    if not text:
        return []
    if isinstance(text, list):
        return text
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise BagError(f'offered_qos_profiles is not valid YAML: {exc}') from None
    return data if isinstance(data, list) else []


@dataclass
class TopicRecord:
    """One topic of a bag: name, type, QoS offered by its publishers and message count."""

    name: str
    type_name: str
    offered_qos_profiles: List[dict] = field(default_factory=list)
    type_description_hash: str = ''
    message_count: int = 0
    serialization_format: str = 'cdr'


@dataclass
class FileRecord:
    """One storage file of a bag (path relative to the bag directory)."""

    path: str
    starting_time_ns: int = 0
    duration_ns: int = 0
    message_count: int = 0


def build_metadata(topics: List[TopicRecord], files: List[FileRecord],
                   custom_data: Optional[Dict[str, str]] = None) -> dict:
    """Return the ``rosbag2_bagfile_information`` document of a single-storage MCAP bag."""
    counted = [f for f in files if f.message_count]
    start = min((f.starting_time_ns for f in counted), default=0)
    end = max((f.starting_time_ns + f.duration_ns for f in counted), default=0)
    return {'rosbag2_bagfile_information': {
        'version': METADATA_VERSION,
        'storage_identifier': 'mcap',
        'duration': {'nanoseconds': int(end - start)},
        'starting_time': {'nanoseconds_since_epoch': int(start)},
        'message_count': int(sum(f.message_count for f in files)),
        'topics_with_message_count': [
            {'topic_metadata': {
                'name': t.name, 'type': t.type_name,
                'serialization_format': t.serialization_format,
                'offered_qos_profiles': list(t.offered_qos_profiles),
                'type_description_hash': t.type_description_hash},
             'message_count': int(t.message_count)}
            for t in topics],
        'compression_format': '',
        'compression_mode': '',
        'relative_file_paths': [f.path for f in files],
        'files': [{'path': f.path,
                   'starting_time': {'nanoseconds_since_epoch': int(f.starting_time_ns)},
                   'duration': {'nanoseconds': int(f.duration_ns)},
                   'message_count': int(f.message_count)} for f in files],
        'custom_data': dict(custom_data) if custom_data else None,
        'ros_distro': ROS_DISTRO,
    }}


def dump_metadata(doc: dict) -> str:
    """Return the YAML text of a metadata document."""
    return yaml.safe_dump(doc, default_flow_style=False, sort_keys=False)


def write_metadata(bag_dir: str, doc: dict) -> str:
    """Write ``metadata.yaml`` atomically (temp file + rename); return its path."""
    path = os.path.join(bag_dir, METADATA_FILE)
    tmp = path + '.tmp'
    with open(tmp, 'w', encoding='utf-8') as f:
        f.write(dump_metadata(doc))
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    return path


def read_metadata(bag_dir: str) -> dict:
    """
    Return the ``rosbag2_bagfile_information`` mapping of a bag directory.

    :raises BagError: missing, unreadable, not YAML, or not a rosbag2 metadata file
    """
    path = os.path.join(bag_dir, METADATA_FILE)
    try:
        with open(path, encoding='utf-8') as f:
            doc = yaml.safe_load(f)
    except OSError as exc:
        raise BagError(f'{path}: cannot read: {exc.strerror}') from None
    except yaml.YAMLError as exc:
        raise BagError(f'{path}: not valid YAML ({exc.__class__.__name__})') from None
    info = doc.get('rosbag2_bagfile_information') if isinstance(doc, dict) else None
    if not isinstance(info, dict):
        raise BagError(f'{path}: not a rosbag2 metadata file (no rosbag2_bagfile_information)')
    storage = info.get('storage_identifier')
    if storage != 'mcap':
        raise BagError(f"{path}: storage '{storage}' is not supported (only mcap bags)")
    paths = info.get('relative_file_paths')
    if not isinstance(paths, list) or not paths:
        raise BagError(f'{path}: lists no storage files (relative_file_paths is empty)')
    return info
