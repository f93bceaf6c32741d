"""
Lifecycle (robot_startup / robot_shutdown, ROS 1 scripts, in-process bringup) and bounded errors.

A missing driver makes the constructor fail within its connect timeout with a message that names
what is missing (Interbotix's "Failed to find services under namespace..." is the model); nodes
that die mid-use make the calls fail within a bounded time with the reason, never hang.
"""
import os
import signal
import threading
import time

from client_support import make_bot
import numpy as np
from px100_control.client import (get_interbotix_global_node, interbotix_is_up,
                                  InterbotixException, InterbotixManipulatorXS, robot_shutdown,
                                  robot_startup)
from px100_control.models.registry import load_robot
import pytest

pytestmark = pytest.mark.ros


def test_missing_driver_fails_fast_with_a_clear_message():
    """No nodes under the namespace: InterbotixException naming them, within the timeout."""
    ns = f'px100_missing_{os.getpid()}'
    load_robot('px100')  # cached: time the wait, not a cold model load
    t0 = time.monotonic()
    try:
        with pytest.raises(InterbotixException) as err:
            InterbotixManipulatorXS('px100', robot_name=ns, connect_timeout=2.0)
        elapsed = time.monotonic() - t0
    finally:
        robot_shutdown()
    message = str(err.value)
    assert f"Failed to find the px100_control nodes under namespace '/{ns}' within 2.0 s" \
        in message
    assert f"no joint states on '/{ns}/joint_states' (sim_driver)" in message
    assert 'trajectory_server' in message and 'ik_service' in message
    assert 'Is sim_driver' in message and 'bringup=True' in message
    # 2 s of waiting plus node creation
    assert 2.0 <= elapsed < 10.0, elapsed


def test_startup_shutdown_lifecycle(monkeypatch):
    """robot_startup once (twice raises), shutdown twice is safe, a new robot works after."""
    bot = make_bot()
    assert interbotix_is_up()  # spinning from construction on (ROS 1 scripts need it)
    assert get_interbotix_global_node().get_name() == 'interbotix_robot_manipulation'
    assert bot.get_node() is get_interbotix_global_node()
    assert bot.dxl is bot.core
    robot_startup()
    with pytest.raises(InterbotixException, match='Startup has already been requested.'):
        robot_startup()
    robot_shutdown()
    assert not interbotix_is_up() and get_interbotix_global_node() is None
    robot_shutdown()  # nothing up: no error

    # ROS 1 style: bringup from the environment, no robot_startup(), arm without gripper
    monkeypatch.setenv('PX100_BRINGUP', '1')
    monkeypatch.setenv('PX100_REAL_TIME_FACTOR', '1')
    bot = InterbotixManipulatorXS('px100', gripper_name=None, moving_time=1.5, accel_time=0.3,
                                  connect_timeout=30.0)
    try:
        assert not hasattr(bot, 'gripper')
        assert bot.arm.set_joint_positions([0.2, -0.2, 0.2, 0.0]) is True
        np.testing.assert_allclose(bot.arm.get_joint_positions(), [0.2, -0.2, 0.2, 0.0],
                                   atol=0.005)
        # the in-process driver at real_time_factor 1 (the shared client tests run faster)
        _pause_waits_for_a_simulation_that_fell_behind(bot)
    finally:
        bot.shutdown()  # the galactic-era name
    assert get_interbotix_global_node() is None


def _pause_waits_for_a_simulation_that_fell_behind(bot):
    """
    core.sleep (a grasp's delay) lasts its seconds of the driver's time, and of wall time.

    The in-process driver's physics is held for 1 s (as a starved process: then it catches up
    on its stamps): a 0.5 s pause begun meanwhile returns only once the stamps advanced 0.5 s,
    after the stall. CI: a grasp(2.0) of pick_place ended with the fingers still closing while
    the simulation lagged, and the arm carried the can away half gripped.
    """
    from px100_control.client.robot import get_bringup
    from px100_control.ros.sim_driver_node import SimDriverNode
    bringup = get_bringup(bot.core.robot_name)
    assert bringup is not None, 'needs the in-process bringup'
    driver = next(n for n in bringup.nodes if isinstance(n, SimDriverNode))

    def stamp():
        s = bot.core.joint_states.header.stamp
        return s.sec + 1e-9 * s.nanosec

    start = time.monotonic()
    bot.core.sleep(0.5)                     # a driver on time: the pause is wall time
    assert time.monotonic() - start >= 0.5
    held, stall_end = threading.Event(), []

    def stall():
        with driver._lock:
            held.set()
            time.sleep(1.0)                 # the driver stalls: its clock stops for 1 s
            stall_end.append(time.monotonic())
    thread = threading.Thread(target=stall, daemon=True)
    thread.start()
    assert held.wait(5.0), 'the driver never let go of its lock'
    before = stamp()
    bot.core.sleep(0.5)
    woke = time.monotonic()
    thread.join(5.0)
    assert stall_end, 'the stall did not end'
    # however late this thread runs, a pause on the driver's clock cannot end inside the stall
    assert woke >= stall_end[0], \
        f'the pause ended {stall_end[0] - woke:.2f} s before the 1 s stall did'
    assert stamp() - before >= 0.5 - 0.011, 'the pause ended before the driver caught up'


def _stop_later(proc, delay: float):
    timer = threading.Timer(delay, proc.stop)
    timer.start()
    return timer


def test_nodes_dying_mid_use_fail_within_bounded_time(node_process):
    """sim_driver, ik_service, trajectory_server killed one by one: calls fail, with reasons."""
    ns = f'px100_dies_{os.getpid()}'
    args = ('--ros-args', '-p', f'robot_name:={ns}')
    driver = node_process('sim_driver', *args)
    ik = node_process('ik_service', *args, '-p', 'orientation_mode:=strict')
    server = node_process('trajectory_server', *args)
    bot = InterbotixManipulatorXS('px100', robot_name=ns, moving_time=1.0, accel_time=0.3,
                                  connect_timeout=30.0)
    try:
        # 10 s bounds catch a hang (a call waiting forever on a dead peer); under load the
        # peer's death reaches this process's DDS graph late, and the call's own deadline rules
        # the driver dies 0.6 s into a slow 3 s move from the sleep pose
        timer = _stop_later(driver, 0.6)
        t0 = time.monotonic()
        ok = bot.arm.set_joint_positions([1.0, 0.3, 0.3, 0.3], moving_time=3.0)
        elapsed = time.monotonic() - t0
        timer.join()
        assert ok is False
        assert 0.6 <= elapsed < 10.0, elapsed
        assert 'joint' in bot.arm.last_error and ('sim_driver' in bot.arm.last_error
                                                  or 'driver' in bot.arm.last_error)
        t0 = time.monotonic()
        assert bot.arm.set_joint_positions([0, 0, 0, 0], moving_time=1.0) is False
        assert time.monotonic() - t0 < 10.0
        assert bot.arm.go_to_home_pose() is None  # logs the failure, returns None

        ik.stop()
        t0 = time.monotonic()
        theta, ok = bot.arm.set_ee_pose_components(x=0.2, z=0.15)
        assert ok is False and len(theta) == 4
        assert time.monotonic() - t0 < 10.0
        assert 'ik_service' in bot.arm.last_error

        server.stop()
        t0 = time.monotonic()
        assert bot.arm.set_joint_positions([0.1, 0, 0, 0], moving_time=1.0) is False
        assert time.monotonic() - t0 < 10.0
        assert 'trajectory_server' in bot.arm.last_error
    finally:
        robot_shutdown()
    for p in (driver, ik, server):
        assert p.returncode is not None and p.returncode != -signal.SIGKILL
