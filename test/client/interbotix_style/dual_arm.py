"""Two arms from one script (like Interbotix's xsarm_dual demo), namespaces arm_1 and arm_2."""
from px100_control.client import (create_interbotix_global_node, InterbotixManipulatorXS,
                                  robot_shutdown, robot_startup)


def main():
    """Move the two arms differently, then print where each is."""
    global_node = create_interbotix_global_node()
    robot_1 = InterbotixManipulatorXS(robot_model='px100', robot_name='arm_1', node=global_node)
    robot_2 = InterbotixManipulatorXS(robot_model='px100', robot_name='arm_2', node=global_node)
    robot_startup(global_node)
    robot_1.arm.set_joint_positions([0.5, 0.0, 0.0, 0.0], blocking=False)
    robot_2.arm.set_joint_positions([-0.5, 0.0, 0.0, 0.0])
    robot_1.gripper.grasp()
    robot_2.gripper.release()
    print('arm_1', [round(q, 2) for q in robot_1.arm.get_joint_positions()])
    print('arm_2', [round(q, 2) for q in robot_2.arm.get_joint_positions()])
    robot_1.arm.go_to_sleep_pose(blocking=False)
    robot_2.arm.go_to_sleep_pose()
    robot_shutdown(global_node)


if __name__ == '__main__':
    main()
