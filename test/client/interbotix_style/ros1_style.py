"""
A ROS 1 (noetic) style script: no robot_startup, positional init_node, ``dxl``, open/close.

Uses the noetic constructor's positional arguments (use_gripper 7th, init_node 11th),
``robot_write_trajectory(..., type=...)``, the standalone ``InterbotixGripperXS`` and a
``gripper_state(event)`` call as a rospy.Timer would make it.
"""
from px100_control.client.arm import InterbotixManipulatorXS
from px100_control.client.gripper import InterbotixGripperXS


def main():
    """Move, write a trajectory, use the gripper twice (interface and standalone)."""
    bot = InterbotixManipulatorXS('px100', 'arm', 'gripper', None, 1.5, 0.3, True, 0.5, 150,
                                  350, True)
    bot.arm.go_to_home_pose()
    bot.dxl.robot_write_trajectory('group', 'arm', type='position', raw_traj=[
        {0.0: [0.0, 0.0, 0.0, 0.0]}, {1.0: [0.3, 0.0, 0.0, 0.0]}, {2.0: [0.6, 0.0, 0.0, 0.0]}])
    import time
    time.sleep(3.0)
    print('trajectory', round(bot.arm.get_joint_positions()[0], 2))
    bot.gripper.close(1.5)
    bot.gripper.gripper_state(None)
    bot.gripper.open(1.5)
    standalone = InterbotixGripperXS('px100', 'gripper', None, 0.5, 150, 350, True)
    standalone.gripper.close(2.0)
    print('standalone', round(standalone.gripper.get_finger_position(), 4),
          standalone.dxl is standalone.core)
    standalone.gripper.open(2.0)
    bot.arm.go_to_sleep_pose()


if __name__ == '__main__':
    main()
