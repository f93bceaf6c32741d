"""
Bad input to the camera and the filter, pure layers: a camera that sees nothing, an empty view.

A pose whose optical axis misses the table within the depth range is refused naming the pose;
a camera that is accepted but looks past everything gives an empty cloud, and the filter then
ends with its reason instead of clusters.
"""
import numpy as np
from px100_control.models.registry import load_robot
from px100_control.perception.camera import back_project, CameraSpec, noisy_depth, view_error
from px100_control.perception.cloud_filter import FilterParams, run_pipeline
from px100_control.sim.camera_render import CameraRenderer, posed_model
from px100_control.sim.scene import load_scene
import pytest


@pytest.mark.parametrize('spec, words', [
    (CameraSpec(look_at=(0.18, 0.0, 1.5)), 'nowhere ahead'),             # at the ceiling
    (CameraSpec(position=(0.2, 0.0, 0.3), look_at=(1.0, 0.0, 0.3)), 'nowhere ahead'),
    (CameraSpec(position=(0.2, 0.0, 0.3), look_at=(5.0, 0.0, 0.29)), 'at 144 m'),
    (CameraSpec(depth_range=(0.7, 3.0)), 'at 0.601 m'),                 # closer than min
])
def test_a_camera_that_sees_nothing_is_refused_naming_its_pose(spec, words):
    text = view_error(spec)
    assert text is not None and 'the camera sees nothing' in text and words in text, text
    assert f'position {list(spec.position)}' in text and 'depth_range' in text


def test_the_default_camera_sees_the_table():
    assert view_error(CameraSpec()) is None


def test_a_view_of_nothing_gives_no_cluster_and_the_reason():
    """Past the table's edge, up to the range: every pixel without return -> empty cloud."""
    robot = load_robot('px100')
    camera = CameraSpec(position=(0.2, 0.0, 0.3), look_at=(1.0, 0.0, 0.35), width=64,
                        height=48, depth_range=(0.16, 0.5), subpixel=0.0)
    model, data = posed_model(robot, load_scene('pick_place', robot), camera)
    renderer = CameraRenderer(model, camera)
    try:
        color, depth = renderer.render(data)
    finally:
        renderer.close()
    depth = noisy_depth(camera, depth, np.random.default_rng(0))   # no return past 0.5 m
    points, colors = back_project(camera.intrinsics(), depth, color)
    assert len(points) == 0
    result = run_pipeline(points, colors, FilterParams(), np.random.default_rng(0))
    assert result.clusters == [] and result.reason == 'no point inside the crop box'
