"""
One fuzz target per input of the px100 nodes: its hypothesis strategy and how to send and sync.

A target's ``send(msg)`` returns True when the node answered that input (the reply the contract
promises), False when no answer came within the bound, None when the input has no answer to
wait for. Valid requests used to prove the nodes still work afterwards live here too.
"""
from dataclasses import dataclass
import math
import time
from typing import Callable, Dict, List, Optional

from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from hypothesis import strategies as st
from px100_control_msgs.srv import ComputeCartesianPath, ComputeIK
from rcl_interfaces.msg import Parameter, ParameterType
from rcl_interfaces.srv import SetParameters, SetParametersAtomically
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectoryPoint

from . import strategies as S
from .harness import Limits, Probe

TERMINAL = (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_CANCELED, GoalStatus.STATUS_ABORTED)
#: reduced-form sizes per target (PX100_STRESS=full: 10,000 each)
REDUCED = {
    'commands/joint_setpoints': 200, 'joint_states': 150, 'torque_enable': 100, 'reset': 60,
    'compute_ik': 300, 'compute_cartesian_path': 150, 'follow_joint_trajectory': 100,
    'follow_joint_trajectory/cancel_goal': 200, '/sim_driver/set_parameters': 80,
    '/ik_service/set_parameters': 60, '/trajectory_server/set_parameters': 60,
}


def goal_of(trajectory) -> FollowJointTrajectory.Goal:
    """Return the FollowJointTrajectory goal of a JointTrajectory."""
    return FollowJointTrajectory.Goal(trajectory=trajectory)


def send_goal_and_wait(probe: Probe, goal, bound: float):
    """Send a goal; return its UUID in hex once a status names it (None: no answer in bound)."""
    with probe.cond:
        mark = probe.status_msgs
    handle = probe.send_goal(goal, bound)
    if handle is None or not handle.accepted:
        return None
    key = bytes(handle.goal_id.uuid).hex()
    ok = probe.wait_for(lambda: probe.status_seen_goals.get(key, 0) > mark, bound)
    return key if ok else None


@dataclass
class Target:
    """A fuzzable input: name, strategy, sender, and its node."""

    name: str
    node: str
    strategy: object
    send: Callable
    #: called before / after the campaign (parameter targets: snapshot and restore)
    before: Optional[Callable] = None
    after: Optional[Callable] = None


def _count(d: Dict[str, list], key: str) -> int:
    return len(d.get(key, ()))


