"""
camera: a simulated RGB-D camera driver (a RealSense D415 by default), in the robot namespace.

Its own MuJoCo model of what it sees (:class:`~px100_control.sim.camera_scene.CameraScene`), so
rendering never slows sim_driver's physics: the robot's geometry from the URDF on
``robot_description`` (sim_driver's; no frame before it arrives), the world's bodies
from ``world/markers`` and the ArmTag on the gripper. Each frame (a timer at ``rate`` Hz) it
poses the model from the last ``joint_states`` and markers and renders it offscreen
(``MUJOCO_GL=egl``: the CPU software renderer on a machine without a GPU), but only while one
of its image, camera_info or cloud topics has a subscriber (an image or the cloud is built and
published only while its own topic has one): an unwatched camera costs no CPU.

- sub ``robot_description`` (std_msgs/String, transient local: the model is rebuilt when it
  changes; one MuJoCo cannot build is logged, no frames until a usable one),
  ``joint_states`` (sensor_msgs/JointState), ``world/markers`` (visualization_msgs/
  MarkerArray, transient local; the model is rebuilt when the set of bodies changes);
- pub ``camera/color/image_raw``, ``camera/color/camera_info``, ``camera/depth/image_rect_raw``
  (32FC1 metres, aligned to colour), ``camera/depth/camera_info``, ``camera/depth/color/points``
  and the camera frames on ``/tf_static`` (:mod:`px100_control.ros.camera_msgs`; with
  ``publish_pose`` false only camera_link -> optical frame, the ArmTag locates the camera).

Parameters (:data:`px100_control.parameters.CAMERA`): the camera's defaults come from the
scene's ``camera`` block (the ``scene`` parameter, as sim_driver's); a set that makes a bad
camera (out of range, NaN, a pose that sees nothing of the table) is refused with the field
named and the node keeps its camera. ``enable: false`` stops rendering.
"""
import os
import sys
import time

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.parameters import CAMERA
from px100_control.perception import armtag
from px100_control.perception.camera import (camera_error, CameraSpec, noisy_depth,
                                             view_error, xyzrgb_cloud)
from px100_control.ros.camera_msgs import (camera_info_msg, image_msg, packed_cloud_msg,
                                           static_tf)
from px100_control.ros.common import (declare_robot_parameters, frame_id, init_robot_node,
                                      LATCHED_QOS, robot_name, robot_topic, shutting_down,
                                      spin_node)
from px100_control.ros.parameter_schema import declare_schema, parameter_descriptor
from px100_control.ros.state_publisher_node import TF_STATIC_QOS
from px100_control.ros.world import WorldPublisher
from px100_control.sim.camera_scene import Body, CameraScene, needs_rebuild
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import CameraInfo, Image, JointState, PointCloud2
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

NODE_NAME = 'camera'
#: the images and the cloud: reliable, last frame only (realsense2_camera's default is the
#: system default, reliable; best effort lost most 1.2 MB depth frames here)
IMAGE_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
#: the camera parameters that make a CameraSpec
SPEC_PARAMS = ('position', 'look_at', 'width', 'height', 'fovy', 'rate', 'depth_min',
               'depth_max', 'subpixel', 'baseline')


def spec_defaults(camera: CameraSpec) -> dict:
    """Return the camera parameters' values of a CameraSpec."""
    return {'position': [float(v) for v in camera.position],
            'look_at': [float(v) for v in camera.look_at], 'width': int(camera.width),
            'height': int(camera.height), 'fovy': float(camera.fovy),
            'rate': float(camera.rate), 'depth_min': float(camera.depth_range[0]),
            'depth_max': float(camera.depth_range[1]), 'subpixel': float(camera.subpixel),
            'baseline': float(camera.baseline)}


def spec_of(values: dict) -> CameraSpec:
    """Return the CameraSpec of parameter values; raise InvalidInputError naming what is wrong."""
    camera = CameraSpec(position=tuple(values['position']), look_at=tuple(values['look_at']),
                        width=int(values['width']), height=int(values['height']),
                        fovy=float(values['fovy']), rate=float(values['rate']),
                        depth_range=(float(values['depth_min']), float(values['depth_max'])),
                        subpixel=float(values['subpixel']), baseline=float(values['baseline']))
    error = camera_error(camera) or view_error(camera)
    if error:
        raise InvalidInputError(f'camera refused: {error}')
    return camera


