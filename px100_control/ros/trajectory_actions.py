"""
The trajectory server's ROS 2 actions, named as ros2_control's controllers name them.

- ``arm_controller/follow_joint_trajectory`` (control_msgs/action/FollowJointTrajectory),
  served by the trajectory server's goal executor (a new goal preempts the running one);
- ``gripper_controller/gripper_cmd`` (control_msgs/action/GripperCommand), for robots with a
  gripper (:mod:`px100_control.control.gripper_action`: position = the left finger [m]).

docs/ros_interfaces.md states their semantics. rclpy 7.1's EventsExecutor, which the nodes spin
in, does not serve rclpy action servers (goal requests are never taken), so the actions live on
a helper node ``trajectory_actions`` in the trajectory server's namespace (names resolved as
the server resolves them: its remaps apply), spun by a single-threaded executor in a thread of
its own; the engine is shared under the server's lock.
Every goal, cancel and result call is published as service introspection events
(:mod:`px100_control.ros.action_events`).
"""
import atexit
import threading
from typing import Optional
import weakref

from action_msgs.msg import GoalInfo, GoalStatus
from control_msgs.action import FollowJointTrajectory, GripperCommand
from px100_control.control.goal_executor import GOAL_TOLERANCE, GoalRequest
from px100_control.control.gripper import GripperLinkage
from px100_control.control.gripper_action import (closing_torque, gripper_target,
                                                  GripperGoalMonitor, GripperSettings,
                                                  SUCCEEDED)
from px100_control.errors import InvalidInputError
from px100_control.ros.action_events import IntrospectedActionServer
from px100_control.ros.common import robot_topic, spin_once
from px100_control.ros.conversions import seconds, stamp_key
from rclpy.action import CancelResponse, GoalResponse
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

ARM_ACTION = 'arm_controller/follow_joint_trajectory'
GRIPPER_ACTION = 'gripper_controller/gripper_cmd'
FJT = FollowJointTrajectory
STATUS = {'SUCCEEDED': GoalStatus.STATUS_SUCCEEDED, 'ABORTED': GoalStatus.STATUS_ABORTED,
          'CANCELED': GoalStatus.STATUS_CANCELED}
#: a preempted FollowJointTrajectory goal ends CANCELED with this, as in ros2_controllers' JTC
PREEMPTED = 'Current goal cancelled due to new incoming action.'


def _helper_node(server) -> Node:
    """
    Return the ``trajectory_actions`` node, on the server's time (wall, or ``/clock``).

    With ``use_sim_time`` its clock follows the server's time source instead of a ``/clock``
    subscription of its own: each ``/clock`` message woke this node's Python executor (at
    250 Hz of simulated time, 0.1 CPU core at twice real time). rclpy keeps a node's time
    source private (``Node._time_source``); without one the node subscribes itself.
    """
    sim_time = bool(server.get_parameter('use_sim_time').value)
    source = getattr(server, '_time_source', None)
    shared = sim_time and hasattr(source, 'attach_clock')
    node = Node('trajectory_actions', namespace=server.get_namespace(), context=server.context,
                use_global_arguments=False, start_parameter_services=False,
                parameter_overrides=[Parameter('use_sim_time', value=sim_time and not shared)])
    if shared:
        source.attach_clock(node.get_clock())
    return node


class ActionGoal:
    """The goal executor's tag of an action goal (read like a GoalStatus by the node)."""

    def __init__(self, handle):
        """Tag the accepted goal ``handle`` (a ServerGoalHandle)."""
        self.handle = handle
        self.goal_info = GoalInfo(goal_id=handle.goal_id, stamp=handle._goal_info.stamp)
        self.status = GoalStatus.STATUS_EXECUTING
        self.diag_id = bytes(handle.goal_id.uuid).hex()   # its /diagnostics hardware_id
        self.label = 'action ' + self.diag_id[:8]


