"""
InterbotixArmTagInterface: Interbotix's ArmTag API over the simulated camera.

Same constructor, method and properties as ``interbotix_perception_modules.armtag``
(humble/jazzy): ``find_ref_to_arm_base_transform(ref_frame, arm_base_frame, num_samples,
position_only)``, ``get_transform(tfBuffer, target_frame, source_frame)``, ``x``, ``y``, ``z``,
``roll``, ``pitch``, ``yaw``, ``parent_frame``, ``child_frame`` (and their ``get_*``).

It detects the ArmTag (:mod:`px100_control.perception.armtag`: tag36h11 id 5, 20 mm) in the
camera node's ``/<robot>/camera/color/image_raw`` with the aligned depth image and
``camera_info``, averages ``num_samples`` detections from successive frames, and publishes the
measured ``ref_frame`` -> ``arm_base_frame`` transform on ``/tf_static`` as upstream does
(T_ref_base = T_ref_cam * T_cam_tag * T_tag_base; T_tag_base from the arm's ``/tf``).

Differences from Interbotix (documented, on purpose):

- No apriltag_ros node: the detection runs in this process (OpenCV); ``apriltag_ns`` and
  ``args`` are unused. ``node_inf`` None: the client's global node, as the robot classes.
- Frames: the camera's are ``<robot>/camera_link`` and ``<robot>/camera_color_optical_frame``
  (the camera node's), so a frame name the tf tree does not know is tried with the robot's
  prefix (``camera_color_optical_frame`` -> ``px100/camera_color_optical_frame``). The URDF has
  no ``ar_tag_link``: its pose is ``ee_arm_link``'s with the tag's mounting offset.
- Refusals return False with the reason logged: the tag not seen in a frame (out of view,
  occluded), no camera frames within ``FRAME_TIMEOUT``, no tf path within ``TF_TIMEOUT`` (a
  transform not on tf yet is waited for, as upstream's lookups), and a camera whose pose is
  already on ``/tf_static`` in the arm's tree (the camera node's ``publish_pose`` true):
  publishing ``ref_frame`` -> ``arm_base_frame`` then would make a tf loop, two publishers for
  one frame; start the camera with ``publish_pose:=false`` to let the ArmTag locate it.
"""
import math
import threading
import time
from typing import Optional

from geometry_msgs.msg import TransformStamped
import numpy as np
import px100_control.client.robot as _robot
from px100_control.client.robot import InterbotixException
from px100_control.errors import InvalidInputError
from px100_control.perception import armtag
from px100_control.perception.camera import Intrinsics
from px100_control.perception.tf_buffer import TfBuffer
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image
from tf2_msgs.msg import TFMessage

#: /tf_static: latched, as tf2's static broadcaster and listener
TF_STATIC_QOS = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                           reliability=ReliabilityPolicy.RELIABLE)
#: the camera's images: reliable, last frame (the camera node's IMAGE_QOS)
IMAGE_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
#: longest wait for one camera frame [s] (the camera renders at 5 Hz on a loaded machine)
FRAME_TIMEOUT = 10.0
#: longest wait for a transform not on tf yet [s] (upstream's lookup_transform timeout; a
#: script started beside bringup may ask before the arm's first /tf arrived)
TF_TIMEOUT = 4.0


