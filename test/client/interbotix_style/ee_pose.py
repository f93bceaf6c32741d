"""End-effector pose control (like Interbotix's ee_pose_components / ee_pose_matrix demos)."""
import numpy as np
from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup


def main():
    """Reach two poses by components and one by matrix."""
    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm', gripper_name='gripper')
    robot_startup()
    bot.arm.go_to_home_pose()
    _, ok1 = bot.arm.set_ee_pose_components(x=0.2, z=0.2)
    _, ok2 = bot.arm.set_ee_pose_components(x=0.15, y=0.1, z=0.1, pitch=0.5)
    T = np.eye(4)
    T[:3, 3] = [0.2, 0.0, 0.15]
    _, ok3 = bot.arm.set_ee_pose_matrix(T)
    print('ee_pose', ok1, ok2, ok3, np.round(bot.arm.get_ee_pose()[:3, 3], 2).tolist())
    bot.arm.go_to_home_pose()
    bot.arm.go_to_sleep_pose()
    robot_shutdown()


if __name__ == '__main__':
    main()
