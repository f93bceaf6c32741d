"""
The client starts only once the servers' processes have matched it, not when it sees them.

DDS matches each side on its own: a client can discover the trajectory server and ik_service
before their process has matched the client's reply readers, and a reply sent meanwhile is
lost (the goal neither ends nor runs). Here the servers run in a participant of their own whose
executor does not spin until the test lets it: they are discoverable at once, but cannot answer
the question that proves the match (a parameter service call), so the constructor must wait,
then return once they spin. Real rclpy nodes over DDS, three participants in this process.
"""
import os
import threading

from client_support import wait_until
import pytest

pytestmark = pytest.mark.ros


def _joint_state_source(ns, context):
    """Return a node (its own participant) that publishes px100 joint_states at 50 Hz."""
    import rclpy
    from px100_control.models.registry import load_robot
    from sensor_msgs.msg import JointState
    model = load_robot('px100')
    names = list(model.joint_names) + [model.gripper.joint, *model.gripper.fingers]
    node = rclpy.create_node('joint_state_source', namespace=ns, context=context)
    pub = node.create_publisher(JointState, 'joint_states', 10)
    msg = JointState(name=names, position=[0.0] * len(names), velocity=[0.0] * len(names),
                     effort=[0.0] * len(names))

    def tick():
        msg.header.stamp = node.get_clock().now().to_msg()
        pub.publish(msg)
    node.create_timer(0.02, tick)
    return node


def test_constructor_waits_for_the_servers_process_to_answer():
    """Servers discoverable but not spinning: no client yet; spinning: the client is made."""
    rclpy = pytest.importorskip('rclpy')
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown
    from px100_control.client.robot import SpinThread
    from px100_control.ros.ik_service_node import IkServiceNode
    from px100_control.ros.trajectory_server_node import TrajectoryServerNode
    from rclpy.executors import SingleThreadedExecutor
    ns = f'px100_side_{os.getpid()}'
    servers_ctx, source_ctx = rclpy.Context(), rclpy.Context()
    rclpy.init(context=servers_ctx)
    rclpy.init(context=source_ctx)
    spins, made = [], {}
    done = threading.Event()
    servers = [TrajectoryServerNode(context=servers_ctx, namespace=ns),
               IkServiceNode(context=servers_ctx, namespace=ns)]
    source = _joint_state_source(ns, source_ctx)

    def construct():
        try:
            made['bot'] = InterbotixManipulatorXS('px100', robot_name=ns, connect_timeout=60.0)
        except BaseException as exc:  # noqa: B902 - reported by the test thread
            made['error'] = exc
        finally:
            done.set()
    try:
        executor = SingleThreadedExecutor(context=source_ctx)
        executor.add_node(source)
        spins.append(SpinThread(executor, 'joint_state_source').start())
        threading.Thread(target=construct, daemon=True).start()
        questions = [f'/{ns}/trajectory_server/get_parameter_types',
                     f'/{ns}/ik_service/get_parameter_types']
        assert wait_until(lambda: done.is_set() or any(servers[0].count_clients(q)
                                                       for q in questions), 60.0), \
            'the client neither asked the servers process nor ended'
        assert not done.is_set(), f'the client started before the servers process answered: {made}'
        assert not done.wait(1.0), \
            f'the client started before the servers process answered: {made}'
        executor = SingleThreadedExecutor(context=servers_ctx)
        for node in servers:
            executor.add_node(node)
        spins.append(SpinThread(executor, 'servers').start())
        assert done.wait(60.0), 'no client 60 s after the servers spin'
        assert 'bot' in made, made
    finally:
        robot_shutdown()
        for spin in spins:
            spin.stop()
        for node in [*servers, source]:
            node.destroy_node()
        servers_ctx.try_shutdown()
        source_ctx.try_shutdown()
