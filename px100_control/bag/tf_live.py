"""
What a live robot_state_publisher publishes, on plain values (no rclpy).

:class:`LiveTf` turns a robot_description (URDF text) into the fixed joints' transforms
(``/tf_static``), joint states into the movable joints' transforms (``/tf``, at most one per
``min_period_ns`` of the joint states' stamps, as robot_state_publisher's ``publish_frequency``)
and ``world/markers`` into the movable objects' frames ``<robot_name>/objects/<name>``
(children of the markers' frame, ``<robot_name>/base_link``). The tree and the object frames are
:mod:`px100_control.bag.tf` and :mod:`px100_control.bag.world`, which the recorder uses for the
/tf it writes into bags. Entries are (parent frame, child frame, (x, y, z) [m],
(qx, qy, qz, qw)); stamps [ns].
"""
import math
from typing import Iterable, List, Optional, Sequence

from px100_control.bag.tf import description_tree, TfTree
from px100_control.bag.world import object_tf_entries, WorldMarker
from px100_control.errors import InvalidInputError, RobotModelError


class LiveTf:
    """
    The state of a live /tf publisher: the current tree and the last /tf stamp.

    :param robot_name: frame prefix ``<robot_name>/`` ('' for none)
    :param min_period_ns: shortest stamp gap between two /tf of the joints [ns] (0: every
        joint state)
    """

    def __init__(self, robot_name: str, min_period_ns: int = 0):
        self.robot_name = robot_name.strip('/')
        self.min_period_ns = int(min_period_ns)
        self.tree: Optional[TfTree] = None
        self._last_ns: Optional[int] = None

    def set_description(self, urdf_xml: str) -> List[tuple]:
        """
        Use a robot_description from now on; return its fixed joints' entries (/tf_static).

        :raises InvalidInputError: not a usable URDF (the reason in one line); the previous
            tree stays
        """
        try:
            tree = description_tree(urdf_xml, self.robot_name)
        except RobotModelError as exc:
            raise InvalidInputError(f'robot_description is not a usable URDF: {exc}') from None
        self.tree = tree
        self._last_ns = None
        return tree.static_entries()

    def joint_state(self, names: Sequence[str], positions: Sequence[float],
                    stamp_ns: int) -> List[tuple]:
        """
        Return the /tf entries of one joint state ([] when no tree yet, none due or none known).

        Joints absent from the message get no transform (as robot_state_publisher). A stamp
        earlier than the last published one (a restarted clock) is published at once.

        :raises InvalidInputError: names and positions of different lengths
        """
        if len(names) != len(positions):
            raise InvalidInputError(f'joint_states has {len(names)} names but '
                                    f'{len(positions)} positions')
        if self.tree is None:
            return []
        last = self._last_ns
        if last is not None and last <= stamp_ns < last + self.min_period_ns:
            return []
        entries = self.tree.moving_entries(
            {n: float(p) for n, p in zip(names, positions) if math.isfinite(p)})
        if entries:
            self._last_ns = int(stamp_ns)
        return entries

    def objects(self, markers: Iterable[WorldMarker]) -> List[tuple]:
        """Return the /tf entries of the movable objects among ``world/markers``."""
        return object_tf_entries(markers, self.robot_name)
