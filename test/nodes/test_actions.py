"""
The actions arm_controller/follow_joint_trajectory and gripper_controller/gripper_cmd over DDS.

bringup (sim_driver with the default pick_place scene, ik_service, trajectory_server) runs as
its executable; rclpy ActionClients in this process (and one in a process of its own) send
goals; joint_states, world/held_object and the actions' service introspection events are
watched as a recorder would.
"""
import math
import os
import subprocess
import sys
import threading
import time

from action_msgs.msg import GoalStatus
from control_msgs.action import FollowJointTrajectory, GripperCommand
from control_msgs.msg import GripperCommand as GripperCommandMsg, JointTolerance
from nodes_helpers import duration, ServerSide, start_node, STARTUP_TIMEOUT, wait_for
import numpy as np
from px100_control.kinematics.solve import solve_ik
from px100_control.models.registry import load_robot
import pytest
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from service_msgs.msg import ServiceEventInfo
from std_msgs.msg import String
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectoryPoint

pytestmark = pytest.mark.ros

NS = '/px100'
ARM_ACTION = f'{NS}/arm_controller/follow_joint_trajectory'
GRIPPER_ACTION = f'{NS}/gripper_controller/gripper_cmd'
MODEL = load_robot('px100')
ARM = list(MODEL.joint_names)
FJT = FollowJointTrajectory.Result
HERE = os.path.dirname(os.path.abspath(__file__))
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)
EVENTS = QoSProfile(depth=200, reliability=ReliabilityPolicy.RELIABLE)
#: the simulation at twice real time: the driver owns /clock, bringup's other nodes follow it;
#: the goals' durations, the gripper's stall timeout and the feedback rate are in its time
SIM_TIME = ('use_sim_time:=true', 'publish_clock:=true', 'real_time_factor:=2.0')


class ActionProbe(Node):
    """Action clients of both actions; joint_states, held object and introspection events."""

    def __init__(self, **kwargs):
        super().__init__('test_action_probe', **kwargs)
        self.lock = threading.Lock()
        self.arm = ActionClient(self, FollowJointTrajectory, ARM_ACTION)
        self.gripper = ActionClient(self, GripperCommand, GRIPPER_ACTION)
        self.js = None
        self.held = None
        self.feedback = []
        self.events = {}
        self.create_subscription(JointState, f'{NS}/joint_states', self._on_js, 10)
        self.create_subscription(String, f'{NS}/world/held_object', self._on_held, LATCHED)
        self.world_reset = self.create_client(Trigger, f'{NS}/world/reset')
        for action, kind in ((ARM_ACTION, FollowJointTrajectory),
                             (GRIPPER_ACTION, GripperCommand)):
            for service, srv in (('send_goal', kind.Impl.SendGoalService),
                                 ('cancel_goal', kind.Impl.CancelGoalService),
                                 ('get_result', kind.Impl.GetResultService)):
                topic = f'{action}/_action/{service}/_service_event'
                self.events[topic] = []
                self.create_subscription(srv.Event, topic, self._keep(topic), EVENTS)

    def _keep(self, topic):
        def cb(msg):
            with self.lock:
                self.events[topic].append(msg)
        return cb

    def _on_js(self, msg):
        with self.lock:
            self.js = dict(zip(msg.name, msg.position))

    def _on_held(self, msg):
        self.held = msg.data

    def arm_q(self):
        """Return the measured arm joints [rad]."""
        with self.lock:
            return np.array([self.js[n] for n in ARM])

    def finger(self) -> float:
        """Return the measured left finger position [m]."""
        with self.lock:
            return self.js['left_finger']

    def call(self, fn):
        """
        Return the future of ``fn()``, called in this node's executor thread.

        rclpy 7.1.6's ActionClient registers a request's future after sending it: a reply taken
        by the executor thread in between is dropped ("Ignoring unexpected goal response") and
        the future never completes (ros2/rclpy#1123). Called from the executor's own thread,
        no reply can come in between.
        """
        task = self.executor.create_task(fn)
        assert wait_for(task.done, 10.0), 'the executor did not run the call'
        return task.result()

    def send(self, client, goal, feedback=True):
        """Send a goal; return its ClientGoalHandle (accepted or not)."""
        cb = (lambda fb: self.feedback.append(fb.feedback)) if feedback else None
        fut = self.call(lambda: client.send_goal_async(goal, feedback_callback=cb))
        assert wait_for(fut.done, 10.0), 'no goal response\n' + self.log()
        return fut.result()

    def result(self, handle, timeout=30.0):
        """Return the goal's GetResult response (status, result)."""
        fut = self.call(handle.get_result_async)
        assert wait_for(fut.done, timeout), 'no result\n' + self.log()
        return fut.result()

    def cancel(self, handle):
        """Cancel a goal; return the CancelGoal response."""
        fut = self.call(handle.cancel_goal_async)
        assert wait_for(fut.done, 5.0), 'no cancel response\n' + self.log()
        return fut.result()

    def log(self) -> str:
        """Return the end of bringup's output (for failure messages)."""
        proc = getattr(self, 'proc', None)
        return proc.output()[-4000:] if proc is not None else ''

    def events_of(self, action, service):
        """Return the events recorded on one of the action's services."""
        with self.lock:
            return list(self.events[f'{action}/_action/{service}/_service_event'])


