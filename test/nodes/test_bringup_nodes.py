"""
bringup: the three nodes in one process, as built by create_nodes and as the executable.

The executable runs the default wall-clock deployment; its timing is only as good as the load of
the machine allows, so the tracking bounds here are loose and the check is the arrival within
2 mrad, a SUCCEEDED status, an IK answer and a clean SIGINT stop.
"""
import time

from nodes_helpers import IkClient, start_node, STARTUP_TIMEOUT, TrajectoryClient, wait_for
import numpy as np
from px100_control.models.registry import load_robot
from px100_control.ros.conversions import matrix_to_pose
import pytest

pytestmark = pytest.mark.ros

MODEL = load_robot('px100')
ARM = list(MODEL.joint_names)


def test_create_nodes_builds_the_four_nodes(ros_ctx):
    """create_nodes returns sim_driver, ik_service, trajectory_server, robot_state_publisher."""
    from px100_control.ros.bringup import create_nodes
    nodes = create_nodes(context=ros_ctx, namespace='/bringup_test')
    try:
        assert [n.get_name() for n in nodes] == ['sim_driver', 'ik_service', 'trajectory_server',
                                                 'robot_state_publisher']
        assert all(n.get_namespace() == '/bringup_test' for n in nodes)
    finally:
        for n in nodes:
            n.destroy_node()


def test_bringup_executable_moves_the_arm_and_answers_ik(ros_ctx, spinner, processes):
    """bringup: a goal ends SUCCEEDED within 2 mrad; an IK request is answered; SIGINT stops."""
    proc = start_node(processes, 'bringup', 'path_tolerance:=2.0', 'path_window:=1.0',
                      'goal_time_tolerance:=10.0', 'state_timeout:=3.0')
    client = spinner.add(TrajectoryClient(context=ros_ctx))
    ik = spinner.add(IkClient('test_bringup_ik_client', context=ros_ctx))
    assert wait_for(lambda: client.measured() is not None, STARTUP_TIMEOUT), proc.output()
    assert wait_for(client.ready, STARTUP_TIMEOUT)
    assert wait_for(ik.ready, STARTUP_TIMEOUT)
    time.sleep(1.0)
    target = [0.4, -0.6, 0.6, 0.2]
    goal = client.send(ARM, [(1.5, target)])
    assert client.wait_terminal(goal, 30.0) == 'SUCCEEDED', client.last_diagnostic(goal)

    def arrived():
        q = client.measured()
        return max(abs(q[j] - v) for j, v in zip(ARM, target)) <= 0.002
    assert wait_for(arrived, 5.0), client.measured()   # (our reader may lag the driver)
    T = MODEL.fk(np.array(target))
    res = ik.reply(ik.request(matrix_to_pose(T)))
    assert res.success, res.message
    np.testing.assert_allclose(MODEL.fk(np.array(res.solution.position))[:3, 3], T[:3, 3],
                               atol=1e-9)
    assert proc.stop() == 0 and not proc.killed


def test_params_file_blocks_are_accepted_by_the_nodes(ros_ctx):
    """config/px100.yaml's ik_service and trajectory_server blocks load into the real nodes."""
    import yaml
    from rclpy.parameter import Parameter
    from px100_control.paths import data_path
    from px100_control.ros.ik_service_node import IkServiceNode
    from px100_control.ros.trajectory_server_node import TrajectoryServerNode
    with open(data_path('config', 'px100.yaml')) as f:
        params = yaml.safe_load(f)
    for cls, block in ((IkServiceNode, 'ik_service'), (TrajectoryServerNode, 'trajectory_server')):
        values = params['/**/' + block]['ros__parameters']
        node = cls(context=ros_ctx, namespace='/params_test',
                   parameter_overrides=[Parameter(k, value=v) for k, v in values.items()])
        try:
            for key, value in values.items():
                assert node.get_parameter(key).value == value, (block, key)
        finally:
            node.destroy_node()
