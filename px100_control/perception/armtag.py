"""
The ArmTag: an AprilTag on the arm that locates the camera relative to the arm's base.

Interbotix mounts it on the gripper: link ``ar_tag_link``, parent ``ee_arm_link``, offset
(-0.017, 0, 0.04155) m, no rotation (interbotix_xsarm_descriptions ``ar_tag.urdf.xacro`` as
px100.urdf.xacro includes it); the tag faces the link's +z. Family tag36h11 (OpenCV's
``DICT_APRILTAG_36h11``; Interbotix's kit prints tagStandard41h12, which OpenCV has not), id 5
(the first of Interbotix's config/tags.yaml) and :data:`TAG_SIZE` [m] = the black square's edge.

Tag frame (OpenCV's ArUco convention, as apriltag_ros): origin at the tag centre, z out of the
printed face, x to the right and y up in the image of the tag as :func:`tag_image` draws it.
:func:`detect` finds the tag in a colour image (OpenCV's ArucoDetector, AprilTag corner
refinement) and solves its pose with ``solvePnP`` (IPPE_SQUARE) and the camera intrinsics.
A 20 mm tag is ~20 px wide at 0.6 m: its corners fix its position but hardly its tilt (the
two IPPE solutions differ by ~14 deg at 0.1 px reprojection error), so with a depth image the
tilt comes from a plane fitted to the tag's depth pixels and the distance from that plane
(RGB-D refinement);
:func:`camera_to_base` is Interbotix's ``find_ref_to_arm_base_transform``: camera -> base =
(camera -> tag) * (base -> tag)^-1, the latter from the arm's forward kinematics.
"""
from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np
from px100_control.perception.camera import Intrinsics

FAMILY = 'tag36h11'
TAG_ID = 5
#: the black square's edge [m] (Interbotix's tags.yaml: 0.02)
TAG_SIZE = 0.02
#: where the tag sits: parent link (unprefixed) and offset in it [m] (no rotation)
PARENT_LINK = 'ee_arm_link'
OFFSET = (-0.017, 0.0, 0.04155)
#: pixels of the tag image per bit cell (the image is 10 cells: 8 + a white border each side)
CELL_PIXELS = 16


def dictionary():
    """Return OpenCV's tag36h11 dictionary."""
    return cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)


def tag_image(tag_id: int = TAG_ID, cell: int = CELL_PIXELS) -> np.ndarray:
    """
    Return the printed tag (uint8 grey, square): the 8 x 8 cell tag and a 1-cell white border.

    Drawn by ``cv2.aruco.generateImageMarker``; the black square is 8/10 of the image.
    """
    marker = cv2.aruco.generateImageMarker(dictionary(), int(tag_id), 8 * cell, borderBits=1)
    return cv2.copyMakeBorder(marker, cell, cell, cell, cell, cv2.BORDER_CONSTANT, value=255)


@dataclass(frozen=True)
class TagDetection:
    """
    A detection result: ``found``, the camera -> tag transform (4x4, optical frame), the reason.

    ``T_camera_tag`` maps tag-frame points [m] into the camera's optical frame; ``corners`` are
    the 4 image corners [px]; ``reason`` says why nothing was found ('' when found).
    """

    found: bool
    T_camera_tag: Optional[np.ndarray] = None
    corners: Optional[np.ndarray] = None
    reason: str = ''


def _detector():
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_APRILTAG
    # the tag is ~2 px a cell at 0.6 m: read its bits from an 8 px/cell warp, not OpenCV's 4
    # (at 4 the default camera moved by 20 mm missed the tag in 2 of 60 poses, at 8 in none)
    params.perspectiveRemovePixelPerCell = 8
    return cv2.aruco.ArucoDetector(dictionary(), params)


