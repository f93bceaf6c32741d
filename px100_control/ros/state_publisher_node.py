"""
robot_state_publisher: live ``/tf`` and ``/tf_static`` of the robot and its world's objects.

What ROS's robot_state_publisher does, for pip users who do not have it; node name
``robot_state_publisher`` in the robot namespace (docs/ros_interfaces.md):

- sub ``robot_description`` (std_msgs/String, transient local: sim_driver's): the URDF. On each
  one, the fixed joints go to ``/tf_static`` (tf2_msgs/TFMessage, transient local, depth 1:
  a late subscriber gets them; stamped with this node's clock). A URDF that cannot be used
  is refused with a one-line error; the previous one stays.
- sub ``joint_states`` (sensor_msgs/JointState): the movable joints present in the message (and
  the mimic joints of those) go to ``/tf``, stamped with the message's stamp, at most one
  message per 1 / ``publish_frequency`` of those stamps.
- sub ``world/markers`` (visualization_msgs/MarkerArray): each movable object (ns 'objects')
  goes to ``/tf`` as ``<robot_name>/objects/<name>``, child of the markers' frame
  (``<robot_name>/base_link``), stamped with the markers' stamp.

Frames are the URDF links as sim_driver publishes them, ``<robot_name>/<link>`` (an
unprefixed URDF gets the prefix). ``/tf`` and ``/tf_static`` are global (one tree for every
robot). The logic is :class:`px100_control.bag.tf_live.LiveTf` (shared with the recorder's bag
/tf through :mod:`px100_control.bag.tf` and :mod:`px100_control.bag.world`).
"""
import sys

from geometry_msgs.msg import TransformStamped
from px100_control.bag.tf_live import LiveTf
from px100_control.bag.world import markers_from_decoded
from px100_control.errors import InvalidInputError
from px100_control.parameters import STATE_PUBLISHER
from px100_control.ros.common import (init_robot_node, LATCHED_QOS, robot_name, robot_topic,
                                      spin_node)
from px100_control.ros.parameter_schema import declare_schema
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, qos_profile_sensor_data, QoSProfile,
                       ReliabilityPolicy)
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

NODE_NAME = 'robot_state_publisher'
#: tf2's broadcaster QoS: /tf reliable, depth 100; /tf_static transient local, depth 1
TF_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
TF_STATIC_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                           reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)


def tf_message(entries, stamp) -> TFMessage:
    """Return the TFMessage of [(parent, child, (x, y, z), (qx, qy, qz, qw))] at ``stamp``."""
    msg = TFMessage()
    for parent, child, t, q in entries:
        tr = TransformStamped()
        tr.header.stamp = stamp
        tr.header.frame_id = parent
        tr.child_frame_id = child
        v, r = tr.transform.translation, tr.transform.rotation
        v.x, v.y, v.z = (float(x) for x in t)
        r.x, r.y, r.z, r.w = (float(x) for x in q)
        msg.transforms.append(tr)
    return msg


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class StatePublisherNode(Node):
    """Publish /tf and /tf_static from robot_description, joint_states and world/markers."""

    def __init__(self, **node_kwargs):
        init_robot_node(self, NODE_NAME, node_kwargs)
        declare_schema(self, STATE_PUBLISHER, skip=(),
                       defaults={'robot_name': self.get_namespace().strip('/')})
        self._tf = LiveTf(robot_name(self))
        self._load_parameters()
        self.add_post_set_parameters_callback(lambda params: self._load_parameters())
        self._pub_tf = self.create_publisher(TFMessage, '/tf', TF_QOS)
        self._pub_static = self.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS)
        self.create_subscription(String, robot_topic(self, 'robot_description'),
                                 self._on_description, LATCHED_QOS)
        self.create_subscription(JointState, robot_topic(self, 'joint_states'),
                                 self._on_joint_states, qos_profile_sensor_data)
        self.create_subscription(MarkerArray, robot_topic(self, 'world/markers'),
                                 self._on_markers, LATCHED_QOS)
        self.get_logger().info(f'robot_state_publisher ready: frames '
                               f"'{robot_name(self) or '(no prefix)'}/...', waiting for "
                               f"{self.resolve_topic_name('robot_description')}")

    def _load_parameters(self) -> None:
        frequency = float(self.get_parameter('publish_frequency').value)
        self._tf.min_period_ns = int(1e9 / frequency) if frequency > 0 else 0

    def _on_description(self, msg: String) -> None:
        try:
            static = self._tf.set_description(msg.data)
        except InvalidInputError as exc:
            self.get_logger().error(f'{exc}; still using the previous one'
                                    if self._tf.tree else f'{exc}; no /tf until a usable one')
            return
        except Exception as exc:  # noqa: B902 - a message must never stop the node
            self.get_logger().error(f'robot_description: internal error {exc!r}')
            return
        if static:
            self._pub_static.publish(tf_message(static, self.get_clock().now().to_msg()))
        self.get_logger().info(f'robot_description: {len(self._tf.tree.joints)} joints, '
                               f'{len(static)} fixed on /tf_static, root '
                               f'{self._tf.tree.frame(self._tf.tree.root)}')

    def _on_joint_states(self, msg: JointState) -> None:
        try:
            entries = self._tf.joint_state(msg.name, msg.position, _ns(msg.header.stamp))
        except InvalidInputError as exc:
            self.get_logger().warning(f'{exc}: ignored', throttle_duration_sec=5.0)
            return
        except Exception as exc:  # noqa: B902 - a message must never stop the node
            self.get_logger().error(f'joint_states: internal error {exc!r}',
                                    throttle_duration_sec=5.0)
            return
        if entries:
            self._pub_tf.publish(tf_message(entries, msg.header.stamp))

    def _on_markers(self, msg: MarkerArray) -> None:
        try:
            entries = self._tf.objects(markers_from_decoded(msg))
        except Exception as exc:  # noqa: B902 - a message must never stop the node
            self.get_logger().error(f'world/markers: {exc!r}', throttle_duration_sec=5.0)
            return
        if entries:
            stamp = msg.markers[0].header.stamp
            if _ns(stamp) == 0:
                stamp = self.get_clock().now().to_msg()
            self._pub_tf.publish(tf_message(entries, stamp))


def main(args=None):
    """Run the node (``ros2 run px100_control state_publisher``)."""
    return spin_node(lambda options: StatePublisherNode(), args, schema=STATE_PUBLISHER,
                     description='Live /tf and /tf_static of px100_control (robot_state_publisher '
                                 'from robot_description, joint_states and world/markers).')


if __name__ == '__main__':
    sys.exit(main())
