"""
Fixtures of the client tests: a robot whose nodes run in this process (bringup=True).

Every test module that uses ``bot`` gets its own in-process sim_driver, ik_service and
trajectory_server (real rclpy nodes over DDS in the test's private domain) and a client on top,
shut down with robot_shutdown() at the end of the module. Its driver owns the clock and runs at
BOT_SPEED times real time (client_support.py): the tests check behaviour, and their pauses and
timings are in simulated seconds. ``PX100_CLIENT_TEST_CONNECT=1`` runs the same tests against
nodes that are already running instead.
"""
from client_support import BOT_SPEED, make_bot
import pytest


@pytest.fixture(scope='module')
def bot():
    """Yield a started InterbotixManipulatorXS on in-process nodes; shut down afterwards."""
    from px100_control.client import robot_shutdown, robot_startup
    robot = make_bot(real_time_factor=BOT_SPEED)
    robot_startup()
    try:
        yield robot
    finally:
        robot_shutdown()
