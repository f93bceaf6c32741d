"""
bringup: sim_driver, ik_service, trajectory_server and robot_state_publisher in one process.

For machines without ``ros2 launch``: ``bringup --ros-args -p robot_model:=px100
--params-file config/px100.yaml`` after ``source scripts/env.sh`` (``ros2 run px100_control
bringup ...`` with a ROS 2 install). The ROS arguments apply to all four nodes
(a params file addresses each by its node name; robot_state_publisher is the
``state_publisher`` executable's node: live /tf); they spin in one executor
(:func:`px100_control.ros.common.make_executor`: rclpy's EventsExecutor by default).
The camera node (:mod:`px100_control.ros.camera_node`) runs in a process of its own, as a
camera driver does (its rendering must not hold this process's executor): bringup starts the
``camera`` executable with the same ROS arguments and stops it on exit; ``--no-camera`` leaves
it out (or ``-p enable:=false`` keeps it idle).
``--viewer`` adds the browser viewer node (:mod:`px100_control.ros.viewer_node`, parameters
``port``, ``host``, ``read_only``) to the same process.
"""
import signal
import subprocess
import sys
from typing import List, Optional

from px100_control.parameters import (CAMERA, IK_SERVICE, SIM_DRIVER, STATE_PUBLISHER,
                                      TRAJECTORY_SERVER, VIEWER)
from px100_control.ros.common import parse_cli, run_nodes
from px100_control.ros.ik_service_node import IkServiceNode
from px100_control.ros.sim_driver_node import SimDriverNode
from px100_control.ros.state_publisher_node import StatePublisherNode
from px100_control.ros.trajectory_server_node import TrajectoryServerNode
from px100_control.tools.processes import executable_path


def create_nodes(viewer: bool = False, **node_kwargs) -> List:
    """Return the sim_driver, ik_service, trajectory_server, robot_state_publisher (+ viewer)."""
    classes = [SimDriverNode, IkServiceNode, TrajectoryServerNode, StatePublisherNode]
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
    parser.add_argument('--no-camera', action='store_true',
                        help='do not start the camera node (its own process)')


def start_camera(argv: List[str]) -> Optional[subprocess.Popen]:
    """
    Start the ``camera`` executable with the ROS arguments of ``argv``; return it.

    It starts with SIGINT ignored (kept across exec, and Python keeps an ignored SIGINT) until
    its entry point takes SIGINT over: a Ctrl-C to the process group that lands while its
    interpreter still starts would print a KeyboardInterrupt traceback (CI: the group stopped
    right after bringup was up). :func:`stop_camera` ends it with SIGTERM.
    """
    ros_args = argv[argv.index('--ros-args'):] if '--ros-args' in argv else []
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        return subprocess.Popen([executable_path('camera'), *ros_args])
    finally:
        signal.signal(signal.SIGINT, previous)


def stop_camera(proc: Optional[subprocess.Popen], timeout: float = 10.0) -> None:
    """
    Stop the camera process (SIGTERM, then SIGKILL after ``timeout`` s).

    SIGTERM, which the camera takes as SIGINT: it may still ignore SIGINT if it is starting.
    """
    if proc is None:
        return
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        try:
            proc.wait(5.0)
        except subprocess.TimeoutExpired:
            print(f'bringup: the camera process {proc.pid} did not end after SIGKILL',
                  file=sys.stderr)


def main(args=None) -> int:
    """Run the four nodes until SIGINT/SIGTERM (``ros2 run px100_control bringup``)."""
    options, argv = parse_cli('Run sim_driver, ik_service, trajectory_server and '
                              'robot_state_publisher of px100_control in one process.', args,
                              _add_arguments, schemas=(SIM_DRIVER, IK_SERVICE, TRAJECTORY_SERVER,
                                                       STATE_PUBLISHER, VIEWER, CAMERA))
    camera = None if options.no_camera else start_camera(argv)
    try:
        return run_nodes(lambda: create_nodes(viewer=options.viewer), argv)
    finally:
        stop_camera(camera)


if __name__ == '__main__':
    sys.exit(main())
