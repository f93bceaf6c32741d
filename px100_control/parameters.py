"""
The parameters of every px100_control node: one schema per node, the single source of defaults.

Each node's parameters with their type, default, range, description and read-only flag, and the
groups a node declares per joint (sim_driver's ``gains.<joint>.<field>``,
``torque_enable.<joint>``, ``operating_mode.<joint>``). The ROS adapter
(:mod:`px100_control.ros.parameter_schema`) turns a schema into ParameterDescriptors (``ros2
param describe`` shows them); ``--help`` prints :meth:`NodeSchema.help_text`;
:func:`check_params_file` validates a ``--params-file`` YAML. The engines' own checks
(goal_executor, ik_requests, sim.driver_parameters, viewer.controls) take their bounds from here
(:meth:`ParamSpec.bounds`, :func:`bound_error`), so a range is written once.

Pure data and checks: no rclpy, no project imports. Units: SI.
"""
from dataclasses import dataclass, replace
import math
from typing import Any, Dict, Iterable, List, Optional, Tuple

import yaml

INF = math.inf


@dataclass(frozen=True)
class ParamSpec:
    """
    One parameter: name, default, meaning, type and the values it takes.

    :param kind: 'double', 'integer', 'bool', 'string' or 'double_array'
    :param default: the default; None when the node computes it (``default_doc`` says how)
    :param low, high: inclusive range of a number (None: unbounded on that side)
    :param above_low: the value must be strictly greater than ``low``
    :param allow_inf: +inf is accepted besides the range (e.g. real_time_factor)
    :param choices: the allowed strings
    :param read_only: fixed once the node started (``ros2 param set`` is refused)
    :param accepts_integer: a 'double' that may also be given as an integer (register values;
        ROS: dynamic typing, the range set for both types)
    """

    name: str
    kind: str
    default: Any
    description: str
    low: Optional[float] = None
    high: Optional[float] = None
    above_low: bool = False
    allow_inf: bool = False
    choices: Tuple[str, ...] = ()
    read_only: bool = False
    default_doc: str = ''
    accepts_integer: bool = False

    def constraints(self) -> str:
        """Return the allowed values in words ('' when any value of the type is)."""
        if self.choices:
            return 'one of ' + ', '.join(c or "''" for c in self.choices)
        if self.low is None and self.high is None:
            return ''
        lo = '' if self.low is None else f'{self.low:g} {"<" if self.above_low else "<="} '
        hi = '' if self.high is None or self.high == INF else f' <= {self.high:g}'
        text = f'{lo}value{hi}'
        return text + (' or inf' if self.allow_inf else '')

    def bounds(self) -> str:
        """
        Return the range of a number in words: '> 0', 'an integer >= 1 and <= 100000'.

        For the engines' messages ('<name> must be <bounds>'); '' when unbounded.
        """
        words = []
        if self.low is not None:
            words.append(f'{">" if self.above_low else ">="} {self.low:g}')
        if self.high is not None and self.high != INF:
            words.append(f'<= {self.high:g}')
        text = ' and '.join(words) + (' (or inf)' if self.allow_inf and words else '')
        return f'an integer {text}'.strip() if self.kind == 'integer' else text

    def check(self, value) -> Optional[str]:
        """Return why ``value`` is not valid for this parameter (None when it is)."""
        if self.kind == 'bool':
            if isinstance(value, bool):
                return None
            return f'{self.name} must be true or false, not {value!r}'
        if self.kind == 'string':
            if not isinstance(value, str):
                return f'{self.name} must be a string, not {value!r}'
            if self.choices and value not in self.choices:
                return f'{self.name} must be {self.constraints()}, not {value!r}'
            return None
        if self.kind == 'double_array':
            if not isinstance(value, (list, tuple)) or not all(
                    isinstance(x, (int, float)) and not isinstance(x, bool)
                    and math.isfinite(x) for x in value):
                return f'{self.name} must be a list of finite numbers, not {value!r}'
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f'{self.name} must be a number, not {value!r}'
        if self.kind == 'integer' and not isinstance(value, int):
            return f'{self.name} must be an integer, not {value!r}'
        if math.isnan(value):
            return f'{self.name} must be a number, not nan'
        if value == INF and self.allow_inf:
            return None
        if math.isinf(value) and not (self.high == INF and value > 0):
            return f'{self.name} must be finite, not {value!r}'
        if self.low is not None and (value <= self.low if self.above_low else value < self.low):
            return f'{self.name} = {value!r} is not {self.constraints()}'
        if self.high is not None and value > self.high:
            return f'{self.name} = {value!r} is not {self.constraints()}'
        return None

    def help_line(self) -> str:
        """Return the --help entry: name, type, default, constraints, flags, description."""
        default = self.default_doc or _fmt(self.default)
        extra = [self.constraints()] if self.constraints() else []
        if self.read_only:
            extra.append('read-only')
        tail = f' [{"; ".join(extra)}]' if extra else ''
        kind = f'{self.kind} or integer' if self.accepts_integer else self.kind
        return f'  {self.name} ({kind}, default {default}){tail}\n      {self.description}'


