"""
``bot.world``: the simulated scene seen from a script (a px100_control extension).

Not part of Interbotix's API (which has no objects); it sits next to it and changes none of its
signatures::

    bot = InterbotixManipulatorXS('px100', 'arm', 'gripper', bringup=True)
    robot_startup()
    bot.world.list_objects()                 # ['blue_cylinder', 'green_cube', 'red_cube']
    T = bot.world.get_object_pose('red_cube')            # (4, 4) in <robot_name>/base_link [m]
    xyz, quat = bot.world.get_object_position_quaternion('red_cube')   # quat (x, y, z, w)
    bot.world.held_object()                  # 'red_cube' while it is between the fingers, else ''
    bot.world.reset()                        # objects back to their initial poses

It reads sim_driver's ``world/markers`` and ``world/held_object`` (both transient local: the
last state arrives on connection) and calls its ``world/reset`` service. Poses are in the robot
base frame ``<robot_name>/base_link``, in meters, as recent as ``world_rate`` (30 Hz) allows.
An unknown object name raises :class:`InterbotixException` listing the known ones; no world
data within the timeout raises it too, naming the topic.
"""
import threading
import time
from typing import Dict, List, Optional, Tuple

import numpy as np
from px100_control.bag.world import MARKER_NS, WorldMarker
from px100_control.client.robot import InterbotixException
from px100_control.kinematics.rotations import quaternion_to_matrix
from px100_control.ros.world_msgs import markers_of
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

_LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: how long [s] calls wait for the first world/markers message
WORLD_TIMEOUT = 5.0


class InterbotixWorldInterface:
    """
    The scene of the robot's sim_driver: objects, their poses, the held object, reset.

    :param core: the robot's InterbotixRobotXSCore (its node and namespace)
    """

    def __init__(self, core):
        self.core = core
        node = core.get_node()
        group = ReentrantCallbackGroup()
        self._lock = threading.Lock()
        self._have = threading.Event()
        self._markers: Dict[str, WorldMarker] = {}
        self._held: Optional[str] = None
        self._stamp_ns = 0
        self._count = 0
        self.sub_markers = node.create_subscription(
            MarkerArray, core.topic('world/markers'), self._on_markers, _LATCHED,
            callback_group=group)
        self.sub_held = node.create_subscription(
            String, core.topic('world/held_object'), self._on_held, _LATCHED,
            callback_group=group)
        self.srv_reset = node.create_client(Trigger, core.topic('world/reset'),
                                            callback_group=group)

    # -- callbacks ------------------------------------------------------------------------------
    def _on_markers(self, msg: MarkerArray) -> None:
        markers = {m.name: m for m in markers_of(msg)}
        stamp = msg.markers[0].header.stamp if msg.markers else None
        with self._lock:
            self._markers = markers
            self._count += 1
            if stamp is not None:
                self._stamp_ns = stamp.sec * 1_000_000_000 + stamp.nanosec
        self._have.set()

    def _on_held(self, msg: String) -> None:
        with self._lock:
            self._held = msg.data

    # -- queries --------------------------------------------------------------------------------
    def _snapshot(self, timeout: float) -> Dict[str, WorldMarker]:
        if not self._have.wait(timeout):
            raise InterbotixException(
                f"no world on '{self.core.topic('world/markers')}' within {timeout:.1f} s: is "
                'sim_driver running with a scene (parameter scene, e.g. pick_place)?')
        with self._lock:
            return dict(self._markers)

    def wait_for_update(self, timeout: float = 1.0) -> bool:
        """Wait until a world/markers message newer than the last one seen arrives."""
        with self._lock:
            count = self._count
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            with self._lock:
                if self._count > count:
                    return True
            time.sleep(0.005)
        return False

    def list_objects(self, kind: Optional[str] = 'object',
                     timeout: float = WORLD_TIMEOUT) -> List[str]:
        """
        Return the names of the scene's bodies, sorted.

        :param kind: 'object' (movable, default), 'fixture', 'table', or None for all
        """
        markers = self._snapshot(timeout)
        if kind is not None and kind not in MARKER_NS:
            raise InterbotixException(f'kind must be one of {sorted(MARKER_NS)} or None, '
                                      f'not {kind!r}')
        return sorted(n for n, m in markers.items()
                      if kind is None or m.ns == MARKER_NS[kind])

    def get_object_info(self, name: str, timeout: float = WORLD_TIMEOUT) -> WorldMarker:
        """
        Return everything published about a body: ns, shape, scale (full extents [m]), rgba, pose.

        :raises InterbotixException: no body of that name
        """
        markers = self._snapshot(timeout)
        if name not in markers:
            raise InterbotixException(
                f"no object '{name}' in the scene (known: {', '.join(sorted(markers)) or 'none'})")
        return markers[name]

    def get_object_position_quaternion(self, name: str, timeout: float = WORLD_TIMEOUT
                                       ) -> Tuple[np.ndarray, np.ndarray]:
        """Return (position (3,) [m], quaternion (x, y, z, w)) of a body in the base frame."""
        m = self.get_object_info(name, timeout)
        return np.array(m.position), np.array(m.orientation)

    def get_object_pose(self, name: str, timeout: float = WORLD_TIMEOUT) -> np.ndarray:
        """Return the (4, 4) pose of a body in ``<robot_name>/base_link`` [m]."""
        p, q = self.get_object_position_quaternion(name, timeout)
        T = np.eye(4)
        T[:3, :3] = quaternion_to_matrix(*q)
        T[:3, 3] = p
        return T

    def get_object_poses(self, timeout: float = WORLD_TIMEOUT) -> Dict[str, np.ndarray]:
        """Return {name: (4, 4) pose} of every movable object (one consistent snapshot)."""
        out = {}
        for name, m in self._snapshot(timeout).items():
            if m.ns == MARKER_NS['object']:
                T = np.eye(4)
                T[:3, :3] = quaternion_to_matrix(*m.orientation)
                T[:3, 3] = m.position
                out[name] = T
        return out

    def held_object(self) -> str:
        """Return the name of the object held between the fingers ('' when none)."""
        with self._lock:
            return self._held or ''

    def reset(self, timeout: float = 3.0) -> bool:
        """Put the scene's objects back at their initial poses (the arm stays); True on success."""
        if not self.srv_reset.wait_for_service(timeout_sec=timeout):
            self.core.get_node().logerror(
                f"Failed to find service '{self.core.topic('world/reset')}'.")
            return False
        ok = self.core._call(self.srv_reset, Trigger.Request(), timeout)
        if ok:
            self.wait_for_update(1.0)
        return ok
