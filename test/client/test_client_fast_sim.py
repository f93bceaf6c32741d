"""
A simulation asked to run faster than the machine can: the client's waits follow simulated time.

With ``real_time_factor`` 50 the in-process driver owns the clock and runs as fast as this machine
lets it (a few times real time on two cores, less under load). A script's pauses (``core.sleep``,
the gripper's ``delay``) are simulated seconds, so they must last until the simulation has
advanced that far, not ``seconds / 50`` of wall time; and a move's wall-time budget must not
expire because the simulation is slower than asked.
"""
from client_support import make_bot
import pytest

pytestmark = pytest.mark.ros

#: asked of the in-process driver; far beyond what two cores can simulate
FAST = 50.0


@pytest.fixture(scope='module')
def bot():
    """Yield a client whose in-process simulation runs at real_time_factor FAST."""
    robot = make_bot(real_time_factor=FAST)
    yield robot
    robot.shutdown()


def _stamp(bot) -> float:
    """Return the stamp [s] of the last joint_states (simulated time)."""
    s = bot.core.joint_states.header.stamp
    return s.sec + 1e-9 * s.nanosec


def test_sleep_lasts_simulated_seconds(bot):
    """core.sleep(0.5) returns once joint_states are stamped at least 0.5 s later."""
    before = _stamp(bot)
    bot.core.sleep(0.5)
    advanced = _stamp(bot) - before
    assert advanced >= 0.5 - 0.011, f'slept {advanced:.3f} s of simulated time, not 0.5'


def test_grasp_closes_before_the_arm_moves_and_moves_succeed(bot):
    """A grasp's delay is simulated time: the fingers travel in it; the moves succeed."""
    bot.gripper.release(delay=1.5)
    assert bot.arm.set_ee_pose_components(x=0.2, z=0.15, moving_time=1.0, accel_time=0.3)
    opened, before = bot.gripper.get_finger_position(), _stamp(bot)
    bot.gripper.grasp(delay=1.5)
    closed, waited = bot.gripper.get_finger_position(), _stamp(bot) - before
    assert waited >= 1.5 - 0.011, f'grasp waited {waited:.3f} s of simulated time, not 1.5'
    assert closed < opened - 0.01, \
        f'fingers at {closed * 1000:.1f} mm after a 1.5 s grasp on nothing (open: ' \
        f'{opened * 1000:.1f} mm)'
    assert bot.arm.publish_positions(list(bot.arm.group_info.joint_sleep_positions),
                                     moving_time=1.0, accel_time=0.3)
