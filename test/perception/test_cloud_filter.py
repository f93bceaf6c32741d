"""
Interbotix's cluster pipeline on synthetic clouds, in the camera's optical frame (z forward).

A table plane 0.6 m from the camera with boxes standing on it (their top and side faces
sampled at 2 mm), plus scattered outliers.
"""
import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.perception.cloud_filter import (euclidean_clusters, FilterParams,
                                                   params_error, run_pipeline,
                                                   top_face_centre, voxel_grid)
import pytest

STEP = 0.002
TABLE_Z = 0.6


def _grid(x0, x1, y0, y1):
    xs, ys = np.meshgrid(np.arange(x0, x1, STEP), np.arange(y0, y1, STEP))
    return xs.ravel(), ys.ravel()


def _table(hole_boxes=()):
    x, y = _grid(-0.2, 0.2, -0.2, 0.2)
    keep = np.ones(len(x), dtype=bool)
    for cx, cy, size, _ in hole_boxes:
        keep &= ~((abs(x - cx) < size / 2) & (abs(y - cy) < size / 2))
    return np.column_stack([x[keep], y[keep], np.full(keep.sum(), TABLE_Z)])


def _box(cx, cy, size, height):
    """Top face and the four side faces of a box standing on the table (optical frame)."""
    x, y = _grid(cx - size / 2, cx + size / 2, cy - size / 2, cy + size / 2)
    top = np.column_stack([x, y, np.full(len(x), TABLE_Z - height)])
    zs = np.arange(TABLE_Z - height, TABLE_Z, STEP)
    s = np.arange(-size / 2, size / 2, STEP)
    ss, zz = np.meshgrid(s, zs)
    ss, zz = ss.ravel(), zz.ravel()
    sides = [np.column_stack([cx + sx * size / 2 + 0 * ss, cy + ss, zz]) for sx in (-1, 1)]
    sides += [np.column_stack([cx + ss, cy + sy * size / 2 + 0 * ss, zz]) for sy in (-1, 1)]
    return np.vstack([top] + sides)


def _scene(boxes, outliers=30, seed=0):
    rng = np.random.default_rng(seed)
    parts, colors = [_table(boxes)], [np.tile((180, 160, 120), (len(_table(boxes)), 1))]
    for k, (cx, cy, size, height) in enumerate(boxes):
        pts = _box(cx, cy, size, height)
        parts.append(pts)
        colors.append(np.tile([(220, 30, 30), (30, 200, 60), (40, 80, 220)][k % 3],
                              (len(pts), 1)))
    noise = np.column_stack([rng.uniform(-0.2, 0.2, outliers), rng.uniform(-0.2, 0.2, outliers),
                             rng.uniform(0.3, 0.55, outliers)])
    parts.append(noise)
    colors.append(np.zeros((outliers, 3)))
    return np.vstack(parts), np.vstack(colors).astype(np.uint8)


PARAMS = FilterParams(z_filter_min=0.3, z_filter_max=0.7, cluster_max_size=5000)


def test_two_boxes_give_two_clusters_at_their_centres():
    boxes = [(0.05, 0.03, 0.03, 0.03), (-0.06, -0.04, 0.025, 0.025)]
    points, colors = _scene(boxes)
    result = run_pipeline(points, colors, PARAMS, np.random.default_rng(1))
    assert result.reason == '' and len(result.clusters) == 2
    assert result.plane is not None and abs(abs(result.plane[2]) - 1) < 1e-3
    assert abs(abs(result.plane[3]) - TABLE_Z) < 1e-3
    colours = [(220, 30, 30), (30, 200, 60)]
    for cluster, (cx, cy, size, height), rgb in zip(result.clusters, boxes, colours):
        assert abs(cluster.position[0] - cx) < 0.002 and abs(cluster.position[1] - cy) < 0.002
        assert np.allclose(cluster.color, rgb, atol=1)
        assert cluster.min_z_point[2] == pytest.approx(TABLE_Z - height, abs=0.003)
    assert result.clusters[0].num_points >= result.clusters[1].num_points


def test_top_face_centre_is_not_pulled_toward_the_side_the_camera_sees():
    """Top and one side seen (the camera off to +x): centroid pulled to +x, top face not."""
    cx, cy, size, height = 0.04, 0.0, 0.03, 0.03
    x, y = _grid(cx - size / 2, cx + size / 2, cy - size / 2, cy + size / 2)
    top = np.column_stack([x, y, np.full(len(x), TABLE_Z - height)])
    ss, zz = np.meshgrid(np.arange(-size / 2, size / 2, STEP),
                         np.arange(TABLE_Z - height, TABLE_Z, STEP))
    side = np.column_stack([np.full(ss.size, cx + size / 2), cy + ss.ravel(), zz.ravel()])
    tx, ty = _grid(-0.2, 0.2, -0.2, 0.2)
    table = np.column_stack([tx, ty, np.full(len(tx), TABLE_Z)])
    table = table[~((abs(tx - cx) < size / 2) & (abs(ty - cy) < size / 2))]
    points = np.vstack([table, top, side])
    colors = np.zeros((len(points), 3), dtype=np.uint8)
    (cluster,) = run_pipeline(points, colors, PARAMS, np.random.default_rng(1)).clusters
    assert cluster.position[0] - cx > 0.004                     # the side pulls the centroid
    assert np.hypot(cluster.top_centre[0] - cx, cluster.top_centre[1] - cy) < 0.001
    assert cluster.top_centre[2] == pytest.approx(TABLE_Z - height, abs=0.003)
    no_plane = top_face_centre(np.vstack([top, side]), None)    # the side's top 4 mm count
    assert np.hypot(no_plane[0] - cx, no_plane[1] - cy) < 0.0025


