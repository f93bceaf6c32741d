"""The camera model on its own: intrinsics, frames, depth noise, back-projection, refusals."""
import math

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.perception.camera import (back_project, camera_error, CameraSpec, checked,
                                             noisy_depth, transform_points, xyzrgb_cloud)
import pytest


def test_default_is_a_d415_at_vga():
    intr = CameraSpec().intrinsics()
    assert (intr.width, intr.height) == (640, 480)
    assert intr.fx == pytest.approx(615.7, abs=1e-9) and intr.fy == intr.fx
    assert (intr.cx, intr.cy) == (319.5, 239.5)
    assert intr.k[0] == intr.fx and intr.p[10] == 1.0


@pytest.mark.parametrize('position,look_at', [((0.45, 0.0, 0.5), (0.15, 0.0, 0.0)),
                                              ((0.16, 0.0, 0.6), (0.16, 0.0, 0.0)),
                                              ((0.0, -0.5, 0.3), (0.2, 0.1, 0.0))])
def test_optical_frame_is_rep103_and_looks_at_the_target(position, look_at):
    spec = CameraSpec(position=position, look_at=look_at)
    R = spec.optical_rotation()
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-12) and np.linalg.det(R) == pytest.approx(1)
    target = transform_points(np.linalg.inv(spec.optical_pose()), np.array([look_at]))[0]
    assert target[0] == pytest.approx(0, abs=1e-12) and target[1] == pytest.approx(0, abs=1e-12)
    assert target[2] == pytest.approx(np.linalg.norm(np.subtract(look_at, position)))
    if abs(R[2, 2]) < 0.999:      # image down (optical y) points down in the world
        assert R[2, 1] < 0


def test_back_projection_inverts_the_pinhole_projection():
    spec = CameraSpec(width=64, height=48, fovy=math.radians(50))
    intr = spec.intrinsics()
    rng = np.random.default_rng(3)
    depth = np.zeros((48, 64), dtype=np.float32)
    u, v = rng.integers(0, 64, 20), rng.integers(0, 48, 20)
    depth[v, u] = rng.uniform(0.3, 2.0, 20)
    color = np.zeros((48, 64, 3), dtype=np.uint8)
    color[v, u] = (200, 10, 20)
    points, colors = back_project(intr, depth, color)
    assert len(points) == len(set(zip(u, v)))
    pu = intr.fx * points[:, 0] / points[:, 2] + intr.cx
    pv = intr.fy * points[:, 1] / points[:, 2] + intr.cy
    assert np.allclose(depth[np.rint(pv).astype(int), np.rint(pu).astype(int)], points[:, 2])
    assert np.allclose(pu, np.rint(pu)) and (colors == (200, 10, 20)).all()
    with pytest.raises(InvalidInputError, match='64 x 48'):
        back_project(CameraSpec().intrinsics(), depth)


def test_packed_cloud_is_the_back_projection_in_pcl_xyzrgb():
    """xyzrgb_cloud: back_project's points in float32, colours as 0x00RRGGBB, no-returns left."""
    spec = CameraSpec(width=64, height=48, fovy=math.radians(50))
    intr = spec.intrinsics()
    rng = np.random.default_rng(5)
    depth = rng.uniform(0.3, 2.0, (48, 64)).astype(np.float32)
    depth[rng.random((48, 64)) < 0.3] = 0.0                   # no return
    color = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    points, colors = back_project(intr, depth, color)
    packed = xyzrgb_cloud(intr, depth, color)
    assert packed.dtype == np.float32 and packed.shape == (len(points), 4)
    np.testing.assert_allclose(packed[:, :3], points, rtol=0, atol=1e-6)
    rgb = packed[:, 3].copy().view('<u4')
    np.testing.assert_array_equal(np.column_stack([rgb >> 16, (rgb >> 8) & 255, rgb & 255]),
                                  colors)
    assert (rgb >> 24 == 0).all()
    with pytest.raises(InvalidInputError, match='64 x 48'):
        xyzrgb_cloud(CameraSpec().intrinsics(), depth, color)


def test_depth_noise_follows_the_stereo_model_and_the_range():
    spec = CameraSpec()
    true = np.full((200, 200), 0.6, dtype=np.float32)
    true[0, :10] = 0.05        # too near: no return
    true[1, :10] = 9.0         # too far
    true[2, :10] = np.nan
    out = noisy_depth(spec, true, np.random.default_rng(0))
    assert (out[:3, :10] == 0).all()
    sample = out[10:, :]
    expected = 0.6 ** 2 * 0.08 / (615.7 * 0.055)     # 0.85 mm at 0.6 m
    assert np.std(sample) == pytest.approx(expected, rel=0.05)
    assert abs(np.mean(sample) - 0.6) < 1e-4
    exact = noisy_depth(CameraSpec(subpixel=0.0), true, np.random.default_rng(0))
    assert (exact[10:] == np.float32(0.6)).all()


def test_a_bad_camera_is_refused_naming_every_wrong_field():
    bad = CameraSpec(position=(0.1, math.nan, 0.5), width=8, fovy=math.radians(170), rate=0.0,
                     depth_range=(0.5, 0.2), subpixel=-1.0)
    text = camera_error(bad)
    for word in ('position', 'width', 'fovy', 'rate', 'depth_range', 'subpixel'):
        assert word in text
    with pytest.raises(InvalidInputError, match="camera 'camera'"):
        checked(bad)
    assert camera_error(CameraSpec(look_at=CameraSpec().position)) == \
        'look_at equals position: the camera looks nowhere'
    assert camera_error(CameraSpec()) is None
