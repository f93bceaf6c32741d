"""
The camera in the page (viser): its colour image, its frustum and the filter's clusters.

No rclpy: the node's adapter (:mod:`px100_control.ros.viewer_camera`) hands over decoded
frames, the camera's pose and field of view, and the clusters in the viewer's root frame (the
robot's base frame, metres). Nothing is created before the first frame: without a camera the
page has no camera panel. The colour image is a GUI image (folder 'Camera'), halved to
320 x 240 for a D415 frame and sent as JPEG at most every :data:`IMAGE_PERIOD`; the frustum is
drawn at the optical frame's pose (viser's frustum is OpenCV's: z forward, y down, as
REP-103's optical frame). Each cluster is a sphere at its centroid in its mean colour; a set
is replaced by the next one and removed :data:`CLUSTER_HOLD` after it arrived (the filter's
markers live 0.1 s and come with every filtered cloud while its pipeline is enabled).
"""
import threading
from typing import Optional, Sequence, Tuple

import numpy as np
from px100_control.kinematics.rotations import matrix_to_quaternion

#: the shortest time [s] between two images sent to the page (the camera runs at 5 Hz)
IMAGE_PERIOD = 0.5
#: the largest image side [px] sent to the page (bigger frames are shrunk by whole factors)
IMAGE_MAX_SIDE = 320
#: how long [s] a cluster set stays on the page without a newer one
CLUSTER_HOLD = 2.0
#: the cluster spheres' radius [m]
CLUSTER_RADIUS = 0.006


def _wxyz_of(R: np.ndarray) -> Tuple[float, float, float, float]:
    """Return the unit quaternion (w, x, y, z) of a rotation matrix (viser's order)."""
    x, y, z, w = (float(v) for v in matrix_to_quaternion(np.asarray(R, dtype=float)))
    return (w, x, y, z)


def shrink(image: np.ndarray, max_side: int = IMAGE_MAX_SIDE) -> np.ndarray:
    """Return ``image`` (H x W x 3) subsampled by the smallest whole factor fitting max_side."""
    factor = max(1, -(-max(image.shape[:2]) // max_side))
    return np.ascontiguousarray(image[::factor, ::factor])


class CameraView:
    """
    The camera's part of the page; thread-safe (the adapter's callbacks, viser's threads).

    :param server: the viser server of the page (:attr:`ViewerScene.server`)
    """

    def __init__(self, server):
        self.server = server
        self._lock = threading.Lock()
        self._folder = self._image = self._frustum = None
        self._frustum_key = None
        self._spheres = []
        self._clusters_at = None
        self.image = None            # the last image sent to the page (uint8 h x w x 3)
        self.images_sent = 0
        self.clusters: list = []     # shown: [(xyz [m] in the root frame, rgb 0..255)]

    def show_image(self, rgb: np.ndarray) -> None:
        """Show a colour frame (uint8 H x W x 3) in the Camera panel (created on the first)."""
        small = shrink(np.asarray(rgb, dtype=np.uint8))
        with self._lock:
            if self._image is None:
                self._folder = self.server.gui.add_folder('Camera', order=3)
                with self._folder:
                    self._image = self.server.gui.add_image(small, label='colour',
                                                            format='jpeg', jpeg_quality=80)
            else:
                self._image.image = small
            self.image = small
            self.images_sent += 1
            self.server.flush()

    def show_frustum(self, T_root_optical: np.ndarray, fovy: float, aspect: float) -> None:
        """Draw the camera's frustum at its optical frame's pose (4 x 4, root frame), fov [rad]."""
        key = (tuple(np.round(np.asarray(T_root_optical, float).ravel(), 6)), round(fovy, 6),
               round(aspect, 6))
        with self._lock:
            if key == self._frustum_key:
                return
            self._frustum_key = key
            if self._frustum is not None:
                self._frustum.remove()
            T = np.asarray(T_root_optical, dtype=float)
            self._frustum = self.server.scene.add_camera_frustum(
                '/camera/frustum', fov=float(fovy), aspect=float(aspect), scale=0.06,
                thickness=2.0, thickness_units='screen', color=(40, 40, 40),
                wxyz=_wxyz_of(T[:3, :3]), position=tuple(T[:3, 3]))
            self.server.flush()

    def show_clusters(self, clusters: Sequence[Tuple[Sequence[float], Sequence[float]]],
                      now: float) -> None:
        """Replace the cluster spheres: [(xyz [m] root frame, rgb 0..255)], at time now [s]."""
        with self._lock:
            self._clear_clusters()
            scene = self.server.scene
            for k, (xyz, rgb) in enumerate(clusters):
                color = tuple(int(min(255, max(0, round(float(c))))) for c in rgb[:3])
                self._spheres.append(scene.add_icosphere(
                    f'/camera/clusters/{k}', radius=CLUSTER_RADIUS, color=color,
                    position=tuple(float(v) for v in xyz)))
                self.clusters.append((tuple(float(v) for v in xyz), color))
            self._clusters_at = now
            self.server.flush()

    def expire(self, now: float) -> None:
        """Remove the clusters once CLUSTER_HOLD [s] passed since they came."""
        with self._lock:
            if self._clusters_at is not None and now - self._clusters_at >= CLUSTER_HOLD:
                self._clear_clusters()
                self.server.flush()

    def _clear_clusters(self) -> None:
        for handle in self._spheres:
            handle.remove()
        self._spheres, self.clusters, self._clusters_at = [], [], None

    @property
    def shown(self) -> bool:
        """Return True once the Camera panel exists (a frame came)."""
        return self._image is not None

    def frustum_pose(self) -> Optional[Tuple[tuple, tuple]]:
        """Return the frustum's (position, wxyz) as drawn, or None."""
        with self._lock:
            if self._frustum is None:
                return None
            return tuple(self._frustum.position), tuple(self._frustum.wxyz)