def test_scattered_outliers_are_removed():
    points, colors = _scene([(0.0, 0.0, 0.03, 0.03)], outliers=200)
    result = run_pipeline(points, colors, PARAMS, np.random.default_rng(2))
    assert len(result.clusters) == 1
    assert not np.any(result.objects[:, 2] < TABLE_Z - 0.035)   # no floating noise left


def test_touching_objects_merge_as_the_real_filter_merges_them():
    """Euclidean clustering joins neighbours within cluster_tol: touching boxes are one."""
    boxes = [(0.0, 0.0, 0.03, 0.03), (0.03, 0.0, 0.03, 0.02)]
    points, colors = _scene(boxes)
    merged = run_pipeline(points, colors, PARAMS, np.random.default_rng(3))
    assert len(merged.clusters) == 1
    assert merged.clusters[0].position[0] == pytest.approx(0.015, abs=0.006)
    apart = run_pipeline(*_scene([(0.0, 0.0, 0.03, 0.03), (0.06, 0.0, 0.03, 0.02)]),
                         PARAMS.updated(cluster_tol=0.01), np.random.default_rng(3))
    assert len(apart.clusters) == 2


def test_cluster_size_bounds_drop_clusters_outside_them():
    points, colors = _scene([(0.05, 0.0, 0.03, 0.03), (-0.06, 0.0, 0.02, 0.016)])
    both = run_pipeline(points, colors, PARAMS, np.random.default_rng(4))
    sizes = sorted(c.num_points for c in both.clusters)
    assert len(sizes) == 2
    only_big = run_pipeline(points, colors, PARAMS.updated(cluster_min_size=sizes[0] + 1),
                            np.random.default_rng(4))
    assert [c.num_points for c in only_big.clusters] == [sizes[1]]
    only_small = run_pipeline(points, colors, PARAMS.updated(cluster_max_size=sizes[0]),
                              np.random.default_rng(4))
    assert [c.num_points for c in only_small.clusters] == [sizes[0]]


def test_empty_and_nothing_in_view_end_with_a_reason():
    nothing = run_pipeline(np.zeros((0, 3)), np.zeros((0, 3)), PARAMS, np.random.default_rng(0))
    assert nothing.clusters == [] and nothing.reason == 'no point inside the crop box'
    table_only = run_pipeline(_table(), np.zeros((len(_table()), 3)), PARAMS,
                              np.random.default_rng(0))
    assert table_only.clusters == [] and 'plane' in table_only.reason
    nan = np.full((10, 3), np.nan)
    assert run_pipeline(nan, np.zeros((10, 3)), PARAMS, np.random.default_rng(0)).clusters == []


def test_voxel_grid_averages_points_and_colours_per_cell():
    pts = np.array([[0.0, 0.0, 0.0], [0.001, 0.0, 0.0], [0.01, 0.0, 0.0]])
    rgb = np.array([[0, 0, 0], [100, 50, 20], [255, 255, 255]])
    centres, colours = voxel_grid(pts, rgb, 0.004)
    order = np.argsort(centres[:, 0])
    assert np.allclose(centres[order], [[0.0005, 0, 0], [0.01, 0, 0]])
    assert np.allclose(colours[order], [[50, 25, 10], [255, 255, 255]])


def test_euclidean_clusters_are_sorted_by_size():
    pts = np.vstack([np.zeros((3, 3)) + [0, 0, k * 0.001] for k in range(1)] +
                    [np.array([[1.0, 0, 0], [1.001, 0, 0]])])
    groups = euclidean_clusters(pts, 0.01, 1, 10)
    assert [len(g) for g in groups] == [3, 2]


def test_bad_parameters_are_refused_naming_every_one():
    bad = FilterParams(voxel_leaf_size=0.0, x_filter_min=0.3, x_filter_max=0.1,
                       cluster_min_size=10, cluster_max_size=5, plane_dist_thresh=float('nan'))
    text = params_error(bad)
    for word in ('voxel_leaf_size', 'x_filter_min', 'cluster_min_size', 'plane_dist_thresh'):
        assert word in text
    with pytest.raises(InvalidInputError, match='filter parameters refused'):
        run_pipeline(np.zeros((5, 3)), np.zeros((5, 3)), bad, np.random.default_rng(0))
    with pytest.raises(InvalidInputError, match="unknown filter parameters \\['leaf'\\]"):
        FilterParams().updated(leaf=0.01)
