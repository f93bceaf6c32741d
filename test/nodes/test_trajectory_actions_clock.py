"""
The actions' helper node (``trajectory_actions``) keeps the trajectory server's time.

With ``use_sim_time`` it follows the server's ``/clock`` subscription rather than one of its own
(each ``/clock`` message would wake its Python executor); its clock must still read simulated
time, which stamps the actions' feedback and goal status.
"""
from nodes_helpers import wait_for
import pytest

pytestmark = pytest.mark.ros
#: a simulated time no wall clock reads [s]
SIM_TIME_S = 1234.5


def test_actions_follow_the_servers_clock_without_a_clock_subscription(ros_ctx, spinner):
    """/clock at 1234.5 s: the helper's clock reads it; only the server subscribes /clock."""
    import rclpy
    from px100_control.ros.trajectory_server_node import TrajectoryServerNode
    from rclpy.parameter import Parameter
    from rclpy.qos import QoSProfile
    from rosgraph_msgs.msg import Clock
    server = spinner.add(TrajectoryServerNode(context=ros_ctx, parameter_overrides=[
        Parameter('use_sim_time', value=True)]))
    helper = server._actions.node
    source = spinner.add(rclpy.create_node('clock_source', context=ros_ctx))
    pub = source.create_publisher(Clock, '/clock', QoSProfile(depth=10))
    msg = Clock()
    msg.clock.sec, msg.clock.nanosec = int(SIM_TIME_S), int(SIM_TIME_S % 1 * 1e9)

    def helper_on_sim_time():
        pub.publish(msg)
        return helper.get_clock().now().nanoseconds == int(SIM_TIME_S * 1e9)
    assert wait_for(helper_on_sim_time, 30.0, period=0.05), \
        f'helper clock at {helper.get_clock().now()}, /clock at {SIM_TIME_S} s'
    assert server.get_clock().now().nanoseconds == int(SIM_TIME_S * 1e9)
    readers = {(i.node_namespace, i.node_name)
               for i in source.get_subscriptions_info_by_topic('/clock')}
    assert (server.get_namespace(), 'trajectory_server') in readers, readers
    assert not any(name == 'trajectory_actions' for _, name in readers), readers
