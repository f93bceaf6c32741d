"""
The standalone InterbotixGripperXS in its ROS 2 (humble/jazzy) and ROS 1 forms, on real nodes.

The first gripper starts sim_driver, ik_service and trajectory_server in this process
(``bringup=True``, BOT_SPEED times real time on the driver's clock); the others connect to
them, constructed with keywords and positionally as Interbotix's signatures allow. Each one
closes and opens the simulated gripper.
"""
import threading
import time

from client_support import BOT_SPEED, wait_until
import pytest

pytestmark = pytest.mark.ros

LOWER, UPPER = 0.015, 0.037


@pytest.fixture(scope='module')
def first():
    """Yield a standalone gripper built with the ROS 2 keywords (nodes in this process)."""
    from px100_control.client import robot_shutdown
    from px100_control.client.gripper import InterbotixGripperXS
    from rclpy.logging import LoggingSeverity
    g = InterbotixGripperXS(
        robot_model='px100', gripper_name='gripper', robot_name='px100', gripper_pressure=0.5,
        gripper_pressure_lower_limit=150, gripper_pressure_upper_limit=350,
        topic_joint_states='joint_states', logging_level=LoggingSeverity.INFO,
        node_name='robot_manipulation', start_on_init=True, bringup=True, connect_timeout=30.0,
        real_time_factor=BOT_SPEED)
    try:
        yield g
    finally:
        robot_shutdown()


def _close_and_open(g) -> None:
    """grasp() closes to the lower finger limit, release() opens to the upper one."""
    g.gripper.grasp(delay=0.1)
    assert wait_until(lambda: g.gripper.get_finger_position() < LOWER + 5e-4, 6.0), \
        g.gripper.get_finger_position()
    g.gripper.release(delay=0.1)
    assert wait_until(lambda: g.gripper.get_finger_position() > UPPER - 5e-4, 6.0), \
        g.gripper.get_finger_position()
    assert wait_until(lambda: not g.gripper.gripper_moving, 1.0)


def test_ros2_keywords(first):
    """Keywords as Interbotix names them: a started core, 250 PWM, grasp and release work."""
    from px100_control.client import interbotix_is_up
    assert interbotix_is_up()
    assert first.gripper.core is first.core and first.dxl is first.core
    assert first.core.topic_joint_states == 'joint_states'
    assert first.gripper.gripper_value == pytest.approx(250.0)
    first.start()  # already spinning: a no-op
    _close_and_open(first)


def test_ros2_positional_with_start_later(first):
    """All ten ROS 2 arguments positionally, start_on_init False, then start()."""
    from px100_control.client.gripper import InterbotixGripperXS
    from rclpy.logging import LoggingSeverity
    g = InterbotixGripperXS('px100', 'gripper', 'px100', 1.0, 150, 350, 'joint_states',
                            LoggingSeverity.INFO, 'robot_manipulation', False)
    assert g.gripper.gripper_value == pytest.approx(350.0)
    g.start()
    _close_and_open(g)


def test_ros1_positional_init_node(first):
    """Noetic's form: init_node is the 7th positional argument; .dxl is the core."""
    from px100_control.client.gripper import InterbotixGripperXS
    g = InterbotixGripperXS('px100', 'gripper', None, 0.0, 150, 350, True)
    assert g.init_node is True and g.dxl is g.core
    assert g.core.topic_joint_states == 'joint_states'
    assert g.gripper.gripper_value == pytest.approx(150.0)
    g.gripper.close(delay=0.1)
    assert wait_until(lambda: g.gripper.get_finger_position() < LOWER + 5e-4, 8.0)
    g.gripper.open(delay=0.1)
    assert wait_until(lambda: g.gripper.get_finger_position() > UPPER - 5e-4, 8.0)


def test_run_blocks_until_shutdown(first):
    """run() (Interbotix: the spin thread's target) returns once shutdown() is called."""
    runner = threading.Thread(target=first.run, daemon=True)
    runner.start()
    time.sleep(0.3)
    assert runner.is_alive()
    first.shutdown()
    runner.join(5.0)
    assert not runner.is_alive()
