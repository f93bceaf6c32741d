"""
InterbotixRobotXSCore: the client's ROS plumbing, wrapping the px100_control nodes.

Interbotix's core talks to its ``xs_sdk`` driver (services, JointGroupCommand...). This one
talks to the px100_control nodes through the public contract (shared/reference/
ros_interfaces.md), in namespace ``/<robot_name>``:

- state: ``joint_states`` and ``ee_pose`` from ``sim_driver``;
- moves: goals of the action ``arm_controller/follow_joint_trajectory``
  (control_msgs/FollowJointTrajectory, ``trajectory_server``), as a ros2_control arm is driven:
  result SUCCEEDED / ABORTED / CANCELED with the reason, cancel through the action
  (:mod:`px100_control.client.calls`);
- IK: the services ``compute_ik`` and, for paths, ``compute_cartesian_path`` (``ik_service``);
- direct setpoints (gripper effort, single motors) on ``commands/joint_setpoints``;
- torque through ``sim_driver``'s ``torque_enable.<joint>`` parameters (``srv_torque`` is a
  client of its Interbotix ``torque_enable`` (interbotix_xs_msgs/TorqueEnable) service).

The xs_sdk services are emulated: robot info from the RobotModel (URDF limits and sleep pose),
the Profile_Velocity / Profile_Acceleration registers kept here (they are what the arm's
moving_time / accel_time become), PID gains and reboots logged as not applicable. Operating
modes as xs_sdk's: position modes move through trajectory_server; 'velocity' [rad/s],
'current' [mA, torque through the joint's DYNAMIXEL figures: :meth:`InterbotixRobotXSCore.servo_of`
from the robot file's ``servos``, the XL430-W250 where it names none] and 'pwm' [+-885]
put the joints of sim_driver in velocity / torque / duty control (its ``operating_mode.<joint>``
parameters) and send the commands on ``commands/joint_setpoints``; positions for a joint in
another mode are refused, never sent as something else. Torque on/off per joint, group or all
through sim_driver's ``torque_enable.<joint>`` parameters.

Bounded failure: the constructor waits at most ``connect_timeout`` (keyword, or env
``PX100_CONNECT_TIMEOUT``, default 10 s) for joint_states and the IK / trajectory peers and then
raises :class:`InterbotixException` naming what is missing. Every blocking call has a deadline.
Units: SI (rad, m, s, N*m) everywhere.
"""
import copy
from dataclasses import dataclass, field
import math
import os
import threading
import time
from typing import Dict, List, Optional, Sequence, Tuple

from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration as DurationMsg
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from interbotix_xs_msgs.srv import TorqueEnable
import numpy as np
from px100_control.client.calls import ARM_ACTION, ArmActionLink, call_service, FJT, GoalCall
from px100_control.client.inprocess import InProcessBringup, ProcessBringup
from px100_control.client.recorder_wait import local_bag_dirs, RecorderWait
import px100_control.client.robot as _robot
from px100_control.client.robot import InterbotixException
from px100_control.control.actuator import DYNAMIXEL, joint_servos, JointServos
from px100_control.control.gripper import effort_to_pwm as _effort_to_pwm
from px100_control.control.gripper import pwm_to_effort as _pwm_to_effort
from px100_control.errors import Px100Error
from px100_control.models.registry import load_robot
from px100_control.models.robot_model import RobotModel
from px100_control.ros.conversions import matrix_to_pose, pose_to_matrix, stamp_id
from px100_control.ros.peers import (DISCOVERY_BOUND_S, duplicates_message, has_unknown,
                                     live_peers)
from px100_control.ros.writer_match import WriterSideCheck
from px100_control_msgs.srv import ComputeCartesianPath, ComputeIK
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.msg import ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.logging import LoggingSeverity
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

#: action_msgs/GoalStatus codes by name and back
STATUS_NAMES = {
    GoalStatus.STATUS_UNKNOWN: 'UNKNOWN', GoalStatus.STATUS_ACCEPTED: 'ACCEPTED',
    GoalStatus.STATUS_EXECUTING: 'EXECUTING', GoalStatus.STATUS_CANCELING: 'CANCELING',
    GoalStatus.STATUS_SUCCEEDED: 'SUCCEEDED', GoalStatus.STATUS_CANCELED: 'CANCELED',
    GoalStatus.STATUS_ABORTED: 'ABORTED',
}
TERMINAL = (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_CANCELED, GoalStatus.STATUS_ABORTED)

_BEST_EFFORT = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
_RELIABLE = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
_LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)
_LATCHED_MANY = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)


#: Interbotix operating mode -> sim_driver's operating_mode (see robot_set_operating_modes)
DRIVER_MODES = {'position': '', 'ext_position': '', 'current_based_position': '',
                'velocity': 'velocity', 'current': 'torque', 'pwm': 'duty'}
#: the modes in which commands are positions
POSITION_MODES = ('position', 'ext_position', 'current_based_position')
#: DYNAMIXEL XL430-W250 figures (ROBOTIS e-Manual, XL430-W250 specifications, at 11.1 V):
#: stall torque 1.4 N*m at a stall current of 1.3 A, PWM_Limit 885 (= 100 % duty): the px100's
#: servos and the default of a joint whose robot file names no servo. 'current' is emulated
#: with the joint's servo torque constant, stall torque / stall current (1.077 N*m/A for the
#: XL430, which has no current mode of its own; 1.78 for the XM430-W350, 2.41 for the
#: XM540-W270), times its servo count (a shadowed shoulder: 2).
DEFAULT_SERVO = JointServos(DYNAMIXEL['XL430-W250'])
STALL_TORQUE = DEFAULT_SERVO.figures.stall_torque
STALL_CURRENT_MA = 1000.0 * DEFAULT_SERVO.figures.stall_current
TORQUE_PER_AMP = DEFAULT_SERVO.torque_per_amp
PWM_LIMIT = 885.0
#: a finger this close to a limit [m] counts as there (the simulated linkage stops at it)
FINGER_TOLERANCE = 2e-4
#: below this horn speed [rad/s] closing fingers are taken as stopped (on an object)
STOPPED_SPEED = 0.05
#: [s] a gripper driven for less than this may still be spinning up (not yet on an object)
GRIP_SETTLE = 0.3


def pwm_to_effort(pwm: float) -> float:
    """Return the gripper torque [N*m] of a signed PWM command (clipped to +-PWM_LIMIT)."""
    return _pwm_to_effort(max(-PWM_LIMIT, min(PWM_LIMIT, float(pwm))), STALL_TORQUE, PWM_LIMIT)


def effort_to_pwm(effort: float) -> float:
    """Return the signed PWM of a gripper torque [N*m] (inverse of pwm_to_effort)."""
    return _effort_to_pwm(float(effort), STALL_TORQUE, PWM_LIMIT)


#: shortest move sent for a Profile_Velocity / moving_time of 0 (the servos' "no profile") [s]
MIN_MOVE_TIME = 0.1


def feasible_duration(distances, velocity_limits, moving_time: float,
                      accel_time: float) -> float:
    """
    Return moving_time [s], or the shortest duration whose trapezoid peak respects the limits.

    :param distances: (n,) joint travel [rad]; :param velocity_limits: (n,) [rad/s]
    :param moving_time: the wanted duration [s]; 0 = no profile (as fast as the limits allow,
        at least MIN_MOVE_TIME); :param accel_time: ramp time [s]
    A servo with a time profile too short for its Velocity_Limit caps the speed the same way;
    trajectory_server refuses a too-fast goal, so such a move is stretched instead.
    """
    d = np.abs(np.asarray(distances, dtype=float))
    ratio = float(np.max(d / np.asarray(velocity_limits, dtype=float))) if d.size else 0.0
    cruise = moving_time - min(accel_time, moving_time / 2.0)
    if ratio <= cruise and moving_time > 0.0:
        return moving_time
    at = min(accel_time, MIN_MOVE_TIME / 2.0) if moving_time <= 0.0 else accel_time
    t_min = ratio + at if ratio >= at else 2.0 * ratio
    return max(MIN_MOVE_TIME if moving_time <= 0.0 else moving_time, 1.02 * t_min)


def env_float(name: str, default: float) -> float:
    """Return float(os.environ[name]) or default (also when unset or unparsable)."""
    try:
        return float(os.environ[name])
    except (KeyError, ValueError):
        return default


def env_flag(name: str) -> bool:
    """Return True when the environment variable is 1/true/yes/on."""
    return os.environ.get(name, '').strip().lower() in ('1', 'true', 'yes', 'on')


