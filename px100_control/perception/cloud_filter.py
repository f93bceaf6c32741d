"""
Interbotix's point-cloud cluster pipeline on numpy arrays (no ROS, no PCL).

The stages and parameters are those of Interbotix's ``pointcloud_pipeline`` (PCL), in its order:
crop box -> voxel grid -> RANSAC plane removal -> radius outlier removal -> Euclidean
clusters. Each cluster reports its centroid (position and mean colour), the point nearest the
camera along the optical axis (``min_z_point``: the top of an object seen from above) and its
point count; and, beyond Interbotix, the centre of its top face (``top_centre``: the centroid
of its points within :data:`TOP_BAND` of its highest point above the fitted plane). A camera
sees an object's top and the sides facing it, so the centroid is pulled toward the camera
(measured 2-5 mm for the pick_place blocks 60 mm off the optical axis at 0.6 m); the top
face's centre is not (within 2 mm). Neighbour searches use scipy's cKDTree (a maintained k-d
tree; PCL uses FLANN).

Input points are in the cloud's frame (the camera's optical frame: z forward), metres; colours
are 0..255. Everything is deterministic given ``rng`` (RANSAC's samples).
"""
from dataclasses import dataclass, fields, replace
import math
from typing import List, Optional, Tuple

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.parameters import PC_FILTER
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree


@dataclass(frozen=True)
class FilterParams:
    """
    The pipeline's parameters, Interbotix's names and defaults.

    Crop box bounds [m] in the cloud frame; ``voxel_leaf_size`` [m]; ``plane_max_iter`` RANSAC
    iterations and ``plane_dist_thresh`` [m] inlier distance; ``ror_radius_search`` [m] and
    ``ror_min_neighbors`` (other points within the radius to keep a point); ``cluster_tol``
    [m] neighbour distance that joins a cluster, ``cluster_min_size`` / ``cluster_max_size``
    points (clusters outside are dropped).
    """

    x_filter_min: float = -0.25
    x_filter_max: float = 0.25
    y_filter_min: float = -0.25
    y_filter_max: float = 0.25
    z_filter_min: float = 0.25
    z_filter_max: float = 0.75
    voxel_leaf_size: float = 0.004
    plane_max_iter: int = 50
    plane_dist_thresh: float = 0.005
    ror_radius_search: float = 0.01
    ror_min_neighbors: int = 5
    cluster_tol: float = 0.02
    cluster_min_size: int = 50
    cluster_max_size: int = 1000

    def updated(self, **changes) -> 'FilterParams':
        """Return a copy with ``changes`` (unknown names refused), checked."""
        names = {f.name for f in fields(self)}
        unknown = sorted(set(changes) - names)
        if unknown:
            raise InvalidInputError(f'unknown filter parameters {unknown}; known: '
                                    f'{sorted(names)}')
        return checked(replace(self, **changes))


#: (lower, upper) bound of each number parameter, from the node's schema (written once)
BOUNDS = {spec.name: (spec.low, spec.high) for spec in PC_FILTER.params
          if spec.kind in ('double', 'integer')}


def params_error(p: FilterParams) -> Optional[str]:
    """Return why ``p`` is refused, naming every wrong parameter, or None."""
    wrong = []
    for f in fields(p):
        value = getattr(p, f.name)
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            wrong.append(f'{f.name} must be a finite number, got {value!r}')
            continue
        lo, hi = BOUNDS.get(f.name, (None, None))
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            wrong.append(f'{f.name} must be in [{lo}, {hi}], got {value}')
    for axis in 'xyz':
        lo, hi = getattr(p, f'{axis}_filter_min'), getattr(p, f'{axis}_filter_max')
        if math.isfinite(lo) and math.isfinite(hi) and lo >= hi:
            wrong.append(f'{axis}_filter_min ({lo}) must be below {axis}_filter_max ({hi})')
    if p.cluster_min_size > p.cluster_max_size:
        wrong.append(f'cluster_min_size ({p.cluster_min_size}) is above cluster_max_size '
                     f'({p.cluster_max_size})')
    return '; '.join(wrong) or None


