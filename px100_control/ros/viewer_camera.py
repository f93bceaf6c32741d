"""
The viewer's camera adapter: the camera's topics and the filter's clusters into the page.

Attached to the viewer node (its guarded ``create_subscription`` / ``create_timer``), drawing
through :class:`px100_control.viewer.camera_view.CameraView`:

- ``camera/color/image_raw`` (sensor_msgs/Image rgb8, bgr8, rgba8, bgra8 or mono8; reliable,
  depth 1), subscribed only while a browser is connected: a viewer without a page (in
  bringup's process) receives no frames;
- ``camera/color/camera_info`` (the frustum's field of view) and ``/tf_static`` (the optical
  frame's pose in the robot's base frame, the page's root);
- ``/pc_filter/markers/objects`` (visualization_msgs/Marker, pc_filter's cluster spheres:
  one set per cloud stamp, in the cloud's frame, mapped to the base frame through /tf_static).

A timer every :data:`~px100_control.viewer.camera_view.IMAGE_PERIOD` sends the newest frame (if
new), the frustum and a changed cluster set, and only while a browser is connected. No camera
(no message on these topics): no panel, nothing logged.
"""
import math
import time
from typing import Optional

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.perception.tf_buffer import TfBuffer
from px100_control.ros.common import robot_topic
from px100_control.ros.state_publisher_node import TF_STATIC_QOS
from px100_control.viewer.camera_view import CameraView, IMAGE_PERIOD
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker

#: pc_filter's cluster markers (Interbotix's pc_filter.launch.py default namespace)
FILTER_MARKERS = '/pc_filter/markers/objects'
#: the camera's images and info: reliable, newest only (as the camera publishes them)
IMAGE_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
#: channels of the image encodings shown, and whether they are BGR
ENCODINGS = {'rgb8': (3, False), 'bgr8': (3, True), 'rgba8': (4, False), 'bgra8': (4, True),
             'mono8': (1, False)}


def image_array(msg: Image) -> np.ndarray:
    """Return an Image's pixels as uint8 H x W x 3 RGB; ValueError for another encoding."""
    if msg.encoding not in ENCODINGS:
        raise ValueError(f"camera image encoding '{msg.encoding}' is not shown (only "
                         f'{sorted(ENCODINGS)})')
    channels, bgr = ENCODINGS[msg.encoding]
    h, w = int(msg.height), int(msg.width)
    if msg.step < w * channels or len(msg.data) < h * msg.step:
        raise ValueError(f'camera image {w} x {h} {msg.encoding}: {len(msg.data)} bytes, '
                         f'step {msg.step}: too short')
    rows = np.frombuffer(bytes(msg.data), np.uint8)[:h * msg.step].reshape(h, msg.step)
    pixels = rows[:, :w * channels].reshape(h, w, channels)
    if channels == 1:
        return np.repeat(pixels, 3, axis=2)
    pixels = pixels[:, :, :3]
    return pixels[:, :, ::-1] if bgr else pixels


class ViewerCamera:
    """
    The camera's part of the viewer node (see the module doc).

    :param node: the viewer node (its create_subscription / create_timer are guarded)
    :param scene: its ViewerScene (``server``, ``has_clients()``)
    :param base_frame: the page's root frame (``px100/base_link``)
    """

    def __init__(self, node, scene, base_frame: str):
        self.node, self.scene, self.base = node, scene, base_frame
        self.view = CameraView(scene.server)
        self.tf = TfBuffer()
        self._image: Optional[Image] = None
        self._info: Optional[CameraInfo] = None
        self._image_sub = None
        self._set_key, self._set, self._set_new = None, {}, False
        self.ticks = 0                  # timer runs with a browser connected
        self._image_topic = robot_topic(node, 'camera/color/image_raw')
        node.create_subscription(CameraInfo, robot_topic(node, 'camera/color/camera_info'),
                                 self._on_info, IMAGE_QOS)
        node.create_subscription(TFMessage, '/tf_static', self._on_tf_static, TF_STATIC_QOS)
        node.create_subscription(Marker, FILTER_MARKERS, self._on_marker, 50)
        node.create_timer(IMAGE_PERIOD, self._on_timer)

    def _on_image(self, msg: Image) -> None:
        self._image = msg

    def _on_info(self, msg: CameraInfo) -> None:
        self._info = msg

    def _on_tf_static(self, msg: TFMessage) -> None:
        for reason in self.tf.add_message(msg):
            self.node.get_logger().warning(f'tf ignored: {reason}', throttle_duration_sec=10.0)

    def _on_marker(self, msg: Marker) -> None:
        if msg.action == Marker.DELETEALL:
            self._set_key, self._set, self._set_new = None, {}, True
            return
        if msg.action != Marker.ADD or msg.type != Marker.SPHERE:
            return
        key = (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id)
        if key != self._set_key:            # a new filter run: a new set
            self._set_key, self._set = key, {}
        p, c = msg.pose.position, msg.color
        self._set[msg.id] = ((p.x, p.y, p.z), (255.0 * c.r, 255.0 * c.g, 255.0 * c.b))
        self._set_new = True

    def _on_timer(self) -> None:
        """Follow the page's clients; send the newest frame, frustum and clusters."""
        if not self._subscribe(self.scene.has_clients()):
            return
        self.ticks += 1
        now = time.monotonic()
        image, self._image = self._image, None
        if image is not None:
            self._show_image(image)
        self._show_frustum()
        if self._set_new:
            self._show_clusters(now)
        self.view.expire(now)

    def _subscribe(self, clients: bool) -> bool:
        """Hold the image subscription while a browser is connected; return ``clients``."""
        if clients and self._image_sub is None:
            self._image_sub = self.node.create_subscription(Image, self._image_topic,
                                                            self._on_image, IMAGE_QOS)
        elif not clients and self._image_sub is not None:
            self.node.destroy_subscription(self._image_sub)
            self._image_sub, self._image = None, None
        return clients

    def _show_image(self, msg: Image) -> None:
        try:
            self.view.show_image(image_array(msg))
        except ValueError as exc:
            self.node.get_logger().warning(str(exc), throttle_duration_sec=10.0)

    def _optical_pose(self, frame: str) -> Optional[np.ndarray]:
        try:
            return self.tf.lookup(self.base, frame)
        except InvalidInputError:
            return None             # the camera's /tf_static has not come (yet)

    def _show_frustum(self) -> None:
        info = self._info
        if info is None or info.k[4] <= 0.0 or not info.height:
            return
        T = self._optical_pose(info.header.frame_id)
        if T is not None:
            fovy = 2.0 * math.atan(0.5 * info.height / info.k[4])
            self.view.show_frustum(T, fovy, info.width / info.height)

    def _show_clusters(self, now: float) -> None:
        frame = self._set_key[2] if self._set_key else self.base
        T = self._optical_pose(frame)
        if T is None:
            return                  # drawn once the transform is known
        self._set_new = False
        clusters = [(T[:3, :3] @ np.asarray(xyz) + T[:3, 3], rgb)
                    for _, (xyz, rgb) in sorted(self._set.items())]
        self.view.show_clusters(clusters, now)