def _fmt(value) -> str:
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return repr(value)
    return str(value)


@dataclass(frozen=True)
class ParamGroup:
    """
    Parameters a node declares per joint of its robot.

    Named ``<prefix><joint>`` or, with ``fields``, ``<prefix><joint>.<field>``.

    :param spec: type, default, range and description of every member; its name is the pattern
        (``gains.<joint>.<field>``), a member's spec is it renamed (:meth:`member`)
    :param fields: the field names (empty: one parameter per joint)
    """

    prefix: str
    spec: ParamSpec
    fields: Tuple[str, ...] = ()

    def matches(self, name: str) -> bool:
        """Return True when ``name`` is under this group's prefix."""
        return name.startswith(self.prefix)

    def member(self, name: str) -> ParamSpec:
        """Return the spec of the member ``name`` (e.g. ``gains.waist.p``)."""
        return replace(self.spec, name=name)

    def check(self, name: str, value) -> Optional[str]:
        """Return why name := value is not valid (the name's shape, then the value)."""
        parts = name[len(self.prefix):].split('.')
        shape = (len(parts) == 2 and parts[1] in self.fields) if self.fields else len(parts) == 1
        if not shape or not parts[0]:
            fields = f" with field one of {', '.join(self.fields)}" if self.fields else ''
            return f'{name}: {self.prefix[:-1]} are {self.spec.name}{fields}'
        return self.member(name).check(value)

    def help_line(self) -> str:
        """Return the --help entry of the group (as a parameter's, fields listed)."""
        line = self.spec.help_line()
        return line + (f"\n      <field>: {', '.join(self.fields)}" if self.fields else '')


@dataclass(frozen=True)
class NodeSchema:
    """
    The parameters of one node.

    :param groups: the parameters the node declares per joint of its robot (:class:`ParamGroup`)
    """

    node: str
    params: Tuple[ParamSpec, ...]
    groups: Tuple[ParamGroup, ...] = ()

    def get(self, name: str) -> Optional[ParamSpec]:
        """Return the spec named ``name``, a group member's included (None: no such parameter)."""
        for p in self.params:
            if p.name == name:
                return p
        for g in self.groups:
            if g.matches(name):
                return g.member(name)
        return None

    def group(self, prefix: str) -> ParamGroup:
        """Return the group of ``prefix`` (``'gains.'``)."""
        for g in self.groups:
            if g.prefix == prefix:
                return g
        raise KeyError(f'{self.node} has no parameter group {prefix!r}')

    def __getitem__(self, name: str) -> ParamSpec:
        """Return the spec named ``name``."""
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(f'{self.node} has no parameter {name!r}')

    @property
    def names(self) -> List[str]:
        """List the parameter names, groups excluded."""
        return [p.name for p in self.params]

    def defaults(self) -> Dict[str, Any]:
        """Return the fixed defaults, {name: default} (computed ones left out)."""
        return {p.name: p.default for p in self.params if p.default is not None}

    def check(self, name: str, value) -> Optional[str]:
        """Return why name := value is not valid (None when it is)."""
        for p in self.params:
            if p.name == name:
                return p.check(value)
        for g in self.groups:
            if g.matches(name):
                return g.check(name, value)
        if name in FRAMEWORK_PARAMETERS:
            return FRAMEWORK_PARAMETERS[name].check(value)
        return f"{self.node} has no parameter '{name}'"

    def help_text(self) -> str:
        """Return the parameter section of ``--help``."""
        lines = [f'parameters of {self.node} (--ros-args -p name:=value, --params-file FILE; '
                 'ros2 param describe shows the same):']
        lines += [p.help_line() for p in self.params]
        lines += [g.help_line() for g in self.groups]
        return '\n'.join(lines)


