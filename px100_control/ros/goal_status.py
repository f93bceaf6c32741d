"""
The trajectory server's goal outcomes as GoalStatus codes and /diagnostics messages.

A terminal status goes to /diagnostics as one DiagnosticStatus: name
``<robot_name>/trajectory_server``, ``hardware_id`` the action goal's UUID in hex, level OK /
WARN / ERROR for SUCCEEDED / CANCELED / ABORTED, value ``status`` its name.
"""
from action_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from px100_control.control.goal_executor import ABORTED, CANCELED, SUCCEEDED

STATUS_NAMES = {GoalStatus.STATUS_ACCEPTED: 'ACCEPTED', GoalStatus.STATUS_EXECUTING: 'EXECUTING',
                GoalStatus.STATUS_CANCELING: 'CANCELING',
                GoalStatus.STATUS_SUCCEEDED: 'SUCCEEDED',
                GoalStatus.STATUS_CANCELED: 'CANCELED', GoalStatus.STATUS_ABORTED: 'ABORTED'}
#: the goal executor's verdicts as GoalStatus codes
STATUS_CODES = {SUCCEEDED: GoalStatus.STATUS_SUCCEEDED, CANCELED: GoalStatus.STATUS_CANCELED,
                ABORTED: GoalStatus.STATUS_ABORTED}
DIAG_LEVEL = {GoalStatus.STATUS_SUCCEEDED: DiagnosticStatus.OK,
              GoalStatus.STATUS_CANCELED: DiagnosticStatus.WARN,
              GoalStatus.STATUS_ABORTED: DiagnosticStatus.ERROR}


def diagnostic(now_msg, name: str, goal_id: str, level, message: str,
               status: str) -> DiagnosticArray:
    """Return the /diagnostics message of a goal's outcome (``goal_id``: its UUID in hex)."""
    arr = DiagnosticArray()
    arr.header.stamp = now_msg
    arr.status = [DiagnosticStatus(level=level, name=name, message=message, hardware_id=goal_id,
                                   values=[KeyValue(key='status', value=status)])]
    return arr
