"""
trajectory_server: joint trajectory execution, as ROS 2 actions.

Names are those of docs/ros_interfaces.md, in the node's namespace. This node is wiring: it
declares the parameters, feeds the goal executor
(:mod:`px100_control.control.goal_executor`: planning, sampling, hold/resume, verdicts, the
watchdog) and publishes what it decides; the actions ``arm_controller/follow_joint_trajectory``
and ``gripper_controller/gripper_cmd`` (:mod:`px100_control.ros.trajectory_actions`) bring
the goals. A goal's outcome goes to its action result and /diagnostics, setpoints at ``rate`` to
``commands/joint_setpoints`` and ``trajectory/feedback``. The goal clock is the node clock
(``use_sim_time`` honoured); state freshness and the watchdog use the steady clock; a
``joint_states`` read late because this node stalled counts from its stamp, and a goal first
reads the joint_states queued behind it (the actions run in a thread of their own).
"""
from dataclasses import fields
import threading
import time
from typing import Optional

from action_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray
from px100_control.control.goal_executor import Goal, GoalExecutor, Outcome, Settings
from px100_control.control.goal_executor import settings_error
from px100_control.errors import InvalidInputError
from px100_control.parameters import TRAJECTORY_SERVER
from px100_control.ros.common import (declare_robot_parameters, init_robot_node, robot_name,
                                      robot_topic, spin_node)
from px100_control.ros.goal_status import DIAG_LEVEL, diagnostic, STATUS_CODES, STATUS_NAMES
from px100_control.ros.parameter_schema import declare_schema
from px100_control.ros.peers import new_duplicates
from px100_control.ros.trajectory_actions import TrajectoryActions
from px100_control.tools.latency import QueueDelay
from px100_control.tools.stall import StallMeter
from px100_control.wire.private_api import take_deserialized
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState

NODE_NAME = 'trajectory_server'

#: the stale-state watchdog's period [s]; a watchdog check this much later than the previous one
#: means the node was not scheduled (logged with what ran longest meanwhile)
WATCHDOG_PERIOD = 0.02
STALL_WARN = 0.25
#: the parameters the goal executor reads (goal_executor.Settings)
SETTINGS = [f.name for f in fields(Settings)]


