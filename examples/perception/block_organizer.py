#!/usr/bin/env python3
"""
Line up the yellow and the blue blocks the camera sees: one line per colour beside the arm.

The px100's version of Interbotix's perception demo ``block_organizer``, written against
Interbotix's API: only the import lines differ. Scene ``block_organizer``; start the robot
first::

    bringup --ros-args -p scene:=block_organizer -p publish_pose:=false
    pc_filter --ros-args --params-file config/perception_demos_filter.yaml

then ``python examples/perception/block_organizer.py``. A cluster's hue names its colour.
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
#: each colour's line [m] in ARM_BASE_FRAME: y, and x of its first block (the next ones
#: LINE_STEP farther out); another colour is put back
LINES = {Color.YELLOW: (-0.13, 0.06), Color.BLUE: (0.13, 0.06)}
LINE_STEP = 0.05
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
        color_x_dict = {}
        # pick up every block and set it down at the end of its colour's line
        for cluster in clusters:
            x, y, z = cluster['position']
            print(x, y, z)
            bot.arm.set_ee_pose_components(x=x, y=y, z=z + 0.04, pitch=PITCH)
            bot.arm.set_ee_cartesian_trajectory(z=-(0.04 + z / 2))
            bot.gripper.grasp(2.0)
            bot.arm.set_ee_cartesian_trajectory(z=0.04 + z / 2)
            clr = color_compare(cluster['color'])
            if clr in LINES:
                color_x_dict[clr] = color_x_dict.get(clr, LINES[clr][1] - LINE_STEP) + LINE_STEP
                tx, ty = color_x_dict[clr], LINES[clr][0]
            else:
                tx, ty = x, y
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
