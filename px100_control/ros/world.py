"""
The sim_driver's world surface: ``world/markers`` and ``world/held_object`` publishing.

A thin adapter: the bodies come from ``ArmSimulator.objects()`` / ``object_poses()`` /
``gripped_objects()``, the marker fields from :func:`px100_control.bag.world.world_markers`, the
messages from :mod:`px100_control.ros.world_msgs`. Both topics are transient local (a late
subscriber gets the last state at once). ``world/markers`` follows ``world_rate`` in the
driver's time (simulated time when it owns the clock); the MarkerArray is built once per scene
and then restamped with the objects' new poses (in its CDR bytes, when the middleware reads
them right). ``world/held_object`` is published when the held
object changes (checked at the same rate): taken when both pads lift it, kept while both still
touch it (set down, not yet released), lost once they stayed off it
:data:`~px100_control.bag.world.HELD_GRACE` s (:class:`~px100_control.bag.world.HeldFilter`).
"""
from typing import List, Optional

from px100_control.bag.world import HeldFilter, world_markers
from px100_control.errors import InvalidInputError
from px100_control.ros.common import LATCHED_QOS, robot_topic
from px100_control.ros.conversions import time_from_ns
from px100_control.ros.world_msgs import marker_array, raw_marker_writer, update_marker_array
from px100_control.sim.scene import load_scene
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray


#: the ``scene`` value that picks the robot file's own scene
AUTO_SCENE = 'auto'


class WorldPublisher:
    """
    Publish the world of a node's simulator.

    :param node: the sim_driver node (topics through ``robot_topic``)
    :param frame_id: the frame of the poses, ``'<robot_name>/base_link'``
    :param rate: world/markers rate [Hz]
    :param outbox: the node's :class:`~px100_control.ros.sim_messages.Outbox` (batched
        publishing while the physics runs as fast as possible, else at once)
    """

    def __init__(self, node, frame_id: str, rate: float, outbox):
        self.frame_id = frame_id
        self._outbox = outbox
        self.rate = float(rate)
        self.pub_markers = node.create_publisher(MarkerArray, robot_topic(node, 'world/markers'),
                                                 LATCHED_QOS)
        self.pub_held = node.create_publisher(String, robot_topic(node, 'world/held_object'),
                                              LATCHED_QOS)
        self._objects: Optional[List] = None
        self._scene = None                          # the scene of self._objects
        self._msg: Optional[MarkerArray] = None     # built once per scene, then updated
        self._movable: List = []                    # (marker index, object name)
        self._raw = None                            # the message's bytes writer, if any
        self._next_ns: Optional[int] = None
        #: the stamp [ns] of the last world/markers published (None before the first)
        self.last_stamp_ns: Optional[int] = None
        self._held: Optional[str] = None           # last published
        self._held_filter = HeldFilter()
        self.has_objects = False

    @staticmethod
    def load(scene: str, robot=None):
        """
        Return the Scene of a ``scene`` parameter value (None for '').

        ``'auto'`` takes the robot file's ``scene`` key (none when it has no such key): the
        default scene is laid out for the px100's reach and would stand in other arms' way.

        :param robot: the RobotModel whose reach every object must be in

        :raises Px100Error: the loader's reason (unknown scene, bad field, overlap, ...)
        """
        if not isinstance(scene, str):
            raise InvalidInputError(f'scene must be a string (a name or a .yaml path), '
                                    f'not {scene!r}')
        scene = scene.strip()
        if scene == AUTO_SCENE:
            scene = str(((getattr(robot, 'extra', None) or {}).get('scene')) or '')
        if not scene:
            return None
        return load_scene(scene, robot=robot)

    def _bodies(self, sim) -> List:
        if self._objects is None or sim.scene is not self._scene:     # a new scene
            self._scene = sim.scene
            self._objects = list(sim.objects())
            self.has_objects = bool(self._objects)
            self._msg = None
        return self._objects

    def publish_now(self, sim, stamp_ns: int) -> None:
        """Publish markers and the held object now (after a reset or a scene change)."""
        self._next_ns = None
        self._held = None
        self._held_filter.reset()
        self.tick(sim, stamp_ns)

    def tick(self, sim, stamp_ns: int) -> None:
        """Publish what is due at stamp_ns [ns] (called with every joint_states sample)."""
        bodies = self._bodies(sim)
        if not (self._next_ns is None or stamp_ns >= self._next_ns or
                stamp_ns < self._next_ns - 2e9 / self.rate):      # (the clock went back)
            return
        self._outbox.publish(self.pub_markers, self._markers(bodies, sim, stamp_ns))
        self.last_stamp_ns = stamp_ns
        period = int(round(1e9 / self.rate))
        self._next_ns = (stamp_ns + period if self._next_ns is None
                         or abs(stamp_ns - self._next_ns) > period
                         else self._next_ns + period)
        gripped = sim.gripped_objects() if bodies else {}
        lifted = next((name for name, off in gripped.items() if off), '')
        held = self._held_filter.update(lifted, stamp_ns, gripped)
        if held != self._held:
            self._held = held
            self.pub_held.publish(String(data=held))

    def _markers(self, bodies, sim, stamp_ns: int):
        """
        Return world/markers at ``stamp_ns`` [ns]: a MarkerArray or its CDR bytes.

        The message is built at the first call of a scene; later calls restamp it and move the
        objects, in its serialized bytes when the middleware reads them right.
        """
        stamp = time_from_ns(stamp_ns)
        if not bodies:
            return marker_array([], stamp)
        poses = sim.object_poses()
        if self._msg is None:
            self._msg = marker_array(world_markers(bodies, poses, self.frame_id), stamp)
            self._movable = [(i, b.name) for i, b in enumerate(bodies) if b.kind == 'object']
            self._raw = raw_marker_writer(self._msg, [i for i, _ in self._movable])
            return self._msg
        if self._raw is not None:
            return self._raw.write(stamp.sec, stamp.nanosec,
                                   [poses[name][0] + poses[name][1] for _, name in self._movable])
        update_marker_array(self._msg, stamp, [(i, poses[name]) for i, name in self._movable])
        return self._msg
