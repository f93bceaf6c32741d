"""
The ArmTag: the tag image, its detection and the camera -> base transform, without ROS.

The camera's own model (:class:`~px100_control.sim.camera_scene.CameraScene`) renders the arm
with the tag in several poses; the truth is the CameraSpec's pose and the tag's link pose from
the URDF's /tf tree (independent of MuJoCo). Tilt from the corners alone is ambiguous for a
20 px tag (measured ~14 deg); with the depth image it is within 1 deg.
"""
import math

import numpy as np
from px100_control.bag.tf import description_tree
from px100_control.bag.world import marker_scale
from px100_control.models.registry import load_robot
from px100_control.perception import armtag
from px100_control.perception.camera import CameraSpec, noisy_depth
from px100_control.sim.camera_scene import Body, CameraScene
from px100_control.sim.scene import load_scene
import pytest

ROBOT = load_robot('px100')
POSES = ([0.0, 0.0, 0.0, 0.0], list(ROBOT.sleep), [0.3, -0.5, 0.3, 0.6], [-0.4, 0.2, 0.1, 0.5])


@pytest.fixture(scope='module')
def scene():
    """Yield the camera's model of pick_place with the tag (one renderer for the module)."""
    world = load_scene('pick_place', ROBOT)
    bodies = [Body(b.name, b.shape, marker_scale(b.shape, b.size), b.rgba) for b in world.bodies]
    poses = {b.name: (b.position, b.quaternion_xyzw) for b in world.bodies}
    view = CameraScene(ROBOT, world.camera, bodies)
    yield view, poses
    view.close()


def _angle(R) -> float:
    return math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0))))


def _tag_in_base(q) -> np.ndarray:
    parent = description_tree(ROBOT.urdf_xml, '').link_poses(
        dict(zip(ROBOT.joint_names, q)))[armtag.PARENT_LINK]
    offset = np.eye(4)
    offset[:3, 3] = armtag.OFFSET
    return parent @ offset


def test_tag_image_is_opencvs_tag36h11():
    """The texture decodes as tag36h11 id 5; the black square is 8 of its 10 cells."""
    image = armtag.tag_image()
    assert image.shape == (10 * armtag.CELL_PIXELS,) * 2
    assert image[0].min() == 255 and image[armtag.CELL_PIXELS + 1, armtag.CELL_PIXELS + 1] == 0
    big = np.pad(np.repeat(image[:, :, None], 3, axis=2), ((40, 40), (40, 40), (0, 0)),
                 constant_values=255)
    cam = CameraSpec(width=big.shape[1], height=big.shape[0])
    found = armtag.detect(big, cam.intrinsics())
    assert found.found, found.reason


@pytest.mark.parametrize('q', POSES)
def test_camera_to_base_within_5mm_1deg(scene, q):
    """Detected with depth (D415 noise): camera pose within 5 mm and 1 deg of the truth."""
    view, poses = scene
    view.set_state(dict(zip(ROBOT.joint_names, q)), poses)
    color, depth = view.render()
    depth = noisy_depth(view.camera, depth, np.random.default_rng(3))
    found = armtag.detect(color, view.camera.intrinsics(), depth=depth)
    assert found.found, found.reason
    pose = np.linalg.inv(armtag.camera_to_base(found.T_camera_tag, _tag_in_base(q)))
    truth = view.camera.optical_pose()
    assert np.linalg.norm(pose[:3, 3] - truth[:3, 3]) < 0.005, (pose, truth)
    assert _angle(pose[:3, :3].T @ truth[:3, :3]) < 1.0


def test_corners_alone_leave_the_tilt_ambiguous(scene):
    """Without depth the 20 px tag's position is right but its tilt is not (why depth helps)."""
    view, poses = scene
    view.set_state(dict(zip(ROBOT.joint_names, POSES[0])), poses)
    color, _ = view.render()
    found = armtag.detect(color, view.camera.intrinsics())
    truth = np.linalg.inv(view.camera.optical_pose()) @ _tag_in_base(POSES[0])
    assert np.linalg.norm(found.T_camera_tag[:3, 3] - truth[:3, 3]) < 0.005
    assert _angle(found.T_camera_tag[:3, :3].T @ truth[:3, :3]) > 2.0


def test_not_found_says_why(scene):
    """No tag in view, an image of another id, not an image: found False and the reason."""
    view, poses = scene
    intr = view.camera.intrinsics()
    empty = armtag.detect(np.full((480, 640, 3), 200, np.uint8), intr)
    assert not empty.found and 'id 5 not found' in empty.reason and 'none' in empty.reason
    other = np.repeat(armtag.tag_image(7)[:, :, None], 3, axis=2)
    other = np.pad(other, ((160, 160), (240, 240), (0, 0)), constant_values=255)
    seen = armtag.detect(other, intr)
    assert not seen.found and '[7]' in seen.reason, seen.reason
    assert 'not an RGB image' in armtag.detect(np.zeros((5, 5)), intr).reason
