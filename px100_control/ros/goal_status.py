"""
The trajectory server's message side: goals in, GoalStatus history and diagnostics out.

``goal_request`` turns a JointTrajectory into the goal executor's ``GoalRequest``;
``shape_error`` checks a serialized goal's names and array lengths before it is deserialized.

``StatusBook`` keeps the last ``limit`` goals' GoalStatus (keyed by the goal stamp, UUID =
``stamp_uuid(stamp)``), answers what CancelGoal returns for a goal that is not running, and
builds the /diagnostics message of a terminal status (name ``<robot_name>/trajectory_server``,
``hardware_id`` the goal id: ``sec.nanosec``, or an action goal's UUID in hex; level OK / WARN /
ERROR for SUCCEEDED / CANCELED / ABORTED).
"""
from collections import OrderedDict

from action_msgs.msg import GoalInfo, GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
import numpy as np
from px100_control.control import trajectory as tj
from px100_control.control.goal_executor import ABORTED, CANCELED, GoalRequest, SUCCEEDED
from px100_control.ros.conversions import seconds, stamp_id, stamp_key, stamp_uuid
from px100_control.wire.cdr import trajectory_shape

STATUS_NAMES = {GoalStatus.STATUS_ACCEPTED: 'ACCEPTED', GoalStatus.STATUS_EXECUTING: 'EXECUTING',
                GoalStatus.STATUS_CANCELING: 'CANCELING',
                GoalStatus.STATUS_SUCCEEDED: 'SUCCEEDED',
                GoalStatus.STATUS_CANCELED: 'CANCELED', GoalStatus.STATUS_ABORTED: 'ABORTED'}
TERMINAL = (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_CANCELED, GoalStatus.STATUS_ABORTED)
#: the goal executor's verdicts as GoalStatus codes
STATUS_CODES = {SUCCEEDED: GoalStatus.STATUS_SUCCEEDED, CANCELED: GoalStatus.STATUS_CANCELED,
                ABORTED: GoalStatus.STATUS_ABORTED}
DIAG_LEVEL = {GoalStatus.STATUS_SUCCEEDED: DiagnosticStatus.OK,
              GoalStatus.STATUS_CANCELED: DiagnosticStatus.WARN,
              GoalStatus.STATUS_ABORTED: DiagnosticStatus.ERROR}


def uuid_bytes(uuid) -> bytes:
    """Return a unique_identifier_msgs/UUID field as 16 bytes."""
    return np.asarray(uuid, dtype=np.uint8).tobytes()


def cancel_matches(status: GoalStatus, key: tuple, uuid: bytes, stamp: tuple) -> bool:
    """Return True when a CancelGoal request (uuid, stamp) names this goal, or all goals."""
    by_id, by_stamp = any(uuid), stamp != (0, 0)
    return ((not by_id and not by_stamp)
            or (by_id and uuid_bytes(status.goal_info.goal_id.uuid) == uuid)
            or (by_stamp and key <= stamp))


class StatusBook:
    """The GoalStatus of the recent goals, oldest first."""

    def __init__(self):
        """Start empty."""
        self.history: 'OrderedDict[tuple, GoalStatus]' = OrderedDict()

    def new(self, stamp, limit: int) -> GoalStatus:
        """Return a new ACCEPTED status of goal ``stamp``, keeping the last ``limit`` goals."""
        key = stamp_key(stamp)
        st = GoalStatus()
        st.goal_info = GoalInfo()
        st.goal_info.stamp = stamp
        st.goal_info.goal_id.uuid = list(stamp_uuid(stamp))
        st.status = GoalStatus.STATUS_ACCEPTED
        self.history.pop(key, None)
        self.history[key] = st
        while len(self.history) > limit:
            self.history.popitem(last=False)
        return st

    def message(self) -> GoalStatusArray:
        """Return the trajectory/status message."""
        msg = GoalStatusArray()
        msg.status_list = list(self.history.values())
        return msg

    def cancel_refusal(self, uuid: bytes, stamp: tuple) -> int:
        """Return CancelGoal's code when no running goal matches (terminated, unknown)."""
        by_id = any(uuid)
        named = None
        for key, st in self.history.items():
            if (by_id and uuid_bytes(st.goal_info.goal_id.uuid) == uuid) or (
                    not by_id and stamp != (0, 0) and key == stamp):
                named = st
        if named is not None and named.status in TERMINAL:
            return CancelGoal.Response.ERROR_GOAL_TERMINATED
        return (CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID if by_id
                else CancelGoal.Response.ERROR_REJECTED)

    def names(self) -> dict:
        """Return {goal id 'sec.nanosec': status name} of the recent goals."""
        return {f'{k[0]}.{k[1]:09d}': STATUS_NAMES.get(v.status, str(v.status))
                for k, v in self.history.items()}


def diagnostic(now_msg, name: str, key: tuple, level, message: str,
               status: str) -> DiagnosticArray:
    """Return the /diagnostics message of a goal's outcome (``key``: its stamp key or id text)."""
    arr = DiagnosticArray()
    arr.header.stamp = now_msg
    arr.status = [DiagnosticStatus(level=level, name=name, message=message,
                                   hardware_id=key if isinstance(key, str) else
                                   f'{key[0]}.{key[1]:09d}',
                                   values=[KeyValue(key='status', value=status)])]
    return arr


def goal_request(msg) -> GoalRequest:
    """Return the goal executor's view of a JointTrajectory (its point arrays, not copies)."""
    pts = msg.points
    return GoalRequest(key=stamp_key(msg.header.stamp), label=stamp_id(msg.header.stamp),
                       names=list(msg.joint_names),
                       times=[seconds(p.time_from_start) for p in pts],
                       positions=[p.positions for p in pts],
                       velocities=[p.velocities for p in pts],
                       accelerations=[p.accelerations for p in pts])


def shape_error(data: bytes, arm_names):
    """
    Return (stamp, reason) when a serialized goal's names or array lengths are wrong, else None.

    None also when the bytes cannot be read this way (the deserializer then says what is wrong).
    """
    try:
        (sec, nanosec), names, lengths = trajectory_shape(data)
    except ValueError:
        return None
    reason = tj.validate_shape(arm_names, names, lengths)
    return (Time(sec=sec, nanosec=nanosec), reason) if reason else None
