"""
A small tf buffer without ROS: the latest transform of every frame, chained lookups.

Transforms arrive as (parent, child, translation [m], quaternion (x, y, z, w)), from /tf and
/tf_static (tf2_msgs/TFMessage; the ROS side unpacks them). Each child keeps its latest
transform (a static one stays until replaced); :meth:`TfBuffer.lookup` walks both frames up to
their common ancestor, so any two frames of one tree are connected. No time interpolation: a
lookup returns the latest transforms (what tf2's ``lookup_transform(..., Time())`` returns).
"""
import threading
import time
from typing import Dict, Optional, Sequence, Tuple

import numpy as np
from px100_control.errors import InvalidInputError


def transform_matrix(translation: Sequence[float], quaternion: Sequence[float]) -> np.ndarray:
    """Return the 4x4 homogeneous matrix of a translation [m] and a quaternion (x, y, z, w)."""
    q = np.asarray(quaternion, dtype=float)
    norm = np.linalg.norm(q)
    if not np.isfinite(norm) or norm < 1e-9:
        raise InvalidInputError(f'quaternion {tuple(q)} has no rotation (norm {norm})')
    x, y, z, w = q / norm
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = translation
    return T


class TfBuffer:
    """Latest transform per child frame; thread-safe (set from callbacks, read by scripts)."""

    def __init__(self):
        self._lock = threading.Lock()
        self._parent: Dict[str, Tuple[str, np.ndarray]] = {}   # child -> (parent, T_parent_child)
        self._changed = threading.Condition(self._lock)

    def set_transform(self, parent: str, child: str, translation, quaternion) -> None:
        """Store T_parent_child (leading '/' of frame names dropped, as tf2 does)."""
        parent, child = parent.lstrip('/'), child.lstrip('/')
        if not parent or not child or parent == child:
            raise InvalidInputError(f"transform '{parent}' -> '{child}' needs two distinct "
                                    'frame names')
        T = transform_matrix(translation, quaternion)
        with self._lock:
            self._parent[child] = (parent, T)
            self._changed.notify_all()

    def add_message(self, msg) -> list:
        """
        Store every transform of a tf2_msgs/TFMessage (read by its fields, no ROS import).

        :return: the reason of each transform refused (the others are stored)
        """
        refused = []
        for t in msg.transforms:
            v, q = t.transform.translation, t.transform.rotation
            try:
                self.set_transform(t.header.frame_id, t.child_frame_id, (v.x, v.y, v.z),
                                   (q.x, q.y, q.z, q.w))
            except InvalidInputError as exc:
                refused.append(str(exc))
        return refused

    def frames(self) -> list:
        """Return every frame the buffer knows, sorted."""
        with self._lock:
            return sorted(set(self._parent) | {p for p, _ in self._parent.values()})

    def ancestors(self, frame: str) -> list:
        """Return the parents of ``frame`` up to its tree's root, nearest first."""
        chain, frame = [], frame.lstrip('/')
        with self._lock:
            while frame in self._parent and self._parent[frame][0] not in chain:
                frame = self._parent[frame][0]
                chain.append(frame)
        return chain

    def lookup(self, target: str, source: str) -> np.ndarray:
        """
        Return T_target_source (4x4): a point in ``source`` times it is in ``target``.

        :raises InvalidInputError: a frame is unknown or the two are not connected (the text
            names both and the frames known)
        """
        target, source = target.lstrip('/'), source.lstrip('/')
        if target == source:
            return np.eye(4)
        with self._lock:
            t_chain, t_mats = self._root_transforms(target)
            s_chain, s_mats = self._root_transforms(source)
            known = sorted(set(self._parent) | {p for p, _ in self._parent.values()})
        if t_chain[-1] != s_chain[-1]:
            raise InvalidInputError(f"no tf path from '{source}' to '{target}' (known frames: "
                                    f'{known})')
        return np.linalg.inv(t_mats[0]) @ s_mats[0]

    def _root_transforms(self, frame: str):
        """Return ([frame, parent, ..., root], [T_root_frame, ...]) (lock held)."""
        chain, parents = [frame], []
        while chain[-1] in self._parent:
            parent, T_pc = self._parent[chain[-1]]
            if parent in chain:
                raise InvalidInputError(f"tf loop through '{parent}'")
            chain.append(parent)
            parents.append(T_pc)
        T_root = np.eye(4)
        mats = [np.eye(4)] * len(chain)
        for i in range(len(chain) - 2, -1, -1):
            T_root = T_root @ parents[i]
            mats[i] = T_root
        return chain, mats

    def wait_for(self, target: str, source: str, timeout: float) -> Optional[np.ndarray]:
        """Return lookup(target, source) once it succeeds within ``timeout`` [s], else None."""
        deadline = None
        while True:
            try:
                return self.lookup(target, source)
            except InvalidInputError:
                pass
            with self._lock:
                now = time.monotonic()
                deadline = now + timeout if deadline is None else deadline
                if now >= deadline:
                    return None
                self._changed.wait(min(0.1, deadline - now))