#: parameters every ROS node has (declared by rclpy itself)
FRAMEWORK_PARAMETERS = {
    'use_sim_time': ParamSpec('use_sim_time', 'bool', False,
                              'follow /clock instead of the system clock (rclpy)'),
}

COMMON = (
    ParamSpec('robot_model', 'string', 'px100',
              'robot description to load: config/robots/<robot_model>.yaml', read_only=True),
    ParamSpec('robot_name', 'string', None,
              'tf frame prefix (<robot_name>/base_link); a node started without a namespace '
              'takes /<robot_name>', read_only=True,
              default_doc="the node's namespace, else 'px100'"),
)

#: gain fields of sim_driver's gains.<joint>.<field> and their meaning
GAIN_FIELDS_DOC = {
    'p': 'N*m/rad', 'i': 'N*m/(rad*s)', 'd': 'N*m*s/rad', 'i_clamp': 'N*m', 'u_clamp': 'N*m',
    'ff_velocity': 'N*m*s/rad',
}

#: values of sim_driver's operating_mode.<joint> ('' = the joint's default)
OPERATING_MODES = ('', 'position', 'velocity', 'torque', 'duty')

SIM_DRIVER = NodeSchema('sim_driver', COMMON + (
    ParamSpec('publish_rate', 'double', 100.0, 'joint_states / ee_pose rate [Hz]; at most '
              'control_rate', low=0.1, high=1000.0),
    ParamSpec('control_rate', 'double', 1000.0, 'physics and PID rate [Hz]',
              low=10.0, high=100000.0),
    ParamSpec('real_time_factor', 'double', 1.0, 'simulated s per wall s; != 1 runs on its own '
              'clock and publishes /clock; 0 or inf = as fast as possible', low=0.0, high=1e6,
              allow_inf=True),
    ParamSpec('publish_clock', 'bool', False, 'own the clock and publish /clock (also when '
              'real_time_factor = 1)', read_only=True),
    ParamSpec('clock_rate', 'double', 250.0, '/clock rate in simulated time [Hz]',
              low=1.0, high=10000.0),
    ParamSpec('dynamics_divider', 'integer', 4, 'ignored, kept for compatibility (MuJoCo '
              'evaluates every step)', low=1, high=1000),
    ParamSpec('object_width', 'double', 0.0, 'width of an object between the fingers [m], '
              '0 = none', low=0.0, high=10.0),
    ParamSpec('world_rate', 'double', 30.0, 'world/markers rate [Hz]', low=0.1, high=1000.0),
    ParamSpec('scene', 'string', 'auto', 'scene of objects: a name in config/scenes, a '
              "path to a .yaml, '' = no objects, 'auto' = the robot file's scene (px100: "
              "pick_place; none for robots without one). A bad one is refused with the loader's "
              'reason'),
    ParamSpec('gains_units', 'string', 'si', "units of gains.*: 'si' or 'dynamixel' (p/i/d as "
              'the XL430 Position P/I/D Gain registers)', choices=('si', 'dynamixel'),
              read_only=True),
), groups=(
    ParamGroup('gains.', ParamSpec(
        'gains.<joint>.<field>', 'double', None, 'PID gains of each arm joint and the gripper, '
        'SI (p N*m/rad, i N*m/(rad*s), d N*m*s/rad, i_clamp N*m, u_clamp N*m, ff_velocity '
        "N*m*s/rad) or, with gains_units 'dynamixel', p/i/d as the XL430 registers", low=0.0,
        accepts_integer=True, default_doc="the servo's gains scaled to the joint"),
        fields=tuple(GAIN_FIELDS_DOC)),
    ParamGroup('torque_enable.', ParamSpec(
        'torque_enable.<joint>', 'bool', True, "torque of the joint's servo on (false: it "
        'coasts); the torque_enable service sets all, reset turns all on')),
    ParamGroup('operating_mode.', ParamSpec(
        'operating_mode.<joint>', 'string', '', 'what commands/joint_setpoints carries for the '
        "joint: '' (default: position; the gripper takes position or effort), position [rad], "
        'velocity [rad/s], torque [N*m] or duty [-1, 1]; a change makes the joint hold',
        choices=OPERATING_MODES)),
))

