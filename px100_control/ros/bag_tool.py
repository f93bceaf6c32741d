"""
The command-line run of a bag tool (``record``, ``replay``): one node, one clear error line.

Init rclpy, build the node, spin it until SIGINT/SIGTERM, a shutdown or the node is done, then
tear down. Bad ROS arguments, a bad bag or option (:class:`px100_control.errors.Px100Error`)
is one line ``<prog>: error: ...`` on stderr and exit status 1; a stop signal while the node
is being built is not an error.
"""
import sys
from typing import Callable, Optional, Sequence

from px100_control.errors import Px100Error
from px100_control.ros.common import (BAG_EXECUTOR, destroy_nodes, ignore_further_interrupts,
                                      init_ros, install_stop_signals, keep_spinning,
                                      make_executor, shutdown_executor, shutting_down,
                                      spin_once)
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node


def run_bag_tool(prog: str, argv: Sequence[str], build: Callable[[], Node],
                 done: Callable[[Node], bool], status: Callable[[Node], int] = lambda n: 0,
                 close: Optional[Callable[[Node], None]] = None) -> int:
    """
    Run one bag tool node; return the exit status.

    :param prog: program name of the error line
    :param argv: full argv for ``rclpy.init`` (ROS arguments included)
    :param build: build() -> the node (called after ``rclpy.init``)
    :param done: done(node) -> True to stop spinning
    :param status: status(node) -> exit status once done (not after an interrupt)
    :param close: close(node), called before the node is destroyed
    """
    install_stop_signals()
    bad_args = init_ros(argv)
    if bad_args:
        print(f'{prog}: error: {bad_args}', file=sys.stderr)
        return 1
    node = None
    executor = None
    result = 0
    try:
        executor = make_executor(kind=BAG_EXECUTOR)   # before the node: see common.run_nodes
        node = build()
        executor.add_node(node)
        while keep_spinning() and not done(node):
            spin_once(executor, 0.1)
        result = status(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Px100Error as exc:  # BagError and a bad robot_model
        print(f'{prog}: error: {exc}', file=sys.stderr)
        result = 1
    except Exception:
        if not shutting_down():
            result = 1
            raise
        # SIGINT/SIGTERM shut the context down while the node was being built: not an error
    finally:
        shutdown_executor(executor)
        if node is not None and close is not None:
            close(node)
        destroy_nodes([node] if node is not None else [], result)
        ignore_further_interrupts()
    return result
