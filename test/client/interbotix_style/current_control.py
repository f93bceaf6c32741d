"""Joint current control (like Interbotix's joint_current_control demo), on the px100."""
import time

from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup


def main():
    """Hold the arm against gravity with currents while the waist turns, then to sleep."""
    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm', gripper_name='gripper')
    robot_startup()
    bot.arm.go_to_home_pose()
    start = bot.arm.get_joint_positions()
    bot.core.robot_set_operating_modes('group', 'arm', 'current')
    bot.core.robot_write_commands('arm', [100, -420, -320, -110])  # mA
    # until the currents arrive the joints hold nothing (goal current 0) and the arm sags: a
    # slow mode switch lets it sag onto the table, from which these currents cannot lift it
    print('current written at', [round(q, 3) for q in bot.arm.get_joint_positions()])
    time.sleep(2.0)
    now = bot.arm.get_joint_positions()
    # with no current the arm falls onto the table: shoulder +0.53 rad, elbow +0.28 rad
    moved = now[0] - start[0] > 0.05 and max(abs(a - b) for a, b in zip(now[1:], start[1:])) < 0.25
    print('current moved', moved, [round(q, 2) for q in now])
    bot.core.robot_set_operating_modes('group', 'arm', 'position')
    bot.arm.capture_joint_positions()
    bot.arm.go_to_sleep_pose()
    at_sleep = max(abs(a - b) for a, b in zip(bot.arm.get_joint_positions(),
                                              [0.0, -1.88, 1.5, 0.8])) < 0.02
    print('current hold', at_sleep)
    robot_shutdown()


if __name__ == '__main__':
    main()