IK_METHODS = ('auto', 'analytic', 'dls', 'newton')

IK_SERVICE = NodeSchema('ik_service', COMMON + (
    ParamSpec('orientation_mode', 'string', 'pitch', "'pitch': position + pitch, the "
              "unreachable roll/yaw named in the reply; 'strict': the whole pose or refused",
              choices=('pitch', 'strict')),
    ParamSpec('orientation_tolerance', 'double', 1e-3, 'pitch mode: dropped roll/yaw above '
              'this is named in the reply message [rad]', low=0.0, above_low=True),
    ParamSpec('method', 'string', 'auto', 'IK method: auto (closed form, iterative fallback), '
              'analytic, dls, newton', choices=IK_METHODS),
    ParamSpec('tol_position', 'double', 1e-9, 'position tolerance of a solution [m]',
              low=0.0, above_low=True),
    ParamSpec('tol_orientation', 'double', 1e-9, 'orientation tolerance of a solution [rad]',
              low=0.0, above_low=True),
    ParamSpec('max_iterations', 'integer', 200, 'iterations per start of an iterative method',
              low=1, high=2**31 - 1),
    ParamSpec('nominal_pose', 'double_array', None, 'secondary-task target and seed before any '
              'joint_states [rad], one value per arm joint',
              default_doc="the robot's home pose"),
    ParamSpec('max_path_joint_velocity', 'double', 1.0, 'compute_cartesian_path timing: points '
              'are spaced so no joint moves faster than this [rad/s] (and no faster than its URDF '
              'velocity limit)', low=0.0, above_low=True),
    ParamSpec('min_path_point_time', 'double', 0.01, 'compute_cartesian_path timing: shortest '
              'time between two points [s]', low=0.0),
))

TRAJECTORY_PROFILES = ('trapezoidal', 'minimum_jerk', 'linear_max_step')

TRAJECTORY_SERVER = NodeSchema('trajectory_server', COMMON + (
    ParamSpec('rate', 'double', 200.0, 'setpoints to the driver [Hz]; fixed at start (the '
              'setpoint timer and the goals planned on its period)', low=0.0, above_low=True,
              high=10000.0, read_only=True),
    ParamSpec('profile', 'string', 'trapezoidal', 'profile of a one-point goal',
              choices=TRAJECTORY_PROFILES),
    ParamSpec('moving_time', 'double', 2.0, 'duration of a one-point goal whose '
              'time_from_start is 0 [s]', low=0.0, above_low=True),
    ParamSpec('accel_time', 'double', 0.3, 'trapezoidal ramp time [s], clipped to '
              'moving_time / 2', low=0.0),
    ParamSpec('max_joint_step', 'double', 0.01, 'linear_max_step: largest joint step between '
              'setpoints [rad]', low=0.0, above_low=True),
    ParamSpec('state_timeout', 'double', 1.0, 'abort a goal when joint_states stop for this '
              'long [s]', low=0.0, above_low=True),
    ParamSpec('hold_after', 'double', 0.25, 'pause a goal (no setpoints, its clock stopped) '
              "while joint_states are older than this [s]; longer than the driver's publish "
              'period', low=0.05),
    ParamSpec('path_tolerance', 'double', 0.2, 'abort when a joint is this far from its '
              'setpoints [rad]', low=0.0, above_low=True),
    ParamSpec('path_window', 'double', 0.2, 'a measurement may lag its setpoints by this much '
              '[s]', low=0.0),
    ParamSpec('goal_tolerance', 'double', 0.002, 'success when every joint is this close to '
              'the end [rad]', low=0.0, above_low=True),
    ParamSpec('goal_time_tolerance', 'double', 1.0, 'time allowed after the trajectory to '
              'settle [s]', low=0.0),
    ParamSpec('stop_deceleration', 'double', 10.0, 'deceleration of a canceled goal '
              '[rad/s^2]', low=0.0, above_low=True),
    ParamSpec('start_tolerance', 'double', 0.05, 'a first point at t = 0 must be this close to '
              'the start [rad]', low=0.0),
    ParamSpec('action_monitor_rate', 'double', 20.0, 'feedback rate of the '
              'arm_controller/follow_joint_trajectory and gripper_controller/gripper_cmd '
              'actions [Hz] (read at start)', low=0.1, high=1000.0, read_only=True),
    ParamSpec('gripper_goal_tolerance', 'double', 0.002, 'gripper_cmd: reached when the '
              'finger position is this close to the goal [m]', low=0.0, above_low=True),
    ParamSpec('gripper_stall_velocity_threshold', 'double', 0.001, 'gripper_cmd: the fingers '
              'count as stopped below this speed [m/s]', low=0.0),
    ParamSpec('gripper_stall_timeout', 'double', 1.0, 'gripper_cmd: stopped this long short of '
              'the goal = stalled [s]', low=0.0, above_low=True),
    ParamSpec('gripper_allow_stalling', 'bool', True, 'gripper_cmd: a stall (the fingers closed '
              'on an object) ends SUCCEEDED; false: ABORTED (both report stalled)'),
))