def _at_rest(read, tol: float, timeout: float = 10.0):
    """Wait until ``read()`` changes by less than tol over 0.2 s; return its value then."""
    seen = []

    def still():
        start = np.asarray(read(), dtype=float)
        time.sleep(0.2)
        seen.append(float(np.max(np.abs(np.asarray(read(), dtype=float) - start))))
        return seen[-1] < tol
    assert wait_for(still, timeout, period=0.0), \
        f'not at rest in {timeout} s: last changes over 0.2 s {seen[-5:]}, now at {read()}'
    return read()


def arm_goal(points, names=ARM, **kwargs):
    """Return a FollowJointTrajectory goal of (time [s], positions) points."""
    goal = FollowJointTrajectory.Goal(**kwargs)
    goal.trajectory.joint_names = list(names)
    goal.trajectory.points = [JointTrajectoryPoint(positions=list(map(float, q)),
                                                   time_from_start=duration(t))
                              for t, q in points]
    return goal


@pytest.fixture(scope='module')
def probe(ros_ctx, spinner, processes):
    """Run bringup (default scene) and return an ActionProbe connected to it."""
    proc = start_node(processes, 'bringup', 'path_window:=1.0', 'state_timeout:=3.0',
                      'goal_time_tolerance:=5.0', *SIM_TIME)
    node = spinner.add(ActionProbe(context=ros_ctx))
    assert node.arm.wait_for_server(timeout_sec=STARTUP_TIMEOUT), proc.output()
    assert node.gripper.wait_for_server(timeout_sec=10.0), proc.output()
    side = ServerSide(node, ARM_ACTION)   # bringup serves both actions: one answer covers both
    assert wait_for(side.matched, STARTUP_TIMEOUT, 0.05), \
        'bringup did not match the action clients\n' + proc.output()
    assert wait_for(lambda: node.js is not None, 10.0), proc.output()
    node.proc = proc
    return node


def test_action_names_and_types_in_the_graph(probe):
    """The actions' hidden services and topics exist under ros2_control's names and types."""
    def graph():
        return (dict(probe.get_service_names_and_types()),
                dict(probe.get_topic_names_and_types()))
    for action, pkg, kind in ((ARM_ACTION, 'control_msgs/action/', 'FollowJointTrajectory'),
                              (GRIPPER_ACTION, 'control_msgs/action/', 'GripperCommand')):
        want_srv = {f'{action}/_action/send_goal': pkg + kind + '_SendGoal',
                    f'{action}/_action/cancel_goal': 'action_msgs/srv/CancelGoal',
                    f'{action}/_action/get_result': pkg + kind + '_GetResult'}
        want_topics = {f'{action}/_action/feedback': pkg + kind + '_FeedbackMessage',
                       f'{action}/_action/status': 'action_msgs/msg/GoalStatusArray',
                       f'{action}/_action/send_goal/_service_event':
                           pkg + kind + '_SendGoal_Event',
                       f'{action}/_action/cancel_goal/_service_event':
                           'action_msgs/srv/CancelGoal_Event',
                       f'{action}/_action/get_result/_service_event':
                           pkg + kind + '_GetResult_Event'}

        def present():
            services, topics = graph()
            return (all(want in services.get(name, []) for name, want in want_srv.items())
                    and all(want in topics.get(name, []) for name, want in want_topics.items()))
        assert wait_for(present, 10.0), graph()


