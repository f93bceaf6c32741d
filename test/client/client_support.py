"""Helpers shared by the client tests (imported by name: test dirs have no __init__.py)."""
import os
import threading
import time

import numpy as np

#: moves long enough for the simulated servos to track them (fast tests, realistic arm)
MOVING_TIME = 1.0
ACCEL_TIME = 0.3
#: wall seconds per simulated second of the scripts' simulations (PX100_REAL_TIME_FACTOR < 1 slows
#: the simulation down for a loaded machine; every timing assertion scales with it)
SLOW = 1.0 / float(os.environ.get('PX100_REAL_TIME_FACTOR', '1') or 1)
#: simulated s per wall s of the shared in-process robot (conftest's ``bot``): its driver owns the
#: clock (/clock) and the nodes follow it, so the behaviour tests run BOT_SPEED times faster and a
#: loaded machine slows simulated time instead of making a node miss a wall clock
#: (PX100_REAL_TIME_FACTOR sets it; the wall-time behaviour of real_time_factor 1 is tested in
#: test_client_lifecycle.py and by the scripts run at real time)
BOT_SPEED = float(os.environ.get('PX100_REAL_TIME_FACTOR') or 3.0)


def wall(t: float) -> float:
    """Return the least wall time [s] that t simulated seconds of ``bot`` take."""
    return t / BOT_SPEED


def pause(bot, t: float) -> None:
    """Sleep t simulated seconds of ``bot``'s driver (its joint_states stamps)."""
    bot.core.sleep(t)


def make_bot(**kwargs):
    """Construct the robot the tests use (in-process nodes unless told to connect)."""
    from px100_control.client import InterbotixManipulatorXS
    kwargs.setdefault('bringup', os.environ.get('PX100_CLIENT_TEST_CONNECT') != '1')
    kwargs.setdefault('connect_timeout', 30.0)
    kwargs.setdefault('moving_time', MOVING_TIME)
    kwargs.setdefault('accel_time', ACCEL_TIME)
    return InterbotixManipulatorXS('px100', 'arm', 'gripper', **kwargs)


def wait_until(predicate, timeout: float = 3.0, period: float = 0.01) -> bool:
    """
    Poll predicate until true or until a deadline; return its last value.

    The deadline is ``timeout`` wall seconds (longer in a slowed simulation, SLOW): never shorter
    than ``timeout`` simulated seconds at any speed up to real time's multiples.
    """
    end = time.monotonic() + timeout * max(1.0, SLOW, 1.0 / BOT_SPEED)
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(period)
    return bool(predicate())


class EeSampler:
    """Sample the measured ee_pose (sim_driver topic) in a background thread."""

    def __init__(self, bot, period: float = 0.01):
        self.bot, self.period = bot, period
        self.samples = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        last = None
        while not self._stop.is_set():
            msg = self.bot.core.ee_pose
            if msg is not None and msg is not last:
                p = msg.pose.position
                self.samples.append((p.x, p.y, p.z))
                last = msg
            time.sleep(self.period)

    def __enter__(self):
        """Start sampling."""
        self._thread.start()
        return self

    def __exit__(self, *exc):
        """Stop sampling."""
        self._stop.set()
        self._thread.join(2.0)

    def array(self) -> np.ndarray:
        """Return the samples as (k, 3) [m]."""
        return np.array(self.samples).reshape(-1, 3)
