"""
The bag viewer shows a bag's goals (path, target, status), IK targets and refusals.

From both protocols: the trajectory action's and compute_ik's introspection events (bags of
today), and the topics trajectory/goal, trajectory/status, ik/request, ik/status (bags recorded
before). Synthetic bags check each case; a run recorded with ``record -a`` from a real client
script checks the real events.
"""
import json
import os
import subprocess
import sys

from action_msgs.msg import GoalInfo, GoalStatus, GoalStatusArray
from builtin_interfaces.msg import Duration, Time
from control_msgs.action import FollowJointTrajectory
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from px100_control.bag.writer import BagWriter
from px100_control.viewer.bag_view import load_bag, state_at
from px100_control.viewer.robot import UrdfRobot
from px100_control.viewer.state import ViewerState
from px100_control_msgs.srv import ComputeIK
import pytest
from rclpy.serialization import serialize_message
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from unique_identifier_msgs.msg import UUID

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), 'bag'))
from bag_support import ARM, joint_state, string, T0_NS  # noqa: E402, I100

NS = '/px100'
ACTION = NS + '/arm_controller/follow_joint_trajectory/_action/'
SEND_GOAL = FollowJointTrajectory.Impl.SendGoalService
GOAL_A = (0.5, -0.2, 0.3, 0.0)
GOAL_B = (-0.4, 0.0, 0.2, 0.1)
TARGET = (0.2, 0.05, 0.15)


