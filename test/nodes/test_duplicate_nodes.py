"""
A second driver or trajectory_server in one namespace is detected and named; replay is safe.

Real processes: two bringups in one namespace (the nodes log the duplicates by name), an
in-process bringup beside a running one (the client refuses, naming both), and a replay of a
bag's setpoints into a namespace with live nodes (withheld unless --send-commands; the retired
goal topic of an older bag is never re-sent). A trajectory server is named by the node that
serves its action (the trajectory_server's helper node ``trajectory_actions``).
"""
import os
import time

from px100_control.bag.writer import BagWriter
import pytest

pytestmark = pytest.mark.ros


def _wait(predicate, timeout):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.1)
    return predicate()


def test_two_bringups_in_one_namespace_are_named(node_process):
    """Both sim_drivers and both trajectory_servers (same namespace, same names) are named."""
    ns = f'px100_dup_{os.getpid()}'
    a = node_process('bringup', '--no-camera', '--ros-args', '-p', f'robot_name:={ns}')
    b = node_process('bringup', '--no-camera', '--ros-args', '-p', f'robot_name:={ns}')
    text = (f"2 drivers publish joint_states under '/{ns}': /{ns}/sim_driver (x2, same name)")
    assert _wait(lambda: text in a.output() or text in b.output(), 40.0), \
        a.output()[-2000:] + b.output()[-2000:]
    text = (f"2 nodes serve arm_controller/follow_joint_trajectory under '/{ns}': "
            f'/{ns}/trajectory_actions (x2, same name)')
    assert _wait(lambda: text in a.output() or text in b.output(), 10.0), \
        a.output()[-2000:] + b.output()[-2000:]


def test_peers_are_looked_for_in_the_node_namespace(rclpy_context):
    """robot_name differs from the namespace: duplicates are found where the topics are."""
    from px100_control.ros.sim_driver_node import SimDriverNode
    from px100_control.ros.trajectory_server_node import TrajectoryServerNode
    from rclpy.parameter import Parameter
    ns = f'/dup_ns_{os.getpid()}'
    kwargs = {'context': rclpy_context, 'namespace': ns,
              'parameter_overrides': [Parameter('robot_name', value='elsewhere')]}
    nodes = []
    try:
        for cls in (SimDriverNode, SimDriverNode, TrajectoryServerNode, TrajectoryServerNode):
            nodes.append(cls(**kwargs))

        def named():
            for node in nodes:
                node._check_peers()
            return all(node._duplicates for node in nodes)
        assert _wait(named, 20.0), [n._duplicates for n in nodes]
        assert nodes[0]._duplicates.startswith(
            f"2 drivers publish joint_states under '{ns}': {ns}/sim_driver (x2, same name)")
        assert nodes[2]._duplicates.startswith(
            f"2 nodes serve arm_controller/follow_joint_trajectory under '{ns}': "
            f'{ns}/trajectory_actions')
    finally:
        for node in nodes:
            node.destroy_node()


def test_in_process_bringup_beside_a_running_one_is_refused(node_process):
    """bringup=True where nodes already run: InterbotixException naming both drivers."""
    from px100_control.client import (InterbotixException, InterbotixManipulatorXS,
                                      robot_shutdown)
    ns = f'px100_dup2_{os.getpid()}'
    nodes = node_process('bringup', '--no-camera', '--ros-args', '-p', f'robot_name:={ns}')
    assert nodes.wait_for_output('trajectory_server ready', 60.0), nodes.output()
    try:
        with pytest.raises(InterbotixException) as err:
            InterbotixManipulatorXS('px100', robot_name=ns, bringup=True, connect_timeout=30.0)
    finally:
        robot_shutdown()
    assert '/sim_driver' in str(err.value) and '/trajectory_actions' in str(err.value)
    assert 'connect to those instead' in str(err.value)


def _command_bag(path, ns):
    """Write a bag with one goal on the retired goal topic and one setpoint on ns."""
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    goal = JointTrajectory(joint_names=['waist'])
    goal.header.stamp.sec = 1
    goal.points = [JointTrajectoryPoint(positions=[1.0])]
    goal.points[0].time_from_start.sec = 1
    sp = JointState(name=['waist'], position=[1.0])
    qos = [{'history': 'keep_last', 'depth': 10, 'reliability': 'reliable',
            'durability': 'volatile'}]
    with BagWriter(path) as bag:
        bag.add_topic(f'/{ns}/trajectory/goal', 'trajectory_msgs/msg/JointTrajectory', qos)
        bag.add_topic(f'/{ns}/commands/joint_setpoints', 'sensor_msgs/msg/JointState', qos)
        t = time.time_ns()
        bag.write(f'/{ns}/trajectory/goal', serialize_message(goal), t)
        bag.write(f'/{ns}/commands/joint_setpoints', serialize_message(sp), t + 1000)


@pytest.mark.parametrize('send', [False, True])
def test_replay_into_a_live_graph_withholds_commands(node_process, tmp_path, send):
    """Live nodes: setpoints withheld, naming them (or sent on request); old goals never sent."""
    ns = f'px100_rep_{os.getpid()}_{int(send)}'
    bag = str(tmp_path / 'bag')
    _command_bag(bag, ns)
    nodes = node_process('bringup', '--no-camera', '--ros-args', '-p', f'robot_name:={ns}')
    assert nodes.wait_for_output('trajectory_server ready', 60.0), nodes.output()
    listener = node_process('record', '-o', str(tmp_path / 'seen'), '--no-tf',
                            'trajectory/goal', 'commands/joint_setpoints', '--ros-args', '-p',
                            f'robot_name:={ns}')
    assert listener.wait_for_output('ready', 30.0), listener.output()
    # --send-commands: the setpoint needs recorder + sim_driver as subscribers before it goes
    # out (withheld, nothing goes out: no wait needed)
    args = ['--send-commands', '--wait-for-subscribers', '20', '--min-subscribers', '2'] \
        if send else []
    replay = node_process('replay', bag, *args, '--ros-args', '-p', f'robot_name:={ns}')
    assert replay.proc.wait(30.0) == 0, replay.output()
    out = replay.output()
    time.sleep(0.5)
    assert listener.stop() == 0
    from px100_control.bag.reader import open_bag
    with open_bag(str(tmp_path / 'seen')) as seen:
        counts = {t: s.message_count for t, s in seen.summary().topics.items()}
    goals = counts.get(f'/{ns}/trajectory/goal', 0)
    setpoints = counts.get(f'/{ns}/commands/joint_setpoints', 0)
    assert 'retired request topics are never re-sent' in out, out
    assert goals == 0, counts
    if send:
        assert 'not replaying' not in out
        assert setpoints >= 1, counts
    else:
        assert 'not replaying' in out and '/sim_driver' in out, out
        assert '/trajectory_actions' in out, out
        assert setpoints == 0, counts
