"""
Send one FollowJointTrajectory goal from a process of its own and print how it ended.

Usage: ``fjt_client_script.py ACTION q1 q2 q3 q4``; exit status 0 when the goal SUCCEEDED.
"""
import sys
import time

from control_msgs.action import FollowJointTrajectory
import rclpy
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from trajectory_msgs.msg import JointTrajectoryPoint

ARM = ['waist', 'shoulder', 'elbow', 'wrist_angle']


def main() -> int:
    """Send the goal, wait for its result, print status and error."""
    action, q = sys.argv[1], [float(x) for x in sys.argv[2:6]]
    rclpy.init()
    node = rclpy.create_node('fjt_client_script')
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    client = ActionClient(node, FollowJointTrajectory, action)
    try:
        if not client.wait_for_server(timeout_sec=30.0):
            print('no server')
            return 2
        goal = FollowJointTrajectory.Goal()
        goal.trajectory.joint_names = ARM
        point = JointTrajectoryPoint(positions=q)
        point.time_from_start.sec = 2
        goal.trajectory.points = [point]
        future = client.send_goal_async(goal)
        executor.spin_until_future_complete(future, timeout_sec=10.0)
        handle = future.result()
        if handle is None or not handle.accepted:
            print('not accepted')
            return 3
        result = handle.get_result_async()
        deadline = time.monotonic() + 60.0
        while not result.done() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        res = result.result()
        name = {4: 'SUCCEEDED', 5: 'CANCELED', 6: 'ABORTED'}.get(res.status, str(res.status))
        print(name, res.result.error_code, res.result.error_string)
        return 0 if res.status == 4 else 1
    finally:
        client.destroy()
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    sys.exit(main())
