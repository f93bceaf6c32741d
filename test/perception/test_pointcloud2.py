"""The PointCloud2 byte codec: round trips, other layouts, and refusals (no ROS)."""
import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.perception.pointcloud2 import decode, encode, XYZRGB_STEP
import pytest


def _cloud(n=50, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1, 1, (n, 3)), rng.integers(0, 256, (n, 3))


def test_encode_decode_round_trip_keeps_float32_points_and_colours():
    points, colors = _cloud()
    fields, step, data = encode(points, colors)
    assert step == XYZRGB_STEP and len(data) == step * len(points)
    got, rgb = decode(fields, step, data, len(points), 1, step * len(points))
    np.testing.assert_array_equal(got, points.astype(np.float32).astype(np.float64))
    np.testing.assert_array_equal(rgb, colors)


def test_any_field_order_offsets_rgba_uint32_and_row_padding():
    """z, rgba (uint32), y, x at odd offsets, a 2-row organised cloud with padded rows."""
    points, colors = _cloud(6, seed=1)
    step, width, height, row_step = 24, 3, 2, 3 * 24 + 8
    raw = np.zeros(row_step * height, dtype=np.uint8)
    word = (colors[:, 0] << 16) | (colors[:, 1] << 8) | colors[:, 2] | (255 << 24)
    for k in range(6):
        base = (k // width) * row_step + (k % width) * step
        raw[base:base + 4] = np.array([points[k, 2]], '<f4').view(np.uint8)
        raw[base + 4:base + 8] = np.array([word[k]], '<u4').view(np.uint8)
        raw[base + 8:base + 16] = np.array([points[k, 1]], '<f8').view(np.uint8)
        raw[base + 16:base + 20] = np.array([points[k, 0]], '<f4').view(np.uint8)
    fields = [('z', 0, 7, 1), ('rgba', 4, 6, 1), ('y', 8, 8, 1), ('x', 16, 7, 1)]
    got, rgb = decode(fields, step, raw.tobytes(), width, height, row_step)
    np.testing.assert_allclose(got[:, 1], points[:, 1])
    np.testing.assert_allclose(got[:, [0, 2]], points[:, [0, 2]], atol=1e-6)
    np.testing.assert_array_equal(rgb, colors)


def test_separate_rgb_fields_and_no_colour():
    pts = np.array([[0.1, 0.2, 0.3]], '<f4')
    data = pts.tobytes() + bytes([10, 20, 30, 0])
    fields = [('x', 0, 7, 1), ('y', 4, 7, 1), ('z', 8, 7, 1), ('r', 12, 2, 1), ('g', 13, 2, 1),
              ('b', 14, 2, 1)]
    _, rgb = decode(fields, 16, data, 1, 1, 16)
    assert rgb.tolist() == [[10, 20, 30]]
    _, rgb = decode(fields[:3], 16, data, 1, 1, 16)
    assert rgb.tolist() == [[0, 0, 0]]


def test_empty_cloud_decodes_to_no_points():
    points, rgb = decode([('x', 0, 7, 1), ('y', 4, 7, 1), ('z', 8, 7, 1)], 16, b'', 0, 1, 0)
    assert points.shape == (0, 3) and rgb.shape == (0, 3)


@pytest.mark.parametrize('kwargs, words', [
    ({'is_bigendian': True}, 'big-endian'),
    ({'fields': [('x', 0, 7, 1), ('y', 4, 7, 1)]}, "no field ['z']"),
    ({'fields': [('x', 0, 7, 1), ('y', 4, 7, 1), ('z', 30, 7, 1)]}, "field 'z'"),
    ({'fields': [('x', 0, 9, 1), ('y', 4, 7, 1), ('z', 8, 7, 1)]}, 'unknown datatype 9'),
    ({'data': b'\0' * 40}, 'data has 40 bytes'),
])
def test_bad_clouds_are_refused_with_the_reason(kwargs, words):
    fields, step, data = encode(*_cloud(2))
    args = {'fields': fields, 'point_step': step, 'data': data, 'width': 2, 'height': 1,
            'row_step': 2 * step}
    args.update(kwargs)
    with pytest.raises(InvalidInputError, match=words.replace('[', r'\[').replace(']', r'\]')):
        decode(**args)