def image_array(msg: Image) -> np.ndarray:
    """Return an ``rgb8`` (H x W x 3 uint8) or ``32FC1`` (H x W float32 [m]) Image as numpy."""
    if msg.encoding == 'rgb8':
        rows = np.frombuffer(bytes(msg.data), np.uint8).reshape(msg.height, msg.step)
        return rows[:, :3 * msg.width].reshape(msg.height, msg.width, 3)
    if msg.encoding == '32FC1':
        rows = np.frombuffer(bytes(msg.data), np.float32).reshape(msg.height, msg.step // 4)
        return rows[:, :msg.width]
    raise InvalidInputError(f"image encoding '{msg.encoding}' is neither rgb8 nor 32FC1")


def rpy_of(R: np.ndarray) -> list:
    """Return [roll, pitch, yaw] [rad] (static x-y-z) of a rotation matrix."""
    return [math.atan2(R[2, 1], R[2, 2]), -math.asin(max(-1.0, min(1.0, R[2, 0]))),
            math.atan2(R[1, 0], R[0, 0])]


def quaternion_of(R: np.ndarray) -> tuple:
    """Return (x, y, z, w) of a rotation matrix."""
    w = math.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2.0
    x = math.copysign(math.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2.0,
                      R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2.0,
                      R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2.0,
                      R[1, 0] - R[0, 1])
    return x, y, z, w


class InterbotixArmTagInterface:
    """Find an arm's base frame relative to a reference frame from the AprilTag on the arm."""

    def __init__(self, armtag_ns: str = 'armtag', apriltag_ns: str = 'apriltag',
                 ref_frame: Optional[str] = None, arm_tag_frame: Optional[str] = None,
                 arm_base_frame: Optional[str] = None, node_inf=None, args=None) -> None:
        """
        Subscribe to the camera and to tf.

        :param ref_frame: reference frame of the transform (default the camera's optical frame)
        :param arm_tag_frame: the tag's frame on the arm (default ``<robot>/ar_tag_link``)
        :param arm_base_frame: the arm's base frame (default ``<robot>/base_link``)
        :param node_inf: a core (``bot.core``), an rclpy Node, or None (the global node)
        """
        robot = getattr(node_inf, 'robot_name', None)
        self.robot_name = 'px100' if robot is None else str(robot).strip('/')
        self.node_inf = _node_of(node_inf)
        prefix = f'{self.robot_name}/' if self.robot_name else ''
        self.ref_frame = ref_frame or f'{prefix}camera_color_optical_frame'
        self.arm_tag_frame = arm_tag_frame or f'{prefix}ar_tag_link'
        self.arm_base_frame = arm_base_frame or f'{prefix}base_link'
        self.image_frame_id = f'{prefix}camera_color_optical_frame'
        self.trans = TransformStamped()
        self.trans.header.frame_id = self.ref_frame
        self.trans.child_frame_id = self.arm_base_frame
        self.trans.transform.rotation.w = 1.0
        self.rpy = [0.0, 0.0, 0.0]
        self.tfBuffer = TfBuffer()
        self._cond = threading.Condition()
        self._count, self._color, self._depth, self._intr = 0, None, {}, None
        node, cam = self.node_inf, f'/{prefix}camera'
        self._subs = [
            node.create_subscription(Image, f'{cam}/color/image_raw', self._on_color, IMAGE_QOS),
            node.create_subscription(Image, f'{cam}/depth/image_rect_raw', self._on_depth,
                                     IMAGE_QOS),
            node.create_subscription(CameraInfo, f'{cam}/color/camera_info', self._on_info,
                                     IMAGE_QOS),
            node.create_subscription(TFMessage, '/tf', self._on_tf, 100),
            node.create_subscription(TFMessage, '/tf_static', self._on_tf, TF_STATIC_QOS)]
        self.pub_transforms = node.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS)
        _robot.ensure_spinning(node)
        node.get_logger().info('Initialized InterbotixArmTagInterface!')

    # ------------------------------------------------------------------ subscriptions
    def _on_color(self, msg: Image) -> None:
        with self._cond:
            self._color = msg
            self._count += 1
            self._cond.notify_all()

    def _on_depth(self, msg: Image) -> None:
        with self._cond:
            key = (msg.header.stamp.sec, msg.header.stamp.nanosec)
            self._depth[key] = msg
            for old in list(self._depth)[:-4]:
                del self._depth[old]
            self._cond.notify_all()

    def _on_info(self, msg: CameraInfo) -> None:
        self._intr = Intrinsics(int(msg.width), int(msg.height), float(msg.k[0]),
                                float(msg.k[4]), float(msg.k[2]), float(msg.k[5]))

    def _on_tf(self, msg: TFMessage) -> None:
        for reason in self.tfBuffer.add_message(msg):
            self.node_inf.get_logger().warning(f'tf ignored: {reason}',
                                               throttle_duration_sec=5.0)

    # ------------------------------------------------------------------ detection
    def _next_frame(self, after: int):
        """
        Return (colour, depth, intrinsics, count) of a frame newer than ``after``, or None.

        A colour image whose depth image (same stamp) does not follow within 1 s is skipped:
        without depth the small tag's tilt is ambiguous (module perception.armtag).
        """
        deadline = time.monotonic() + FRAME_TIMEOUT
        with self._cond:
            while True:
                if not self._cond.wait_for(
                        lambda: self._count > after and self._intr is not None,
                        max(0.0, deadline - time.monotonic())):
                    return None
                color, after = self._color, self._count
                key = (color.header.stamp.sec, color.header.stamp.nanosec)
                if self._cond.wait_for(lambda: key in self._depth, 1.0):
                    return color, self._depth[key], self._intr, after

    def find_pose(self, after: int = -1):
        """
        Return (T_camera_tag 4x4, frame count) from the next frame, or (None, reason).

        The pose is the tag's in the image's optical frame, refined by the frame's depth.
        """
        frame = self._next_frame(self._count if after < 0 else after)
        if frame is None:
            return None, (f'no camera frame (colour and its depth) on /{self.robot_name}/camera '
                          f'within {FRAME_TIMEOUT} s (is the camera node running?)')
        color, depth, intr, count = frame
        self.image_frame_id = color.header.frame_id
        found = armtag.detect(image_array(color), intr, depth=image_array(depth))
        return (found.T_camera_tag, count) if found.found else (None, found.reason)

    def find_ref_to_arm_base_transform(self, ref_frame: Optional[str] = None,
                                       arm_base_frame: Optional[str] = None,
                                       num_samples: int = 5, position_only: bool = False
                                       ) -> bool:
        """
        Snap the tag in ``num_samples`` frames and publish ``ref_frame`` -> ``arm_base_frame``.

        :param ref_frame: parent of the published transform (default: the constructor's)
        :param arm_base_frame: the arm's base frame or a parent of it (default: the
            constructor's)
        :param num_samples: frames whose tag poses are averaged
        :param position_only: keep the tag's measured position but its orientation from tf
            (needs a tf path from the camera to the tag already)
        :return: True when published; False with the reason logged
        """
        log = self.node_inf.get_logger()
        samples, count = [], self._count
        for _ in range(max(int(num_samples), 1)):
            T, count = self.find_pose(count)
            if T is None:
                log.error(f'ArmTag: no camera -> arm base transform: {count}')
                return False
            samples.append(T)
        T_cam_tag = armtag.average(samples)
        ref = self._resolve(ref_frame or self.ref_frame)
        base = self._resolve(arm_base_frame or self.arm_base_frame)
        try:
            self._refuse_loop(ref, base)
            if position_only:
                T_cam_tag[:3, :3] = self._tag_in(self.image_frame_id)[:3, :3]
            T_tag_base = np.linalg.inv(self._tag_in(base))
            T_ref_cam = self._lookup(ref, self.image_frame_id)
        except InvalidInputError as exc:
            log.error(f'ArmTag: no camera -> arm base transform: {exc}')
            return False
        self._publish(ref, base, T_ref_cam @ T_cam_tag @ T_tag_base)
        return True

    def _resolve(self, frame: str) -> str:
        """Return ``frame``, or ``<robot>/<frame>`` when only that one is in the tf tree."""
        frame = frame.lstrip('/')
        known = self.tfBuffer.frames()
        prefixed = f'{self.robot_name}/{frame}'
        return prefixed if frame not in known and prefixed in known else frame

    def _tag_in(self, frame: str) -> np.ndarray:
        """Return T_frame_tag: the arm_tag_frame from tf, else ee_arm_link with the offset."""
        tag = self._resolve(self.arm_tag_frame)
        if tag in self.tfBuffer.frames():
            return self._lookup(frame, tag)
        parent = tag.rsplit('/', 1)[0] + '/' + armtag.PARENT_LINK if '/' in tag \
            else armtag.PARENT_LINK
        offset = np.eye(4)
        offset[:3, 3] = armtag.OFFSET
        return self._lookup(frame, parent) @ offset

    def _lookup(self, target: str, source: str) -> np.ndarray:
        """
        Return T_target_source from tf, waiting up to TF_TIMEOUT [s] for it to be known.

        :raises InvalidInputError: still no tf path then (the text names the frames known)
        """
        T = self.tfBuffer.wait_for(target, source, TF_TIMEOUT)
        return self.tfBuffer.lookup(target, source) if T is None else T

    def _refuse_loop(self, ref: str, base: str) -> None:
        """Raise when ``base`` is already an ancestor of ``ref`` (publishing would loop)."""
        if base in self.tfBuffer.ancestors(ref):
            raise InvalidInputError(
                f"'{ref}' is already placed under '{base}' on tf (the camera node publishes "
                "its pose: publish_pose true); publishing the ArmTag's transform too would make "
                'a tf loop. Start the camera with publish_pose:=false to let the ArmTag locate '
                'it')

    def _publish(self, ref: str, base: str, T: np.ndarray) -> None:
        self.rpy = rpy_of(T[:3, :3])
        t = TransformStamped(child_frame_id=base)
        t.header.frame_id = ref
        t.header.stamp = self.node_inf.get_clock().now().to_msg()
        tr, r = t.transform.translation, t.transform.rotation
        tr.x, tr.y, tr.z = (float(v) for v in T[:3, 3])
        r.x, r.y, r.z, r.w = quaternion_of(T[:3, :3])
        self.trans = t
        self.tfBuffer.set_transform(ref, base, T[:3, 3], (r.x, r.y, r.z, r.w))
        self.pub_transforms.publish(TFMessage(transforms=[t]))

    def get_transform(self, tfBuffer: TfBuffer, target_frame: str,
                      source_frame: str) -> np.ndarray:
        """Return T_target_source (4x4) from ``tfBuffer``; identity (logged) without a path."""
        try:
            return tfBuffer.lookup(target_frame, source_frame)
        except InvalidInputError as exc:
            self.node_inf.get_logger().error(f'Failed to look up the transform from '
                                             f"'{target_frame}' to '{source_frame}'. {exc}")
            return np.identity(4)

    # ------------------------------------------------------------------ upstream accessors
    def get_x(self) -> float:
        """Return x of T_RefBase [m]."""
        return self.trans.transform.translation.x

    def get_y(self) -> float:
        """Return y of T_RefBase [m]."""
        return self.trans.transform.translation.y

    def get_z(self) -> float:
        """Return z of T_RefBase [m]."""
        return self.trans.transform.translation.z

    def get_roll(self) -> float:
        """Return roll of T_RefBase [rad]."""
        return self.rpy[0]

    def get_pitch(self) -> float:
        """Return pitch of T_RefBase [rad]."""
        return self.rpy[1]

    def get_yaw(self) -> float:
        """Return yaw of T_RefBase [rad]."""
        return self.rpy[2]

    def get_parent_frame(self) -> str:
        """Return the parent frame of T_RefBase (the camera's optical frame by default)."""
        return self.trans.header.frame_id

    def get_child_frame(self) -> str:
        """Return the child frame of T_RefBase (the arm's base frame)."""
        return self.trans.child_frame_id

    x = property(get_x)
    y = property(get_y)
    z = property(get_z)
    roll = property(get_roll)
    pitch = property(get_pitch)
    yaw = property(get_yaw)
    parent_frame = property(get_parent_frame)
    child_frame = property(get_child_frame)


def _node_of(node_inf) -> Node:
    """Return the rclpy Node of ``node_inf``: a Node, a core (get_node()) or None (global)."""
    if node_inf is None:
        return _robot.get_interbotix_global_node() or _robot.create_interbotix_global_node()
    if isinstance(node_inf, Node):
        return node_inf
    if hasattr(node_inf, 'get_node'):
        return node_inf.get_node()
    raise InterbotixException(f'node_inf must be an rclpy Node or a core, got {node_inf!r}')
