"""
The demo's pick planning: the open fingers' footprints against the neighbours, no ROS graph.

scripts/pick_and_place_demo.py picks the object whose open pads have the most room first and,
where a pad's footprint (30 x 5 mm on the px100) would land on a neighbour, grasps off centre
along the closing direction. Seed 100's jittered default scene (the perception demo's test
case) had the open left pad of the red cube's grasp on the green cube's top: the shoulder
stalled 0.07 rad short at its torque limit and the pick failed.
"""
from types import SimpleNamespace

import numpy as np
import pytest
from scripts_support import load_script


@pytest.fixture(scope='module')
def demo():
    """Return scripts/pick_and_place_demo.py as a module (its main is not run)."""
    return load_script('pick_and_place_demo')


def _cube(x, y, size):
    return SimpleNamespace(position=(x, y, size / 2), shape='box', scale=(size, size, size))


def _cylinder(x, y, diameter):
    return SimpleNamespace(position=(x, y, 0.015), shape='cylinder',
                           scale=(diameter, diameter, 0.03))


#: seed 100's jittered default scene after the blue cylinder was placed [m]
SEED100 = {'red_cube': _cube(0.1533, -0.0590, 0.028), 'green_cube': _cube(0.1579, -0.0046, 0.025),
           'blue_cylinder': _cylinder(0.100, -0.080, 0.030)}


def test_a_pad_on_a_neighbour_is_seen_and_a_shifted_grasp_clears_it(demo):
    """Seed 100: at the centre the red cube's pad overlaps the green cube; a shift clears it."""
    assert demo.pad_room('red_cube', SEED100) < 0.0       # the pad lands on the green cube
    shift, room = demo.grasp_shift('red_cube', SEED100)
    assert room >= demo.PAD_MARGIN and room == pytest.approx(
        demo.pad_room('red_cube', SEED100, shift))
    assert 0.0 < abs(shift) <= demo.MAX_GRASP_SHIFT
    # away from the green cube: the closing direction turned towards +y, so a negative shift
    p = np.array(SEED100['red_cube'].position[:2])
    closing = np.array([-p[1], p[0]]) / np.hypot(*p)
    grasp = p + shift * closing
    green = np.array(SEED100['green_cube'].position[:2])
    assert np.hypot(*(grasp - green)) > np.hypot(*(p - green))
    assert demo.plan_pick(SEED100, ['red_cube', 'green_cube']) == ('red_cube', shift)


def test_room_enough_means_no_shift_and_the_default_scene_is_unchanged(demo):
    """The default scene's objects have room at their centres: picked in the same order, as is."""
    bodies = {'red_cube': _cube(0.15, -0.06, 0.028), 'green_cube': _cube(0.16, 0.0, 0.025),
              'blue_cylinder': _cylinder(0.15, 0.06, 0.030)}
    name, shift = demo.plan_pick(bodies, list(bodies))
    assert (name, shift) == ('red_cube', 0.0)
    alone = {'red_cube': bodies['red_cube']}
    assert demo.grasp_shift('red_cube', alone) == (0.0, float('inf'))


def test_no_shift_gives_room_then_the_best_one_is_returned(demo):
    """A neighbour on each side, too close for any shift: the shift with the most room."""
    tight = {'red_cube': _cube(0.15, 0.0, 0.028), 'left': _cube(0.15, 0.045, 0.028),
             'right': _cube(0.15, -0.045, 0.028)}
    shift, room = demo.grasp_shift('red_cube', tight)
    assert room < demo.PAD_MARGIN
    assert all(demo.pad_room('red_cube', tight, s / 2000) <= room + 1e-12
               for s in range(-20, 21))
