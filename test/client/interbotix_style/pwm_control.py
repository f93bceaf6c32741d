"""Joint PWM control (like Interbotix's joint_pwm_control demo), on the px100."""
import time

from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup


def main():
    """Turn the waist with PWM, stop it, then back to position control and to sleep."""
    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm', gripper_name='gripper')
    robot_startup()
    bot.arm.go_to_sleep_pose()
    start = bot.arm.get_joint_positions()[0]
    bot.core.robot_set_operating_modes('single', 'waist', 'pwm')
    bot.core.robot_write_joint_command('waist', 150)
    time.sleep(1.0)
    turned = bot.arm.get_joint_positions()[0] - start
    print('pwm moved', turned > 0.3, round(turned, 2))
    bot.core.robot_write_joint_command('waist', 0)
    time.sleep(0.5)
    stopped = abs(bot.arm.get_joint_velocities()[0]) < 0.05
    print('pwm stopped', stopped)
    bot.core.robot_set_operating_modes('single', 'waist', 'position')
    bot.arm.capture_joint_positions()
    bot.arm.go_to_sleep_pose()
    robot_shutdown()


if __name__ == '__main__':
    main()
