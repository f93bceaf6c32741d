"""
An Interbotix-style script interrupted by the test (run as a process): one long waist move.

Usage: ``python interrupt_script.py NAMESPACE BAG_DIR`` (BAG_DIR '' = no Recorder). Prints
``MOVING`` when the move starts; a Ctrl-C must then cancel it (see test_client_interrupt.py).
"""
import sys

from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
from px100_control.ros.recorder import Recorder


def run(namespace: str) -> None:
    """Connect, move the waist for 5 s, shut down."""
    bot = InterbotixManipulatorXS('px100', 'arm', 'gripper', robot_name=namespace,
                                  connect_timeout=30.0)
    robot_startup()
    print('MOVING', flush=True)
    bot.arm.set_single_joint_position('waist', 1.5, moving_time=5.0, accel_time=0.5)
    print('MOVE ENDED', flush=True)
    robot_shutdown()


if __name__ == '__main__':
    ns, bag = sys.argv[1], sys.argv[2]
    if bag:
        with Recorder(bag, robot_name=ns):
            run(ns)
    else:
        run(ns)