def test_goal_moves_the_arm_within_goal_tolerance_with_feedback_and_events(probe):
    """A two-point goal: SUCCEEDED, joint_states within its goal tolerance, feedback, events."""
    q0 = probe.arm_q()
    target = [0.3, -0.5, 0.5, 0.3]
    mid = (q0 + np.array(target)) / 2
    tol = [JointTolerance(name=n, position=0.01) for n in ARM]
    probe.feedback.clear()
    handle = probe.send(probe.arm, arm_goal([(1.0, mid), (2.0, target)], goal_tolerance=tol))
    assert handle.accepted
    res = probe.result(handle)
    assert res.status == GoalStatus.STATUS_SUCCEEDED, res
    assert res.result.error_code == FJT.SUCCESSFUL, res.result.error_string
    # the server judged the arm there; this probe's joint_states may trail
    assert wait_for(lambda: np.max(np.abs(probe.arm_q() - target)) <= 0.01, 5.0), \
        f'arm at {probe.arm_q().tolist()} 5 s after SUCCEEDED, not {target}'
    assert len(probe.feedback) >= 10, len(probe.feedback)   # 20 Hz for 2 s
    fb = probe.feedback[-1]
    assert list(fb.joint_names) == ARM and fb.header.stamp.sec > 0
    assert len(fb.desired.positions) == len(fb.actual.positions) == len(fb.error.positions) == 4
    np.testing.assert_allclose(np.array(fb.desired.positions) - fb.actual.positions,
                               fb.error.positions, atol=1e-12)
    uuid = list(handle.goal_id.uuid)

    def recorded():
        goals = [e for e in probe.events_of(ARM_ACTION, 'send_goal')
                 if (e.request and list(e.request[0].goal_id.uuid) == uuid) or e.response]
        results = [e for e in probe.events_of(ARM_ACTION, 'get_result')
                   if (e.request and list(e.request[0].goal_id.uuid) == uuid)
                   or (e.response and e.response[0].status == GoalStatus.STATUS_SUCCEEDED)]
        return goals, results
    assert wait_for(lambda: all(len(x) >= 2 for x in recorded()), 5.0), recorded()
    goals, results = recorded()
    received = [e for e in goals if e.info.event_type == ServiceEventInfo.REQUEST_RECEIVED][-1]
    sent = [e for e in goals if e.info.event_type == ServiceEventInfo.RESPONSE_SENT
            and e.info.sequence_number == received.info.sequence_number][-1]
    assert sent.response[0].accepted and not sent.request
    assert list(received.request[0].goal.trajectory.points[-1].positions) == target
    assert sent.info.stamp.sec * 10**9 + sent.info.stamp.nanosec >= \
        received.info.stamp.sec * 10**9 + received.info.stamp.nanosec
    assert any(e.response and e.response[0].result.error_code == FJT.SUCCESSFUL
               for e in results)


def test_cancel_stops_the_arm_and_ends_canceled(probe):
    """A canceled goal decelerates to rest short of its target; result CANCELED; events."""
    q0 = probe.arm_q()
    target = q0 + np.array([1.0, 0.0, 0.0, 0.0])
    handle = probe.send(probe.arm, arm_goal([(4.0, target)]))
    assert wait_for(lambda: abs(probe.arm_q()[0] - q0[0]) > 0.1, 10.0), probe.arm_q()
    assert len(probe.cancel(handle).goals_canceling) == 1
    res = probe.result(handle)
    assert res.status == GoalStatus.STATUS_CANCELED, res
    q2 = _at_rest(probe.arm_q, 5e-4)   # the driver settles on the last setpoint after the result
    assert abs(q2[0] - target[0]) > 0.2, q2                  # short of the target
    events = probe.events_of(ARM_ACTION, 'cancel_goal')
    types = [e.info.event_type for e in events]
    assert ServiceEventInfo.REQUEST_RECEIVED in types and ServiceEventInfo.RESPONSE_SENT in types
    assert len([e for e in events if e.response][-1].response[0].goals_canceling) == 1


def test_a_new_goal_preempts_the_running_one(probe):
    """The running goal ends CANCELED (INVALID_GOAL, 'preempted' said); the new one runs."""
    q0 = probe.arm_q()
    first = probe.send(probe.arm, arm_goal([(4.0, q0 + np.array([0.8, 0.0, 0.0, 0.0]))]))
    assert wait_for(lambda: abs(probe.arm_q()[0] - q0[0]) > 0.05, 10.0)
    target = [0.0, -0.5, 0.5, 0.0]
    second = probe.send(probe.arm, arm_goal([(2.0, target)]))
    res1 = probe.result(first)
    assert res1.status == GoalStatus.STATUS_CANCELED, res1
    assert res1.result.error_code == FJT.INVALID_GOAL
    assert 'cancelled due to new incoming action' in res1.result.error_string
    res2 = probe.result(second)
    assert res2.status == GoalStatus.STATUS_SUCCEEDED, res2.result.error_string


