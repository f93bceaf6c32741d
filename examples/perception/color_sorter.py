#!/usr/bin/env python3
"""
Sort the blocks the camera sees by colour: each hue to a spot of its own beside the arm.

The px100's version of Interbotix's perception demo ``color_sorter``, written against
Interbotix's API: only the import lines differ. Scene ``color_sorter``; start the robot first::

    bringup --ros-args -p scene:=color_sorter -p publish_pose:=false
    pc_filter --ros-args --params-file config/perception_demos_filter.yaml

then ``python examples/perception/color_sorter.py``. The colour of a cluster is its mean RGB;
its hue (HSV) names it, as Interbotix's demo does.
"""
from colorsys import rgb_to_hsv
from enum import Enum
import math
import time
from typing import List

from px100_control.client.arm import InterbotixManipulatorXS
from px100_control.client.armtag import InterbotixArmTagInterface
from px100_control.client.pointcloud import InterbotixPointCloudInterface
from px100_control.client.robot import (create_interbotix_global_node, robot_shutdown,
                                        robot_startup)


class Color(Enum):
    UNKNOWN = 0
    RED = 1
    ORANGE = 2
    YELLOW = 3
    GREEN = 4
    BLUE = 5
    PURPLE = 6


ROBOT_MODEL = 'px100'
ROBOT_NAME = ROBOT_MODEL
REF_FRAME = 'camera_color_optical_frame'
ARM_TAG_FRAME = f'{ROBOT_NAME}/ar_tag_link'
ARM_BASE_FRAME = f'{ROBOT_NAME}/base_link'
#: where each colour goes [m] in ARM_BASE_FRAME (an unknown colour is put back)
SPOTS = {Color.RED: (0.06, -0.13), Color.YELLOW: (0.12, -0.13), Color.BLUE: (0.06, 0.13),
         Color.PURPLE: (0.12, 0.13)}
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

    # get the cluster positions, sorted from max to min 'y' in ARM_BASE_FRAME
    success, clusters = pcl.get_cluster_positions(ref_frame=ARM_BASE_FRAME, sort_axis='y',
                                                  reverse=True)
    if success:
        # pick up every block and set it down on the spot of its colour
        for cluster in clusters:
            x, y, z = cluster['position']
            print(x, y, z)
            bot.arm.set_ee_pose_components(x=x, y=y, z=z + 0.04, pitch=PITCH)
            bot.arm.set_ee_cartesian_trajectory(z=-(0.04 + z / 2))
            bot.gripper.grasp(2.0)
            bot.arm.set_ee_cartesian_trajectory(z=0.04 + z / 2)
            clr = color_compare(cluster['color'])
            tx, ty = SPOTS.get(clr, (x, y))
            bot.arm.set_ee_pose_components(x=tx, y=ty, z=z + 0.04, pitch=PITCH)
            bot.arm.set_ee_cartesian_trajectory(z=-(0.037 + z / 2))
            bot.gripper.release()
            bot.arm.set_ee_cartesian_trajectory(z=0.037 + z / 2)
    else:
        print('Could not get cluster positions.')

    bot.arm.go_to_sleep_pose()
    robot_shutdown(global_node)


def color_compare(rgb: List[float]) -> Color:
    """
    Return the Color of an [R, G, B] (0..255) by its hue in the HSV colour space.

    :param rgb: the cluster's mean colour
    """
    r, g, b = [x / 255.0 for x in rgb]
    h, _, _ = rgb_to_hsv(r, g, b)
    if h < 0.025 or h > 0.95:
        return Color.RED
    elif 0.025 < h < 0.05:
        return Color.ORANGE
    elif 0.1 < h < 0.15:
        return Color.YELLOW
    elif 0.3 < h < 0.4:
        return Color.GREEN
    elif 0.55 < h < 0.65:
        return Color.BLUE
    elif 0.75 < h < 0.85:
        return Color.PURPLE
    else:
        return Color.UNKNOWN


if __name__ == '__main__':
    main()