VIEWER = NodeSchema('viewer', COMMON + (
    ParamSpec('host', 'string', '127.0.0.1', 'address the web server binds (not loopback: '
              'read-only unless allow_remote_control)', read_only=True),
    ParamSpec('port', 'integer', 8080, 'web server port', low=1, high=65535, read_only=True),
    ParamSpec('read_only', 'bool', False, 'show the robot only: no sliders, buttons or gizmo',
              read_only=True),
    ParamSpec('allow_remote_control', 'bool', False, 'keep the controls when host is not '
              'loopback', read_only=True),
    ParamSpec('rate', 'double', 30.0, 'page update rate [Hz]', low=1.0, high=60.0,
              read_only=True),
    ParamSpec('trail_length', 'integer', 500, 'end-effector trail points kept', low=2,
              high=100000, read_only=True),
    ParamSpec('moving_time', 'double', 1.0, 'shortest duration of a move sent by a control '
              '[s]', low=0.0, above_low=True),
))
_SCENE_CAMERA = "the scene's camera block, else the D415 default"
CAMERA = NodeSchema('camera', COMMON + (
    ParamSpec('enable', 'bool', True, 'render and publish (false: the camera is off)'),
    ParamSpec('scene', 'string', 'auto', 'scene whose camera block gives the defaults below: '
              "as sim_driver's scene ('auto' = the robot file's scene, '' = none)",
              read_only=True),
    ParamSpec('position', 'double_array', None, 'camera position in the base frame [m], 3 '
              'values', default_doc=_SCENE_CAMERA + ' [0.18, 0.0, 0.6]'),
    ParamSpec('look_at', 'double_array', None, 'point the optical axis goes through, base '
              'frame [m], 3 values', default_doc=_SCENE_CAMERA + ' [0.15, 0.0, 0.0]'),
    ParamSpec('width', 'integer', None, 'image width [px]', low=16, high=4096,
              default_doc=_SCENE_CAMERA + ' 640'),
    ParamSpec('height', 'integer', None, 'image height [px]', low=16, high=4096,
              default_doc=_SCENE_CAMERA + ' 480'),
    ParamSpec('fovy', 'double', None, 'vertical field of view [rad]', low=math.radians(5),
              high=math.radians(150), default_doc=_SCENE_CAMERA + ' 0.743365 (42.6 deg)'),
    ParamSpec('rate', 'double', None, 'frame rate [Hz] (a timer on the node clock)', low=0.0,
              above_low=True, high=60.0, default_doc=_SCENE_CAMERA + ' 5.0'),
    ParamSpec('depth_min', 'double', None, 'nearest depth with a return [m]', low=0.0,
              above_low=True, high=100.0, default_doc=_SCENE_CAMERA + ' 0.16'),
    ParamSpec('depth_max', 'double', None, 'farthest depth with a return [m]', low=0.0,
              above_low=True, high=100.0, default_doc=_SCENE_CAMERA + ' 3.0'),
    ParamSpec('subpixel', 'double', None, 'stereo disparity noise RMS [px] (0: noise-free '
              'depth)', low=0.0, high=10.0, default_doc=_SCENE_CAMERA + ' 0.08'),
    ParamSpec('baseline', 'double', None, 'stereo baseline [m]', low=0.0, above_low=True,
              high=1.0, default_doc=_SCENE_CAMERA + ' 0.055'),
    ParamSpec('seed', 'integer', 0, 'seed of the depth noise', low=0, high=2**31 - 1,
              read_only=True),
    ParamSpec('armtag', 'bool', True, 'render the ArmTag (tag36h11 id 5) on the gripper'),
    ParamSpec('publish_pose', 'bool', True, "publish camera_link's pose in the base frame on "
              '/tf_static (false: only camera_link -> optical frame, as a RealSense driver; '
              "the client's InterbotixArmTagInterface then locates the arm)", read_only=True),
))
RECORDER = NodeSchema('recorder', COMMON)
REPLAYER = NodeSchema('replayer', COMMON)
STATE_PUBLISHER = NodeSchema('robot_state_publisher', (
    COMMON[1],
    ParamSpec('publish_frequency', 'double', 20.0, 'largest rate of the joints on /tf, in '
              'joint_states stamps [Hz] (as robot_state_publisher; 0: every joint_states)',
              low=0.0),
))

