"""
InterbotixManipulatorXS: an arm with its gripper, through the px100_control nodes.

Drop-in for ``interbotix_xs_modules.xs_robot.arm.InterbotixManipulatorXS`` (humble/jazzy):
same constructor signature and defaults, ``.core``, ``.arm``, ``.gripper`` (absent when
``gripper_name`` is None) and ``get_node()``. Only the import lines of a script change::

    from px100_control.client import InterbotixManipulatorXS, robot_startup, robot_shutdown

    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm',
                                  gripper_name='gripper')
    robot_startup()
    bot.arm.go_to_home_pose()
    bot.gripper.release()
    bot.arm.go_to_sleep_pose()
    robot_shutdown()

px100_control keywords (after the Interbotix ones): ``bringup=True`` (or env
``PX100_BRINGUP=1``) starts sim_driver, ik_service and trajectory_server in this process, so
the script is the only command to run (``bringup='process'`` / ``PX100_BRINGUP=process``: as
child processes instead, which share no interpreter lock with the script);
``real_time_factor`` speeds that simulation up (the driver then owns the clock);
``connect_timeout`` [s] bounds the wait for the nodes (env ``PX100_CONNECT_TIMEOUT``, default
10 s) before an InterbotixException names what is missing. ROS 1 scripts work too: they never
call ``robot_startup()`` (the node spins from construction on), may pass ``init_node`` /
``use_gripper`` / ``joint_state_topic`` (also positionally in the noetic order: a bool 7th
argument is ``use_gripper`` and shifts the rest), and use ``bot.dxl``,
``gripper.open()/close()``. ``recorder=`` (px100_control) waits for a recorder first (see
:class:`~px100_control.client.core.InterbotixRobotXSCore`). ``bot.world`` (px100_control
extension, :mod:`px100_control.client.world`) lists the simulated scene's objects, reads their
poses and resets them.
"""
from typing import Optional

from px100_control.client.arm_interface import InterbotixArmXSInterface
from px100_control.client.core import InterbotixRobotXSCore
from px100_control.client.gripper import InterbotixGripperXSInterface
from px100_control.client.robot import robot_shutdown
from px100_control.client.world import InterbotixWorldInterface
from rclpy.logging import LoggingSeverity


class InterbotixManipulatorXS:
    """
    Standalone module to control an Interbotix arm and gripper.

    :param robot_model: robot model ('px100')
    :param group_name: joint group of the arm ('arm')
    :param gripper_name: gripper motor ('gripper'); None for an arm without gripper
    :param robot_name: namespace of the robot's nodes (default robot_model)
    :param moving_time: default move duration [s] (sticky)
    :param accel_time: default ramp time [s] (sticky)
    :param gripper_pressure: 0..1 of the gripper PWM range
    :param gripper_pressure_lower_limit: PWM at pressure 0
    :param gripper_pressure_upper_limit: PWM at pressure 1
    :param topic_joint_states: joint state topic under the namespace
    :param logging_level: rclpy logging severity
    :param node_name: kept for compatibility
    :param node: (optional) node to use instead of the global one
    :param iterative_update_fk: update the commanded EE pose after each joint command
    :param args: ignored (as in Interbotix)
    :param bringup: start the nodes: True in this process, 'process' as child processes
        (px100_control)
    :param real_time_factor: in-process simulation speed (px100_control)
    :param connect_timeout: [s] how long to wait for the nodes (px100_control)
    :param node_kwargs: extra keyword arguments of the in-process nodes (px100_control)
    """

    def __init__(self, robot_model: str, group_name: str = 'arm',
                 gripper_name: Optional[str] = 'gripper', robot_name: Optional[str] = None,
                 moving_time: float = 2.0, accel_time: float = 0.3,
                 gripper_pressure: float = 0.5, gripper_pressure_lower_limit: int = 150,
                 gripper_pressure_upper_limit: int = 350,
                 topic_joint_states: str = 'joint_states',
                 logging_level: LoggingSeverity = LoggingSeverity.INFO,
                 node_name: str = 'robot_manipulation', node=None,
                 iterative_update_fk: bool = True, args=None, *,
                 bringup=None, real_time_factor: Optional[float] = None,
                 connect_timeout: Optional[float] = None, node_kwargs: Optional[dict] = None,
                 use_gripper: bool = True, init_node: bool = True,
                 joint_state_topic: Optional[str] = None, recorder=None) -> None:
        if isinstance(gripper_pressure, bool):
            # ROS 1 (noetic) positional layout: (..., accel_time, use_gripper, gripper_pressure,
            # lower, upper, init_node): the values sit one slot later than in ROS 2
            (use_gripper, gripper_pressure, gripper_pressure_lower_limit,
             gripper_pressure_upper_limit, topic_joint_states, logging_level, init_node) = \
                _ros1_layout(gripper_pressure, gripper_pressure_lower_limit,
                             gripper_pressure_upper_limit, topic_joint_states, logging_level,
                             init_node)
        if not use_gripper:
            gripper_name = None
        if joint_state_topic is not None:
            topic_joint_states = joint_state_topic
        self.robot_name = robot_name
        self.core = InterbotixRobotXSCore(
            robot_model=robot_model, robot_name=robot_name,
            topic_joint_states=topic_joint_states, logging_level=logging_level,
            node_name=node_name, node=node, args=args, bringup=bringup,
            real_time_factor=real_time_factor, connect_timeout=connect_timeout,
            node_kwargs=node_kwargs, recorder=recorder)
        self.arm = InterbotixArmXSInterface(
            core=self.core, robot_model=robot_model, group_name=group_name,
            moving_time=moving_time, accel_time=accel_time,
            iterative_update_fk=iterative_update_fk)
        #: the simulated scene (px100_control extension): objects, poses, held object, reset
        self.world = InterbotixWorldInterface(self.core)
        if gripper_name is not None:
            self.gripper = InterbotixGripperXSInterface(
                core=self.core, gripper_name=gripper_name, gripper_pressure=gripper_pressure,
                gripper_pressure_lower_limit=gripper_pressure_lower_limit,
                gripper_pressure_upper_limit=gripper_pressure_upper_limit)

    @property
    def dxl(self) -> InterbotixRobotXSCore:
        """ROS 1 name of :attr:`core`."""
        return self.core

    def get_node(self):
        """Return the client's ROS node."""
        return self.core.get_node()

    def shutdown(self) -> None:
        """Shut the API down (the galactic-era method; calls robot_shutdown)."""
        robot_shutdown()


def _ros1_layout(use_gripper, slot8, slot9, slot10, slot11, init_node):
    """
    Map ROS 1 positional arguments 7..11 found in the ROS 2 slots to their meaning.

    ROS 1: use_gripper, gripper_pressure, lower, upper, init_node; ROS 2 has gripper_pressure,
    lower, upper, topic_joint_states, logging_level there. A slot still holding its ROS 2
    default was not given, so the ROS 1 default applies.
    :return: (use_gripper, pressure, lower, upper, topic_joint_states, logging_level, init_node)
    """
    pressure = float(slot8) if slot8 != 150 else 0.5
    lower = slot9 if slot9 != 350 else 150
    upper = slot10 if isinstance(slot10, (int, float)) else 350
    if isinstance(slot11, bool):
        init_node = slot11
    return (bool(use_gripper), pressure, lower, upper, 'joint_states', LoggingSeverity.INFO,
            init_node)