def arm_goal_request(goal, names, tag: ActionGoal):
    """
    Return (GoalRequest, '') for a FollowJointTrajectory goal; (None, why) for wrong joints.

    :raises InvalidInputError: what the server does not support (multi-DOF trajectories,
        component, velocity or acceleration tolerances)
    """
    traj = goal.trajectory
    given = list(traj.joint_names)
    unknown = [n for n in given if n not in names]
    if not given or unknown or len(set(given)) != len(given):
        return None, (f'joint_names {given} must be distinct joints of the arm {list(names)}'
                      + (f': unknown {unknown}' if unknown else ''))
    if goal.multi_dof_trajectory.joint_names or goal.multi_dof_trajectory.points:
        raise InvalidInputError('multi_dof_trajectory is not supported: the arm has no '
                                'multi-DOF joints')
    if goal.component_path_tolerance or goal.component_goal_tolerance:
        raise InvalidInputError('component tolerances are not supported')
    for what, tols in (('path_tolerance', goal.path_tolerance),
                       ('goal_tolerance', goal.goal_tolerance)):
        for t in tols:
            if t.velocity > 0.0 or t.acceleration > 0.0:
                raise InvalidInputError(f"{what} of joint '{t.name}': only position tolerances "
                                        'are checked (velocity and acceleration must be 0 or '
                                        '-1)')
    if not traj.points:
        raise InvalidInputError('the trajectory has no points')
    pts = traj.points
    return GoalRequest(
        key=stamp_key(tag.goal_info.stamp), label=tag.label, names=given,
        times=[seconds(p.time_from_start) for p in pts], positions=[p.positions for p in pts],
        velocities=[p.velocities for p in pts], accelerations=[p.accelerations for p in pts],
        path_tolerance={t.name: t.position for t in goal.path_tolerance},
        goal_tolerance={t.name: t.position for t in goal.goal_tolerance},
        goal_time_tolerance=seconds(goal.goal_time_tolerance)), ''


