# flake8: noqa  (the body of main() is the seed's code, kept verbatim)
"""
Seed 000, section V.8: the pick-and-place main() with the iterative (null-space) algorithm.

The body of ``main()`` is the seed's, unchanged. Only the import lines differ: Interbotix's
``InterbotixManipulatorXS`` comes from px100_control.client, and the seed's own functions and
``q_nom`` (defined in the seed's own file) from seed000_model.py beside this file. Targets
are the seed's millimetres. Run it through seed000_px100.py (which starts the simulated robot
in-process first).
"""
from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup  # noqa: F401
from seed000_model import iterative_algorithm, q_dh_to_q_actuator, q_nom
import numpy as np


def main():

    bot = InterbotixManipulatorXS("px100", "arm",
        "gripper")
    bot.gripper.open()

    object1 = [[100, 250, 100], [90, -100, 10]]
    object2 = [[20, 0, 250], [150, 50, 10]]
    object3 = [[150, 0, 80], [40, -100, -30]]
    q_initial = q_nom
    for i in np.array([object1, object2, object3]):

        qdh1 = iterative_algorithm(q_initial, i[0],
            qnom=q_nom)
        qa1 = q_dh_to_q_actuator(qdh1)
        bot.arm.set_joint_positions(qa1)
        bot.gripper.close()
        q_initial = qdh1

        qdh2 = iterative_algorithm(q_initial, i[1],
            qnom=q_nom)
        qa2 = q_dh_to_q_actuator(qdh2)
        bot.arm.set_joint_positions(qa2)
        bot.gripper.open()
        q_initial = qdh2

    bot.arm.go_to_sleep_pose()
