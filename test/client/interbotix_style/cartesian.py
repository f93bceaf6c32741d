"""Cartesian trajectories (like Interbotix's ee_cartesian_trajectory demo)."""
from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup


def main():
    """Straight lines up, forward, back down."""
    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm', gripper_name='gripper')
    robot_startup()
    bot.arm.go_to_home_pose()
    ok1 = bot.arm.set_ee_cartesian_trajectory(z=-0.05)
    ok2 = bot.arm.set_ee_cartesian_trajectory(x=-0.05, z=0.05)
    ok3 = bot.arm.set_ee_cartesian_trajectory(x=0.05)
    print('cartesian', ok1, ok2, ok3)
    bot.arm.go_to_sleep_pose()
    robot_shutdown()


if __name__ == '__main__':
    main()
