"""
A FollowJointTrajectory goal sent before the driver's first joint_states.

trajectory_server runs alone; an rclpy ActionClient sends a goal; the goal waits for the first
joint_states (up to ``state_timeout``) as a ros2_control controller is not active before its
state interfaces are read: with sim_driver started meanwhile it SUCCEEDS, without one it ends
ABORTED with the reason.
"""
from action_msgs.msg import GoalStatus
from control_msgs.action import FollowJointTrajectory
from nodes_helpers import duration, ServerSide, start_node, STARTUP_TIMEOUT, wait_for
from px100_control.models.registry import load_robot
import pytest
from rclpy.action import ActionClient
from rclpy.node import Node
from trajectory_msgs.msg import JointTrajectoryPoint

pytestmark = pytest.mark.ros

ARM = list(load_robot('px100').joint_names)


def _goal(target):
    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = ARM
    goal.trajectory.points = [JointTrajectoryPoint(positions=list(map(float, target)),
                                                   time_from_start=duration(1.0))]
    return goal


def _client(ros_ctx, spinner, server, ns):
    """Return (node, ActionClient) once the server's process has matched the client."""
    node = spinner.add(Node(f'{ns}_client', context=ros_ctx))
    name = f'/{ns}/arm_controller/follow_joint_trajectory'
    client = ActionClient(node, FollowJointTrajectory, name)
    side = ServerSide(node, name)
    assert wait_for(lambda: client.server_is_ready() and side.matched(), STARTUP_TIMEOUT,
                    0.05), f'server_is_ready {client.server_is_ready()}\n{server.output()}'
    return node, client


def _call(node, fn, what):
    """Return fn()'s future, called in the node's executor thread (ros2/rclpy#1123)."""
    task = node.executor.create_task(fn)
    assert wait_for(task.done, 10.0), f'the executor did not run the {what} call'
    return task.result()


def _accepted(node, client, goal, server):
    """Send a goal; return its handle once accepted."""
    sent = _call(node, lambda: client.send_goal_async(goal), 'send_goal')
    assert wait_for(sent.done, 10.0), f'no goal response:\n{server.output()[-3000:]}'
    handle = sent.result()
    assert handle.accepted, server.output()[-3000:]
    return handle


def test_goal_waits_for_the_driver_that_starts_after_it(ros_ctx, spinner, processes):
    """The goal is sent with no driver; sim_driver starts then: SUCCEEDED, no refusal."""
    ns = 'early_goal'
    server = start_node(processes, 'trajectory_server', f'robot_name:={ns}',
                        'state_timeout:=60.0')
    node, client = _client(ros_ctx, spinner, server, ns)
    handle = _accepted(node, client, _goal([0.3, 0, 0, 0]), server)
    driver = start_node(processes, 'sim_driver', f'robot_name:={ns}', "scene:=''")
    result = _call(node, handle.get_result_async, 'get_result')
    assert wait_for(result.done, STARTUP_TIMEOUT + 30.0), \
        server.output()[-3000:] + driver.output()[-2000:]
    res = result.result()
    assert res.status == GoalStatus.STATUS_SUCCEEDED, (res.result.error_string,
                                                       server.output()[-3000:])
    # no refusal (a pause of the goal while the loaded driver is silent says 'no joint_states
    # for 0.25 s': not a refusal)
    assert 'no joint_states from the driver yet' not in server.output()


def test_goal_with_no_driver_ends_aborted_naming_it(ros_ctx, spinner, processes):
    """No driver within state_timeout: ABORTED, INVALID_GOAL, 'no joint_states ... yet'."""
    ns = 'no_driver'
    server = start_node(processes, 'trajectory_server', f'robot_name:={ns}',
                        'state_timeout:=0.5')
    node, client = _client(ros_ctx, spinner, server, ns)
    handle = _accepted(node, client, _goal([0.3, 0, 0, 0]), server)
    result = _call(node, handle.get_result_async, 'get_result')
    assert wait_for(result.done, 30.0), f'no result:\n{server.output()[-3000:]}'
    res = result.result()
    assert res.status == GoalStatus.STATUS_ABORTED, server.output()[-3000:]
    assert res.result.error_code == FollowJointTrajectory.Result.INVALID_GOAL
    assert 'no joint_states from the driver yet' in res.result.error_string