@dataclass
class RobotInfo:
    """The fields of interbotix_xs_msgs/srv/RobotInfo's response (limits in rad or m)."""

    mode: str = ''
    profile_type: str = ''
    joint_names: List[str] = field(default_factory=list)
    joint_ids: List[int] = field(default_factory=list)
    joint_lower_limits: List[float] = field(default_factory=list)
    joint_upper_limits: List[float] = field(default_factory=list)
    joint_velocity_limits: List[float] = field(default_factory=list)
    joint_sleep_positions: List[float] = field(default_factory=list)
    joint_state_indices: List[int] = field(default_factory=list)
    num_joints: int = 0
    name: List[str] = field(default_factory=list)


@dataclass
class IkReply:
    """
    One ik_service answer.

    :param q: (n,) solution [rad] or None
    :param success: the service solved it (level OK and a solution)
    :param reason: the status message (``solved`` or why not)
    :param values: the status key/values (method, errors, ...)
    """

    q: Optional[np.ndarray]
    success: bool
    reason: str
    values: Dict[str, str]


#: a goal of this client (px100_control.client.calls.GoalCall)
_Pending = GoalCall


class InterbotixRobotXSCore:
    """
    The robot's ROS interface: state, moves, IK and the emulated xs_sdk services.

    :param robot_model: robot model name ('px100'); selects the RobotModel
    :param robot_name: namespace of the nodes (default: robot_model; '' = no namespace)
    :param topic_joint_states: joint state topic under the namespace
    :param logging_level: rclpy LoggingSeverity of the client node's logger
    :param node_name: kept for compatibility (the global node is always
        'interbotix_robot_manipulation', as in Interbotix)
    :param node: (optional) a node to use instead of the global one
    :param args: ignored (as in Interbotix)
    :param bringup: start sim_driver, ik_service and trajectory_server in this process: True
        (threads of this process) or 'process' (child processes); default env ``PX100_BRINGUP``
        (1 / process)
    :param real_time_factor: simulation speed for an in-process bringup (env
        ``PX100_REAL_TIME_FACTOR``, default 1)
    :param connect_timeout: [s] how long to wait for the nodes (env ``PX100_CONNECT_TIMEOUT``,
        default 10; 30 when this call starts them)
    :param init_node: ROS 1 argument, accepted and unused (the global node always exists)
    :param joint_state_topic: ROS 1 / standalone-gripper name of topic_joint_states
    :param node_kwargs: extra keyword arguments for the in-process nodes
    :param recorder: wait before the first command until the recorders record everything
        (:mod:`px100_control.client.recorder_wait`): None (default) the recorders found at
        startup (in this process or in the graph), a
        :class:`px100_control.ros.recorder.Recorder` that one, True also one still starting
        (env ``PX100_RECORDER=wait``), False none
    """

    def __init__(self, robot_model: str, robot_name: Optional[str] = None,
                 topic_joint_states: str = 'joint_states',
                 logging_level: LoggingSeverity = LoggingSeverity.INFO,
                 node_name: str = 'interbotix_robot_manipulation', node=None, args=None, *,
                 bringup: Optional[bool] = None, real_time_factor: Optional[float] = None,
                 connect_timeout: Optional[float] = None, node_kwargs: Optional[dict] = None,
                 recorder=None, init_node: bool = True, joint_state_topic: Optional[str] = None):
        if isinstance(topic_joint_states, bool):  # ROS 1: (robot_model, robot_name, init_node)
            topic_joint_states = 'joint_states'
        if joint_state_topic is not None:
            topic_joint_states = joint_state_topic
        self._created_monotonic = time.monotonic()
        # the node first: its discovery of the graph (how long the duplicate checks must watch
        # it) runs while the model loads and the nodes of a bringup start
        if node is None:
            node = _robot.get_interbotix_global_node()
            if node is None:
                node = _robot.create_interbotix_global_node()
        try:
            self.model: RobotModel = load_robot(robot_model)
        except Px100Error as exc:
            raise InterbotixException(f"Unknown robot_model '{robot_model}': {exc}") from exc
        self.robot_model = robot_model
        self.robot_name = robot_model if robot_name is None else robot_name.strip('/')
        self.ns = f'/{self.robot_name}' if self.robot_name else ''
        self.topic_joint_states = topic_joint_states
        self.node_name = node_name
        self.real_time_factor = float(real_time_factor if real_time_factor is not None
                                      else env_float('PX100_REAL_TIME_FACTOR', 1.0))
        if not (self.real_time_factor > 0 and math.isfinite(self.real_time_factor)):
            raise InterbotixException(f'real_time_factor must be > 0, got {real_time_factor}')
        self.connect_timeout = float(connect_timeout if connect_timeout is not None
                                     else env_float('PX100_CONNECT_TIMEOUT', 10.0))
        #: joint_states older than this [s] (wall) mean the driver stopped (trajectory_server
        #: itself aborts a running goal after its state_timeout, 1 s by default)
        self.stale_timeout = env_float('PX100_STALE_TIMEOUT', 3.0)
        self._started_at = time.monotonic()
        self._torn_down = False
        self.js_mutex = threading.Lock()
        self.joint_states: Optional[JointState] = None
        self.ee_pose: Optional[PoseStamped] = None
        self._js_monotonic = 0.0
        self._js_count = 0
        self._pending_lock = threading.Lock()
        self._goals: Dict[Tuple[int, int], _Pending] = {}
        self._last_stamp_ns = 0
        self._server_accel: Optional[float] = None
        self.last_path_reason = ''
        self._param_clients: Dict[str, object] = {}
        self._registers: Dict[str, Dict[str, int]] = {}
        self._modes: Dict[str, Tuple[str, str]] = {}
        #: True once the recorders of the startup were waited for (see recorder_wait)
        self._recorders_checked = False
        #: bag directories announced on recorder/ready (and of a Recorder given to us)
        self.bag_paths: List[str] = []
        #: the last pwm / current command sent to the gripper, and when (time.monotonic)
        self._gripper_effort = 0.0
        self._gripper_effort_at = 0.0
        #: called before an arm move; each returns a warning or None (the gripper's timing)
        self._before_arm_move: List = []
        #: the last velocity / current / pwm command of each joint (xs_sdk units)
        self._last_effort: Dict[str, float] = {}
        self._servos = joint_servos(
            self.model.extra.get('servos'), list(self.model.joint_names)
            + ([self.model.gripper.joint] if self.model.gripper is not None else []))
        for j in self.model.joint_names:
            self._registers[j] = {'Profile_Velocity': 2000, 'Profile_Acceleration': 300}
            self._modes[j] = ('position', 'time')
        if self.model.gripper is not None:
            self._registers[self.model.gripper.joint] = {'Profile_Velocity': 0,
                                                         'Profile_Acceleration': 0}
            self._modes[self.model.gripper.joint] = ('pwm', 'velocity')

        if bringup is None:
            env = os.environ.get('PX100_BRINGUP', '').strip().lower()
            bringup = 'process' if env == 'process' else env_flag('PX100_BRINGUP')
        self.robot_node = node
        self.robot_node.get_logger().set_level(logging_level)
        _robot.register_robot(self)
        self._started_bringup = False
        if bringup:
            self._start_bringup(bringup, node_kwargs or {})
            if connect_timeout is None and 'PX100_CONNECT_TIMEOUT' not in os.environ:
                self.connect_timeout = 30.0  # the nodes start now: allow a slow machine
        self._make_interfaces()
        _robot.ensure_spinning(self.robot_node)
        self._wait_for_peers()
        self._check_duplicates()
        self.js_index_map = {n: i for i, n in enumerate(self.joint_states.name)}
        self.wait_for_recorder(recorder)
        self.get_node().loginfo(
            f'\n\tRobot Name: {self.robot_name}\n\tRobot Model: {self.robot_model}')
        self.get_node().loginfo('Initialized InterbotixRobotXSCore!')

    # ------------------------------------------------------------------ setup
    def _start_bringup(self, mode, node_kwargs: dict) -> None:
        if _robot.get_bringup(self.robot_name) is not None:
            return  # a second client of the same robot (e.g. a standalone gripper) shares it
        self._refuse_beside_running_nodes()
        cls = ProcessBringup if str(mode).lower() == 'process' else InProcessBringup
        bringup = cls(self.robot_model, self.robot_name,
                      real_time_factor=self.real_time_factor, **node_kwargs)
        try:
            bringup.start(context=self.robot_node.context)
        except BaseException:   # Ctrl-C while its nodes start: stop those already up
            bringup.stop()
            raise
        _robot.set_bringup(bringup, self.robot_name)
        self._started_bringup = True

    def topic(self, name: str) -> str:
        """Return the absolute topic/service name ``/<robot_name>/<name>``."""
        return f'{self.ns}/{name}' if self.ns else name

    def _make_interfaces(self) -> None:
        n = self.robot_node
        cbg = ReentrantCallbackGroup()
        self._cbg = cbg
        self.sub_joint_states = n.create_subscription(
            JointState, self.topic(self.topic_joint_states), self._joint_state_cb, _BEST_EFFORT,
            callback_group=cbg)
        self.sub_ee_pose = n.create_subscription(
            PoseStamped, self.topic('ee_pose'), self._ee_pose_cb, _BEST_EFFORT,
            callback_group=cbg)
        self.pub_setpoints = n.create_publisher(
            JointState, self.topic('commands/joint_setpoints'), _RELIABLE)
        self.srv_ik = n.create_client(ComputeIK, self.topic('compute_ik'), callback_group=cbg)
        self.srv_ik_path = n.create_client(ComputeCartesianPath,
                                           self.topic('compute_cartesian_path'),
                                           callback_group=cbg)
        self.arm_action = ArmActionLink(n, f'{n.get_name()}_actions', self.topic(ARM_ACTION),
                                        callback_group=cbg)
        self.srv_torque = n.create_client(TorqueEnable, self.topic('torque_enable'),
                                          callback_group=cbg)
        self.srv_reset = n.create_client(Trigger, self.topic('reset'), callback_group=cbg)
        self.sub_recorder = n.create_subscription(
            String, self.topic('recorder/ready'), self._recorder_cb, _LATCHED_MANY,
            callback_group=cbg)

    def _recorder_cb(self, msg: String) -> None:
        if msg.data and msg.data not in self.bag_paths:
            self.bag_paths.append(msg.data)
            if self._recorders_checked and msg.data not in local_bag_dirs():
                self.get_node().logwarn(
                    f'A recorder ({msg.data}) got ready after this script started: the start '
                    'of the run may be missing from its bag (start the recorder earlier, or '
                    'set PX100_RECORDER=wait).')

    def wait_for_recorder(self, recorder=None, timeout: Optional[float] = None) -> bool:
        """
        Wait until the recorders record everything this client sends.

        Which recorders: see ``recorder`` and :mod:`px100_control.client.recorder_wait`.
        :param timeout: [s] for a Recorder given or recorder=True (default connect_timeout)
        :return: False when a recorder was not ready and matched in time (a warning says so)
        """
        timeout = self.connect_timeout if timeout is None else float(timeout)
        ok = RecorderWait(self, [self.pub_setpoints], self.call_event_topics()).run(
            recorder, timeout)
        self._recorders_checked = recorder is not False
        return ok

    def interrupt(self, settle: float = 0.5) -> str:
        """
        Ctrl-C: cancel this client's unfinished goals and stop driven joints; return a report.

        trajectory_server decelerates a canceled goal to rest where the arm is; joints in
        velocity / current / pwm mode are put back in position mode (they hold); a gripper
        driven in pwm / current mode stops unless it squeezes an object (_interrupt_gripper).
        The report (one line) names the canceled goals, where the arm holds [rad], what the
        gripper does and the bag directory.
        """
        with self._pending_lock:
            running = [p for p in self._goals.values() if p.status not in TERMINAL]
        canceled = [p for p in running if self.cancel_goal(p, timeout=0.5)]
        moded = [j for j in self.model.joint_names if self.mode_of(j) not in POSITION_MODES]
        if moded:  # velocity / current / pwm joints: position mode holds them where they are
            node = self._peer_node('commands/joint_setpoints', 'sim_driver')
            if node is not None:
                self.set_remote_parameters(node, {f'operating_mode.{j}': '' for j in moded}, 0.5)
        grip = self._interrupt_gripper()
        end = time.monotonic() + settle
        while any(p.status not in TERMINAL for p in canceled) and time.monotonic() < end:
            time.sleep(0.01)
        name = self.robot_name or self.robot_model
        what = ('canceled goal ' + ', '.join(p.label for p in canceled)
                if canceled else 'no goal was running')
        try:
            q = self.joint_positions(self.model.joint_names)
            where = ', holding at ' + ' '.join(
                f'{j}={v:.3f}' for j, v in zip(self.model.joint_names, q)) + ' rad'
        except Exception:  # noqa: B902 - no joint states: say so
            where = ', joint states unknown'
        bags = self.bag_paths or local_bag_dirs()
        bag = ('bag: ' + ', '.join(bags)) if bags else 'no bag recorded'
        return f'{name} {what}{where}{grip}; {bag}'

    def _interrupt_gripper(self) -> str:
        """
        Ctrl-C: stop a gripper driven in pwm/current mode; return what was done, in words.

        Fingers still moving (or driven less than GRIP_SETTLE s ago) get effort 0 and stop
        where they are; fingers at rest between their limits squeeze an object and keep their
        effort, so the object is not dropped (as the real servo keeps its last Goal_PWM).
        """
        g = self.model.gripper
        if g is None or self.mode_of(g.joint) not in ('pwm', 'current') or \
                self._gripper_effort == 0.0:
            return ''
        try:
            finger = float(self.joint_positions([g.fingers[0]])[0])
            speed = abs(float(self._joint_field([g.joint], 'velocity')[0]))
        except InterbotixException:
            finger, speed = float('nan'), math.inf
        between = g.finger_lower + FINGER_TOLERANCE < finger < g.finger_upper - FINGER_TOLERANCE
        unit = 'PWM' if self.mode_of(g.joint) == 'pwm' else 'mA'
        if between and speed < STOPPED_SPEED and \
                time.monotonic() - self._gripper_effort_at > GRIP_SETTLE:
            return (f', gripper keeps squeezing an object at {finger * 1000:.1f} mm '
                    f'({self._gripper_effort:g} {unit})')
        self.robot_write_joint_command(g.joint, 0.0)
        return f', gripper stopped at {finger * 1000:.1f} mm (effort 0)'

    def _missing_peers(self) -> List[str]:
        """Return what is still missing, in words (empty when everything is there)."""
        missing = []
        if self.joint_states is None:
            missing.append(f"no joint states on '{self.topic(self.topic_joint_states)}' "
                           '(sim_driver)')
        if not self.arm_action.ready():
            missing.append(f"no trajectory_server serving the action '{self.topic(ARM_ACTION)}'")
        if not (self.srv_ik.service_is_ready() and self.srv_ik_path.service_is_ready()):
            missing.append(f"no ik_service serving '{self.topic('compute_ik')}' / "
                           f"'{self.topic('compute_cartesian_path')}'")
        return missing

    def _server_publishers(self) -> list:
        """
        Return publishers of the processes that serve this client (TopicEndpointInfo).

        The driver's (joint_states; it serves torque_enable and reset), the trajectory server's
        (the action's status) and ik_service's (its /rosout).
        """
        n = self.robot_node
        infos = list(n.get_publishers_info_by_topic(
            n.resolve_topic_name(self.topic(self.topic_joint_states))))
        infos += n.get_publishers_info_by_topic(
            n.resolve_topic_name(self.topic(ARM_ACTION) + '/_action/status'))
        ik = (n.resolve_topic_name(self.topic('compute_ik')).rsplit('/', 1)[0] or '/',
              'ik_service')
        infos += [i for i in n.get_publishers_info_by_topic('/rosout')
                  if (i.node_namespace, i.node_name) == ik]
        return infos

    def _wait_for_peers(self) -> None:
        """
        Wait up to connect_timeout for the nodes; raise InterbotixException naming the gaps.

        Found, the servers' processes must also have matched this client's reply readers (DDS
        matches each side on its own: a goal or IK reply sent before is lost, and the call
        waits for nothing): a question to each process, asked after all of this client's
        endpoints were created, proves it (:class:`WriterSideCheck`). Unconfirmed at the
        deadline, the client goes on with a warning.
        """
        start = time.monotonic()
        deadline = start + self.connect_timeout
        next_log = start + 2.0
        # its question clients stay on the node: destroying entities under rclpy 7.1's
        # EventsExecutor, which spins this node, fails its spin_once
        servers = WriterSideCheck(self.robot_node)
        while True:
            missing = self._missing_peers()
            unmatched = servers.unconfirmed(self._server_publishers()) if not missing else []
            now = time.monotonic()
            if not missing and (not unmatched or now >= deadline):
                if unmatched:
                    self.get_node().logwarn(
                        'No answer within the connect timeout from '
                        f"{', '.join(servers.describe(k) for k in unmatched)}: its process "
                        'may not have matched this client yet (its first replies may be lost)')
                return
            if now >= deadline:
                break
            if now >= next_log:
                self.get_node().logwarn('Waiting for the nodes: ' + '; '.join(
                    missing or ['their processes to answer (matching this client)']))
                next_log = now + 2.0
            time.sleep(0.02)
        self._raise_missing(missing)

    def _raise_missing(self, missing: List[str]) -> None:
        """Raise InterbotixException naming what is missing and how to start it."""
        bringup = _robot.get_bringup(self.robot_name)
        problems = bringup.problems() if hasattr(bringup, 'problems') else ''
        if problems:
            missing.append(f'bringup processes: {problems}')
        message = (
            f"Failed to find the px100_control nodes under namespace '{self.ns or '/'}' within "
            f"{self.connect_timeout:.1f} s: {'; '.join(missing)}. Is sim_driver (with ik_service "
            'and trajectory_server) running under that namespace? Start them with '
            "'ros2 run px100_control bringup', or construct the robot with bringup=True "
            '(or PX100_BRINGUP=1) to run them in this process.')
        self.get_node().logerror(message)
        raise InterbotixException(message)

    def _refuse_beside_running_nodes(self, discovery: float = 1.0) -> None:
        """
        Raise before starting nodes where a driver or trajectory_server already runs.

        The graph is watched until the client's node has been discovering for ``discovery``
        [s] (other processes' nodes take a moment to be discovered by a new node; found ones
        end the wait at once).
        """
        end = self._node_born() + discovery
        while True:
            peers = live_peers(self.robot_node, self.ns or '/')
            names = peers['drivers'] + peers['trajectory_servers']
            if (names and not has_unknown(peers)) or time.monotonic() >= end:
                break
            time.sleep(0.05)
        if names:
            message = (f"nodes already run under '{self.ns or '/'}' ({', '.join(names)}): this "
                       'script does not start its own beside them (bringup=True would put two '
                       'drivers on the same joints); connect to those instead (bringup=False, '
                       'PX100_BRINGUP unset) or stop them.')
            self.get_node().logerror(message)
            raise InterbotixException(message)

    def _node_born(self) -> float:
        """Return time.monotonic() [s] when the client's node began discovering the graph."""
        return getattr(self.robot_node, 'created_monotonic', self._created_monotonic)

    def duplicates(self) -> str:
        """Return a sentence naming a second driver / trajectory_server here ('' if none)."""
        end = time.monotonic() + 1.0
        peers = live_peers(self.robot_node, self.ns or '/')
        while has_unknown(peers) and time.monotonic() < end:
            time.sleep(0.05)  # a node being discovered: wait for its name
            peers = live_peers(self.robot_node, self.ns or '/')
        return duplicates_message(peers, self.ns)

    def _check_duplicates(self) -> None:
        """
        Refuse to run beside the nodes this call started twice; warn otherwise.

        After starting its own nodes the client watches the graph until its node has been
        discovering for DISCOVERY_BOUND_S (a running driver missed by the first announcements
        shows up by then).
        """
        problem = self.duplicates()
        if self._started_bringup:
            born = self._node_born()
            while not problem and time.monotonic() - born < DISCOVERY_BOUND_S:
                time.sleep(0.1)
                problem = self.duplicates()
        if not problem:
            return
        if self._started_bringup:
            message = (f'{problem} This script started its own nodes (bringup=True) although '
                       f"nodes already run under '{self.ns or '/'}': connect to those instead "
                       '(bringup=False, PX100_BRINGUP unset).')
            self.get_node().logerror(message)
            raise InterbotixException(message)
        self.get_node().logwarn(problem)

    def _teardown(self) -> None:
        """Release waiters (called by robot_shutdown)."""
        self._torn_down = True
        with self._pending_lock:
            for p in list(self._goals.values()):
                p.reason = p.reason or 'robot_shutdown() was called'
                p.event.set()
        link = getattr(self, 'arm_action', None)   # None: interrupted before it was made
        if link is not None:
            link.close()

    # -------------------------------------------------------------- callbacks
    def _joint_state_cb(self, msg: JointState) -> None:
        with self.js_mutex:
            self.joint_states = msg
            self._js_monotonic = time.monotonic()
            self._js_count += 1

    def _ee_pose_cb(self, msg: PoseStamped) -> None:
        self.ee_pose = msg

    # ---------------------------------------------------------------- helpers
    def get_node(self):
        """Return the client's ROS node."""
        return self.robot_node

    def get_logger(self):
        """Return the client node's logger."""
        return self.robot_node.get_logger()

    def new_stamp(self) -> Time:
        """Return a unique, increasing stamp (the request / goal id) from the node clock."""
        with self._pending_lock:
            now_ns = self.robot_node.get_clock().now().nanoseconds
            now_ns = max(now_ns, self._last_stamp_ns + 1)
            self._last_stamp_ns = now_ns
        return _time_of((now_ns // 1_000_000_000, now_ns % 1_000_000_000))

    def sleep(self, seconds: float) -> None:
        """
        Sleep ``seconds`` of simulated time.

        The wait follows the stamps of joint_states (the driver's time) until they advanced by
        ``seconds``. At real_time_factor 1 it also lasts ``seconds`` of wall time (as on the
        real robot; a driver on time takes no longer), so a simulation that fell behind (its
        process starved, then catching up on its stamps) still gives a grasp its time; if the
        stamps stop coming it gives up after 2 x ``seconds`` + 2 s. Otherwise the in-process
        driver owns the clock and may run slower than asked on a loaded machine; if its stamps
        stop, the wait ends after the wall time the factor promised, four times over, plus 2 s.
        Before any joint_states: ``seconds`` / real_time_factor of wall time.
        """
        if not seconds > 0:
            return
        if self.joint_states is None:
            time.sleep(seconds / self.real_time_factor)
            return
        start = time.monotonic()
        target_ns = self._js_stamp_ns() + int(seconds * 1e9)
        if self.real_time_factor == 1.0:
            time.sleep(seconds)
            give_up = start + 2.0 * seconds + 2.0
        else:
            give_up = start + 4.0 * seconds / self.real_time_factor + 2.0
        while self._js_stamp_ns() < target_ns and time.monotonic() < give_up:
            time.sleep(0.001)

    def _js_stamp_ns(self) -> int:
        """Return the stamp [ns] of the last joint_states message (simulated time)."""
        with self.js_mutex:
            stamp = self.joint_states.header.stamp
        return stamp.sec * 1_000_000_000 + stamp.nanosec

    def joint_state_age(self) -> float:
        """Return the wall time [s] since the last joint_states message (inf before any)."""
        with self.js_mutex:
            if self.joint_states is None:
                return math.inf
            return time.monotonic() - self._js_monotonic

    def _driver_problem(self) -> Optional[str]:
        """Return why the driver looks dead, or None."""
        age = self.joint_state_age()
        if age > self.stale_timeout:
            return (f"joint states on '{self.topic(self.topic_joint_states)}' stopped "
                    f'{age:.1f} s ago: is sim_driver still running under namespace '
                    f"'{self.ns or '/'}'?")
        return None

    def joint_positions(self, names: Sequence[str]) -> np.ndarray:
        """Return the measured positions [rad | m] of ``names`` from the latest joint states."""
        return self._joint_field(names, 'position')

    def _joint_field(self, names: Sequence[str], fieldname: str) -> np.ndarray:
        with self.js_mutex:
            js = self.joint_states
        values = list(getattr(js, fieldname))
        index = {n: i for i, n in enumerate(js.name)}
        out = []
        for n in names:
            i = index.get(n)
            if i is None:
                raise InterbotixException(f"joint '{n}' is not in the joint states "
                                          f'({list(js.name)})')
            if i >= len(values):
                raise InterbotixException(
                    f"the joint states carry no {fieldname} for '{n}' (driver publishes "
                    f'{len(values)} {fieldname} values for {len(js.name)} joints)')
            out.append(float(values[i]))
        return np.array(out)

    def measured_ee_pose(self) -> Optional[np.ndarray]:
        """Return the latest (4, 4) pose published on ``ee_pose`` by sim_driver (or None)."""
        msg = self.ee_pose
        if msg is None:
            return None
        T, _ = pose_to_matrix(msg.pose)
        return T

    # ----------------------------------------------------------------- goals
    def send_trajectory(self, joint_names: Sequence[str], points: Sequence[Sequence[float]],
                        times: Sequence[float], accel_time: Optional[float] = None) -> _Pending:
        """
        Send a FollowJointTrajectory goal to trajectory_server; return its pending handle.

        :param joint_names: a subset of the arm's joints
        :param points: (k, len(joint_names)) positions [rad]
        :param times: (k,) strictly increasing time_from_start [s]; one point = move there
        :param accel_time: [s] trapezoid ramp time for a one-point goal (None: server default)
        :raises InterbotixException: no trajectory_server is listening; a joint is not in a
            position mode (its positions would be executed as something else) or its mode was
            refused
        """
        refused = self.refused_mode_problem(joint_names)
        if refused:
            raise InterbotixException(refused)
        moded = [f"'{n}' ({self.mode_of(n)})" for n in joint_names
                 if n in self._modes and self.mode_of(n) not in POSITION_MODES]
        if moded:
            raise InterbotixException(
                f"joints {', '.join(moded)} are not in a position mode: positions are not "
                "sent (robot_set_operating_modes(..., 'position') first)")
        if not self.arm_action.ready():
            raise InterbotixException(
                f"no trajectory_server serves the action '{self.topic(ARM_ACTION)}': is "
                f"trajectory_server running under namespace '{self.ns or '/'}'?")
        goal = FJT.Goal()
        msg = goal.trajectory
        msg.joint_names = [str(n) for n in joint_names]
        for pos, t in zip(points, times):
            pt = JointTrajectoryPoint()
            pt.positions = [float(v) for v in pos]
            pt.time_from_start = _duration(t)
            msg.points.append(pt)
        if accel_time is not None and len(msg.points) == 1:
            self._set_server_accel_time(float(accel_time))
        stamp = self.new_stamp()
        pending = _Pending((stamp.sec, stamp.nanosec))
        with self._pending_lock:
            self._goals[pending.key] = pending
            self._prune(self._goals)
        self.arm_action.send(goal, pending)
        return pending

    def _set_server_accel_time(self, accel_time: float, timeout: float = 2.0) -> None:
        """
        Make trajectory_server's ``accel_time`` parameter equal to ``accel_time`` [s].

        trajectory_server reads its ``accel_time`` parameter when a one-point goal arrives (its
        documented way to choose a move's trapezoid ramp), so the client sets it (only when it
        changes: sticky, like Interbotix's Profile_Acceleration register) and waits for the
        answer before publishing the goal. A failure is logged; the server's value then applies.
        """
        if self._server_accel is not None and abs(self._server_accel - accel_time) < 1e-9:
            return
        node = self.find_node('trajectory_server')
        if node is None:
            return
        problem = self.set_remote_parameters(node, {'accel_time': float(accel_time)}, timeout)
        if problem:
            self.get_node().logwarn(f"Cannot set trajectory_server's accel_time to "
                                    f'{accel_time:.3f} s: {problem}')
            return
        self._server_accel = float(accel_time)

    def _peer_node(self, topic: str, name: str) -> Optional[str]:
        """
        Return the full name of the node ``name`` subscribed to ``topic`` (None if none is).

        Other subscribers (a recorder records every topic) are skipped; a node renamed at
        launch is accepted when it is the only subscriber.
        """
        infos = self.robot_node.get_subscriptions_info_by_topic(self.topic(topic))
        named = [i for i in infos if i.node_name == name] or (infos if len(infos) == 1 else [])
        if not named:
            return None
        return f"{named[0].node_namespace.rstrip('/')}/{named[0].node_name}"

    def set_remote_parameters(self, node: str, values: dict, timeout: float = 2.0) -> str:
        """
        Set parameters of another node (e.g. ``'/px100/sim_driver'``) through its set_parameters.

        px100_control extension. :return: '' on success, else the reason in words
        """
        service = f"{node.rstrip('/')}/set_parameters"
        if not service.startswith('/'):
            service = '/' + service
        client = self._param_clients.get(service)
        if client is None:
            client = self.robot_node.create_client(SetParameters, service,
                                                   callback_group=self._cbg)
            self._param_clients[service] = client
        if not client.wait_for_service(timeout_sec=timeout):
            return f"no service '{service}' (is {node} running?)"
        params = [ParameterMsg(name=k, value=_parameter_value(v)) for k, v in values.items()]
        future = client.call_async(SetParameters.Request(parameters=params))
        end = time.monotonic() + timeout
        while not future.done() and time.monotonic() < end:
            time.sleep(0.002)
        if not future.done() or future.result() is None:
            return f"'{service}' did not answer within {timeout:.1f} s"
        bad = [r.reason for r in future.result().results if not r.successful]
        return '; '.join(r or 'refused' for r in bad)

    def get_remote_parameter(self, node: str, name: str, timeout: float = 2.0):
        """Return the value of another node's parameter (None when it cannot be read)."""
        service = f"/{node.strip('/')}/get_parameters"
        client = self._param_clients.get(service)
        if client is None:
            client = self.robot_node.create_client(GetParameters, service,
                                                   callback_group=self._cbg)
            self._param_clients[service] = client
        if not client.wait_for_service(timeout_sec=timeout):
            return None
        future = client.call_async(GetParameters.Request(names=[name]))
        end = time.monotonic() + timeout
        while not future.done() and time.monotonic() < end:
            time.sleep(0.002)
        if not future.done() or future.result() is None or not future.result().values:
            return None
        v = future.result().values[0]
        return {ParameterType.PARAMETER_BOOL: v.bool_value,
                ParameterType.PARAMETER_INTEGER: v.integer_value,
                ParameterType.PARAMETER_DOUBLE: v.double_value,
                ParameterType.PARAMETER_STRING: v.string_value}.get(v.type)

    def find_node(self, name: str) -> Optional[str]:
        """Return the full name of a running node called ``name`` (robot namespace first)."""
        found = [(ns, n) for n, ns in self.robot_node.get_node_names_and_namespaces()
                 if n == name]
        for ns, n in sorted(found, key=lambda x: x[0] != (self.ns or '/')):
            return f"{ns.rstrip('/')}/{n}"
        return None

    def wait_for_goal(self, pending: _Pending, timeout: float) -> Tuple[bool, str]:
        """
        Wait until the goal ends or ``timeout`` [s wall] passes; watch the driver meanwhile.

        :return: (succeeded, reason in words when not)
        """
        deadline = time.monotonic() + timeout
        while not pending.event.wait(0.02):
            if self._torn_down:
                break
            problem = self._driver_problem()
            if problem is not None:
                self.cancel_goal(pending)
                return False, problem
            if time.monotonic() > deadline:
                state = STATUS_NAMES.get(pending.current_status(), 'no status at all')
                self.cancel_goal(pending)
                return False, (f'trajectory_server did not finish goal {_gid(pending)} within '
                               f'{timeout:.1f} s (last status: {state}): is trajectory_server '
                               f"still running under namespace '{self.ns or '/'}'?")
        if pending.status == GoalStatus.STATUS_SUCCEEDED:
            problem = self._driver_problem()
            if problem is not None:
                return False, problem
            return True, ''
        if self._torn_down and pending.status not in TERMINAL:
            return False, 'robot_shutdown() was called during the move'
        state = STATUS_NAMES.get(pending.status, 'UNKNOWN')
        reason = pending.reason or 'see the trajectory_server log'
        duplicates = self.duplicates()
        if duplicates:
            reason += f' ({duplicates})'
        return False, f'goal {_gid(pending)} ended {state}: {reason}'

    def goal_status(self, pending: _Pending) -> str:
        """Return the latest status name of a goal ('NONE' before any)."""
        status = pending.current_status()
        return STATUS_NAMES.get(status, 'NONE') if status is not None else 'NONE'

    def cancel_goal(self, pending: Optional[_Pending] = None, timeout: float = 1.0) -> bool:
        """
        Cancel one goal (or with None every unfinished one of this client) through the action.

        :return: True if the server accepted a cancel
        """
        if pending is not None:
            return self.arm_action.cancel(pending, timeout)
        with self._pending_lock:
            running = [p for p in self._goals.values() if p.status not in TERMINAL]
        accepted = [self.arm_action.cancel(p, timeout) for p in running]   # each one
        return any(accepted)

    def _prune(self, table: dict, keep: int = 200) -> None:
        if len(table) > keep:
            for k in sorted(table)[:len(table) - keep]:
                del table[k]

    # -------------------------------------------------------------------- IK
    def request_ik(self, T_sd: np.ndarray, orientation_free: bool = False,
                   timeout: float = 5.0) -> IkReply:
        """
        Ask ik_service for the joints that put the end effector at T_sd (4, 4) [m].

        :param orientation_free: position-only IK (all-zero quaternion)
        :raises InterbotixException: ik_service is missing or did not answer within timeout
        """
        if not self.srv_ik.service_is_ready():
            raise InterbotixException(
                f"no ik_service serves '{self.topic('compute_ik')}': is ik_service "
                f"running under namespace '{self.ns or '/'}'?")
        req = ComputeIK.Request()
        req.target.header.stamp = self.new_stamp()
        req.target.header.frame_id = self._base_frame_id()
        req.target.pose = matrix_to_pose(np.asarray(T_sd, dtype=float))
        if orientation_free:
            o = req.target.pose.orientation
            o.x = o.y = o.z = o.w = 0.0
        res = self._call_ik(self.srv_ik, req, timeout,
                            f'IK request {stamp_id(req.target.header.stamp)}')
        values = {'method': res.method, 'iterations': str(res.iterations),
                  'position_error': f'{res.position_error:.6g}',
                  'orientation_error': f'{res.orientation_error:.6g}',
                  'num_solutions': str(res.num_solutions)}
        sol = res.solution
        q = None
        if len(sol.position) > 0:
            by_name = dict(zip(sol.name, sol.position))
            try:
                q = np.array([by_name[j] for j in self.model.joint_names], dtype=float)
            except KeyError:
                q = np.array(sol.position, dtype=float)
        return IkReply(q=q, success=bool(res.success) and q is not None, reason=res.message,
                       values=values)

    def _base_frame_id(self) -> str:
        """Return the frame of IK targets: ``<robot_name>/<base frame>``."""
        return f'{self.robot_name}/{self.model.base_frame}' if self.robot_name \
            else self.model.base_frame

    def _call_ik(self, client, request, timeout: float, what: str):
        """Call an ik_service service; raise InterbotixException when no answer comes."""
        response = call_service(client, request, timeout)
        if response is None:
            if self._torn_down:
                raise InterbotixException(f'robot_shutdown() was called during an {what}')
            raise InterbotixException(
                f'ik_service did not answer {what} within {timeout:.1f} s: is ik_service '
                f"still running under namespace '{self.ns or '/'}'?")
        return response

    def request_ik_path(self, poses: Sequence[np.ndarray], timeout: float = 10.0) -> \
            JointTrajectory:
        """
        Ask ik_service for a joint path through Cartesian poses (each seeded by the previous).

        ``compute_cartesian_path``; :attr:`last_path_reason` is why it stopped short ('' when
        every pose was solved).
        :return: the JointTrajectory answer (one point per solved pose)
        :raises InterbotixException: ik_service is missing or did not answer
        """
        if not self.srv_ik_path.service_is_ready():
            raise InterbotixException(
                f"no ik_service serves '{self.topic('compute_cartesian_path')}': is ik_service "
                f"running under namespace '{self.ns or '/'}'?")
        req = ComputeCartesianPath.Request()
        req.waypoints.header.stamp = self.new_stamp()
        req.waypoints.header.frame_id = self._base_frame_id()
        req.waypoints.poses = [matrix_to_pose(np.asarray(T, dtype=float)) for T in poses]
        res = self._call_ik(self.srv_ik_path, req, timeout,
                            f'path request {stamp_id(req.waypoints.header.stamp)}')
        self.last_path_reason = '' if res.success else res.message
        return res.trajectory

    def call_event_topics(self) -> List[str]:
        """Return the service event topics where the servers publish this client's calls."""
        action = self.topic(ARM_ACTION) + '/_action/'
        return [self.topic('compute_ik/_service_event'),
                self.topic('compute_cartesian_path/_service_event')] + [
            action + f'{name}/_service_event' for name in ('send_goal', 'cancel_goal',
                                                           'get_result')]

    def _await_matched(self, pub, timeout: float = 0.5) -> None:
        """
        Wait (at most timeout [s]) until pub has matched every subscriber the graph knows.

        A recorder that just discovered the topic would otherwise miss the message: DDS
        delivers only to readers the writer has matched, and matching trails graph discovery.
        """
        deadline = time.monotonic() + timeout
        while pub.get_subscription_count() < \
                self.robot_node.count_subscribers(pub.topic_name) and \
                time.monotonic() < deadline:
            time.sleep(0.005)

    # ------------------------------------------------------------- setpoints
    def publish_setpoints(self, names: Sequence[str], positions=None, efforts=None,
                          velocities=None) -> None:
        """Publish a JointState setpoint straight to sim_driver (position, velocity or effort)."""
        msg = JointState()
        msg.header.stamp = self.robot_node.get_clock().now().to_msg()
        msg.name = [str(n) for n in names]
        if positions is not None:
            msg.position = [float(v) for v in positions]
        if velocities is not None:
            msg.velocity = [float(v) for v in velocities]
        if efforts is not None:
            msg.effort = [float(v) for v in efforts]
        self._await_matched(self.pub_setpoints)
        self.pub_setpoints.publish(msg)

    # ------------------------------------------------ emulated xs_sdk services
    def _names_of(self, cmd_type: str, name: str) -> List[str]:
        """Return the joints addressed by (cmd_type, name)."""
        g = self.model.gripper
        if cmd_type == 'group':
            if name in ('arm', getattr(self, '_group_name', 'arm')):
                return list(self.model.joint_names)
            if name == 'all':
                return list(self.model.joint_names) + ([g.joint] if g else [])
        elif cmd_type == 'single':
            if name in self.model.joint_names or (g is not None and name == g.joint):
                return [name]
        else:
            raise InterbotixException(f"cmd_type must be 'group' or 'single', not {cmd_type!r}")
        raise InterbotixException(
            f"no {cmd_type} named '{name}' on {self.robot_model} (groups: arm, all; joints: "
            f"{', '.join(self._registers)})")

    def robot_set_operating_modes(self, cmd_type: str, name: str, mode: str,
                                  profile_type: str = 'velocity', profile_velocity: int = 0,
                                  profile_acceleration: int = 0) -> bool:
        """
        Set the operating mode of a group or motor, emulated as xs_sdk does (module docstring).

        'position', 'ext_position', 'current_based_position': positions [rad] through
        trajectory_server; 'velocity': commands in rad/s; 'current': commands in mA, torque
        control through the joint's servo figures (:meth:`servo_of`); 'pwm': commands in PWM units
        (+-885 = full duty). sim_driver switches the joints (parameter
        ``operating_mode.<joint>``) and they hold. Any other mode is refused with the reason and
        its commands are refused with that reason until a supported mode is set (as xs_sdk
        does for a group: it then refuses the group's commands). With profile_type 'time',
        profile_velocity / profile_acceleration [ms]
        set the Profile_Velocity / Profile_Acceleration registers.
        :return: True when applied (Interbotix returns None)
        """
        names = self._names_of(cmd_type, name)
        if mode not in DRIVER_MODES:
            for j in names:  # as xs_sdk's group: commands are refused until a valid mode
                self._modes[j] = (str(mode), profile_type)
            self.get_node().logerror(
                f"Operating mode '{mode}' is not emulated (supported: "
                f"{', '.join(DRIVER_MODES)}): refused. Commands to {cmd_type} '{name}' are "
                'refused (never executed as positions or anything else) until a supported '
                'mode is set; the motors hold in their present control meanwhile.')
            return False
        g = self.model.gripper
        values = {}
        for j in names:
            target = DRIVER_MODES[mode]
            if g is not None and j == g.joint and mode == 'pwm':
                target = ''  # the gripper's default mode takes its PWM as effort [N*m]
            values[f'operating_mode.{j}'] = target
        arm = [j for j in names if g is None or j != g.joint]
        if arm and any(v for k, v in values.items() if k[len('operating_mode.'):] in arm):
            self._cancel_running()  # a running move must not fight the new mode
        node = self._peer_node('commands/joint_setpoints', 'sim_driver')
        problem = (f"no sim_driver on '{self.topic('commands/joint_setpoints')}'"
                   if node is None else self.set_remote_parameters(node, values))
        if problem:
            self.get_node().logerror(f"Operating mode '{mode}' of {cmd_type} '{name}' not set: "
                                     f'{problem}')
            return False
        for j in names:
            self._modes[j] = (mode, profile_type)
            if profile_type == 'time':
                self._registers[j]['Profile_Velocity'] = int(profile_velocity)
                self._registers[j]['Profile_Acceleration'] = int(profile_acceleration)
        return True

    def _cancel_running(self) -> None:
        """Cancel this client's unfinished goals and wait (briefly) for them to end."""
        with self._pending_lock:
            running = [p for p in self._goals.values() if p.status not in TERMINAL]
        for p in running:
            self.cancel_goal(p, timeout=0.5)
        end = time.monotonic() + 1.0
        while any(p.status not in TERMINAL for p in running) and time.monotonic() < end:
            time.sleep(0.01)

    def running_effort_joints(self) -> List[str]:
        """Return the arm joints whose last velocity / current / pwm command is not zero."""
        return [j for j in self.model.joint_names if self._last_effort.get(j, 0.0) != 0.0
                and self.mode_of(j) not in POSITION_MODES]

    def play_out(self, limit: float, still: float = 0.02, hold: float = 0.5) -> str:
        """
        Let a last velocity / current / pwm command of an in-process simulation play out.

        On the real robot such a command keeps the motors going after the script ends; the
        simulation started by this client (bringup) ends with it. Waits until the joints are
        still (|velocity| < ``still`` rad/s for ``hold`` s) or ``limit`` [s]; return what it
        did in one line ('' when nothing was running or no bringup of this client).
        """
        joints = self.running_effort_joints() if self._started_bringup else []
        if not joints or limit <= 0:
            return ''
        modes = sorted({self.mode_of(j) for j in joints})
        q0 = self.joint_positions(joints)
        start = time.monotonic()
        since = start
        while time.monotonic() - start < limit:
            time.sleep(0.05)
            if np.max(np.abs(self._joint_field(joints, 'velocity'))) >= still:
                since = time.monotonic()
            elif time.monotonic() - since >= hold:
                break
        moved = ', '.join(f'{j} {d:+.2f} rad' for j, d in
                          zip(joints, self.joint_positions(joints) - q0))
        return (f"robot_shutdown: the last {'/'.join(modes)} command played out "
                f'{time.monotonic() - start:.1f} s in the simulation ({moved}; limit {limit:g} '
                's: the simulation ends with the script, a real arm keeps going until torque '
                'off)')

    def servo_of(self, joint: str) -> JointServos:
        """Return the DYNAMIXEL(s) of a joint (robot file ``servos``; default XL430-W250)."""
        return self._servos.get(joint, DEFAULT_SERVO)

    def mode_of(self, joint: str) -> str:
        """Return the Interbotix operating mode of a joint ('position', 'current', ...)."""
        return self._modes[joint][0]

    def refused_mode_problem(self, names: Sequence[str]) -> Optional[str]:
        """Return why commands to ``names`` are refused (a refused operating mode), or None."""
        bad = [j for j in names if j in self._modes and self.mode_of(j) not in DRIVER_MODES]
        if not bad:
            return None
        return (f"operating mode '{self.mode_of(bad[0])}' of {', '.join(bad)} was refused "
                '(not emulated): commands are not executed until a supported mode is set '
                "(e.g. robot_set_operating_modes('group', 'arm', 'position'))")

    def _effort_commands(self, names: Sequence[str], commands: Sequence[float]) -> None:
        """
        Send velocity / current / pwm commands (xs_sdk units) of joints in those modes.

        :raises InterbotixException: a command beyond the servo's range (nothing is sent)
        """
        groups: Dict[str, List[Tuple[str, float]]] = {}
        for j, c in zip(names, commands):
            groups.setdefault(self.mode_of(j), []).append((j, float(c)))
        out = []
        for mode, items in groups.items():
            if mode == 'velocity':
                out.append(('velocities', items))
            elif mode == 'current':
                for j, c in items:
                    figures = self.servo_of(j).figures
                    if abs(c) > 1000.0 * figures.stall_current:
                        raise InterbotixException(
                            f"current {c:g} mA for '{j}' exceeds the {figures.model}'s stall "
                            f'current ({1000.0 * figures.stall_current:g} mA): not sent')
                out.append(('efforts', [(j, c / 1000.0 * self.servo_of(j).torque_per_amp)
                                        for j, c in items]))
            elif mode == 'pwm':
                g = self.model.gripper
                for j, c in items:
                    if abs(c) > PWM_LIMIT:
                        raise InterbotixException(f"PWM {c:g} for '{j}' is beyond the PWM "
                                                  f'limit +-{PWM_LIMIT:g}: not sent')
                out.append(('efforts', [
                    (j, pwm_to_effort(c) if g is not None and j == g.joint
                     else c / PWM_LIMIT) for j, c in items]))
        for kind, items in out:
            self.publish_setpoints([j for j, _ in items], **{kind: [v for _, v in items]})
        self._last_effort.update(zip(names, (float(c) for c in commands)))

    def robot_set_motor_pid_gains(self, cmd_type: str, name: str, kp_pos: int, ki_pos: int = 0,
                                  kd_pos: int = 0, k1: int = 0, k2: int = 0, kp_vel: int = 100,
                                  ki_vel: int = 1920) -> None:
        """
        Not emulated: DYNAMIXEL register gains have no SI meaning for sim_driver.

        Logs an error saying how to change the simulated PID gains instead.
        """
        self._names_of(cmd_type, name)
        self.get_node().logerror(
            'robot_set_motor_pid_gains is not emulated: the simulated joints use SI PID gains. '
            f"Set sim_driver's 'gains.<joint>.p|i|d' parameters instead (e.g. ros2 param set "
            f'{self.ns}/sim_driver gains.shoulder.p 20.0).')

    def robot_set_motor_registers(self, cmd_type: str, name: str, reg: str, value: int) -> None:
        """Set a register of a group or motor (emulated: stored and readable back)."""
        for j in self._names_of(cmd_type, name):
            self._registers[j][str(reg)] = int(value)

    def robot_get_motor_registers(self, cmd_type: str, name: str, reg: str) -> List[int]:
        """Return the register's values, one per motor (0 for a register never written)."""
        return [int(self._registers[j].get(str(reg), 0)) for j in self._names_of(cmd_type, name)]

    def robot_get_robot_info(self, cmd_type: str, name: str) -> RobotInfo:
        """
        Return a RobotInfo (limits, sleep positions, joint-state indices) of a group or motor.

        As in Interbotix the gripper motor is described by its left finger (limits in m).
        """
        names = self._names_of(cmd_type, name)
        m, g = self.model, self.model.gripper
        info = RobotInfo(name=['all', 'arm'] if cmd_type == 'group' else [name])
        js = self.js_index_map if hasattr(self, 'js_index_map') else {}
        for j in names:
            if g is not None and j == g.joint:
                finger = g.fingers[0]
                info.joint_names.append(j)
                info.joint_ids.append(m.dof + 1)
                info.joint_lower_limits.append(float(g.finger_lower))
                info.joint_upper_limits.append(float(g.finger_upper))
                info.joint_velocity_limits.append(1.0)
                info.joint_sleep_positions.append(float(
                    math.sqrt(g.arm_length ** 2 - g.horn_radius ** 2)))
                info.joint_state_indices.append(js.get(finger, -1))
            else:
                i = m.joint_index(j)
                info.joint_names.append(j)
                info.joint_ids.append(i + 1)
                info.joint_lower_limits.append(float(m.lower[i]))
                info.joint_upper_limits.append(float(m.upper[i]))
                info.joint_velocity_limits.append(float(m.velocity_limits[i]))
                info.joint_sleep_positions.append(float(m.sleep[i]))
                info.joint_state_indices.append(js.get(j, -1))
        info.num_joints = len(info.joint_names)
        info.mode, info.profile_type = self._modes[names[0]]
        return info

    def robot_torque_enable(self, cmd_type: str, name: str, enable: bool,
                            timeout: float = 3.0) -> bool:
        """
        Torque motors on or off: one joint ('single'), a group ('arm') or everything ('all').

        Sets sim_driver's ``torque_enable.<joint>`` parameters, so only the addressed joints
        change (``robot_torque_enable('single', 'gripper', False)`` leaves the arm holding);
        a joint switched back on holds where it is (call the arm's capture_joint_positions()
        afterwards, as with Interbotix). Returns True when sim_driver applied it.
        """
        names = self._names_of(cmd_type, name)
        node = self._peer_node('commands/joint_setpoints', 'sim_driver')
        if node is None:
            self.get_node().logerror(
                f"Failed to find sim_driver on '{self.topic('commands/joint_setpoints')}'. Is "
                f"sim_driver running under namespace '{self.ns or '/'}'?")
            return False
        problem = self.set_remote_parameters(
            node, {f'torque_enable.{j}': bool(enable) for j in names}, timeout)
        if problem:
            self.get_node().logerror(f"Torque {'on' if enable else 'off'} of {cmd_type} "
                                     f"'{name}' failed: {problem}")
            return False
        return True

    def robot_reboot_motors(self, cmd_type: str, name: str, enable: bool,
                            smart_reboot: bool = False) -> None:
        """Reboot motors (emulated: simulated servos have no error state; torque set to enable)."""
        self._names_of(cmd_type, name)
        self.get_node().loginfo(
            f"Reboot of {cmd_type} '{name}' emulated: simulated servos never enter an error "
            'state.')
        self.robot_torque_enable(cmd_type, name, enable)

    def robot_reset(self, timeout: float = 3.0) -> bool:
        """Put the simulation back at the sleep pose through sim_driver's ``reset`` service."""
        if not self.srv_reset.wait_for_service(timeout_sec=timeout):
            self.get_node().logerror(f"Failed to find service '{self.topic('reset')}'.")
            return False
        return self._call(self.srv_reset, Trigger.Request(), timeout)

    def _call(self, client, request, timeout: float) -> bool:
        future = client.call_async(request)
        end = time.monotonic() + timeout
        while not future.done() and time.monotonic() < end:
            time.sleep(0.005)
        if not future.done():
            self.get_node().logerror(f"Service '{client.srv_name}' did not answer within "
                                     f'{timeout:.1f} s.')
            return False
        res = future.result()
        if res is not None and not res.success:
            self.get_node().logwarn(f"Service '{client.srv_name}': {res.message}")
        return bool(res is not None and res.success)

    def robot_write_commands(self, group_name: str, commands: Sequence[float]) -> None:
        """
        Command a group (non-blocking), like JointGroupCommand, in the group's operating mode.

        Position modes: positions [rad]; the move lasts the Profile_Velocity register [ms]
        (time profile) with Profile_Acceleration [ms] ramps, through trajectory_server.
        Velocity: rad/s; current: mA; pwm: PWM units (see robot_set_operating_modes).
        """
        names = self._names_of('group', group_name)
        cmds = [float(c) for c in commands]
        if len(cmds) != len(names):
            self.get_node().logerror(
                f'Number of commands ({len(cmds)}) does not match the number of joints in group '
                f"'{group_name}' ({len(names)}). Will not execute.")
            return
        bad = next((f'command {i} ({names[i]}) is {c}' for i, c in enumerate(cmds)
                    if not math.isfinite(c)), None) or self.refused_mode_problem(names)
        if bad:
            self.get_node().logerror(f'{bad}. Will not execute.')
            return
        g = self.model.gripper
        moded = [(n, c) for n, c in zip(names, cmds) if self.mode_of(n) not in POSITION_MODES
                 and (g is None or n != g.joint)]
        if moded:
            try:
                self._effort_commands([n for n, _ in moded], [c for _, c in moded])
            except InterbotixException as exc:
                self.get_node().logerror(f'{exc}. Will not execute.')
                return
        arm = [(n, c) for n, c in zip(names, cmds) if (g is None or n != g.joint)
               and self.mode_of(n) in POSITION_MODES]
        if g is not None and g.joint in names:
            self.robot_write_joint_command(g.joint, cmds[names.index(g.joint)])
        if arm:
            self._write_positions([n for n, _ in arm], [c for _, c in arm])

    def _profile_times(self, joint: str) -> Tuple[float, float]:
        """Return the (moving_time, accel_time) [s] of a joint's time-profile registers."""
        regs = self._registers[joint]
        mt = max(regs.get('Profile_Velocity', 2000), 0) / 1000.0
        at = max(regs.get('Profile_Acceleration', 300), 0) / 1000.0
        return mt, min(at, mt / 2)

    def _write_positions(self, names: List[str], positions: List[float]) -> bool:
        """
        Move arm joints to positions [rad] in their Profile_Velocity time (non-blocking).

        A profile too short for the joints' velocity limits (0 = no profile) is stretched to
        the shortest feasible move, as the servos cap their speed; positions outside the
        joint limits are refused. Every refusal is logged; returns True when the goal was sent.
        """
        for j, c in zip(names, positions):
            i = self.model.joint_index(j)
            if not float(self.model.lower[i]) - 1e-9 <= c <= float(self.model.upper[i]) + 1e-9:
                self.get_node().logerror(
                    f"position {c:.4f} rad for '{j}' is outside its limits "
                    f'[{float(self.model.lower[i]):.4f}, {float(self.model.upper[i]):.4f}]. '
                    'Will not execute.')
                return False
        mt, at = self._profile_times(names[0])
        if mt <= 0.0:
            at = MIN_MOVE_TIME / 2.0  # no profile: short ramps at the velocity limits
        idx = [self.model.joint_index(j) for j in names]
        vmax = np.asarray(self.model.velocity_limits, dtype=float)[idx]
        try:
            here = self.joint_positions(names)
            # a move that starts while the arm moves blends the present velocity in, which
            # raises the peak by up to a third of it (trajectory_server's plan_move)
            vmax = np.maximum(0.25 * vmax, vmax - np.abs(self._joint_field(names, 'velocity'))
                              / 2.5)
        except InterbotixException:
            here = np.asarray(positions, dtype=float)
        duration = feasible_duration(np.asarray(positions) - here, vmax, mt, at)
        if mt > 0.0 and duration > mt + 1e-9:
            self.get_node().logwarn(
                f'A {mt:.2f} s move (Profile_Velocity {int(mt * 1000)} ms) of '
                f"{', '.join(names)} exceeds the joint velocity limits: it takes "
                f'{duration:.2f} s (the servos would cap the speed the same way).')
        at = min(at, duration / 2.0)
        try:
            self.send_trajectory(names, [positions], [duration], at)
        except InterbotixException as exc:
            self.get_node().logerror(f'{exc}. Will not execute.')
            return False
        return True

    def robot_write_joint_command(self, joint_name: str, command: float) -> None:
        """
        Command one motor (non-blocking), like JointSingleCommand, in its operating mode.

        Gripper in pwm mode: ``command`` is PWM, sent as an effort setpoint [N*m]
        (:func:`~px100_control.client.gripper.pwm_to_effort`); current: mA; position: rad. An
        arm joint in a position mode moves through trajectory_server; velocity / current / pwm
        as robot_write_commands.
        """
        names = self._names_of('single', joint_name)
        problem = (f"command for '{joint_name}' is {command}"
                   if not math.isfinite(float(command)) else self.refused_mode_problem(names))
        if problem:
            self.get_node().logerror(f'{problem}. Will not execute.')
            return
        g = self.model.gripper
        mode = self.mode_of(names[0])
        if g is not None and names[0] == g.joint:
            if mode in POSITION_MODES:
                self.publish_setpoints([g.joint], positions=[float(command)])
                return
            try:
                if mode == 'pwm' and abs(float(command)) > PWM_LIMIT:
                    raise InterbotixException(f'PWM {command} for the gripper is beyond the PWM '
                                              f'limit +-{PWM_LIMIT:g}')
                if mode == 'pwm':
                    self.publish_setpoints([g.joint], efforts=[pwm_to_effort(float(command))])
                else:
                    self._effort_commands([g.joint], [float(command)])
            except InterbotixException as exc:
                self.get_node().logerror(f'{exc}. Will not execute.')
                return
            if mode in ('pwm', 'current'):  # for Ctrl-C (_interrupt_gripper)
                self._gripper_effort, self._gripper_effort_at = float(command), time.monotonic()
            return
        if mode not in POSITION_MODES:
            try:
                self._effort_commands([joint_name], [float(command)])
            except InterbotixException as exc:
                self.get_node().logerror(f'{exc}. Will not execute.')
            return
        self._write_positions([joint_name], [float(command)])

    def robot_write_trajectory(self, cmd_type: str, name: str, traj_type: str = None,
                               raw_traj: Sequence[dict] = None, *,
                               type: str = None) -> None:  # noqa: A002 - ROS 1 name
        """
        Command a position trajectory (non-blocking).

        :param traj_type: 'position' (ROS 1 scripts pass it as ``type=``)
        :param raw_traj: list of ``{t [s]: [positions]}``; a point at t = 0 is taken as the
            start and skipped (trajectory_server starts from the measured state)
        """
        if traj_type is None:
            traj_type = type
        if traj_type is None or raw_traj is None:
            raise TypeError('robot_write_trajectory() needs traj_type (or type=) and raw_traj')
        names = self._names_of(cmd_type, name)
        problem = self.refused_mode_problem(names)
        if problem:
            self.get_node().logerror(f'{problem}. Will not execute.')
            return
        if traj_type != 'position':
            self.get_node().logerror(
                f"traj_type '{traj_type}' is not emulated: trajectory_server executes position "
                'trajectories only.')
            return
        pts, times = [], []
        for point in raw_traj:
            for t, values in point.items():
                if float(t) <= 0.0:
                    continue
                pts.append(list(values))
                times.append(float(t))
        if not pts:
            self.get_node().logerror('Trajectory has no point after t = 0. Aborting...')
            return
        try:
            self.send_trajectory(names, pts, times)
        except InterbotixException as exc:
            self.get_node().logerror(f'{exc}. Will not execute.')

    def robot_get_joint_states(self) -> JointState:
        """Return a copy of the latest JointState (position, velocity, effort of every joint)."""
        with self.js_mutex:
            return copy.deepcopy(self.joint_states)

    def robot_get_single_joint_state(self, name: str) -> dict:
        """Return {'position', 'velocity', 'effort'} of one joint (rad, rad/s, N*m)."""
        with self.js_mutex:
            js = copy.deepcopy(self.joint_states)
        try:
            i = list(js.name).index(name)
        except ValueError:
            raise InterbotixException(f"joint '{name}' is not in the joint states "
                                      f'({list(js.name)})') from None

        def at(values):
            return float(values[i]) if i < len(values) else float('nan')
        return {'position': at(js.position), 'velocity': at(js.velocity),
                'effort': at(js.effort)}


def _time_of(key: Tuple[int, int]) -> Time:
    return Time(sec=int(key[0]), nanosec=int(key[1]))


def _gid(pending: _Pending) -> str:
    """Return a goal's name in messages: its action goal id (the server logs the same)."""
    return pending.label or 'not yet accepted'


def _duration(t: float) -> DurationMsg:
    sec = int(math.floor(t))
    return DurationMsg(sec=sec, nanosec=int(round((t - sec) * 1e9)) % 1_000_000_000)


def _parameter_value(value) -> ParameterValue:
    """Return the rcl_interfaces ParameterValue of a bool, int, float or str."""
    if isinstance(value, bool):
        return ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
    if isinstance(value, int):
        return ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=value)
    if isinstance(value, float):
        return ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
    return ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=str(value))
