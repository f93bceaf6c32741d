"""
A FollowJointTrajectory goal sent before the driver's first joint_states.

trajectory_server runs alone; an rclpy ActionClient sends a goal; the goal waits for the first
joint_states (up to ``state_timeout``) as a ros2_control controller is not active before its
state interfaces are read: with sim_driver started meanwhile it SUCCEEDS, without one it ends
ABORTED with the reason.
"""
from action_msgs.msg import GoalStatus
from control_msgs.action import FollowJointTrajectory
from nodes_helpers import duration, start_node, STARTUP_TIMEOUT, wait_for
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


def _send(node, client, goal, timeout):
    """Send from the node's executor thread (ros2/rclpy#1123); return the GetResult response."""
    task = node.executor.create_task(lambda: client.send_goal_async(goal))
    assert wait_for(task.done, 10.0), 'the executor did not run the call'
    sent = task.result()
    assert wait_for(sent.done, 10.0), 'no goal response'
    handle = sent.result()
    assert handle.accepted
    task = node.executor.create_task(handle.get_result_async)
    assert wait_for(task.done, 10.0), 'the executor did not run the call'
    result = task.result()
    assert wait_for(result.done, timeout), 'no result'
    return result.result()


def test_goal_waits_for_the_driver_that_starts_after_it(ros_ctx, spinner, processes):
    """The goal is sent with no driver; sim_driver starts then: SUCCEEDED, no refusal."""
    ns = 'early_goal'
    server = start_node(processes, 'trajectory_server', f'robot_name:={ns}',
                        'state_timeout:=60.0')
    node = spinner.add(Node('early_goal_client', context=ros_ctx))
    client = ActionClient(node, FollowJointTrajectory,
                          f'/{ns}/arm_controller/follow_joint_trajectory')
    assert client.wait_for_server(timeout_sec=STARTUP_TIMEOUT), server.output()
    task = node.executor.create_task(lambda: client.send_goal_async(_goal([0.3, 0, 0, 0])))
    assert wait_for(task.done, 10.0)
    assert wait_for(task.result().done, 10.0), server.output()
    handle = task.result().result()
    assert handle.accepted
    driver = start_node(processes, 'sim_driver', f'robot_name:={ns}', "scene:=''")
    task = node.executor.create_task(handle.get_result_async)
    assert wait_for(task.done, 10.0)
    assert wait_for(task.result().done, STARTUP_TIMEOUT + 30.0), \
        server.output()[-3000:] + driver.output()[-2000:]
    res = task.result().result()
    assert res.status == GoalStatus.STATUS_SUCCEEDED, (res.result.error_string,
                                                       server.output()[-3000:])
    assert 'no joint_states' not in server.output()


def test_goal_with_no_driver_ends_aborted_naming_it(ros_ctx, spinner, processes):
    """No driver within state_timeout: ABORTED, INVALID_GOAL, 'no joint_states ... yet'."""
    ns = 'no_driver'
    server = start_node(processes, 'trajectory_server', f'robot_name:={ns}',
                        'state_timeout:=0.5')
    node = spinner.add(Node('no_driver_client', context=ros_ctx))
    client = ActionClient(node, FollowJointTrajectory,
                          f'/{ns}/arm_controller/follow_joint_trajectory')
    assert client.wait_for_server(timeout_sec=STARTUP_TIMEOUT), server.output()
    res = _send(node, client, _goal([0.3, 0, 0, 0]), 30.0)
    assert res.status == GoalStatus.STATUS_ABORTED
    assert res.result.error_code == FollowJointTrajectory.Result.INVALID_GOAL
    assert 'no joint_states from the driver yet' in res.result.error_string
