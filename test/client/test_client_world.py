"""
bot.world: the scene through the client (in-process nodes, the default pick_place scene).

Objects listed by kind, poses in the base frame equal to the simulator's, unknown names named,
the held object seen while the gripper holds a cube, world reset puts it back; the Interbotix
signatures are untouched (test_client_api_surface).
"""

import math

from client_support import pause, wait_until
import numpy as np
from px100_control.client import InterbotixException
import pytest

pytestmark = pytest.mark.ros


def _driver(bot):
    from px100_control.client import robot
    return next(n for n in robot.get_bringup().nodes if n.get_name() == 'sim_driver')


def test_list_objects_and_poses(bot):
    """Objects, fixtures and table by kind; 4x4 and (xyz, quat) poses match the simulator."""
    assert bot.world.list_objects() == ['blue_cylinder', 'green_cube', 'red_cube']
    assert 'pedestal' in bot.world.list_objects('fixture')
    assert bot.world.list_objects('table') == ['table']
    assert set(bot.world.list_objects(None)) >= {'table', 'pedestal', 'red_cube'}
    sim_poses = _driver(bot).sim.object_poses()
    T = bot.world.get_object_pose('red_cube')
    assert T.shape == (4, 4)
    np.testing.assert_allclose(T[:3, 3], sim_poses['red_cube'][0], atol=2e-3)
    np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-9)
    xyz, quat = bot.world.get_object_position_quaternion('green_cube')
    np.testing.assert_allclose(xyz, sim_poses['green_cube'][0], atol=2e-3)
    assert np.linalg.norm(quat) == pytest.approx(1.0)
    poses = bot.world.get_object_poses()
    assert sorted(poses) == ['blue_cylinder', 'green_cube', 'red_cube']
    info = bot.world.get_object_info('blue_cylinder')
    assert info.shape == 'cylinder' and info.ns == 'objects'
    assert info.scale[0] == pytest.approx(0.026) and info.scale[2] == pytest.approx(0.03)


def test_unknown_names_are_refused_clearly(bot):
    """An unknown object or kind raises InterbotixException listing what exists."""
    with pytest.raises(InterbotixException, match="no object 'purple_cube'.*red_cube"):
        bot.world.get_object_pose('purple_cube')
    with pytest.raises(InterbotixException, match='kind must be one of'):
        bot.world.list_objects('robot')


def test_pick_shows_held_object_and_world_reset_puts_it_back(bot):
    """Grasp the green cube: held_object names it, it rises; world.reset puts it back."""
    start = bot.world.get_object_pose('green_cube')[:3, 3].copy()
    assert bot.world.held_object() == ''
    x, y, z = start
    bot.gripper.release(delay=0.3)
    assert bot.arm.set_ee_pose_components(x=x, y=y, z=z + 0.05, pitch=math.pi / 2,
                                          moving_time=1.5)[1], bot.arm.last_error
    assert bot.arm.set_ee_cartesian_trajectory(z=-0.05, moving_time=1.0), bot.arm.last_error
    bot.gripper.grasp(delay=1.5)                     # closed on the cube before lifting
    assert bot.arm.set_ee_cartesian_trajectory(z=0.05, moving_time=1.0), bot.arm.last_error
    assert wait_until(lambda: bot.world.held_object() == 'green_cube', 2.0), \
        bot.world.held_object()
    pause(bot, 0.2)
    lifted = bot.world.get_object_pose('green_cube')[:3, 3]
    assert lifted[2] > start[2] + 0.03, (start, lifted)
    assert bot.world.reset()
    # the reset's markers come on another topic than the service's reply: wait for them
    back = [None]

    def returned():
        back[0] = bot.world.get_object_pose('green_cube')[:3, 3]
        return np.linalg.norm(back[0] - start) < 0.003
    assert wait_until(returned, 3.0), (start, back[0])
    bot.gripper.release(delay=0.5)
    assert wait_until(lambda: bot.world.held_object() == '', 2.0)
    bot.arm.go_to_sleep_pose(moving_time=1.5)
