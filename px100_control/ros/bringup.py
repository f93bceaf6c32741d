"""
bringup: sim_driver, ik_service and trajectory_server in one process.

For machines without ``ros2 launch``: ``ros2 run px100_control bringup --ros-args -p
robot_model:=px100 --params-file config/px100.yaml``. The ROS arguments apply to all three nodes
(a params file addresses each by its node name); they spin in one executor
(:func:`px100_control.ros.common.make_executor`: rclpy's EventsExecutor by default).
"""
import sys
from typing import List

from px100_control.ros.common import parse_cli, run_nodes
from px100_control.ros.ik_service_node import IkServiceNode
from px100_control.ros.parameter_schema import IK_SERVICE, SIM_DRIVER, TRAJECTORY_SERVER
from px100_control.ros.sim_driver_node import SimDriverNode
from px100_control.ros.trajectory_server_node import TrajectoryServerNode


def create_nodes(**node_kwargs) -> List:
    """Return [SimDriverNode, IkServiceNode, TrajectoryServerNode] built with node_kwargs."""
    nodes = []
    try:
        for cls in (SimDriverNode, IkServiceNode, TrajectoryServerNode):
            nodes.append(cls(**node_kwargs))
    except BaseException:
        for node in nodes:
            node.destroy_node()
        raise
    return nodes


def main(args=None) -> int:
    """Run the three nodes until SIGINT/SIGTERM (``ros2 run px100_control bringup``)."""
    _, argv = parse_cli('Run sim_driver, ik_service and trajectory_server of px100_control in '
                        'one process.', args,
                        schemas=(SIM_DRIVER, IK_SERVICE, TRAJECTORY_SERVER))
    return run_nodes(create_nodes, argv)


if __name__ == '__main__':
    sys.exit(main())