def _bad_goals(q):
    hi = MODEL.upper[1] + 0.1
    return [
        ('unknown joint', arm_goal([(1.0, [0.0])], names=['elbow_typo']), FJT.INVALID_JOINTS,
         'elbow_typo'),
        ('no joints', arm_goal([(1.0, [])], names=[]), FJT.INVALID_JOINTS, 'joint_names'),
        ('no points', arm_goal([]), FJT.INVALID_GOAL, 'no points'),
        ('times not increasing', arm_goal([(1.0, q), (1.0, q)]), FJT.INVALID_GOAL, 'time'),
        ('NaN', arm_goal([(1.0, [math.nan, 0.0, 0.0, 0.0])]), FJT.INVALID_GOAL, 'waist'),
        ('out of limits', arm_goal([(1.0, [0.0, hi, 0.0, 0.0])]), FJT.INVALID_GOAL, 'shoulder'),
        ('too fast', arm_goal([(0.05, [1.5, q[1], q[2], q[3]])]), FJT.INVALID_GOAL, 'waist'),
        ('tolerance of an unknown joint', arm_goal(
            [(1.0, q)], path_tolerance=[JointTolerance(name='nope', position=0.1)]),
         FJT.INVALID_GOAL, 'nope'),
    ]


def test_malformed_goals_end_invalid_with_the_reason_and_nothing_moves(probe):
    """Each malformed goal: ABORTED, INVALID_JOINTS/INVALID_GOAL, the reason; the arm stays."""
    q0 = _at_rest(probe.arm_q, 5e-4)   # the previous test's goal may still be settling
    for what, goal, code, word in _bad_goals(list(q0)):
        res = probe.result(probe.send(probe.arm, goal, feedback=False), 10.0)
        assert res.status == GoalStatus.STATUS_ABORTED, (what, res)
        assert res.result.error_code == code, (what, res.result)
        assert word in res.result.error_string, (what, res.result.error_string)
    assert np.max(np.abs(probe.arm_q() - q0)) < 2e-3, (q0, probe.arm_q())
    ok = probe.result(probe.send(probe.arm, arm_goal([(1.0, q0)])))   # still serving
    assert ok.status == GoalStatus.STATUS_SUCCEEDED, ok.result.error_string
    assert probe.proc.proc.poll() is None


def test_goal_tolerance_violated_names_the_joint(probe):
    """A goal tolerance the arm cannot meet: GOAL_TOLERANCE_VIOLATED naming joint and error."""
    q = probe.arm_q()
    goal = arm_goal([(0.5, q + np.array([0.0, 0.0, 0.0, 0.1]))],
                    goal_tolerance=[JointTolerance(name='wrist_angle', position=1e-12)],
                    goal_time_tolerance=duration(0.2))
    res = probe.result(probe.send(probe.arm, goal, feedback=False))
    assert res.status == GoalStatus.STATUS_ABORTED, res
    assert res.result.error_code == FJT.GOAL_TOLERANCE_VIOLATED, res.result
    assert "'wrist_angle'" in res.result.error_string, res.result.error_string