#: range of a crop box bound [m] (a camera sees a few metres)
CROP_LIMIT = 10.0

PC_FILTER = NodeSchema('pointcloud_pipeline', (
    ParamSpec('robot_name', 'string', 'px100', 'robot whose camera cloud is filtered: the '
              'default cloud_topic is /<robot_name>/camera/depth/color/points', read_only=True),
    ParamSpec('cloud_topic', 'string', '', "PointCloud2 to filter; '' = "
              '/<robot_name>/camera/depth/color/points', read_only=True),
    ParamSpec('cloud_reliability', 'string', 'reliable', "the cloud subscription's "
              "reliability: 'reliable' (realsense2_camera's and this camera's default; a "
              'best-effort cloud of several MB is lost whole when one fragment is) or '
              "'best_effort' (for a camera that publishes best effort, e.g. with the "
              'sensor-data profile)', read_only=True, choices=('reliable', 'best_effort')),
    ParamSpec('enable_pipeline', 'bool', False, 'filter every cloud as it arrives (false, as '
              "Interbotix's pc_filter launch file: only when get_cluster_positions is called); "
              'the enable_pipeline service sets it'),
    ParamSpec('cluster_position', 'string', 'centroid', "what a cluster's position is: "
              "'centroid' (of its points, as Interbotix) or 'top_face' (the centre of its top "
              'face, not pulled toward the camera by the sides it sees)',
              choices=('centroid', 'top_face')),
) + tuple(ParamSpec(f'{axis}_filter_{end}', 'double', default, f'crop box {end} {axis} in the '
                    'cloud frame [m]', low=-CROP_LIMIT, high=CROP_LIMIT)
          for axis, lo, hi in (('x', -0.25, 0.25), ('y', -0.25, 0.25), ('z', 0.25, 0.75))
          for end, default in (('min', lo), ('max', hi))) + (
    ParamSpec('voxel_leaf_size', 'double', 0.004, 'voxel grid cell edge [m]', low=1e-4,
              high=0.1),
    ParamSpec('plane_max_iter', 'integer', 50, 'RANSAC iterations of the plane fit', low=1,
              high=100000),
    ParamSpec('plane_dist_thresh', 'double', 0.005, 'plane inlier distance [m]', low=0.0,
              high=0.5),
    ParamSpec('ror_radius_search', 'double', 0.01, 'radius outlier removal: search radius [m]',
              low=1e-4, high=0.5),
    ParamSpec('ror_min_neighbors', 'integer', 5, 'radius outlier removal: neighbours a kept '
              'point needs', low=0, high=10000),
    ParamSpec('cluster_tol', 'double', 0.02, 'Euclidean clustering: neighbour distance that '
              'joins a cluster [m]', low=1e-4, high=0.5),
    ParamSpec('cluster_min_size', 'integer', 50, 'clusters with fewer points are dropped',
              low=1, high=10 ** 7),
    ParamSpec('cluster_max_size', 'integer', 1000, 'clusters with more points are dropped',
              low=1, high=10 ** 7),
))