class CameraNode(Node):
    """Render the robot's world from a fixed camera and publish it as a RealSense driver."""

    def __init__(self, **node_kwargs):
        init_robot_node(self, NODE_NAME, node_kwargs)
        self.robot = declare_robot_parameters(self)
        scene = self.declare_parameter('scene', CAMERA['scene'].default,
                                       parameter_descriptor(CAMERA['scene'])).value
        scene_camera = getattr(WorldPublisher.load(scene, self.robot), 'camera', None)
        declare_schema(self, CAMERA, defaults=spec_defaults(scene_camera or CameraSpec()),
                       skip=('robot_model', 'robot_name', 'scene'))
        self.camera = spec_of(self._values())
        self.add_on_set_parameters_callback(self._check_camera)
        self.add_post_set_parameters_callback(lambda params: self._load_camera())
        self._rng = np.random.default_rng(int(self.get_parameter('seed').value))
        self._frames = {k: frame_id(self, k) for k in
                        ('base_link', 'camera_link', 'camera_color_optical_frame')}
        self._scene = None
        self._joints, self._stamp = {}, None
        # the newest joint_states and world/markers, kept serialized and read once per frame
        self._raw = {JointState: None, MarkerArray: None}
        self._bodies, self._poses = (), {}
        self._urdf = None
        self.frame_seconds = []              # render + publish time of each frame [s]
        self._make_publishers()
        self.create_subscription(String, robot_topic(self, 'robot_description'),
                                 self._on_description, LATCHED_QOS)
        self.create_subscription(JointState, robot_topic(self, 'joint_states'),
                                 self._on_joint_states, qos_profile_sensor_data, raw=True)
        self.create_subscription(MarkerArray, robot_topic(self, 'world/markers'),
                                 self._on_markers, LATCHED_QOS, raw=True)
        self._timer = self.create_timer(1.0 / self.camera.rate, self._on_timer)
        self._publish_tf()
        self.get_logger().info(f'camera ready: {self.camera.width} x {self.camera.height} at '
                               f'{self.camera.rate} Hz from {list(self.camera.position)} '
                               f"looking at {list(self.camera.look_at)} (scene '{scene}')")

    def _make_publishers(self) -> None:
        def pub(kind, name, qos=IMAGE_QOS):
            return self.create_publisher(kind, robot_topic(self, f'camera/{name}'), qos)
        self._pub = {'color': pub(Image, 'color/image_raw'),
                     'color_info': pub(CameraInfo, 'color/camera_info'),
                     'depth': pub(Image, 'depth/image_rect_raw'),
                     'depth_info': pub(CameraInfo, 'depth/camera_info'),
                     'points': pub(PointCloud2, 'depth/color/points')}
        self._pub_tf = self.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS)

    def _values(self, changes=()) -> dict:
        values = {n: self.get_parameter(n).value for n in SPEC_PARAMS}
        values.update({p.name: p.value for p in changes if p.name in SPEC_PARAMS})
        return values

    def _check_camera(self, params) -> SetParametersResult:
        if not any(p.name in SPEC_PARAMS for p in params):
            return SetParametersResult(successful=True)
        try:
            spec_of(self._values(params))
        except (InvalidInputError, TypeError, ValueError) as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _load_camera(self) -> None:
        camera = spec_of(self._values())
        if camera != self.camera:
            self.camera = camera
            self._timer.timer_period_ns = int(1e9 / camera.rate)
            self._publish_tf()

    def _publish_tf(self) -> None:
        f = self._frames
        msg = static_tf(self.camera, f['base_link'], f['camera_link'],
                        f['camera_color_optical_frame'], self.get_clock().now().to_msg())
        if not self.get_parameter('publish_pose').value:     # the ArmTag will place it
            msg.transforms = [t for t in msg.transforms if t.header.frame_id != f['base_link']]
        self._pub_tf.publish(msg)

    def _on_description(self, msg: String) -> None:
        self._urdf = msg.data

    def _on_joint_states(self, raw: bytes) -> None:
        self._raw[JointState] = raw

    def _on_markers(self, raw: bytes) -> None:
        self._raw[MarkerArray] = raw

    def _take(self, kind):
        """Return the newest message of ``kind`` received since the last call, or None."""
        raw, self._raw[kind] = self._raw[kind], None
        if raw is None:
            return None
        try:
            return deserialize_message(raw, kind)
        except Exception as exc:  # noqa: B902 - a bad message must never stop the node
            self.get_logger().error(f'{kind.__name__} not readable, ignored: {exc!r}',
                                    throttle_duration_sec=5.0)
            return None

    def _read_inputs(self) -> None:
        """Take the newest joint_states (positions [rad, m], stamp) and world/markers."""
        msg = self._take(JointState)
        if msg is not None:
            self._joints.update(zip(msg.name, msg.position))
            self._stamp = msg.header.stamp
        markers = self._take(MarkerArray)
        if markers is not None:
            self._read_markers(markers)

    def _read_markers(self, msg: MarkerArray) -> None:
        """Take the bodies (box, sphere, cylinder ADD markers) and their poses of a world."""
        bodies, poses = [], {}
        for m in msg.markers:
            shape = {1: 'box', 2: 'sphere', 3: 'cylinder'}.get(int(m.type))
            if shape is None or int(m.action) != 0:
                continue
            name = str(m.text) or f'{m.ns}_{m.id}'
            s, c, p, o = m.scale, m.color, m.pose.position, m.pose.orientation
            bodies.append(Body(name, shape, (s.x, s.y, s.z), (c.r, c.g, c.b, c.a)))
            poses[name] = ((p.x, p.y, p.z), (o.x, o.y, o.z, o.w))
        self._bodies, self._poses = tuple(bodies), poses

    def _listeners(self) -> set:
        """Return the keys of self._pub whose topics have a subscriber now."""
        return {k for k, pub in self._pub.items() if pub.get_subscription_count()}

    def _on_timer(self) -> None:
        self._read_inputs()
        if not self.get_parameter('enable').value or self._stamp is None or not self._urdf:
            return
        listeners = self._listeners()
        if not listeners:            # as a RealSense with no consumer: no frame rendered
            return
        start = time.perf_counter()
        try:
            self._frame(listeners)
        except Exception as exc:  # noqa: B902 - a frame must never stop the node
            if shutting_down(self.context):
                return
            self.get_logger().error(f'camera frame failed: {exc!r}', throttle_duration_sec=5.0)
            return
        self.frame_seconds.append(time.perf_counter() - start)
        del self.frame_seconds[:-100]

    def _frame(self, listeners=frozenset(('color', 'depth', 'points'))) -> None:
        """
        Render the last state: the camera_infos, and each image and the cloud with a listener.

        An image without a subscriber is not built (the depth image is a 1.2 MB message).
        """
        tag = armtag.TAG_ID if self.get_parameter('armtag').value else None
        if needs_rebuild(self._scene, self.camera, self._bodies, tag, self._urdf):
            prefix = f'{robot_name(self)}/' if robot_name(self) else ''
            scene = CameraScene(self.robot, self.camera, self._bodies, tag, self._urdf, prefix)
            if self._scene is not None:
                self._scene.close()
            self._scene = scene
        self._scene.set_state(self._joints, self._poses)
        color, depth = self._scene.render()
        depth = noisy_depth(self.camera, depth, self._rng)
        stamp, frame = self._stamp, self._frames['camera_color_optical_frame']
        info = camera_info_msg(self.camera, stamp, frame)
        if 'color' in listeners:
            self._pub['color'].publish(image_msg(color, 'rgb8', stamp, frame))
        self._pub['color_info'].publish(info)
        if 'depth' in listeners:
            self._pub['depth'].publish(image_msg(depth, '32FC1', stamp, frame))
        self._pub['depth_info'].publish(info)
        if 'points' in listeners:
            packed = xyzrgb_cloud(self.camera.intrinsics(), depth, color)
            self._pub['points'].publish(packed_cloud_msg(packed, stamp, frame))

    def destroy_node(self):
        """Free the renderer, then destroy the node."""
        if self._scene is not None:
            self._scene.close()
            self._scene = None
        return super().destroy_node()


def main(args=None):
    """Run the node (``ros2 run px100_control camera``): one thread renders, whatever executor."""
    if os.environ.get('PX100_EXECUTOR', '').strip().lower() == 'multi':
        os.environ['PX100_EXECUTOR'] = 'single'    # OpenGL contexts belong to one thread
    return spin_node(lambda options: CameraNode(), args, schema=CAMERA,
                     description='Simulated RGB-D camera of px100_control (RealSense topics).')


if __name__ == '__main__':
    sys.exit(main())
