"""
What every px100_control node shares: the common parameters, topic naming and QoS.

Every node declares ``robot_model`` (default ``px100``: which robot description to load) and
``robot_name`` (default ``px100``: the namespace of its topics, as in the Interbotix stack).
Topic names are ``/<robot_name>/<name>``; an empty robot_name makes them relative, so
``--ros-args -r __ns:=/x`` places them.
"""
import argparse
from typing import List, Optional, Sequence

from px100_control.models.registry import load_robot
from px100_control.models.robot_model import RobotModel
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

#: latched topics (robot_description, trajectory/status)
LATCHED_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)


def declare_robot_parameters(node: Node) -> RobotModel:
    """Declare robot_model/robot_name on the node and return the loaded RobotModel."""
    model_name = node.declare_parameter('robot_model', 'px100').value
    node.declare_parameter('robot_name', 'px100')
    return load_robot(model_name)


def robot_name(node: Node) -> str:
    """Return the node's robot_name parameter ('' for none)."""
    return str(node.get_parameter('robot_name').value).strip('/')


def robot_topic(node: Node, name: str) -> str:
    """Return ``/<robot_name>/<name>``, or ``name`` relative when robot_name is empty."""
    ns = robot_name(node)
    return f'/{ns}/{name}' if ns else name


def frame_id(node: Node, frame: str) -> str:
    """Return the tf frame name ``<robot_name>/<frame>`` (``frame`` when robot_name is '')."""
    ns = robot_name(node)
    return f'{ns}/{frame}' if ns else frame


def parse_cli(description: str, args: Optional[Sequence[str]] = None,
              add_arguments=None) -> (argparse.Namespace, List[str]):
    """
    Parse a node's command line: ``--help`` and its own options, ROS args passed through.

    :return: (parsed options, the full argv to hand to ``rclpy.init(args=...)``)
    """
    import sys

    from rclpy.utilities import remove_ros_args
    argv = list(sys.argv if args is None else args)
    parser = argparse.ArgumentParser(
        prog=argv[0].rsplit('/', 1)[-1] if argv else None, description=description,
        epilog='ROS arguments: --ros-args -p robot_model:=px100 -p robot_name:=px100 '
               '--params-file config/px100.yaml -r from:=to')
    if add_arguments is not None:
        add_arguments(parser)
    options = parser.parse_args(remove_ros_args(argv)[1:])
    return options, argv


#: executor kinds :func:`make_executor` knows (env ``PX100_EXECUTOR`` picks one)
EXECUTOR_KINDS = ('events', 'single', 'multi')
#: the recorder's raw subscriptions with message info (for the DDS timestamps) fail in rclpy
#: 7.1's EventsExecutor ("SystemError: null argument to internal routine" in spin_once), and
#: it destroys subscriptions while spinning: the recorder and replayer spin single-threaded
BAG_EXECUTOR = 'single'


def make_executor(context=None, kind: Optional[str] = None):
    """
    Return the executor every px100_control node and the client spin in.

    ``events`` (default): rclpy's C++ EventsExecutor (rclpy >= 7.1, Jazzy); ``single``:
    SingleThreadedExecutor; ``multi``: MultiThreadedExecutor. The kind comes from ``kind``, else
    env ``PX100_EXECUTOR``. Nodes spinning in an EventsExecutor must not destroy their own
    entities while it spins (rclpy 7.1 fails in spin_once). Measured on a 2-core machine
    (in-process bringup + client, one 2 s move): events 0.44 CPU cores, single 1.0
    (saturated), multi > 1 core and moves stalled by seconds (the Python wait-set rebuild runs
    per callback). None of the nodes blocks inside a callback, so a single-threaded executor
    is safe for all of them.
    """
    import os

    from rclpy import executors
    kind = (kind or os.environ.get('PX100_EXECUTOR') or 'events').strip().lower()
    if kind not in EXECUTOR_KINDS:
        raise ValueError(f'PX100_EXECUTOR must be one of {", ".join(EXECUTOR_KINDS)}, '
                         f'not {kind!r}')
    if kind == 'events':
        try:
            from rclpy.experimental import EventsExecutor
        except ImportError:    # rclpy older than Jazzy's 7.1: fall back
            kind = 'single'
        else:
            return EventsExecutor(context=context)
    if kind == 'single':
        return executors.SingleThreadedExecutor(context=context)
    return executors.MultiThreadedExecutor(context=context)


def spin_node(node_factory, args=None, description: str = '', add_arguments=None) -> int:
    """
    Run one node the Jazzy way: init, spin until SIGINT/shutdown, destroy, try_shutdown.

    :param node_factory: callable(options) -> Node; it spins in :func:`make_executor`'s executor
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException

    options, argv = parse_cli(description, args, add_arguments)
    rclpy.init(args=argv)
    node = None
    try:
        node = node_factory(options)
        executor = make_executor()
        executor.add_node(node)
        # spin_once in a loop, not spin(): rclpy 7.1's EventsExecutor.spin() does not return
        # when SIGINT shuts the context down
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
