"""
bringup: sim_driver, ik_service and trajectory_server in one process.

For machines without ``ros2 launch``: ``bringup --ros-args -p robot_model:=px100
--params-file config/px100.yaml`` after ``source scripts/env.sh`` (``ros2 run px100_control
bringup ...`` with a ROS 2 install). The ROS arguments apply to all three nodes
(a params file addresses each by its node name); they spin in one executor
(:func:`px100_control.ros.common.make_executor`: rclpy's EventsExecutor by default).
``--viewer`` adds the browser viewer node (:mod:`px100_control.ros.viewer_node`, parameters
``port``, ``host``, ``read_only``) to the same process.
"""
import sys
from typing import List

from px100_control.parameters import IK_SERVICE, SIM_DRIVER, TRAJECTORY_SERVER, VIEWER
from px100_control.ros.common import parse_cli, run_nodes
from px100_control.ros.ik_service_node import IkServiceNode
from px100_control.ros.sim_driver_node import SimDriverNode
from px100_control.ros.trajectory_server_node import TrajectoryServerNode


def create_nodes(viewer: bool = False, **node_kwargs) -> List:
    """Return [SimDriverNode, IkServiceNode, TrajectoryServerNode] (+ ViewerNode if viewer)."""
    classes = [SimDriverNode, IkServiceNode, TrajectoryServerNode]
    if viewer:
        from px100_control.ros.viewer_node import ViewerNode  # optional: viser, loaded when asked
        classes.append(ViewerNode)
    nodes = []
    try:
        for cls in classes:
            nodes.append(cls(**node_kwargs))
    except BaseException:
        for node in nodes:
            node.destroy_node()
        raise
    return nodes


def _add_arguments(parser) -> None:
    parser.add_argument('--viewer', action='store_true',
                        help='also serve the browser viewer (http://127.0.0.1:8080; '
                             '--ros-args -p port:=N to change)')


def main(args=None) -> int:
    """Run the three nodes until SIGINT/SIGTERM (``ros2 run px100_control bringup``)."""
    options, argv = parse_cli('Run sim_driver, ik_service and trajectory_server of px100_control '
                              'in one process.', args, _add_arguments,
                              schemas=(SIM_DRIVER, IK_SERVICE, TRAJECTORY_SERVER, VIEWER))
    return run_nodes(lambda: create_nodes(viewer=options.viewer), argv)


if __name__ == '__main__':
    sys.exit(main())
