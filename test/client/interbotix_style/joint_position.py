"""Joint position control (like Interbotix's bartender / joint_position_control demos)."""
from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup


def main():
    """Move by joint positions, one joint, home and sleep."""
    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm', gripper_name='gripper')
    robot_startup()
    bot.arm.go_to_home_pose()
    ok = bot.arm.set_joint_positions([0.5, -0.4, 0.3, 0.2], moving_time=1.5)
    print('set_joint_positions', ok, [round(q, 2) for q in bot.arm.get_joint_positions()])
    ok = bot.arm.set_single_joint_position('waist', -0.5)
    print('set_single_joint_position', ok, round(bot.arm.get_joint_positions()[0], 2))
    bot.arm.go_to_home_pose()
    bot.arm.go_to_sleep_pose()
    robot_shutdown()


if __name__ == '__main__':
    main()
