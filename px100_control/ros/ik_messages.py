"""
The ik_service's requests and replies on the wire.

Requests (geometry_msgs/PoseStamped) are read from their serialized bytes; replies
(sensor_msgs/JointState on ``ik/solution``, diagnostic_msgs/DiagnosticStatus on ``ik/status``)
are written as CDR bytes (:mod:`px100_control.ros.cdr`) or into preallocated messages whose
changing fields alone are set per request. Positions [rad]; poses in the base frame [m].
"""
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from px100_control.ros import cdr
from px100_control.ros.conversions import stamp_id
from px100_control.wire.cdr import read_pose_stamped
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState


def parse_pose_stamped(raw: bytes, in_place: bool = True):
    """
    Return (stamp (builtin_interfaces/Time), frame_id, (x, y, z, qx, qy, qz, qw)) of a request.

    ``raw`` is a serialized geometry_msgs/PoseStamped, read in place (``wire.cdr``) when
    ``in_place`` (the reader agreed with rclpy at start); anything it cannot read goes through
    rclpy's deserializer.
    """
    got = read_pose_stamped(raw) if in_place else None
    if got is not None:
        sec, nanosec, frame, values = got
        return Time(sec=sec, nanosec=nanosec), frame, values
    msg = deserialize_message(raw, PoseStamped)
    p, o = msg.pose.position, msg.pose.orientation
    return msg.header.stamp, msg.header.frame_id, (p.x, p.y, p.z, o.x, o.y, o.z, o.w)


class IkReplies:
    """
    Build the (ik/solution, ik/status) pair of one request.

    :param names: the arm joint names of ``ik/solution``
    :param diag_name: ``name`` of every ``ik/status``
    """

    def __init__(self, names, diag_name: str):
        self._writer = cdr.JointStateWriter(list(names))
        self._diag_name = diag_name
        self._solution = JointState()
        self._solution.name = list(names)
        self._status = DiagnosticStatus()
        self._status.name = diag_name
        self._key_values = [KeyValue() for _ in range(8)]

    def raw(self, stamp, q, level: int, message: str, values):
        """Return the pair as CDR bytes (q None: no solution; values: (key, text) pairs)."""
        solution = self._writer.write(stamp.sec, stamp.nanosec,
                                      () if q is None else [float(x) for x in q])
        status = cdr.diagnostic_status(level, self._diag_name, message, stamp_id(stamp),
                                       values)
        return solution, status

    def messages(self, stamp, q, level: int, message: str, values):
        """Return the pair in reused message objects, valid until the next call."""
        sol = self._solution
        sol.header.stamp = stamp
        sol.position = [] if q is None else [float(x) for x in q]
        st = self._status
        st.level = level
        st.message = message
        st.hardware_id = stamp_id(stamp)
        pool = self._key_values
        while len(pool) < len(values):
            pool.append(KeyValue())
        for kv, (key, value) in zip(pool, values):
            kv.key = key
            kv.value = value
        st.values = pool[:len(values)]
        return sol, st