def checked(p: FilterParams) -> FilterParams:
    """Return ``p``, or raise InvalidInputError naming every wrong parameter."""
    error = params_error(p)
    if error:
        raise InvalidInputError(f'filter parameters refused: {error}')
    return p


#: depth [m] below a cluster's highest point (above the plane) that still counts as its top face:
#: a voxel layer (the default leaf, 4 mm) and 4 sigma of the D415's depth noise at 0.6 m
TOP_BAND = 0.004


@dataclass(frozen=True)
class Cluster:
    """One object candidate: centroid [m], mean colour (0..255), top point [m], size, top face."""

    position: Tuple[float, float, float]
    color: Tuple[float, float, float]
    min_z_point: Tuple[float, float, float]
    num_points: int
    top_centre: Tuple[float, float, float] = (math.nan, math.nan, math.nan)


def top_face_centre(points: np.ndarray, plane: Optional[np.ndarray],
                    band: float = TOP_BAND) -> np.ndarray:
    """
    Return the centroid [m] of the ``points`` within ``band`` of the highest one above ``plane``.

    Height is the distance from the plane on the camera's side (the cloud frame's origin);
    without a plane, the points nearest the camera along z are the top.
    """
    if plane is None:
        height = -points[:, 2]
    else:
        height = (points @ plane[:3] + plane[3]) * (1.0 if plane[3] >= 0.0 else -1.0)
    return points[height >= height.max() - band].mean(axis=0)


@dataclass
class FilterResult:
    """The clusters, the cloud after each stage (for display) and the fitted plane."""

    clusters: List[Cluster]
    filtered: np.ndarray          # points after crop + voxel grid (N, 3)
    objects: np.ndarray           # points after plane and outlier removal (M, 3)
    plane: Optional[np.ndarray]   # (a, b, c, d) with a x + b y + c z + d = 0, |(a, b, c)| = 1
    reason: str = ''              # why the pipeline stopped early ('' when it ran through)
    filtered_rgb: Optional[np.ndarray] = None   # colours of ``filtered`` (N, 3), 0..255
    objects_rgb: Optional[np.ndarray] = None    # colours of ``objects`` (M, 3), 0..255


def crop_box(points: np.ndarray, p: FilterParams) -> np.ndarray:
    """Return the mask of ``points`` inside the crop box (bounds included)."""
    lo = np.array([p.x_filter_min, p.y_filter_min, p.z_filter_min])
    hi = np.array([p.x_filter_max, p.y_filter_max, p.z_filter_max])
    return np.all((points >= lo) & (points <= hi), axis=1)


def voxel_grid(points: np.ndarray, colors: np.ndarray,
               leaf: float) -> Tuple[np.ndarray, np.ndarray]:
    """Return one point per occupied voxel of size ``leaf``: its points' centroid and colour."""
    cells = np.floor((points - points.min(axis=0)) / leaf).astype(np.int64)
    span = cells.max(axis=0) + 1
    keys = (cells[:, 0] * span[1] + cells[:, 1]) * span[2] + cells[:, 2]
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    n = len(counts)
    centroid = np.column_stack([np.bincount(inverse, points[:, k], n) for k in range(3)])
    mean_rgb = np.column_stack([np.bincount(inverse, colors[:, k].astype(np.float64), n)
                                for k in range(3)])
    return centroid / counts[:, None], mean_rgb / counts[:, None]