def _depth_plane(depth: np.ndarray, corners: np.ndarray, intr: Intrinsics):
    """Return (unit normal, a point) of the plane of the depth pixels inside ``corners``."""
    mask = np.zeros(depth.shape, dtype=np.uint8)
    centre = corners.mean(axis=0)
    inner = centre + 1.05 * (corners - centre)   # into the white border, 2 mm off the plate edge
    cv2.fillConvexPoly(mask, np.round(inner).astype(np.int32), 1)
    v, u = np.nonzero((mask > 0) & (depth > 0.0))
    if len(v) < 12:
        return None
    z = depth[v, u].astype(np.float64)
    points = np.column_stack([(u - intr.cx) * z / intr.fx, (v - intr.cy) * z / intr.fy, z])
    mean = points.mean(axis=0)
    normal = np.linalg.svd(points - mean, full_matrices=False)[2][2]
    return normal / np.linalg.norm(normal), mean


def _refine(T: np.ndarray, plane) -> np.ndarray:
    """Return T with its z axis the plane's normal and its origin on the plane."""
    normal, point = plane
    if normal @ T[:3, 2] < 0.0:
        normal = -normal
    x = T[:3, 0] - (T[:3, 0] @ normal) * normal
    x /= np.linalg.norm(x)
    out = np.eye(4)
    out[:3, :3] = np.column_stack([x, np.cross(normal, x), normal])
    ray = T[:3, 3] / np.linalg.norm(T[:3, 3])          # the tag centre's line of sight
    out[:3, 3] = ray * ((point @ normal) / (ray @ normal))
    return out


def detect(color: np.ndarray, intr: Intrinsics, tag_id: int = TAG_ID,
           size: float = TAG_SIZE, depth: Optional[np.ndarray] = None) -> TagDetection:
    """
    Find tag ``tag_id`` of edge ``size`` [m] in an RGB image; return its pose in the camera.

    :param depth: the aligned depth image [m] (0: no return); given, it refines the tilt and
        the distance (see the module docstring)

    Not found (no tag, another id only, an empty image): ``found`` False with the reason.
    """
    image = np.asarray(color)
    if image.ndim != 3 or image.shape[2] != 3 or image.size == 0:
        return TagDetection(False, reason=f'not an RGB image: shape {image.shape}')
    grey = cv2.cvtColor(np.ascontiguousarray(image, dtype=np.uint8), cv2.COLOR_RGB2GRAY)
    corners, ids, _ = _detector().detectMarkers(grey)
    seen = [] if ids is None else [int(i) for i in ids.ravel()]
    if tag_id not in seen:
        return TagDetection(False, reason=f'ArmTag {FAMILY} id {tag_id} not found in the '
                                          f'image (tags seen: {seen or "none"})')
    image_points = np.asarray(corners[seen.index(tag_id)], dtype=np.float64).reshape(4, 2)
    h = 0.5 * size      # IPPE_SQUARE's order: top-left, top-right, bottom-right, bottom-left
    object_points = np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], dtype=np.float64)
    K = np.array(intr.k, dtype=np.float64).reshape(3, 3)
    ok, rvec, tvec = cv2.solvePnP(object_points, image_points, K, None,
                                  flags=cv2.SOLVEPNP_IPPE_SQUARE)
    if not ok:
        return TagDetection(False, corners=image_points, reason='solvePnP found no tag pose')
    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(rvec)[0]
    T[:3, 3] = tvec.ravel()
    plane = None if depth is None else _depth_plane(np.asarray(depth), image_points, intr)
    return TagDetection(True, T if plane is None else _refine(T, plane), image_points)


def average(transforms) -> np.ndarray:
    """
    Return the mean of 4x4 transforms (Interbotix averages ``num_samples`` tag detections).

    Translations are averaged; the rotation is the nearest rotation (SVD) to the mean matrix.
    """
    stack = np.asarray(list(transforms), dtype=np.float64)
    u, _, vt = np.linalg.svd(stack[:, :3, :3].mean(axis=0))
    out = np.eye(4)
    out[:3, :3] = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
    out[:3, 3] = stack[:, :3, 3].mean(axis=0)
    return out


def camera_to_base(T_camera_tag: np.ndarray, T_base_tag: np.ndarray) -> np.ndarray:
    """
    Return the camera -> arm base transform (4x4): base-frame points into the optical frame.

    :param T_camera_tag: the tag's pose in the camera's optical frame (:func:`detect`)
    :param T_base_tag: the tag's pose in the arm's base frame (forward kinematics)
    """
    return np.asarray(T_camera_tag) @ np.linalg.inv(T_base_tag)
