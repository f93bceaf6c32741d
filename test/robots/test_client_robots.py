"""
End to end for other robot models: the Interbotix-compatible client on in-process nodes.

``InterbotixManipulatorXS(<robot_model>, bringup=True)`` starts sim_driver, ik_service and
trajectory_server with that model; the arm goes home, to an end-effector pose (IK through the
client), and to sleep, and the measured end effector (sim_driver's ee_pose) arrives at the pose.
Robots without a gripper are built with ``gripper_name=None``. The RRRP and the myArm run by
default; every robot with PX100_STRESS=full (all 18 passed on 2026-11-22, see the report).
"""
import os
import time

import numpy as np
from px100_control.models.registry import available_robots, load_robot
from px100_control.ros.conversions import pose_to_matrix
import pytest

pytestmark = pytest.mark.ros

DEFAULT = ['rrrp', 'myarm300pi']        # prismatic joint, 7 DOF (about 8 s each)
ROBOTS = available_robots() if os.environ.get('PX100_STRESS', '').lower() == 'full' else DEFAULT
#: simulated s per wall s of the in-process driver
SPEED = 3.0


def _measured_pose(bot, timeout=3.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        msg = bot.core.ee_pose
        if msg is not None:
            return pose_to_matrix(msg.pose)[0]
        time.sleep(0.02)
    raise AssertionError('no ee_pose from sim_driver')


def _settle(bot, T, tol_p, timeout=3.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        M = _measured_pose(bot)
        if np.linalg.norm(M[:3, 3] - T[:3, 3]) < tol_p:
            return M
        time.sleep(0.05)
    return _measured_pose(bot)


@pytest.mark.parametrize('name', ROBOTS)
def test_client_drives_robot_model(name):
    """Home, an IK pose target and sleep through the client; the measured pose arrives."""
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
    m = load_robot(name)
    # physics at 250 Hz (500 Hz with a prismatic joint, whose default gains need it); the
    # driver owns the clock at SPEED times real time (where the arm ends, not when: a busy
    # machine slows the simulated time, the nodes follow it)
    rate = 500.0 if 'prismatic' in m.joint_types else 250.0
    bot = InterbotixManipulatorXS(name, 'arm', 'gripper' if m.gripper else None, bringup=True,
                                  moving_time=1.5, accel_time=0.3, connect_timeout=30.0,
                                  real_time_factor=SPEED,
                                  node_kwargs={'parameters': {'control_rate': rate}})
    robot_startup()
    try:
        assert bot.arm.get_number_of_joints() == m.dof
        bot.arm.go_to_home_pose()
        # a target near home, reachable within the limits by construction
        rng = np.random.default_rng(88)
        span = m.upper - m.lower
        q_target = np.clip(m.home + rng.uniform(-0.06, 0.06, m.dof) * np.minimum(span, 3.0),
                           m.lower, m.upper)
        T = m.fk(q_target)
        theta, ok = bot.arm.set_ee_pose_matrix(T)
        assert ok, f'{name}: IK/move refused'
        assert np.abs(m.fk(np.array(theta)) - T).max() < 1e-6
        M = _settle(bot, T, 0.003)
        assert np.linalg.norm(M[:3, 3] - T[:3, 3]) < 0.003, (name, M[:3, 3], T[:3, 3])
        q_meas = np.array(bot.arm.get_joint_positions())
        assert np.abs(q_meas - np.array(theta)).max() < 0.03
        bot.arm.go_to_sleep_pose()
        Ms = _settle(bot, m.fk(m.sleep), 0.005)
        assert np.linalg.norm(Ms[:3, 3] - m.fk(m.sleep)[:3, 3]) < 0.005
    finally:
        robot_shutdown()