def fit_plane(points: np.ndarray, max_iter: int, threshold: float,
              rng: np.random.Generator) -> Tuple[Optional[np.ndarray], np.ndarray]:
    """
    Return the RANSAC plane (a, b, c, d) of ``points`` and its inlier mask.

    Each iteration fits a plane through 3 random points and counts the points within
    ``threshold`` [m]; the best is refitted by least squares on its inliers and its inliers
    selected again (PCL's optimised coefficients). Fewer than 3 points: (None, all False).
    """
    n = len(points)
    if n < 3:
        return None, np.zeros(n, dtype=bool)
    samples = rng.integers(0, n, size=(max_iter, 3))
    a, b, c = points[samples[:, 0]], points[samples[:, 1]], points[samples[:, 2]]
    normals = np.cross(b - a, c - a)
    norms = np.linalg.norm(normals, axis=1)
    ok = norms > 1e-12
    if not np.any(ok):
        return None, np.zeros(n, dtype=bool)
    normals = normals[ok] / norms[ok, None]
    offsets = -np.einsum('ij,ij->i', normals, a[ok])
    counts = [(np.abs(points @ nrm + off) <= threshold).sum() for nrm, off in
              zip(normals, offsets)]
    best = int(np.argmax(counts))
    inliers = np.abs(points @ normals[best] + offsets[best]) <= threshold
    centre = points[inliers].mean(axis=0)
    _, _, vt = np.linalg.svd(points[inliers] - centre, full_matrices=False)
    normal = vt[-1]
    plane = np.append(normal, -normal @ centre)
    return plane, np.abs(points @ normal + plane[3]) <= threshold


def radius_outliers(points: np.ndarray, radius: float, min_neighbors: int) -> np.ndarray:
    """Return the mask of points with at least ``min_neighbors`` others within ``radius``."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    counts = cKDTree(points).query_ball_point(points, radius, return_length=True)
    return counts - 1 >= min_neighbors


def euclidean_clusters(points: np.ndarray, tol: float, min_size: int,
                       max_size: int) -> List[np.ndarray]:
    """Return the index arrays of the connected groups (neighbours within ``tol``), by size."""
    n = len(points)
    if n == 0:
        return []
    pairs = cKDTree(points).query_pairs(tol, output_type='ndarray')
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    count, labels = connected_components(graph, directed=False)
    groups = [np.flatnonzero(labels == k) for k in range(count)]
    groups = [g for g in groups if min_size <= len(g) <= max_size]
    return sorted(groups, key=len, reverse=True)


def run_pipeline(points: np.ndarray, colors: np.ndarray, params: FilterParams,
                 rng: np.random.Generator) -> FilterResult:
    """
    Run the whole pipeline on a cloud (N, 3) [m] with colours (N, 3) in 0..255.

    An empty stage ends the run early with no clusters and the stage named in ``reason``
    (as Interbotix's node returns nothing then); the parameters are checked first.
    """
    checked(params)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    colors = np.asarray(colors).reshape(-1, 3)
    finite = np.all(np.isfinite(points), axis=1)
    points, colors = points[finite], colors[finite]
    empty = np.zeros((0, 3))
    inside = crop_box(points, params)
    if not np.any(inside):
        return FilterResult([], empty, empty, None, 'no point inside the crop box', empty, empty)
    pts, rgb = voxel_grid(points[inside], colors[inside], params.voxel_leaf_size)
    if len(pts) < 4:
        return FilterResult([], pts, empty, None, 'fewer than 4 points after the voxel grid',
                            rgb, empty)
    plane, on_plane = fit_plane(pts, params.plane_max_iter, params.plane_dist_thresh, rng)
    rest, rest_rgb = pts[~on_plane], rgb[~on_plane]
    if len(rest) == 0:
        return FilterResult([], pts, empty, plane, 'nothing left off the plane', rgb, empty)
    keep = radius_outliers(rest, params.ror_radius_search, params.ror_min_neighbors)
    rest, rest_rgb = rest[keep], rest_rgb[keep]
    if len(rest) == 0:
        return FilterResult([], pts, rest, plane, 'every point off the plane was an outlier',
                            rgb, rest_rgb)
    clusters = []
    for idx in euclidean_clusters(rest, params.cluster_tol, params.cluster_min_size,
                                  params.cluster_max_size):
        cp = rest[idx]
        top = cp[int(np.argmin(cp[:, 2]))]
        clusters.append(Cluster(tuple(cp.mean(axis=0)), tuple(rest_rgb[idx].mean(axis=0)),
                                tuple(top), len(idx), tuple(top_face_centre(cp, plane))))
    return FilterResult(clusters, pts, rest, plane, '', rgb, rest_rgb)
