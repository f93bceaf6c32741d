"""Gripper control (like Interbotix's gripper_control demo)."""
from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup


def main():
    """Close and open at two pressures."""
    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm', gripper_name='gripper')
    robot_startup()
    bot.gripper.grasp(2.0)
    closed = bot.gripper.get_finger_position()
    bot.gripper.release(2.0)
    opened = bot.gripper.get_finger_position()
    bot.gripper.set_pressure(1.0)
    bot.gripper.grasp(2.0)
    print('gripper', round(closed, 4), round(opened, 4), round(
        bot.gripper.get_finger_position(), 4))
    bot.gripper.release(2.0)
    robot_shutdown()


if __name__ == '__main__':
    main()
