"""
The camera rendered by MuJoCo and the cluster pipeline on what it sees: the pick_place scene.

Each object's cluster centre (mapped to the base frame) lies within 5 mm (x, y) of the object's
true position, its top face's centre within 2.5 mm, and its colour is the object's; the
camera's depth matches the geometry.
"""
import threading

import numpy as np
from px100_control.models.registry import load_robot
from px100_control.perception.camera import (back_project, CameraSpec, noisy_depth,
                                             transform_points)
from px100_control.perception.cloud_filter import FilterParams, run_pipeline
from px100_control.sim.camera_render import CameraRenderer, posed_model
from px100_control.sim.scene import load_scene
import pytest


@pytest.fixture(scope='module')
def view():
    """Render the default camera over the pick_place scene, the arm at its sleep pose."""
    robot = load_robot('px100')
    scene = load_scene('pick_place', robot)
    camera = CameraSpec()
    model, data = posed_model(robot, scene, camera)
    renderer = CameraRenderer(model, camera)
    try:
        color, depth = renderer.render(data)
    finally:
        renderer.close()
    return scene, camera, color, depth


def test_depth_of_the_table_matches_the_geometry(view):
    scene, camera, color, depth = view
    assert color.shape == (480, 640, 3) and color.dtype == np.uint8
    assert depth.shape == (480, 640) and depth.dtype == np.float32
    points, _ = back_project(camera.intrinsics(), depth)
    base = transform_points(camera.optical_pose(), points)
    on_table = np.abs(base[:, 2]) < 0.002
    assert on_table.mean() > 0.5          # most of the view is the table top at z = 0


def test_each_object_is_a_cluster_at_its_position_and_colour(view):
    scene, camera, color, depth = view
    noisy = noisy_depth(camera, depth, np.random.default_rng(7))
    points, colors = back_project(camera.intrinsics(), noisy, color)
    base = transform_points(camera.optical_pose(), points)
    # the crop box of a user who measured the workspace: the table in front of the arm
    near = ((base[:, 0] > 0.08) & (base[:, 0] < 0.26) & (np.abs(base[:, 1]) < 0.1)
            & (base[:, 2] > -0.02) & (base[:, 2] < 0.06))
    params = FilterParams(x_filter_min=-1, x_filter_max=1, y_filter_min=-1, y_filter_max=1,
                          z_filter_min=0.1, z_filter_max=2.0)
    result = run_pipeline(points[near], colors[near], params, np.random.default_rng(1))
    found = [(transform_points(camera.optical_pose(), np.array([c.position]))[0], c.color)
             for c in result.clusters]
    assert len(found) == len(scene.objects), result.reason
    for body in scene.objects:
        xy = np.array(body.position[:2])
        position, rgb = min(found, key=lambda f: np.linalg.norm(f[0][:2] - xy))
        assert np.linalg.norm(position[:2] - xy) < 0.005, (body.name, position)
        assert int(np.argmax(rgb)) == int(np.argmax(body.rgba[:3])), (body.name, rgb)
    # the centre of each top face (pc_filter's cluster_position:=top_face) is closer: the
    # centroid is pulled toward the camera by the sides it sees
    tops = [transform_points(camera.optical_pose(), np.array([c.top_centre]))[0]
            for c in result.clusters]
    for body in scene.objects:
        xy = np.array(body.position[:2])
        top = min(tops, key=lambda t: np.linalg.norm(t[:2] - xy))
        assert np.linalg.norm(top[:2] - xy) < 0.0025, (body.name, top)


def test_renders_and_closes_from_any_thread():
    """A multi-threaded executor renders and closes from other threads (was EGL_BAD_ACCESS)."""
    robot = load_robot('px100')
    camera = CameraSpec(width=64, height=48)
    model, data = posed_model(robot, load_scene('pick_place', robot), camera)
    renderer = CameraRenderer(model, camera)
    errors, depths = [], []

    def run(job):
        try:
            job()
        except Exception as exc:  # noqa: B902 - reported below with its thread
            errors.append(repr(exc))
    for job in [lambda: depths.append(renderer.render(data)[1])] * 3 + [renderer.close]:
        thread = threading.Thread(target=run, args=(job,))
        thread.start()
        thread.join()
    assert not errors and len(depths) == 3, errors
    assert all(np.array_equal(depths[0], d) for d in depths)