def _time(t: float) -> Time:
    ns = T0_NS + int(round(t * 1e9))
    return Time(sec=ns // 10**9, nanosec=ns % 10**9)


def _trajectory(t: float, positions) -> JointTrajectory:
    msg = JointTrajectory(joint_names=ARM, points=[JointTrajectoryPoint(
        positions=list(positions), time_from_start=Duration(sec=1))])
    msg.header.stamp = _time(t)
    return msg


def _statuses(*entries) -> GoalStatusArray:
    """Return a GoalStatusArray of (uuid bytes, stamp [s], status)."""
    return GoalStatusArray(status_list=[GoalStatus(status=s, goal_info=GoalInfo(
        goal_id=UUID(uuid=list(u)), stamp=_time(t))) for u, t, s in entries])


def _target(t: float) -> PoseStamped:
    msg = PoseStamped()
    msg.header.stamp = _time(t)
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = TARGET
    msg.pose.orientation.w = 1.0
    return msg


def _event(srv, event_type: int, t: float, seq: int, request=None, response=None):
    msg = srv.Event()
    msg.info.event_type, msg.info.stamp, msg.info.sequence_number = event_type, _time(t), seq
    if request is not None:
        msg.request = [request]
    if response is not None:
        msg.response = [response]
    return msg


def _write(bag_dir: str, messages) -> None:
    """Write joint_states (at rest, 0..4 s), the URDF and messages [(topic, type, t, msg)]."""
    from px100_control.models.registry import load_robot
    from px100_control.models.urdf_prefix import prefix_urdf
    with BagWriter(bag_dir) as bag:
        topics = {(NS + '/robot_description', 'std_msgs/msg/String'),
                  (NS + '/joint_states', 'sensor_msgs/msg/JointState')}
        topics |= {(topic, type_name) for topic, type_name, _, _ in messages}
        for topic, type_name in sorted(topics):
            bag.add_topic(topic, type_name)
        bag.write(NS + '/robot_description',
                  string(prefix_urdf(load_robot('px100').urdf_xml, 'px100')), T0_NS)
        rows = [(T0_NS + i * 10**7, NS + '/joint_states',
                 joint_state(T0_NS + i * 10**7, ARM, [0.0] * 4)) for i in range(400)]
        rows += [(T0_NS + int(round(t * 1e9)) + 1, topic, serialize_message(msg))
                 for topic, _, t, msg in messages]
        for t_ns, topic, data in sorted(rows, key=lambda r: r[0]):
            bag.write(topic, data, t_ns)


def _state(bag_dir: str):
    timeline = load_bag(bag_dir)
    state = ViewerState()
    state.fk = UrdfRobot(timeline.urdf_xml).ee_pose
    return timeline, state


def _fk_target(state, positions):
    return state.fk(dict(zip(ARM, positions)))[0]


def test_old_bag_goals_statuses_ik_targets_and_refusals(tmp_path):
    """trajectory/goal and /status, ik/request and /status: path, status lines, target, error."""
    status = 'action_msgs/msg/GoalStatusArray'
    ua, ub = bytes(16), bytes(range(16))
    bag = str(tmp_path / 'old')
    _write(bag, [
        (NS + '/ik/request', 'geometry_msgs/msg/PoseStamped', 0.5, _target(0.5)),
        (NS + '/ik/status', 'diagnostic_msgs/msg/DiagnosticStatus', 0.6,
         DiagnosticStatus(level=DiagnosticStatus.ERROR, message='unreachable by 0.3 m')),
        (NS + '/trajectory/goal', 'trajectory_msgs/msg/JointTrajectory', 1.0,
         _trajectory(1.0, GOAL_A)),
        (NS + '/trajectory/status', status, 1.1, _statuses((ua, 1.0, 2))),
        (NS + '/trajectory/status', status, 2.0, _statuses((ua, 1.0, 4))),
        (NS + '/trajectory/goal', 'trajectory_msgs/msg/JointTrajectory', 2.5,
         _trajectory(2.5, GOAL_B)),
        (NS + '/trajectory/status', status, 2.6, _statuses((ua, 1.0, 4), (ub, 2.5, 2))),
    ])
    tl, st = _state(bag)
    state_at(tl, st, 0.4)
    assert st.path == [] and st.ik_target is None and 'trajectory: no goal yet' in \
        st.status_lines() and st.last_error == ''
    state_at(tl, st, 0.7)
    assert st.ik_target == (TARGET, (0.0, 0.0, 0.0, 1.0))
    assert 'last error: ik: unreachable by 0.3 m' in st.status_lines()
    state_at(tl, st, 1.5)
    assert st.target == pytest.approx(_fk_target(st, GOAL_A), abs=1e-9)
    assert 'trajectory: goal 1: EXECUTING' in st.status_lines()
    state_at(tl, st, 2.2)
    assert st.path == [] and 'trajectory: goal 1: SUCCEEDED' in st.status_lines()
    state_at(tl, st, 3.0)
    assert st.target == pytest.approx(_fk_target(st, GOAL_B), abs=1e-9)
    assert 'trajectory: goal 2: EXECUTING' in st.status_lines()
    state_at(tl, st, 1.5)       # back again: goal 1's path, status and number
    assert st.target == pytest.approx(_fk_target(st, GOAL_A), abs=1e-9)
    assert 'trajectory: goal 1: EXECUTING' in st.status_lines()


def test_action_and_ik_events_give_goals_statuses_targets_and_refusals(tmp_path):
    """send_goal requests/responses, _action/status, compute_ik events as the live viewer."""
    ua, ub = b'\xaa' * 16, b'\xbb' * 16
    goal_type = 'control_msgs/action/FollowJointTrajectory_SendGoal_Event'
    ik_type = 'px100_control_msgs/srv/ComputeIK_Event'
    status = (ACTION + 'status', 'action_msgs/msg/GoalStatusArray')

    def goal(t, u, positions, seq):
        request = SEND_GOAL.Request(goal_id=UUID(uuid=list(u)))
        request.goal.trajectory = _trajectory(0.0, positions)
        return (ACTION + 'send_goal/_service_event', goal_type, t,
                _event(SEND_GOAL, 1, t, seq, request=request))

    def answer(t, accepted, seq):
        return (ACTION + 'send_goal/_service_event', goal_type, t, _event(
            SEND_GOAL, 2, t, seq, response=SEND_GOAL.Response(accepted=accepted)))

    bag = str(tmp_path / 'events')
    _write(bag, [
        (NS + '/compute_ik/_service_event', ik_type, 0.5,
         _event(ComputeIK, 1, 0.5, 1, request=ComputeIK.Request(target=_target(0.5)))),
        (NS + '/compute_ik/_service_event', ik_type, 0.6, _event(
            ComputeIK, 2, 0.6, 1, response=ComputeIK.Response(success=False,
                                                              message='out of reach'))),
        goal(1.0, ua, GOAL_A, 1), answer(1.01, True, 1),
        (*status, 1.1, _statuses((ua, 1.0, 2))),
        (*status, 2.0, _statuses((ua, 1.0, 5))),
        # a second client's goal with the same sequence number, refused
        goal(2.5, ub, GOAL_B, 1), answer(2.51, False, 1),
    ])
    tl, st = _state(bag)
    state_at(tl, st, 0.7)
    assert st.ik_target == (TARGET, (0.0, 0.0, 0.0, 1.0))
    assert 'last error: ik: out of reach' in st.status_lines()
    state_at(tl, st, 1.05)      # the request's path before any status
    assert st.target == pytest.approx(_fk_target(st, GOAL_A), abs=1e-9)
    state_at(tl, st, 1.5)
    assert 'trajectory: goal 1: EXECUTING' in st.status_lines()
    state_at(tl, st, 2.2)
    assert st.path == [] and 'trajectory: goal 1: CANCELED' in st.status_lines()
    state_at(tl, st, 3.0)
    assert st.path == [] and 'trajectory: goal 2: REJECTED' in st.status_lines()
    assert 'last error: goal 2: not accepted by the action server' in st.status_lines()


def test_a_recorded_run_shows_its_goals_and_ik_target(node_process, tmp_path):
    """A run of recording_script.py recorded by record -a: goals' paths and statuses, IK target."""
    ns = f'px100_vbag_{os.getpid()}'
    node_process('bringup', '--no-camera', '--ros-args', '-p', f'robot_name:={ns}')
    bag = str(tmp_path / 'run')
    rec = node_process('record', '-a', '-o', bag, '--ros-args', '-p', f'robot_name:={ns}')
    env = dict(os.environ, PX100_RECORDER='wait', PYTHONPATH=os.pathsep.join(
        [ROOT] + [p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep) if p]))
    proc = subprocess.run([sys.executable, os.path.join(os.path.dirname(HERE), 'bag',
                                                        'recording_script.py'), ns],
                          env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    sent = json.loads(proc.stdout.strip().splitlines()[-1])
    assert rec.stop(timeout=30.0) == 0, rec.output()[-2000:]
    tl, st = _state(bag)
    calls = tl.calls
    assert len(calls.goals) == len(sent['goals']) == 5, (calls.goals, sent)
    assert calls.ik_targets[0][0] == pytest.approx((0.2, 0.0, 0.15))   # set_ee_pose_components
    assert calls.ik_times[0] < calls.goal_times[0]
    state_at(tl, st, calls.ik_times[0])
    assert st.ik_target[0] == pytest.approx((0.2, 0.0, 0.15))
    for k, t in enumerate(calls.goal_times):
        state_at(tl, st, t)
        assert st.path and st.target == pytest.approx(
            st.fk(dict(tl.joints_at(t), **dict(zip(calls.goals[k].names,
                                                   calls.goals[k].points[-1]))))[0])
    state_at(tl, st, calls.goal_times[0] + 0.01)
    assert st.target == pytest.approx((0.2, 0.0, 0.15), abs=2e-3)      # the IK move's goal
    ends = [next(s for (g, s), ts in zip(calls.statuses, calls.status_times)
                 if g == goal.goal_id and s in ('SUCCEEDED', 'CANCELED')) for goal in calls.goals]
    assert ends == ['SUCCEEDED'] * 3 + ['CANCELED', 'SUCCEEDED'], calls.statuses
    state_at(tl, st, tl.duration)
    assert st.path == [] and 'trajectory: goal 5: SUCCEEDED' in st.status_lines()
    assert st.last_error == '', st.status_lines()
