"""
The camera node's messages, as realsense2_camera publishes them.

- ``color/image_raw``: sensor_msgs/Image rgb8; ``depth/image_rect_raw``: 32FC1, metres along
  the optical axis, 0 = no return, aligned to colour (same size, intrinsics and frame);
- ``*/camera_info``: the pinhole intrinsics (plumb_bob, zero distortion, R identity);
- ``depth/color/points``: sensor_msgs/PointCloud2, unorganised (height 1), fields x, y, z
  (float32, m) and rgb (float32 holding 0x00RRGGBB, PCL's packing), point step 16;
- ``/tf_static``: ``<robot>/camera_link`` in ``<robot>/base_link`` and
  ``<robot>/camera_color_optical_frame`` in ``camera_link`` (REP-103).
All are stamped with the joint_states stamp of the state rendered, frame ``<optical frame>``.
"""
import numpy as np
from px100_control.kinematics.rotations import matrix_to_quaternion
from px100_control.perception.camera import CameraSpec, LINK_TO_OPTICAL
from px100_control.ros.state_publisher_node import tf_message
from sensor_msgs.msg import CameraInfo, Image, PointCloud2, PointField

POINT_FIELDS = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1)
                for i, n in enumerate(('x', 'y', 'z', 'rgb'))]


def image_msg(array: np.ndarray, encoding: str, stamp, frame_id: str) -> Image:
    """Return the Image of an H x W x 3 uint8 (rgb8) or H x W float32 (32FC1) array."""
    array = np.ascontiguousarray(array)
    msg = Image(height=int(array.shape[0]), width=int(array.shape[1]), encoding=encoding,
                is_bigendian=0, step=int(array.strides[0]))
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.data = array.tobytes()
    return msg


def camera_info_msg(camera: CameraSpec, stamp, frame_id: str) -> CameraInfo:
    """Return the CameraInfo of the camera's (distortion-free) intrinsics."""
    intr = camera.intrinsics()
    msg = CameraInfo(height=intr.height, width=intr.width, distortion_model='plumb_bob',
                     d=[0.0] * 5, k=list(intr.k), r=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                     p=list(intr.p))
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    return msg


def cloud_msg(points: np.ndarray, colors: np.ndarray, stamp, frame_id: str) -> PointCloud2:
    """Return the XYZRGB PointCloud2 of points (N, 3) [m] and colours (N, 3) uint8."""
    n = len(points)
    packed = np.empty((n, 4), dtype=np.float32)
    packed[:, :3] = points
    c = np.asarray(colors, dtype=np.uint32)
    packed[:, 3] = ((c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]).view(np.float32)
    return packed_cloud_msg(packed, stamp, frame_id)


def packed_cloud_msg(packed: np.ndarray, stamp, frame_id: str) -> PointCloud2:
    """Return the PointCloud2 of (N, 4) float32 XYZRGB points (:func:`xyzrgb_cloud`'s)."""
    n = len(packed)
    msg = PointCloud2(height=1, width=n, fields=POINT_FIELDS, is_bigendian=False,
                      point_step=16, row_step=16 * n, is_dense=True)
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.data = packed.tobytes()
    return msg


def cloud_arrays(msg: PointCloud2):
    """Return (points (N, 3) float64 [m], colours (N, 3) uint8) of a :func:`cloud_msg` cloud."""
    packed = np.frombuffer(bytes(msg.data), dtype=np.float32).reshape(-1, 4)
    rgb = packed[:, 3].copy().view(np.uint32)
    colors = np.column_stack([(rgb >> 16) & 255, (rgb >> 8) & 255, rgb & 255])
    return packed[:, :3].astype(np.float64), colors.astype(np.uint8)


def static_tf(camera: CameraSpec, base: str, link: str, optical: str, stamp):
    """Return the /tf_static TFMessage of camera_link (in ``base``) and the optical frame."""
    T = camera.link_pose()
    q_link = matrix_to_quaternion(T[:3, :3])
    q_opt = matrix_to_quaternion(LINK_TO_OPTICAL)
    return tf_message([(base, link, T[:3, 3], _xyzw(q_link)),
                       (link, optical, (0.0, 0.0, 0.0), _xyzw(q_opt))], stamp)


def _xyzw(q):
    """Return (x, y, z, w) of matrix_to_quaternion's result."""
    return tuple(float(v) for v in q)