def make_targets(probe: Probe, lim: Limits, params: Dict[str, List[str]] = None,
                 robot_name: str = 'px100') -> Dict[str, Target]:
    """
    Return every fuzz target of sim_driver, ik_service and trajectory_server.

    :param params: {node: [parameter names]} for the parameter-service targets
    """
    limits = lim.position_limits()
    vel = lim.velocity_ranges()
    sent_goals: List[bytes] = []

    def send_setpoint(msg):
        probe.publish_setpoint(msg)
        return probe.wait_joint_states(2, 1.0)

    def send_joint_state(msg):
        # trajectory_server reads joint_states: a second, lying publisher must not make it send
        # an invalid setpoint or die; nothing answers, so just let a driver sample follow
        probe.publish_joint_state(msg)
        probe.wait_joint_states(1, 0.5)
        return None

    def send_ik(req):
        res = probe.call(probe.cli_ik, req, 3.0)
        if res is not None and not all(math.isfinite(x) for x in res.solution.position):
            probe._violation('compute_ik', ['non-finite solution'], res)
        return res is not None

    def send_path(req):
        return probe.call(probe.cli_path, req, 3.0 + 0.01 * len(req.waypoints.poses)) is not None

    def send_goal(goal):
        # answered: the action status names the goal. A goal of huge arrays (up to 10,000
        # points x 10,000 values: 800 MB) takes seconds to serialize and deliver before the
        # server sees it, so the bound grows by 1 s per 100 MB
        values = sum(len(p.positions) + len(p.velocities) + len(p.accelerations)
                     + len(p.effort) for p in goal.trajectory.points)
        key = send_goal_and_wait(probe, goal, 3.0 + 8e-8 * values)
        if key is not None:
            sent_goals.append(bytes.fromhex(key))
            del sent_goals[:-50]
        return key is not None

    def send_cancel(req):
        return probe.call(probe.cli_cancel, req, 3.0) is not None

    def with_setpoint(client):
        def send(pair):
            req, setpoint = pair
            ok = probe.call(client, req, 3.0) is not None
            if setpoint is not None:
                probe.publish_setpoint(setpoint)
            probe.wait_joint_states(1, 0.5)
            return ok
        return send

    def param_sender(node):
        cli = probe.param_client(node, 'set_parameters')

        def send(plist):
            res = probe.call(cli, SetParameters.Request(parameters=plist), 3.0)
            if res is None:
                return False
            for p, r in zip(plist, res.results):
                v = p.value
                bad = (v.type == ParameterType.PARAMETER_DOUBLE
                       and not math.isfinite(v.double_value)) or (
                    v.type == ParameterType.PARAMETER_DOUBLE_ARRAY
                    and not all(math.isfinite(x) for x in v.double_array_value))
                if r.successful and bad and p.name in params.get(node, ()):
                    probe._violation(f'/{node}/set_parameters',
                                     [f'accepted non-finite value for {p.name}'], p)
            if node == 'sim_driver':
                # a few ms of the driver running on the new values (bounded: a fuzzed slow
                # publish rate must not make every later input wait a full period)
                probe.wait_joint_states(1, 0.1)
            return True
        return send

    setpoints = S.joint_states(lim.known, limits, vel, robot_name)
    # service calls interleaved with setpoints (torque off + setpoints, reset mid-move...)
    maybe_setpoint = st.one_of(st.none(), setpoints)
    targets = {
        'commands/joint_setpoints': Target(
            'commands/joint_setpoints', 'sim_driver', setpoints, send_setpoint),
        'joint_states': Target('joint_states', 'trajectory_server', setpoints, send_joint_state),
        'torque_enable': Target('torque_enable', 'sim_driver',
                                st.tuples(S.setbool_requests(), maybe_setpoint),
                                with_setpoint(probe.cli_torque)),
        'reset': Target('reset', 'sim_driver', st.tuples(S.trigger_requests(), maybe_setpoint),
                        with_setpoint(probe.cli_reset)),
        'compute_ik': Target('compute_ik', 'ik_service', S.pose_stampeds(robot_name).map(
            lambda msg: ComputeIK.Request(target=msg)), send_ik),
        'compute_cartesian_path': Target(
            'compute_cartesian_path', 'ik_service', S.pose_arrays(robot_name).map(
                lambda msg: ComputeCartesianPath.Request(waypoints=msg)), send_path),
        'follow_joint_trajectory': Target(
            'follow_joint_trajectory', 'trajectory_server',
            S.joint_trajectories(lim.arm, limits, vel, robot_name).map(goal_of), send_goal),
        'follow_joint_trajectory/cancel_goal': Target(
            'follow_joint_trajectory/cancel_goal', 'trajectory_server',
            S.cancel_requests(known_stamps=()), send_cancel),
    }
    for node, names in (params or {}).items():
        saved = {}
        targets[f'/{node}/set_parameters'] = Target(
            f'/{node}/set_parameters', node, S.parameter_sets(names), param_sender(node),
            before=lambda node=node, names=names, saved=saved: saved.update(
                {node: probe.get_parameters(node, names)}),
            after=lambda node=node, saved=saved: restore_parameters(probe, node,
                                                                    saved.get(node)))
    targets['_sent_goals'] = sent_goals
    return targets


def restore_parameters(probe: Probe, node: str, values) -> List[str]:
    """
    Set a node's parameters back to a snapshot {name: ParameterValue}; return those that failed.

    All at once first (a node checks rates against each other: restoring them one by one can
    be refused in one order), then one by one, repeated while that makes progress.
    """
    if not values:
        return []
    now = probe.get_parameters(node, list(values))
    if now is None:
        return list(values)
    # only those that changed (read-only ones cannot, and setting them is refused)
    params = [Parameter(name=name, value=value) for name, value in values.items()
              if now.get(name) != value]
    if not params:
        return []
    res = probe.call(probe.param_client(node, 'set_parameters_atomically'),
                     SetParametersAtomically.Request(parameters=params), 3.0)
    if res is not None and res.result.successful:
        return []
    cli = probe.param_client(node, 'set_parameters')
    pending = params
    while pending:
        failed = []
        for p in pending:
            res = probe.call(cli, SetParameters.Request(parameters=[p]), 3.0)
            if res is None or not res.results[0].successful:
                failed.append(p)
        if len(failed) == len(pending):
            break
        pending = failed
    return [p.name for p in pending]


# -- valid requests: the nodes still work ----------------------------------------------------

def level_of(status: DiagnosticStatus) -> int:
    """Return a DiagnosticStatus level as an int (rclpy gives a 1-byte bytes object)."""
    lv = status.level
    return lv[0] if isinstance(lv, (bytes, bytearray)) else int(lv)


