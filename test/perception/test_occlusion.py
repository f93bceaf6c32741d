"""
What the real filter makes of touching and hidden objects, on the camera's rendered cloud.

The occlusion scene (config/scenes/occlusion.yaml): a red and a yellow cube touching side by
side, a cube behind a wall (from the camera, which looks from in front of the arm at a low
angle) and a bigger cube half behind the wall's end. Rendered by MuJoCo, depth noise added,
filtered with Interbotix's default parameters; the same scene without the wall (or with the
cubes apart) is the reference. Cluster positions are mapped to the base frame [m].
"""
import dataclasses

import numpy as np
from px100_control.models.registry import load_robot
from px100_control.perception.camera import back_project, noisy_depth, transform_points
from px100_control.perception.cloud_filter import FilterParams, run_pipeline
from px100_control.sim.camera_render import CameraRenderer, posed_model
from px100_control.sim.scene import load_scene
import pytest

ROBOT = load_robot('px100')
SCENE = load_scene('occlusion', ROBOT)


def _clusters(scene):
    """Return [(xyz in the base frame, rgb, points)] of the default filter on the scene's view."""
    camera = scene.camera
    model, data = posed_model(ROBOT, scene, camera)
    renderer = CameraRenderer(model, camera)
    try:
        color, depth = renderer.render(data)
    finally:
        renderer.close()
    points, colors = back_project(camera.intrinsics(),
                                  noisy_depth(camera, depth, np.random.default_rng(7)), color)
    result = run_pipeline(points, colors, FilterParams(), np.random.default_rng(1))
    base = transform_points(camera.optical_pose(), np.array([c.position for c in
                                                             result.clusters]).reshape(-1, 3))
    return [(xyz, c.color, c.num_points) for xyz, c in zip(base, result.clusters)]


def _near(clusters, xy, radius):
    return [c for c in clusters if np.hypot(*(c[0][:2] - np.asarray(xy))) < radius]


def _without(scene, name):
    return dataclasses.replace(scene, bodies=tuple(b for b in scene.bodies if b.name != name))


def _moved(scene, name, position):
    return dataclasses.replace(scene, bodies=tuple(
        dataclasses.replace(b, position=position) if b.name == name else b
        for b in scene.bodies))


@pytest.fixture(scope='module')
def seen():
    """Return the clusters with the wall and without it."""
    return _clusters(SCENE), _clusters(_without(SCENE, 'wall'))


def test_touching_cubes_are_one_cluster_of_mixed_colour(seen):
    """Red and yellow touching: one cluster between them, orange; apart: two, each its own."""
    with_wall, _ = seen
    red, yellow = (np.array(SCENE.body(n).position[:2]) for n in ('red_cube', 'yellow_cube'))
    pair = _near(with_wall, (red + yellow) / 2, 0.03)
    assert len(pair) == 1, pair
    xyz, rgb, _ = pair[0]
    assert red[1] < xyz[1] < yellow[1]                 # between the two centres
    assert 60 < rgb[1] < 170 and rgb[0] > 150          # red + yellow: an orange mean
    apart = _clusters(_moved(SCENE, 'yellow_cube', (0.16, -0.02, 0.0125)))
    assert len(_near(apart, red, 0.01)) == 1 and len(_near(apart, (0.16, -0.02), 0.01)) == 1


def test_a_hidden_cube_has_no_cluster(seen):
    """Behind the wall it is not in the cloud; without the wall it is found."""
    with_wall, no_wall = seen
    hidden = SCENE.body('hidden_cube').position[:2]
    assert _near(with_wall, hidden, 0.02) == []
    assert len(_near(no_wall, hidden, 0.01)) == 1


def test_a_half_hidden_cube_is_a_smaller_cluster_off_its_centre(seen):
    """Half behind the wall's end: fewer points, centroid shifted to its visible side."""
    with_wall, no_wall = seen
    truth = np.array(SCENE.body('peeking_cube').position[:2])
    (partial,), (whole,) = _near(with_wall, truth, 0.02), _near(no_wall, truth, 0.02)
    assert partial[2] < 0.7 * whole[2], (partial[2], whole[2])
    assert partial[0][1] - whole[0][1] > 0.004           # away from the wall (+y)
    assert np.hypot(*(partial[0][:2] - truth)) > 0.005   # off the true centre