class TrajectoryServerNode(Node):
    """Execute the actions' joint trajectories: setpoints, feedback, diagnostics."""

    def __init__(self, **node_kwargs):
        init_robot_node(self, NODE_NAME, node_kwargs)
        self.model = declare_robot_parameters(self)
        declare_schema(self, TRAJECTORY_SERVER)
        self.add_on_set_parameters_callback(self._check_parameters)
        bad = self._check_parameters(
            [self.get_parameter(name) for name in TRAJECTORY_SERVER.names]).reason
        if bad:
            raise InvalidInputError(f'trajectory_server parameters: {bad}')
        self._names = list(self.model.joint_names)
        self._index = {name: i for i, name in enumerate(self._names)}
        self._lock = threading.RLock()
        self.first_state = threading.Event()   # set once every arm joint has been measured
        self._rate = float(self.get_parameter('rate').value)
        self._diag_name = f'{robot_name(self) or "px100"}/{NODE_NAME}'
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        m = self.model
        self._engine = GoalExecutor(self._names, m.lower, m.upper, m.velocity_limits,
                                    self._settings())
        self.add_post_set_parameters_callback(self._on_parameters_set)
        # a joint_states read late (this node stalled) counts from when it was stamped, not read
        self._queue_delay = QueueDelay()
        self._js_map_names = None
        self._js_map = None
        self._js_finger = None       # index of the gripper's finger in joint_states
        # late watchdog checks (the node not scheduled, a publish blocked): logged with their cause
        self._stalls = StallMeter(WATCHDOG_PERIOD, STALL_WARN)
        self._last_stall = None   # (steady ns when noticed, Stall)

        # deep enough that a reader stalled for a moment loses no setpoint (200 Hz)
        self._pub_setpoint = self.create_publisher(
            JointState, robot_topic(self, 'commands/joint_setpoints'), 100)
        self._pub_feedback = self.create_publisher(
            JointState, robot_topic(self, 'trajectory/feedback'), 100)
        self._pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._js_sub = self.create_subscription(JointState, robot_topic(self, 'joint_states'),
                                                self._on_joint_states, qos_profile_sensor_data)
        self._timer = self.create_timer(1.0 / self._rate, self._on_tick)
        self._watchdog = self.create_timer(WATCHDOG_PERIOD, self._on_watchdog,
                                           clock=self._steady)
        self._duplicates = ''
        self.create_timer(2.0, self._check_peers, clock=self._steady)
        self._setpoint = JointState(name=list(self._names))
        self._actions = TrajectoryActions(self)
        self.get_logger().info(
            f'trajectory_server ready: {self.model.name} joints {self._names}, '
            f'{self._rate:g} Hz, profile {self.get_parameter("profile").value}')

    # ------------------------------------------------------------------ parameters
    def _check_parameters(self, params) -> SetParametersResult:
        for p in params:
            reason = settings_error(p.name, p.value)
            if reason:
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _settings(self) -> Settings:
        """Return the engine settings from the parameters (the rate is read at start only)."""
        values = {name: self.get_parameter(name).value for name in SETTINGS}
        values['rate'] = self._rate
        return Settings(**values)

    def _on_parameters_set(self, params) -> None:
        with self._lock:
            self._engine.settings = self._settings()

    # ------------------------------------------------------------------ inputs
    def _on_joint_states(self, msg: JointState) -> None:
        if msg.name != self._js_map_names:
            self._map_names(list(msg.name))
        if self._js_finger is not None:
            self._note_finger(msg, self._js_finger)
        pos = msg.position
        values = [(j, pos[i]) for i, j in self._js_map if i < len(pos)]
        with self._lock:
            steady = self._steady.now().nanoseconds
            now = self.get_clock().now().nanoseconds
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            # states queued while this node was stalled are as old as their stamps say
            waited = self._queue_delay.update(steady, now - stamp) if stamp else 0
            if not self._engine.measure(values, steady - waited, stamp or now):
                self.get_logger().warning(
                    'joint_states with a non-finite arm position ignored (a driver fault or a '
                    'second publisher?)', throttle_duration_sec=5.0)
            elif not self.first_state.is_set() and self._engine.has_state():
                self.first_state.set()

    def _map_names(self, names: list) -> None:
        """Index a joint_states name list: the arm joints' items, the gripper finger's."""
        self._js_map_names = names
        self._js_map = [(i, self._index[x]) for i, x in enumerate(names) if x in self._index]
        finger = self._actions.finger_joint
        self._js_finger = names.index(finger) if finger in names else None

    def _note_finger(self, msg: JointState, i: int) -> None:
        """Hand the gripper action the finger's state (item ``i`` of joint_states)."""
        pos, vel, effort = msg.position, msg.velocity, msg.effort
        self._actions.note_finger(pos[i] if i < len(pos) else 0.0,
                                  vel[i] if i < len(vel) else 0.0,
                                  effort[i] if i < len(effort) else 0.0)

    def start_goal(self, request, tag) -> None:
        """Start a goal (under the lock); raise InvalidInputError when it is invalid."""
        self._take_queued_states()
        goal, old = self._engine.start(request, self.get_clock().now().nanoseconds,
                                       self._steady.now().nanoseconds, tag)
        self._started(goal, old)

    def _take_queued_states(self) -> None:
        """Read the joint_states queued for this node (its executor may lag the action thread)."""
        for _ in range(qos_profile_sensor_data.depth):
            try:
                taken = take_deserialized(self._js_sub)
            except Exception:  # noqa: B902 - destroyed meanwhile (stop in progress)
                return
            if taken is None:
                return
            self._on_joint_states(taken[0])

    def _started(self, goal: Goal, old: Optional[Goal]) -> None:
        """Log a started goal after ending the one it preempted."""
        if old is not None:
            self._finish(old, GoalStatus.STATUS_CANCELED, f'preempted by goal {goal.label}')
        self.get_logger().info(f'goal {goal.label} accepted: {goal.info["kind"]}, '
                               f'{goal.traj.duration:.3f} s')
        self._on_tick()

    def cancel_active(self) -> None:
        """Decelerate the running goal to rest (CANCELING), once; under the lock."""
        g = self._engine.active
        if g.phase != 'canceling':
            self._engine.cancel(self.get_clock().now().nanoseconds)
            g.tag.status = GoalStatus.STATUS_CANCELING
            self.get_logger().info(f'goal {g.label} canceling: stopping in '
                                   f'{g.traj.duration:.3f} s')

    # ------------------------------------------------------------------ execution
    def _on_tick(self) -> None:
        t0 = time.monotonic_ns()
        try:
            with self._lock:
                now = self.get_clock().now()
                self._apply(self._engine.tick(now.nanoseconds, self._steady.now().nanoseconds),
                            now)
        finally:
            self._stalls.note('a setpoint tick', time.monotonic_ns() - t0)

    def _check_peers(self) -> None:
        """Log (once per change) a second trajectory server in the namespace, by name."""
        self._duplicates = new_duplicates(self, 'trajectory_servers', self.get_namespace(),
                                          self._duplicates)

    def _on_watchdog(self) -> None:
        """Abort the running goal when joint_states stopped (the engine decides); log stalls."""
        now_ns = self._steady.now().nanoseconds
        stall = self._stalls.check(now_ns)
        if stall is not None:
            self._last_stall = (now_ns, stall)
            self.get_logger().warning(f'trajectory_server {stall.describe()}')
        last = self._last_stall
        with self._lock:
            self._apply(self._engine.watchdog(now_ns, *(
                (last[0], last[1].describe()) if last is not None else (None, ''))))

    def _apply(self, out: Outcome, now=None) -> None:
        """Publish what the engine decided: setpoints, log lines, a finished goal."""
        for level, text in out.notes:
            self._log(level, text)
        for q, qd in out.sends:
            self._send(q, qd, now)
        if out.finished is not None:
            goal, status, reason = out.finished
            self._finish(goal, STATUS_CODES[status], reason, out.code)

    def _send(self, q, qd, now=None) -> None:
        """Publish a setpoint (and the same as feedback), stamped with its sample time."""
        msg = self._setpoint
        msg.header.stamp = (now or self.get_clock().now()).to_msg()
        msg.position = q.tolist()
        msg.velocity = qd.tolist()
        t0 = time.monotonic_ns()
        self._pub_setpoint.publish(msg)
        t1 = time.monotonic_ns()
        self._pub_feedback.publish(msg)
        self._stalls.note('publishing a setpoint', t1 - t0)
        self._stalls.note('publishing feedback', time.monotonic_ns() - t1)

    # ------------------------------------------------------------------ outcome
    def _finish(self, goal: Goal, status: int, reason: str, code: str = '') -> None:
        name = STATUS_NAMES[status]
        self._actions.finished(goal, name, reason, code)   # an action goal's result
        goal.tag.status = status
        self._diagnose(goal.tag.diag_id, DIAG_LEVEL[status], reason, name)
        self._log({GoalStatus.STATUS_ABORTED: 'error', GoalStatus.STATUS_CANCELED: 'warning'}
                  .get(status, 'info'), f'goal {goal.label} {name}: {reason}')

    def _log(self, level: str, text: str) -> None:
        # one call site per severity: rclpy refuses a severity change at the same call site
        if level == 'error':
            self.get_logger().error(text)
        elif level == 'warning':
            self.get_logger().warning(text)
        else:
            self.get_logger().info(text)

    def _diagnose(self, key: str, level, message: str, status: str) -> None:
        self._pub_diag.publish(diagnostic(self.get_clock().now().to_msg(), self._diag_name, key,
                                          level, message, status))

    def destroy_node(self):
        """Stop the actions' thread and helper node, then destroy this node."""
        self._actions.close()
        super().destroy_node()


def main(args=None):
    """Run the trajectory_server node (``ros2 run px100_control trajectory_server``)."""
    return spin_node(lambda options: TrajectoryServerNode(), args, schema=TRAJECTORY_SERVER,
                     description='Joint trajectory server of px100_control (actions '
                                 'arm_controller/follow_joint_trajectory, gripper_controller/'
                                 'gripper_cmd).')


if __name__ == '__main__':
    import sys
    sys.exit(main())
