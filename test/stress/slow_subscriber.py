"""
A badly behaved subscriber, run as a process.

It subscribes to every output of the px100 nodes with RELIABLE, deep-queue QoS and then either
never spins (``--mode nospin``) or spins but sleeps ``--sleep`` s in every callback
(``--mode sleep``). The nodes must not stall because of it. Prints ``ready`` once its
subscriptions exist. Usage: ``python slow_subscriber.py --mode nospin``.
"""
import argparse
import sys
import time


def main(argv=None) -> int:
    """Subscribe, then misbehave until SIGINT."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--mode', choices=('nospin', 'sleep'), default='nospin')
    parser.add_argument('--sleep', type=float, default=1.0)
    parser.add_argument('--robot-name', default='px100')
    opts = parser.parse_args(argv)

    from action_msgs.msg import GoalStatusArray
    from control_msgs.action import FollowJointTrajectory
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import PoseStamped
    from px100_control_msgs.srv import ComputeCartesianPath, ComputeIK
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    rclpy.init()
    node = rclpy.create_node('slow_subscriber')
    ns = f'/{opts.robot_name}'
    reliable = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    keep_all = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)

    ARM = 'arm_controller/follow_joint_trajectory'

    def slow(_msg):
        time.sleep(opts.sleep)

    subs = [
        (JointState, 'joint_states', keep_all), (PoseStamped, 'ee_pose', keep_all),
        (JointState, 'commands/joint_setpoints', reliable),
        (JointState, 'trajectory/feedback', keep_all),
        (GoalStatusArray, f'{ARM}/_action/status', latched),
        (FollowJointTrajectory.Impl.FeedbackMessage, f'{ARM}/_action/feedback', keep_all),
        (ComputeIK.Event, 'compute_ik/_service_event', keep_all),
        (ComputeCartesianPath.Event, 'compute_cartesian_path/_service_event', reliable),
        (String, 'robot_description', latched),
    ]
    for msg_type, name, qos in subs:
        node.create_subscription(msg_type, f'{ns}/{name}', slow, qos)
    node.create_subscription(DiagnosticArray, '/diagnostics', slow, keep_all)
    print('ready', flush=True)
    try:
        if opts.mode == 'sleep':
            rclpy.spin(node)
        else:
            while True:
                time.sleep(1.0)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