def ik_works(probe: Probe, model, timeout: float = 3.0) -> str:
    """Call compute_ik for a reachable target; return '' if solved, else what went wrong."""
    from px100_control.ros.conversions import matrix_to_pose
    q = [0.3, -0.2, 0.4, 0.2][:model.dof]
    target = PoseStamped(pose=matrix_to_pose(model.fk(q)))
    target.header.frame_id = f'{probe.ns.strip("/")}/base_link'
    res = probe.call(probe.cli_ik, ComputeIK.Request(target=target), timeout)
    if res is None:
        return f'no compute_ik response for a reachable target within {timeout} s'
    if not res.success or not res.solution.position:
        return f'reachable target not solved: {res.message!r}'
    return ''


#: the px100 sleep pose [rad]
SLEEP = (0.0, -1.88, 1.5, 0.8)
#: a gentle valid goal from the sleep pose: waist +0.3 rad (no gravity load on that joint)
GENTLE = (0.3, -1.88, 1.5, 0.8)


def goal_works(probe: Probe, lim: Limits, target=GENTLE, duration: float = 2.0,
               timeout: float = 8.0) -> str:
    """
    Send a valid one-point goal; return '' if the server ran it to the end, else what is wrong.

    Served means: ACCEPTED/EXECUTING, setpoints sent, then a terminal status within timeout.
    SUCCEEDED is not required: on 2 shared cores a CPU-starved simulation sometimes lags its
    setpoints by more than ``path_tolerance`` and the server (rightly) aborts for tracking; such
    endings are counted in ``probe.tracking_aborts`` and reported, not failed. Any other ABORTED
    reason for this valid goal (refused as invalid...) is a failure.
    """
    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = list(lim.arm)
    p = JointTrajectoryPoint()
    p.positions = [float(v) for v in target]
    p.time_from_start = Duration(sec=int(duration), nanosec=int((duration % 1) * 1e9))
    goal.trajectory.points = [p]
    with probe.cond:
        setpoints_before = probe.setpoints_seen
    handle = probe.send_goal(goal, timeout)
    if handle is None or not handle.accepted:
        return f'valid goal not accepted within {timeout} s: {handle}'
    key = bytes(handle.goal_id.uuid).hex()
    if not probe.wait_for(lambda: probe.goal_status.get(key) in TERMINAL, timeout):
        return f'valid goal not finished within {timeout} s (status ' \
               f'{probe.goal_history.get(key)})'
    probe.goals_checked += 1
    if probe.goal_status[key] == GoalStatus.STATUS_SUCCEEDED:
        return ''
    probe.wait_for(lambda: any(d.hardware_id == key for d in probe.diagnostics), 1.0)
    reasons = [d.message for d in list(probe.diagnostics) if d.hardware_id == key]
    history = probe.goal_history.get(key)
    executed = GoalStatus.STATUS_EXECUTING in (history or ()) and \
        probe.setpoints_seen > setpoints_before
    if probe.goal_status[key] == GoalStatus.STATUS_ABORTED and executed and any(
            'tracking error' in r or 'did not settle' in r for r in reasons):
        probe.tracking_aborts.append(f'{key}: {reasons[0]}')
        return ''
    return f'valid goal ended {probe.goal_status[key]} (history {history}): {reasons}'


ARM = ('waist', 'shoulder', 'elbow', 'wrist_angle')


def _near(js, target, tol) -> bool:
    if js is None:
        return False
    by_name = dict(zip(js.name, js.position))
    return all(n in by_name and abs(by_name[n] - t) <= tol for n, t in zip(ARM, target))


def driver_works(probe: Probe) -> str:
    """Torque on and reset; return '' if both answered with success and joint_states flow."""
    r = probe.call(probe.cli_torque, SetBool.Request(data=True), 3.0)
    if r is None or not r.success:
        return f'torque_enable(true) failed: {r}'
    r = probe.call(probe.cli_reset, Trigger.Request(), 3.0)
    if r is None or not r.success:
        return f'reset failed: {r}'
    if not probe.wait_joint_states(10, 2.0):
        return 'joint_states stopped'
    # the driver really is back at the sleep pose (its state responds to commands)
    if not probe.wait_for(lambda: _near(probe.last_joint_state, SLEEP, 0.05), 2.0):
        return f'after reset the joints are not at the sleep pose: ' \
               f'{list(probe.last_joint_state.position)[:4]}'
    # let every node see the reset state before the next request (a goal sent at once would
    # start from the pre-reset measurement)
    time.sleep(0.5)
    return ''


def settle(probe: Probe, seconds: float = 0.3) -> None:
    """Let in-flight messages arrive."""
    time.sleep(seconds)
