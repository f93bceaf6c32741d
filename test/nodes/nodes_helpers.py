"""Test-side rclpy clients of the trajectory_server's action and the ik_service (real DDS)."""
from dataclasses import dataclass
import threading
import time
from typing import Any

from action_msgs.msg import GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, qos_profile_action_status_default, QoSProfile,
                       ReliabilityPolicy)
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectoryPoint

#: seconds a node process may take to come up on a loaded 2-core machine
STARTUP_TIMEOUT = 90.0
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)
NAMES = {v: k[7:] for k, v in vars(GoalStatus).items() if k.startswith('STATUS_')}
ARM_ACTION = 'arm_controller/follow_joint_trajectory'
FJT = FollowJointTrajectory


def duration(t: float) -> Duration:
    """Return a Duration message of t seconds."""
    return Duration(sec=int(t), nanosec=int(round((t - int(t)) * 1e9)))


def wait_for(predicate, timeout: float, period: float = 0.01) -> bool:
    """Poll predicate until true or timeout [s]; return its last value."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period)
    return bool(predicate())


class ServerSide:
    """
    Whether the process that serves an action (or a service) has matched a node's clients.

    DDS matches endpoints on each side separately: the client's node can see the server (and
    ``server_is_ready``) before the server's process has matched the client's reply readers.
    A reply to a reader the server has not matched is not sent (Fast DDS's rmw waits the
    writer's max_blocking_time, 100 ms, for it; rclpy then logs "Failed to send goal response"
    and drops the goal, which neither ends nor runs): on a loaded machine the goal request
    waits forever for its response. An answer of the server's process to a client created after
    the action client proves that it has matched the action client too
    (:class:`px100_control.ros.writer_match.WriterSideCheck`; a node's endpoints are announced in
    order). Create it after the clients; a service reply is lost the same way.
    """

    def __init__(self, node, action_name: str = '', server_node: str = ''):
        """
        Follow the server of ``action_name``, or the node ``server_node`` (a service's).

        :param server_node: the serving node's name, in ``node``'s namespace: its process is
            found from its /rosout publisher
        """
        from px100_control.ros.writer_match import WriterSideCheck
        self._node = node
        self._status = node.resolve_topic_name(action_name + '/_action/status') \
            if action_name else ''
        self._server = (node.get_namespace(), server_node)
        self._check = WriterSideCheck(node)

    def matched(self) -> bool:
        """Return True once every process serving it has answered (never blocks)."""
        if self._status:
            infos = self._node.get_publishers_info_by_topic(self._status)
        else:
            infos = [i for i in self._node.get_publishers_info_by_topic('/rosout')
                     if (i.node_namespace, i.node_name) == self._server]
        return bool(infos) and not self._check.unconfirmed(infos)


def arm_goal(names, points) -> FollowJointTrajectory.Goal:
    """Return a goal of points = [(time_from_start [s], positions[, velocities])]."""
    goal = FJT.Goal()
    goal.trajectory.joint_names = list(names)
    for p in points:
        pt = JointTrajectoryPoint(time_from_start=duration(p[0]))
        pt.positions = [float(x) for x in p[1]]
        if len(p) > 2:
            pt.velocities = [float(x) for x in p[2]]
        goal.trajectory.points.append(pt)
    return goal


@dataclass
class SentGoal:
    """A goal sent by TrajectoryClient: its UUID (the /diagnostics hardware_id in hex)."""

    uuid: bytes
    handle: Any
    result: Any                      # the GetResult future

    @property
    def hex_id(self) -> str:
        """Return the UUID in hex (the goal's /diagnostics hardware_id)."""
        return self.uuid.hex()


class TrajectoryClient(Node):
    """
    Send FollowJointTrajectory goals; follow their status, /diagnostics and joint_states.

    Goals go through an rclpy ActionClient; the statuses of a goal are those of the action's
    status topic, its last one that of its result. Cancel requests go to the action's
    ``_action/cancel_goal`` service (by UUID, or all goals when none is given).
    """

    def __init__(self, **kwargs):
        kwargs.setdefault('namespace', '/px100')   # the robot's: names below are relative
        super().__init__('test_trajectory_client', **kwargs)
        self.lock = threading.Lock()
        self.seen = {}     # goal uuid (bytes) -> status names in arrival order
        self.diagnostics = []
        self.joint_state = None
        self.setpoints = []
        self.arm = ActionClient(self, FJT, ARM_ACTION)
        self.create_subscription(GoalStatusArray, ARM_ACTION + '/_action/status',
                                 self._on_status, qos_profile_action_status_default)
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, 50)
        self.create_subscription(JointState, 'joint_states', self._on_js, 10)
        self.create_subscription(JointState, 'commands/joint_setpoints', self._on_sp, 100)
        self.cancel_client = self.create_client(CancelGoal,
                                                ARM_ACTION + '/_action/cancel_goal')
        self.server_side = ServerSide(self, ARM_ACTION)    # after self.arm and cancel_client

    def _on_status(self, msg):
        with self.lock:
            for st in msg.status_list:
                self._note(bytes(st.goal_info.goal_id.uuid), NAMES[st.status])

    def _note(self, uuid: bytes, name: str) -> None:
        seen = self.seen.setdefault(uuid, [])
        if not seen or seen[-1] != name:
            seen.append(name)

    def _on_diag(self, msg):
        with self.lock:
            self.diagnostics.extend(msg.status)

    def _on_js(self, msg):
        with self.lock:
            self.joint_state = (time.monotonic(), dict(zip(msg.name, msg.position)))

    def _on_sp(self, msg):
        with self.lock:
            self.setpoints.append((time.monotonic(), dict(zip(msg.name, msg.position)),
                                   dict(zip(msg.name, msg.velocity))))

    def ready(self) -> bool:
        """Return True once the action server is there and its process has matched this client."""
        return self.arm.server_is_ready() and self.server_side.matched()

    def _call(self, fn):
        """
        Return what ``fn()`` returns, called in this node's executor thread.

        rclpy 7.1.6's ActionClient registers a request's future after sending it: a reply
        taken by the executor thread in between is dropped (ros2/rclpy#1123). Called from the
        executor's own thread, no reply can come in between.
        """
        task = self.executor.create_task(fn)
        assert wait_for(task.done, 10.0), 'the executor did not run the call'
        return task.result()

    def send_goal(self, goal, timeout: float = 10.0) -> SentGoal:
        """Send a FollowJointTrajectory goal; return it once accepted (or refused)."""
        assert wait_for(self.ready, timeout, 0.05), \
            f'no FollowJointTrajectory server (or its process did not match this client: ' \
            f'server_is_ready {self.arm.server_is_ready()})'
        fut = self._call(lambda: self.arm.send_goal_async(goal))
        assert wait_for(fut.done, timeout), "no goal response (see the server's log)"
        handle = fut.result()
        assert handle.accepted, 'goal not accepted'
        return SentGoal(bytes(handle.goal_id.uuid), handle, self._call(handle.get_result_async))

    def send(self, names, points) -> SentGoal:
        """Send a goal; points = [(time_from_start, positions[, velocities])]."""
        return self.send_goal(arm_goal(names, points))

    def statuses(self, goal: SentGoal):
        """Return the status names seen for a goal so far (its result's last)."""
        with self.lock:
            if goal.result.done():
                self._note(goal.uuid, NAMES[goal.result.result().status])
            return list(self.seen.get(goal.uuid, []))

    def wait_terminal(self, goal: SentGoal, timeout: float):
        """Wait for SUCCEEDED/CANCELED/ABORTED of a goal; return its name or None."""
        if not wait_for(goal.result.done, timeout):
            return None
        return self.statuses(goal)[-1]

    def result(self, goal: SentGoal, timeout: float = 10.0):
        """Wait for and return a goal's FollowJointTrajectory.Result."""
        assert wait_for(goal.result.done, timeout), 'no result'
        return goal.result.result().result

    def wait_status(self, goal: SentGoal, name: str, timeout: float) -> bool:
        """Wait until a goal has reached the status called name."""
        return wait_for(lambda: name in self.statuses(goal), timeout)

    def diagnostics_for(self, goal: SentGoal):
        """Return the /diagnostics statuses whose hardware_id is this goal's UUID (hex)."""
        with self.lock:
            return [d for d in self.diagnostics if d.hardware_id == goal.hex_id]

    def last_diagnostic(self, goal: SentGoal, timeout: float = 5.0):
        """Wait for and return the last /diagnostics status of a goal (None if none came)."""
        wait_for(lambda: self.diagnostics_for(goal), timeout)
        found = self.diagnostics_for(goal)
        return found[-1] if found else None

    def measured(self):
        """Return the latest joint_states as {name: position} (or None)."""
        with self.lock:
            return None if self.joint_state is None else dict(self.joint_state[1])

    def setpoint_count(self) -> int:
        """Return how many setpoints this client saw."""
        with self.lock:
            return len(self.setpoints)

    def cancel(self, goal: SentGoal = None, uuid: bytes = None, timeout: float = 5.0):
        """Call the action's cancel_goal (a goal, a UUID, or all); return the response."""
        assert self.cancel_client.wait_for_service(timeout_sec=timeout)
        req = CancelGoal.Request()
        uuid = goal.uuid if goal is not None else uuid
        if uuid is not None:
            req.goal_info.goal_id.uuid = list(uuid)
        fut = self.cancel_client.call_async(req)
        wait_for(fut.done, timeout)
        return fut.result() if fut.done() else None


def seed_probe(model, new, old, tries: int = 200):
    """
    Return (target (4, 4), answer q) that tells the measured state ``new`` from ``old``, or None.

    compute_ik seeds a request without a seed with the measured state: its 'pitch' answer for
    the target is ``answer`` once ik_service has read ``new``, another solution while it still
    has ``old``. None when no target tried tells them apart (their answers are the same).
    """
    import numpy as np
    from px100_control.kinematics.solve import solve_ik
    new, old = np.asarray(new, float), np.asarray(old, float)
    rng = np.random.default_rng(0)
    for q in [new, *model.random_configurations(tries, rng, margin=0.05)]:
        T = model.fk(q)
        a = solve_ik(model, T, mode='pitch', q_seed=new)
        b = solve_ik(model, T, mode='pitch', q_seed=old)
        if a.success and (not b.success or np.max(np.abs(a.q - b.q)) > 1e-3):
            return T, np.asarray(a.q)
    return None


def wait_seeded_by(model, new, old, compute_pitch, timeout: float = 10.0) -> None:
    """
    Wait until ik_service answers from the measured state ``new`` rather than ``old``.

    ``compute_pitch(T)`` calls compute_ik (mode 'pitch', no seed) and returns the response; it
    is called on seed_probe's target until the answer is new's. Returns at once when no target
    tells the two states apart.
    """
    import numpy as np
    probe = seed_probe(model, new, old)
    if probe is None:       # no answer depends on which of the two the node has
        return
    T, want = probe
    got = []

    def seeded():
        res = compute_pitch(T)
        got.append(list(res.solution.position))
        return res.success and np.allclose(res.solution.position, want, rtol=0, atol=1e-6)
    assert wait_for(seeded, timeout), \
        f'ik_service still answers {got[-1]} (seeded by {list(old)}?), not {want.tolist()} ' \
        f'(seeded by {list(new)}), after {len(got)} calls'


def start_node(processes, name: str, *params: str):
    """
    Start an installed executable with ``-p`` parameters; return the NodeProcess.

    ``bringup`` starts without its camera process (``--no-camera``): the node tests do not look
    at images, and a camera renders on ~0.3 core.
    """
    from px100_control.tools.processes import NodeProcess
    args = (['--no-camera'] if name == 'bringup' else []) + ['--ros-args']
    for p in params:
        args += ['-p', p]
    proc = NodeProcess(name, args)
    processes.append(proc)
    return proc


class IkClient(Node):
    """compute_ik and compute_cartesian_path clients (calls from any thread; spun elsewhere)."""

    def __init__(self, name: str = 'test_ik_client', **kwargs):
        from px100_control.ros.ik_services import SERVICE_QOS
        from px100_control_msgs.srv import ComputeCartesianPath, ComputeIK
        kwargs.setdefault('namespace', '/px100')   # the robot's: names below are relative
        super().__init__(name, **kwargs)
        # as deep as the server's: a burst of calls loses none in this client's writer
        self.ik = self.create_client(ComputeIK, 'compute_ik', qos_profile=SERVICE_QOS)
        self.path = self.create_client(ComputeCartesianPath, 'compute_cartesian_path',
                                       qos_profile=SERVICE_QOS)
        # after the clients: an answer of ik_service's process covers them (see ServerSide)
        self.server_side = ServerSide(self, server_node='ik_service')

    def ready(self) -> bool:
        """Return True once both services are there and ik_service's process matched them."""
        return (self.ik.service_is_ready() and self.path.service_is_ready()
                and self.server_side.matched())

    def request(self, pose, frame_id: str = '', mode: str = '', seed=()):
        """Call compute_ik for a geometry_msgs/Pose; return the call's future."""
        from geometry_msgs.msg import PoseStamped
        from px100_control_msgs.srv import ComputeIK
        req = ComputeIK.Request(target=PoseStamped(pose=pose), orientation_mode=mode,
                                seed=[float(x) for x in seed])
        req.target.header.frame_id = frame_id
        return self.ik.call_async(req)

    def request_path(self, poses, frame_id: str = '', mode: str = ''):
        """Call compute_cartesian_path; return the call's future."""
        from px100_control_msgs.srv import ComputeCartesianPath
        req = ComputeCartesianPath.Request(orientation_mode=mode)
        req.waypoints.header.frame_id = frame_id
        req.waypoints.poses = list(poses)
        return self.path.call_async(req)

    @staticmethod
    def reply(future, timeout: float = 10.0):
        """Wait for and return the response of a call."""
        assert wait_for(future.done, timeout), f'no response in {timeout} s'
        return future.result()