class TrajectoryActions:
    """Serve both actions for a TrajectoryServerNode (its engine, lock and finish path)."""

    def __init__(self, server):
        """Create the helper node, the action servers and the executor thread."""
        self._server = server
        self._engine = server._engine
        self._lock = server._lock
        self.node = _helper_node(server)
        self._log = self.node.get_logger()

        def name(relative: str) -> str:   # as the server resolves it: its remaps apply
            return server.resolve_topic_name(robot_topic(server, relative))
        self.arm = IntrospectedActionServer(
            self.node, FJT, name(ARM_ACTION), self._on_arm_goal,
            goal_callback=lambda goal: GoalResponse.ACCEPT, cancel_callback=self._on_arm_cancel)
        self.gripper = self._grip = self._finger = None
        g = server.model.gripper
        if g is not None:
            self._gripper_joint, self._finger_joint = g.joint, g.fingers[0]
            self._linkage = GripperLinkage(g.horn_radius, g.arm_length, g.finger_lower,
                                           g.finger_upper)
            self.gripper = IntrospectedActionServer(
                self.node, GripperCommand, name(GRIPPER_ACTION), self._on_gripper_goal,
                goal_callback=lambda goal: GoalResponse.ACCEPT,
                cancel_callback=self._on_gripper_cancel)
            self._pub_setpoint = self.node.create_publisher(
                JointState, name('commands/joint_setpoints'), 10)
        rate = float(server.get_parameter('action_monitor_rate').value)
        self.node.create_timer(1.0 / rate, self._on_monitor)
        self._executor = SingleThreadedExecutor(context=server.context)
        self._executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name='trajectory_actions',
                                        daemon=True)
        self._thread.start()
        # a node left undestroyed (its process interrupted while it was being built) must not
        # keep spinning into interpreter finalization: a daemon thread that wakes in rclpy's
        # wait then aborts the process ("terminate called without an active exception")
        stop = weakref.WeakMethod(self._stop_spinning)
        atexit.register(lambda: stop() and stop()())

    def _spin(self) -> None:
        try:
            while not self._stop.is_set() and self.node.context.ok():
                spin_once(self._executor, 0.1)
        except ExternalShutdownException:
            pass

    def _stop_spinning(self, timeout: float = 5.0) -> None:
        self._stop.set()
        self._thread.join(timeout=timeout)

    def close(self) -> None:
        """Stop the executor thread and destroy the servers and the helper node."""
        self._stop_spinning()
        self._executor.shutdown(timeout_sec=1.0)
        for server in (self.arm, self.gripper):
            if server is not None:
                server.destroy()
        self.node.destroy_node()

    # ------------------------------------------------------------------ arm
    def _on_arm_goal(self, handle) -> None:
        """Start an accepted FollowJointTrajectory goal, or end it INVALID_* with the reason."""
        tag = ActionGoal(handle)
        code = FJT.Result.INVALID_GOAL
        try:
            req, reason = arm_goal_request(handle.request, self._engine.names, tag)
            if req is None:
                code = FJT.Result.INVALID_JOINTS
            else:
                self._start_arm_goal(req, tag)
        except InvalidInputError as exc:
            reason = str(exc)
        except Exception as exc:  # noqa: B902 - a bad goal must never stop the node
            reason = f'internal error planning the goal: {exc!r}'
        if reason:
            self._log.error(f'{ARM_ACTION} goal {tag.label} ABORTED (invalid, nothing sent): '
                            f'{reason}')
            self.arm.end(handle, GoalStatus.STATUS_ABORTED,
                         FJT.Result(error_code=code, error_string=reason))

    def _start_arm_goal(self, req, tag) -> None:
        """
        Start a valid goal; raise InvalidInputError when it cannot start.

        A goal sent just after the start waits (``state_timeout`` at most) for the driver's
        first joint_states, as a ros2_control controller is not active before it reads its
        state interfaces.
        """
        self._server.first_state.wait(self._engine.settings.state_timeout)
        with self._lock:
            self._server.start_goal(req, tag)

    def _on_arm_cancel(self, handle):
        with self._lock:
            g = self._engine.active
            if g is None or not isinstance(g.tag, ActionGoal) or g.tag.handle is not handle:
                return CancelResponse.REJECT
            self._server.cancel_active()
        return CancelResponse.ACCEPT

    def finished(self, goal, status: str, reason: str, code: str) -> None:
        """End an action goal that the engine ended; called under the server's lock."""
        tag = goal.tag
        if not isinstance(tag, ActionGoal):
            return
        result = FJT.Result(error_code=FJT.Result.SUCCESSFUL, error_string=reason)
        if status == 'ABORTED':
            result.error_code = (FJT.Result.GOAL_TOLERANCE_VIOLATED if code == GOAL_TOLERANCE
                                 else FJT.Result.PATH_TOLERANCE_VIOLATED)
        elif status == 'CANCELED' and tag.status != GoalStatus.STATUS_CANCELING:
            result.error_code = FJT.Result.INVALID_GOAL
            result.error_string = f'{PREEMPTED} ({reason})'
        tag.status = STATUS[status]
        self._executor.create_task(self.arm.end, tag.handle, STATUS[status], result)

    def _arm_feedback(self):
        """Return (handle, Feedback) of the running action goal, else None (under the lock)."""
        g, e = self._engine.active, self._engine
        if g is None or not isinstance(g.tag, ActionGoal) or g.last_q is None:
            return None
        fb = FJT.Feedback(joint_names=list(e.names))
        fb.header.stamp = self.node.get_clock().now().to_msg()
        fb.desired.positions, fb.desired.velocities = g.last_q.tolist(), g.last_qd.tolist()
        fb.actual.positions = e.meas.tolist()
        fb.error.positions = (g.last_q - e.meas).tolist()
        return g.tag.handle, fb

    # ------------------------------------------------------------------ gripper
    @property
    def finger_joint(self) -> Optional[str]:
        """Return the finger joint whose joint_states the gripper action follows (or None)."""
        return self._finger_joint if self.gripper is not None else None

    def note_finger(self, position: float, velocity: float, effort: float) -> None:
        """Take the finger's measured state [m, m/s, effort units] from joint_states."""
        self._finger = (position, velocity, effort)

    def _gripper_settings(self) -> GripperSettings:
        p = self._server.get_parameter
        return GripperSettings(p('gripper_goal_tolerance').value,
                               p('gripper_stall_velocity_threshold').value,
                               p('gripper_stall_timeout').value,
                               p('gripper_allow_stalling').value)

    def _gripper_result(self, cls, stalled=False, reached=False):
        pos, _, effort = self._finger or (0.0, 0.0, 0.0)
        return cls(position=pos, effort=effort, stalled=stalled, reached_goal=reached)

    def _on_gripper_goal(self, handle) -> None:
        """Start an accepted GripperCommand goal (preempting the running one), or abort it."""
        cmd = handle.request.command
        try:
            angle = gripper_target(self._linkage, cmd.position, cmd.max_effort)
        except InvalidInputError as exc:
            self._log.error(f'{GRIPPER_ACTION} goal ABORTED (nothing sent): {exc}')
            return self.gripper.end(handle, GoalStatus.STATUS_ABORTED,
                                    self._gripper_result(GripperCommand.Result))
        if self._grip is not None:
            self._end_gripper(GoalStatus.STATUS_CANCELED, 'preempted by a new goal')
        now = self.node.get_clock().now().nanoseconds
        if self._finger is None:   # just started: wait for the driver's first joint_states
            self._grip = [handle, None, angle, now]
            return
        self._start_gripper(handle, cmd, angle, now)

    def _start_gripper(self, handle, cmd, angle: float, now: int) -> None:
        settings = self._gripper_settings()
        self._grip = [handle, GripperGoalMonitor(cmd.position, settings, now), angle, False]
        pos = self._finger[0]
        if cmd.position < pos - settings.goal_tolerance:   # closing: force-limited
            self._grip[3] = True
            torque = closing_torque(self._linkage, cmd.max_effort,
                                    self._linkage.angle_from_finger(self._clip(pos)))
            self._pub_setpoint.publish(JointState(name=[self._gripper_joint], effort=[-torque]))
            words = f'closing with {torque:.3f} N*m'
        else:
            self._pub_setpoint.publish(JointState(name=[self._gripper_joint], position=[angle]))
            words = 'opening'
        self._log.info(f'{GRIPPER_ACTION}: fingers to {cmd.position:.4f} m '
                       f'(gripper {angle:.3f} rad), {words}')

    def _clip(self, finger: float) -> float:
        return min(max(finger, self._linkage.finger_lower), self._linkage.finger_upper)

    def _on_gripper_cancel(self, handle):
        ok = self._grip is not None and self._grip[0] is handle
        return CancelResponse.ACCEPT if ok else CancelResponse.REJECT

    def _end_gripper(self, status: int, words: str, stalled=False, reached=False) -> None:
        handle = self._grip[0]
        self._grip = None
        self._log.info(f'{GRIPPER_ACTION} goal {status_name(status)}: {words}')
        self.gripper.end(handle, status, self._gripper_result(GripperCommand.Result, stalled,
                                                              reached))

    def _monitor_gripper(self) -> None:
        handle, monitor, angle, closing = self._grip
        if monitor is None:   # waiting for the first joint_states since closing = its start
            timeout = float(self._server.get_parameter('state_timeout').value)
            if self._finger is not None:
                return self._start_gripper(handle, handle.request.command, angle, closing)
            if (self.node.get_clock().now().nanoseconds - closing) * 1e-9 > timeout:
                return self._end_gripper(GoalStatus.STATUS_ABORTED, 'no joint_states of the '
                                         f'gripper for state_timeout {timeout} s')
            return
        pos, vel, _ = self._finger
        if handle.is_cancel_requested:   # hold where the fingers are, as the JTC gripper does
            angle = self._linkage.angle_from_finger(self._clip(pos))
            self._pub_setpoint.publish(JointState(name=[self._gripper_joint], position=[angle]))
            return self._end_gripper(GoalStatus.STATUS_CANCELED, f'canceled at {pos:.4f} m')
        period = 1.0 / float(self._server.get_parameter('action_monitor_rate').value)
        if closing and pos <= monitor.goal + max(monitor.settings.goal_tolerance,
                                                 abs(vel) * period):
            self._grip[3] = False   # there (or there by the next check): hold the goal
            self._pub_setpoint.publish(JointState(name=[self._gripper_joint], position=[angle]))
        verdict = monitor.update(pos, vel, self.node.get_clock().now().nanoseconds)
        if verdict is None:
            handle.publish_feedback(self._gripper_result(GripperCommand.Feedback))
            return
        status, reached, stalled, words = verdict
        self._end_gripper(GoalStatus.STATUS_SUCCEEDED if status == SUCCEEDED
                          else GoalStatus.STATUS_ABORTED, words, stalled, reached)

    # ------------------------------------------------------------------ monitor
    def _on_monitor(self) -> None:
        """Publish feedback at action_monitor_rate; follow the gripper goal."""
        with self._lock:
            arm = self._arm_feedback()
        if arm is not None:
            arm[0].publish_feedback(arm[1])
        if self._grip is not None:
            self._monitor_gripper()


def status_name(status: int) -> str:
    """Return 'SUCCEEDED', 'ABORTED' or 'CANCELED' for a terminal GoalStatus code."""
    return {v: k for k, v in STATUS.items()}.get(status, str(status))