#: schema of every node, by node name
SCHEMAS = {s.node: s for s in (SIM_DRIVER, IK_SERVICE, TRAJECTORY_SERVER, VIEWER, RECORDER,
                               REPLAYER, STATE_PUBLISHER, PC_FILTER, CAMERA)}


def register(schema: NodeSchema) -> NodeSchema:
    """Add (or replace) a node's schema, e.g. a node of another module; return it."""
    SCHEMAS[schema.node] = schema
    return schema


def bound_error(schema: NodeSchema, name: str, value) -> Optional[str]:
    """
    Return '<name> must be <bounds>, got <value>' when a number is out of the schema's range.

    None for a valid value and for parameters that are not numbers (or not in the schema).
    """
    spec = schema.get(name)
    if spec is None or spec.kind not in ('double', 'integer') or spec.check(value) is None:
        return None
    return f'{name} must be {spec.bounds()}, got {value!r}'


def _flatten(values: dict, prefix: str = '') -> Dict[str, Any]:
    out = {}
    for key, value in values.items():
        name = f'{prefix}{key}'
        if isinstance(value, dict):
            out.update(_flatten(value, name + '.'))
        else:
            out[name] = value
    return out


def _node_of(selector: str) -> str:
    """Return the node name a params-file key addresses ('**' for every node)."""
    return selector.rstrip('/').rsplit('/', 1)[-1] or '**'


def check_params(data: dict, schemas: Optional[Dict[str, NodeSchema]] = None,
                 source: str = 'params') -> List[str]:
    """
    Return the problems of a loaded ``--params-file`` document (empty when it is valid).

    Keys are node selectors (``/**``, ``/**/sim_driver``, ``/px100/sim_driver``, ``sim_driver``)
    each with ``ros__parameters``. Parameters for every node (``/**``, ``/**/*``) must be
    common ones; a known node's must be in its schema and valid; an unknown node is reported.
    """
    schemas = SCHEMAS if schemas is None else schemas
    problems = []
    if not isinstance(data, dict):
        return [f'{source}: not a mapping of node names']
    for selector, block in data.items():
        where = f'{source}: {selector}'
        if not isinstance(block, dict) or set(block) != {'ros__parameters'} \
                or not isinstance(block['ros__parameters'], dict):
            problems.append(f'{where}: expected exactly one key ros__parameters with a mapping')
            continue
        node = _node_of(str(selector))
        values = _flatten(block['ros__parameters'])
        if node in ('**', '*'):
            common = NodeSchema('every node', COMMON)
            for name, value in values.items():
                problem = common.check(name, value)
                problems += [f'{where}: {problem}'] if problem else []
            continue
        schema = schemas.get(node)
        if schema is None:
            problems.append(f"{where}: no px100_control node is called '{node}' "
                            f"(nodes: {', '.join(sorted(schemas))})")
            continue
        for name, value in values.items():
            problem = schema.check(name, value)
            problems += [f'{where}: {problem}'] if problem else []
    return problems


def check_params_file(path: str, schemas: Optional[Dict[str, NodeSchema]] = None) -> List[str]:
    """Load a ``--params-file`` YAML and return its problems (empty when it is valid)."""
    with open(path, encoding='utf-8') as f:
        data = yaml.safe_load(f)
    return check_params(data, schemas, source=path)


def names_of(schemas: Iterable[NodeSchema]) -> List[str]:
    """Return every parameter name of the schemas (sorted, unique)."""
    return sorted({p.name for s in schemas for p in s.params})
