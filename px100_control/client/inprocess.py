"""
In-process bringup: sim_driver, ik_service and trajectory_server spun inside the client process.

``InterbotixManipulatorXS(..., bringup=True)`` (or env ``PX100_BRINGUP=1``) uses this so a
script is the only command to run. The nodes come from :func:`px100_control.ros.bringup.
create_nodes` (the same ones ``ros2 run px100_control bringup`` starts), live in the client's
rclpy context, and spin in their own executor thread; :func:`robot_shutdown` stops them.
"""
import inspect
import threading
from typing import List, Optional

from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.parameter import Parameter


#: parameters the client sets on its own in-process nodes. ik_service 'strict': the whole pose
#: or nothing, which is what Interbotix's IK guarantees (eomg/ev); in 'pitch' mode a 4-DOF arm
#: may be answered with the roll-flipped "over the top" configuration (same tool x axis, gripper
#: upside down), which the client would have to refuse.
NODE_PARAMETERS = {'ik_service': {'orientation_mode': 'strict'}}


class InProcessBringup:
    """
    The robot's nodes running in this process.

    :param robot_model: robot model parameter of every node
    :param robot_name: namespace parameter of every node
    :param real_time_factor: simulation speed (sim_driver parameter ``real_time_factor``, when
        the driver declares it)
    :param parameters: extra {name: value} parameters given to every node
    """

    def __init__(self, robot_model: str = 'px100', robot_name: str = 'px100',
                 real_time_factor: float = 1.0, parameters: Optional[dict] = None, **kwargs):
        self.robot_model = robot_model
        self.robot_name = robot_name
        self.real_time_factor = float(real_time_factor)
        self.parameters = dict(parameters or {})
        self.kwargs = kwargs
        self.nodes: List = []
        self.executor: Optional[MultiThreadedExecutor] = None
        self.thread: Optional[threading.Thread] = None

    def start(self, context=None) -> None:
        """Create the nodes and spin them in a background thread."""
        from px100_control.ros import bringup
        params = {'robot_model': self.robot_model, 'robot_name': self.robot_name}
        if self.real_time_factor != 1.0:
            params['real_time_factor'] = self.real_time_factor
        params.update(self.parameters)
        kwargs = dict(self.kwargs)
        kwargs.setdefault('parameter_overrides',
                          [Parameter(k, value=v) for k, v in params.items()])
        kwargs.setdefault('allow_undeclared_parameters', True)
        if context is not None:
            kwargs.setdefault('context', context)
        sig = inspect.signature(bringup.create_nodes)
        if not any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values()):
            kwargs = {k: v for k, v in kwargs.items() if k in sig.parameters}
        self.nodes = list(bringup.create_nodes(**kwargs))
        for node in self.nodes:
            for name, value in NODE_PARAMETERS.get(node.get_name(), {}).items():
                if node.has_parameter(name):
                    node.set_parameters([Parameter(name, value=value)])
        self.executor = MultiThreadedExecutor(context=context)
        for n in self.nodes:
            self.executor.add_node(n)
        self.thread = threading.Thread(target=self._spin, name='px100_bringup', daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except (ExternalShutdownException, KeyboardInterrupt):
            pass
        except Exception:  # noqa: B902 - the context was shut down under the executor
            pass

    def stop(self) -> None:
        """Stop spinning and destroy the nodes."""
        from px100_control.client.robot import stop_executor
        stop_executor(self.executor, self.thread)
        for n in self.nodes:
            try:
                n.destroy_node()
            except Exception:  # noqa: B902 - already destroyed
                pass
        self.nodes = []
        self.executor = None
        self.thread = None
