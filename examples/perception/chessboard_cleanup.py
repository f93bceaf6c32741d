#!/usr/bin/env python3
"""
Clear the chess pieces the camera sees off the board: white to one side, black to the other.

The px100's version of Interbotix's perception demo ``chessboard_cleanup``, written against
Interbotix's API: only the import lines differ. Scene ``chessboard_cleanup``; start the robot
first::

    bringup --ros-args -p scene:=chessboard_cleanup -p publish_pose:=false
    pc_filter --ros-args --params-file config/perception_demos_filter.yaml

then ``python examples/perception/chessboard_cleanup.py``. The board is flat enough for the
filter's plane to take it with the table; a piece's value (HSV) tells black from white.
"""
import colorsys
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
    BLACK = 0
    WHITE = 1


ROBOT_MODEL = 'px100'
ROBOT_NAME = ROBOT_MODEL
REF_FRAME = 'camera_color_optical_frame'
ARM_TAG_FRAME = f'{ROBOT_NAME}/ar_tag_link'
ARM_BASE_FRAME = f'{ROBOT_NAME}/base_link'
#: each colour's side [m] in ARM_BASE_FRAME: y, and x of the first piece (the next ones
#: STEP farther out)
SIDES = {Color.WHITE: (-0.13, 0.06), Color.BLACK: (0.13, 0.06)}
STEP = 0.05
PITCH = math.pi / 2


def main():
    global_node = create_interbotix_global_node()
    bot = InterbotixManipulatorXS(robot_model=ROBOT_MODEL, moving_time=1.5, accel_time=0.75,
                                  gripper_pressure=1.0, node=global_node)
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

    # get the cluster positions, sorted from min to max 'x' in ARM_BASE_FRAME
    success, clusters = pcl.get_cluster_positions(ref_frame=ARM_BASE_FRAME, sort_axis='x',
                                                  reverse=False)

    if success:
        next_x = {clr: x for clr, (_, x) in SIDES.items()}
        # pick up every piece and set it down on the side of its colour
        for cluster in clusters:
            x, y, z = cluster['position']
            bot.arm.set_ee_pose_components(x=x, y=y, z=z + 0.04, pitch=PITCH)
            bot.arm.set_ee_cartesian_trajectory(z=-(0.04 + z / 2))
            bot.gripper.grasp(2.0)
            bot.arm.set_ee_cartesian_trajectory(z=0.04 + z / 2)
            clr = color_compare(cluster['color'])
            bot.arm.set_ee_pose_components(x=next_x[clr], y=SIDES[clr][0], z=z + 0.04,
                                           pitch=PITCH)
            bot.arm.set_ee_cartesian_trajectory(z=-(0.037 + z / 2))
            bot.gripper.release()
            bot.arm.set_ee_cartesian_trajectory(z=0.037 + z / 2)
            next_x[clr] += STEP
        bot.arm.go_to_sleep_pose()
    else:
        print('Could not get cluster positions.')

    robot_shutdown(global_node)


def color_compare(rgb: List[float]) -> Color:
    """
    Return BLACK or WHITE of an [R, G, B] (0..255) by its value in the HSV colour space.

    :param rgb: the cluster's mean colour
    """
    r, g, b = [x / 255.0 for x in rgb]
    _, _, v = colorsys.rgb_to_hsv(r, g, b)
    if v < 0.3:
        return Color.BLACK
    return Color.WHITE


if __name__ == '__main__':
    main()
