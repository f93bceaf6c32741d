# flake8: noqa  (the body of main() is the seed's code, kept verbatim)
"""
Seed 000, section V.6: the pick-and-place main() in joint space (convert_param_op_to_qdh).

The body of ``main()`` is the seed's, unchanged. Only the import lines differ: Interbotix's
``InterbotixManipulatorXS`` comes from px100_control.client, and the seed's own functions (which
the seed defines in the same file) from seed000_model.py beside this file. Values are the
seed's millimetres: its functions work in mm and return DH joint angles [rad]. Run it through
seed000_px100.py (which starts the simulated robot in-process first).
"""
from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup  # noqa: F401
from seed000_model import convert_param_op_to_qdh, q_dh_to_q_actuator
import numpy as np


def main():
    bot = InterbotixManipulatorXS("px100", "arm",
                                   "gripper")
    # Generalization of the task on a set of objects
    # to move
    object1 = \
        [[100,200,3,np.pi/4],[100,-200,3,np.pi/4]]
    object2 = \
        [[0,0,250,-np.pi/10],[20,100,20,np.pi/2]]
    object3 = \
        [[180,200,80,np.pi/10],[180,-200,80,np.pi/10]]
    for i in [object1,object2,object3]:
        initial_position = i[0]
        second_position = i[1]
        initial_qdh_cord = \
            convert_param_op_to_qdh(initial_position)
        initial_qa_cord = \
            q_dh_to_q_actuator(initial_qdh_cord)
        second_qdh_cord = \
            convert_param_op_to_qdh(second_position)
        second_qa_cord = \
            q_dh_to_q_actuator(second_qdh_cord)
        bot.gripper.open()
        bot.arm.set_joint_positions(initial_qa_cord)
        bot.gripper.close()
        bot.arm.set_joint_positions(second_qa_cord)
        bot.gripper.open()
    bot.arm.go_to_sleep_pose()
