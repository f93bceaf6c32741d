"""
The private APIs of rclpy and mcap_ros2 this package relies on, in one place.

- ``take_serialized``: rclpy's ``Subscription.handle.take_message`` (no public call takes one
  more queued message outside the executor; the IK service and the recorder drain bursts with
  it, one executor wake-up per burst instead of per message), and ``take_deserialized``, the same
  for a subscription of messages (the trajectory server reads the joint_states queued behind
  its stalled executor before judging their age). Duck-typed: no rclpy import here.
- ``definition_decoders``: ``mcap_ros2._dynamic.generate_dynamic`` (decoders from the message
  definition text stored in a bag; mcap_ros2's public reader only decodes whole files).

A change of either library shows up here first: test/test_architecture.py checks that no other
module uses them.
"""
from mcap_ros2._dynamic import generate_dynamic


def take_serialized(sub):
    """
    Return (bytes, message info dict) of the next message queued on a raw subscription, or None.

    :param sub: an rclpy Subscription created with ``raw=True``
    :raises Exception: whatever rclpy raises when the subscription is destroyed meanwhile
    """
    with sub.handle:
        return sub.handle.take_message(sub.msg_type, True)


def take_deserialized(sub):
    """
    Return (message, message info dict) of the next message queued on a subscription, or None.

    :param sub: an rclpy Subscription (not raw)
    :raises Exception: whatever rclpy raises when the subscription is destroyed meanwhile
    """
    with sub.handle:
        return sub.handle.take_message(sub.msg_type, False)


def definition_decoders(type_name: str, definition: str) -> dict:
    """Return {type name: decode(bytes) -> message} from a ROS 2 message definition text."""
    return generate_dynamic(type_name, definition)
