"""
Ends right after a PWM command (as Interbotix's joint_pwm_control demo does), on the px100.

On the real robot the waist keeps turning after the script ends; with the in-process
simulation robot_shutdown lets the command play out (bounded) and says so.
"""
from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup


def main():
    """Put the waist in PWM mode, command PWM 150 and end at once."""
    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm', gripper_name='gripper')
    robot_startup()
    bot.core.robot_set_operating_modes('single', 'waist', 'pwm')
    bot.core.robot_write_joint_command('waist', 150)
    robot_shutdown()


if __name__ == '__main__':
    main()