def test_goal_from_another_process(probe):
    """An rclpy ActionClient in its own process moves the arm (exit 0 = SUCCEEDED)."""
    out = subprocess.run([sys.executable, os.path.join(HERE, 'fjt_client_script.py'),
                          ARM_ACTION, '0.2', '-0.4', '0.4', '0.0'],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert 'SUCCEEDED' in out.stdout
    # the server judged the arm there; this probe's joint_states may trail (CI: read 7 mm behind)
    target = [0.2, -0.4, 0.4, 0.0]
    assert wait_for(lambda: np.max(np.abs(probe.arm_q() - target)) < 0.01, 5.0), \
        f'arm at {probe.arm_q().tolist()} 5 s after SUCCEEDED, not {target}\n{out.stdout}'


def _gripper(probe, position, max_effort=0.0, timeout=15.0):
    goal = GripperCommand.Goal()
    goal.command.position, goal.command.max_effort = position, max_effort
    handle = probe.send(probe.gripper, goal)
    assert handle.accepted
    return probe.result(handle, timeout)


def _move(probe, q, t=1.5):
    res = probe.result(probe.send(probe.arm, arm_goal([(t, q)]), feedback=False))
    assert res.status == GoalStatus.STATUS_SUCCEEDED, res.result.error_string


def test_gripper_closes_on_an_object_stalls_holds_it_and_opens(probe):
    """Close on red_cube: stalled, not reached, SUCCEEDED, held when lifted; open: reached."""
    cube = np.array([0.15, -0.06, 0.014])   # config/scenes/pick_place.yaml, 28 mm wide
    yaw = math.atan2(cube[1], cube[0])      # the cube faces the arm
    c, s = math.cos(yaw), math.sin(yaw)
    down = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
        [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])   # pitch pi/2

    def pose(z):
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = down, cube + [0.0, 0.0, z]
        r = solve_ik(MODEL, T, mode='pitch', q_seed=probe.arm_q())
        assert r.success, r
        return r.q
    res = _gripper(probe, MODEL.gripper.finger_upper)
    assert res.status == GoalStatus.STATUS_SUCCEEDED and res.result.reached_goal, res
    assert wait_for(lambda: abs(probe.finger() - MODEL.gripper.finger_upper) < 0.003, 5.0), \
        f'left finger at {probe.finger()} 5 s after reached_goal, not {MODEL.gripper.finger_upper}'
    _move(probe, pose(0.05))
    _move(probe, pose(0.0), 1.0)
    probe.feedback.clear()
    res = _gripper(probe, MODEL.gripper.finger_lower)
    assert res.status == GoalStatus.STATUS_SUCCEEDED, res
    assert res.result.stalled and not res.result.reached_goal, res.result
    # stopped by the cube's faces, short of the closed limit (the pads: a few mm inside d)
    assert MODEL.gripper.finger_lower + 0.002 < res.result.position < 0.025, res.result
    assert res.result.effort < -1.0, res.result       # squeezing [N]
    assert any(isinstance(f, GripperCommand.Feedback) for f in probe.feedback)
    _move(probe, pose(0.05), 1.0)
    assert wait_for(lambda: probe.held == 'red_cube', 5.0), probe.held
    res = _gripper(probe, MODEL.gripper.finger_upper)
    assert res.status == GoalStatus.STATUS_SUCCEEDED and res.result.reached_goal, res
    assert wait_for(lambda: probe.held == '', 5.0), probe.held
    assert probe.world_reset.wait_for_service(timeout_sec=5.0)
    fut = probe.world_reset.call_async(Trigger.Request())
    assert wait_for(fut.done, 5.0)
    events = probe.events_of(GRIPPER_ACTION, 'send_goal')
    assert len([e for e in events if e.response and e.response[0].accepted]) >= 3


def test_gripper_position_outside_the_finger_limits_is_refused(probe):
    """A position outside [finger_lower, finger_upper] ends ABORTED; the fingers stay."""
    before = _at_rest(probe.finger, 2e-4)   # the previous test's opening may still be ending
    res = _gripper(probe, 0.2)
    assert res.status == GoalStatus.STATUS_ABORTED, res
    time.sleep(0.3)
    assert abs(probe.finger() - before) < 1e-3


def test_gripper_cancel_holds_the_fingers_and_a_new_goal_preempts(probe):
    """Cancel a closing goal: CANCELED, the fingers stay; a second goal preempts the first."""
    assert _gripper(probe, MODEL.gripper.finger_upper).result.reached_goal
    goal = GripperCommand.Goal()
    goal.command.position = MODEL.gripper.finger_lower
    handle = probe.send(probe.gripper, goal)
    assert wait_for(lambda: probe.finger() < MODEL.gripper.finger_upper - 0.004, 10.0)
    assert len(probe.cancel(handle).goals_canceling) == 1
    res = probe.result(handle)
    assert res.status == GoalStatus.STATUS_CANCELED, res
    # at rest where the cancel stopped them: fingers that went on closing would rest at
    # finger_lower, failing the second check
    here = _at_rest(probe.finger, 2e-4)
    time.sleep(0.5)
    assert abs(probe.finger() - here) < 0.002 and here > MODEL.gripper.finger_lower + 0.003, \
        (here, probe.finger(), MODEL.gripper.finger_lower)
    first = probe.send(probe.gripper, goal)
    second = probe.send(probe.gripper, GripperCommand.Goal(
        command=GripperCommandMsg(position=MODEL.gripper.finger_upper)))
    assert probe.result(first).status == GoalStatus.STATUS_CANCELED
    assert probe.result(second).result.reached_goal
