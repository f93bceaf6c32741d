"""
The recorders running on this machine, by DDS domain: one small JSON file per recorder.

A recorder node writes its entry when it starts and removes it when its bag is closed; the
client reads the entries of its domain at startup (:mod:`px100_control.client.recorder_wait`).
DDS discovery between two processes started together takes seconds on a loaded machine; the
entry is there at once, so a client started just after ``record`` knows that a recorder is
coming and waits for its announcement on ``recorder/ready``. An entry whose process is gone
(SIGKILL) is ignored and removed. Directory: ``<tmp>/px100_control_recorders_<uid>``.
"""
import json
import os
import tempfile
from typing import Dict, Iterable, List


def _folder() -> str:
    return os.path.join(tempfile.gettempdir(), f'px100_control_recorders_{os.getuid()}')


def domain_id() -> str:
    """Return this process's ROS domain id as text (env ROS_DOMAIN_ID, default '0')."""
    return os.environ.get('ROS_DOMAIN_ID', '').strip() or '0'


def register(namespace: str, all_topics: bool, every_namespace: bool, topics: Iterable[str],
             output: str) -> str:
    """
    Write this process's recorder entry; return its path ('' when it cannot be written).

    :param namespace: the recorder's namespace (``/px100``; ``/`` for none)
    :param all_topics: it records every topic of its namespace
    :param every_namespace: ... and of every other namespace (``record -a``)
    :param topics: topics it records by name (absolute)
    :param output: its bag directory
    """
    folder = _folder()
    path = os.path.join(folder, f'{domain_id()}_{os.getpid()}_{id(output):x}.json')
    entry = {'pid': os.getpid(), 'domain': domain_id(), 'namespace': namespace,
             'all_topics': bool(all_topics), 'every_namespace': bool(every_namespace),
             'topics': sorted(topics), 'output': output}
    try:
        os.makedirs(folder, exist_ok=True)
        with open(path + '.tmp', 'w', encoding='utf-8') as f:
            json.dump(entry, f)
        os.replace(path + '.tmp', path)
    except OSError:
        return ''
    return path


def unregister(path: str) -> None:
    """Remove an entry written by register() (no error when it is gone)."""
    if path:
        try:
            os.remove(path)
        except OSError:
            pass


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def running(exclude_pid: int = -1) -> List[Dict]:
    """Return the entries of this domain's live recorders (except those of exclude_pid)."""
    folder, prefix = _folder(), f'{domain_id()}_'
    try:
        names = [n for n in os.listdir(folder) if n.startswith(prefix) and n.endswith('.json')]
    except OSError:
        return []
    out = []
    for name in names:
        path = os.path.join(folder, name)
        try:
            with open(path, encoding='utf-8') as f:
                entry = json.load(f)
        except (OSError, ValueError):
            continue
        pid = int(entry.get('pid', -1))
        if not _alive(pid):
            unregister(path)
        elif pid != exclude_pid:
            out.append(entry)
    return out


def records(entry: Dict, topic: str) -> bool:
    """Return True if the recorder of ``entry`` records ``topic`` (absolute name)."""
    prefix = entry.get('namespace', '/').rstrip('/') + '/'
    return topic in entry.get('topics', ()) or bool(entry.get('every_namespace')) or (
        bool(entry.get('all_topics')) and topic.startswith(prefix))
