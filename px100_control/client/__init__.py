"""
Interbotix-compatible Python client of px100_control.

Scripts written against Interbotix's Python API (ROS 2 humble/jazzy, or ROS 1) run with only the
import lines changed::

    from px100_control.client import InterbotixManipulatorXS, robot_startup, robot_shutdown

Modules mirror Interbotix's layout: ``client.arm`` (like ``interbotix_xs_modules.xs_robot.arm``,
also exporting InterbotixManipulatorXS), ``client.gripper``, ``client.core``, ``client.robot``
(like ``interbotix_common_modules.common_robot.robot``), ``client.mr_descriptions`` and
``client.pointcloud`` (like ``interbotix_perception_modules.pointcloud``:
InterbotixPointCloudInterface over the ``pc_filter`` node).
"""
from px100_control.client.manipulator import InterbotixManipulatorXS
from px100_control.client.robot import (create_interbotix_global_node,
                                        get_interbotix_global_node, interbotix_is_up,
                                        InterbotixException, robot_shutdown, robot_startup)

__all__ = ['InterbotixManipulatorXS', 'robot_startup', 'robot_shutdown', 'interbotix_is_up',
           'InterbotixException', 'create_interbotix_global_node', 'get_interbotix_global_node']
