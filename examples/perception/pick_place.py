#!/usr/bin/env python3
"""
Pick every object the camera sees and drop it in the tray beside the arm.

The px100's version of Interbotix's perception demo ``pick_place``, written against Interbotix's
API: only the import lines differ. Scene ``perception_pick_place``; start the robot first::

    bringup --ros-args -p scene:=perception_pick_place -p publish_pose:=false
    pc_filter --ros-args --params-file config/perception_demos_filter.yaml

then ``python examples/perception/pick_place.py``. At sleep the arm leaves the objects in view
and shows its ArmTag to the camera: the ArmTag places the camera, the filter's clusters give the
objects (their tops, in the arm's base frame).
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
#: the tray's centre [m] in ARM_BASE_FRAME; objects are dropped from DROP_Z [m] above it
TRAY = (0.08, -0.16)
DROP_Z = 0.055
#: every move keeps the gripper pointing down [rad]
PITCH = math.pi / 2


def main():
    global_node = create_interbotix_global_node()
    bot = InterbotixManipulatorXS(robot_model=ROBOT_MODEL, robot_name=ROBOT_NAME,
                                  node=global_node)
    pcl = InterbotixPointCloudInterface(node_inf=global_node)
    armtag = InterbotixArmTagInterface(ref_frame=REF_FRAME, arm_tag_frame=ARM_TAG_FRAME,
                                       arm_base_frame=ARM_BASE_FRAME, node_inf=global_node)
    robot_startup(global_node)

    # set initial arm and gripper pose
    bot.arm.go_to_sleep_pose()
    bot.gripper.release()

    # get the ArmTag pose
    time.sleep(0.5)
    armtag.find_ref_to_arm_base_transform()

    # get the cluster positions, sorted from max to min 'x' in ARM_BASE_FRAME
    success, clusters = pcl.get_cluster_positions(ref_frame=ARM_BASE_FRAME, sort_axis='x',
                                                  reverse=True)
    if success:
        # pick up every object and drop it in the tray
        for cluster in clusters:
            x, y, z = cluster['position']
            print(x, y, z)
            bot.arm.set_ee_pose_components(x=x, y=y, z=z + 0.04, pitch=PITCH)
            bot.arm.set_ee_cartesian_trajectory(z=-(0.04 + z / 2))
            bot.gripper.grasp(2.0)
            bot.arm.set_ee_cartesian_trajectory(z=0.04 + z / 2)
            bot.arm.set_ee_pose_components(x=TRAY[0], y=TRAY[1], z=DROP_Z, pitch=PITCH)
            bot.gripper.release()
    else:
        print('Could not get cluster positions.')

    bot.arm.go_to_sleep_pose()
    robot_shutdown(global_node)


if __name__ == '__main__':
    main()
