#!/usr/bin/env python3
"""
Line up the objects the camera sees by size, largest first, in a row beside the arm.

The px100's version of Interbotix's perception demo ``size_organizer``, written against
Interbotix's API: only the import lines differ. Scene ``size_organizer``; start the robot
first::

    bringup --ros-args -p scene:=size_organizer -p publish_pose:=false
    pc_filter --ros-args --params-file config/perception_demos_filter.yaml

then ``python examples/perception/size_organizer.py``. A cluster's size is its point count.
"""
import math
import time

from px100_control.client.arm import InterbotixManipulatorXS
from px100_control.client.armtag import InterbotixArmTagInterface
from px100_control.client.pointcloud import InterbotixPointCloudInterface
from px100_control.client.robot import (create_interbotix_global_node, robot_shutdown,
                                        robot_startup)

ROBOT_MODEL = 'px100'
ROBOT_NAME = ROBOT_MODEL
REF_FRAME = 'camera_color_optical_frame'
ARM_TAG_FRAME = f'{ROBOT_NAME}/ar_tag_link'
ARM_BASE_FRAME = f'{ROBOT_NAME}/base_link'
#: the row [m] in ARM_BASE_FRAME: its y, the x of the largest object and the step to the next
ROW_Y, ROW_X, ROW_STEP = -0.13, 0.03, 0.04
PITCH = math.pi / 2


def main():
    global_node = create_interbotix_global_node()
    bot = InterbotixManipulatorXS(robot_model=ROBOT_MODEL, robot_name=ROBOT_NAME,
                                  node=global_node)
    pcl = InterbotixPointCloudInterface(node_inf=global_node)
    armtag = InterbotixArmTagInterface(ref_frame=REF_FRAME, arm_tag_frame=ARM_TAG_FRAME,
                                       arm_base_frame=ARM_BASE_FRAME, node_inf=global_node)
    robot_startup(global_node)

    # set the initial arm and gripper pose
    bot.arm.go_to_sleep_pose()
    bot.gripper.release()

    # get the ArmTag pose
    time.sleep(0.5)
    armtag.find_ref_to_arm_base_transform()

    # get the cluster positions, sorted from min to max 'y' in ARM_BASE_FRAME
    success, clusters = pcl.get_cluster_positions(ref_frame=ARM_BASE_FRAME, sort_axis='y')

    if success:
        # sort the clusters by size: most points first
        sorted_clusters = sorted(clusters, key=lambda cluster: cluster['num_points'],
                                 reverse=True)

        # pick up every object and set it down in the row, in order of size
        x_des = ROW_X
        for cluster in sorted_clusters:
            x, y, z = cluster['position']
            bot.arm.set_ee_pose_components(x=x, y=y, z=z + 0.04, pitch=PITCH)
            bot.arm.set_ee_cartesian_trajectory(z=-(0.04 + z / 2))
            print('about to close')
            bot.gripper.grasp(2.0)
            bot.arm.set_ee_cartesian_trajectory(z=0.04 + z / 2)
            bot.arm.set_ee_pose_components(x=x_des, y=ROW_Y, z=z + 0.04, pitch=PITCH)
            bot.arm.set_ee_cartesian_trajectory(z=-(0.037 + z / 2))
            print('about to open')
            bot.gripper.release()
            bot.arm.set_ee_cartesian_trajectory(z=0.037 + z / 2)
            x_des += ROW_STEP
    else:
        print('Could not get cluster positions.')

    bot.arm.go_to_sleep_pose()
    robot_shutdown(global_node)


if __name__ == '__main__':
    main()
