"""
The module of ``interbotix_xs_modules.xs_robot.arm``: InterbotixManipulatorXS and its arm.

``from px100_control.client.arm import InterbotixManipulatorXS`` works like the Interbotix
import it replaces. The classes live in :mod:`~px100_control.client.manipulator` and
:mod:`~px100_control.client.arm_interface`.
"""
from px100_control.client.arm_interface import (EOMG, EV, InterbotixArmXSInterface,
                                                MrDescription, pose_error_norms)
from px100_control.client.manipulator import InterbotixManipulatorXS

__all__ = ['InterbotixManipulatorXS', 'InterbotixArmXSInterface', 'MrDescription',
           'pose_error_norms', 'EOMG', 'EV']
