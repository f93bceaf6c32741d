"""
The client exposes every public name of Interbotix's Python API with the same signature.

The table is shared/reference/interbotix_api.md (humble = jazzy), plus the ROS 1 names old
scripts use. Each entry lists the leading parameters (name, default) that must match exactly;
px100_control may only add parameters that have defaults after them.
"""
import inspect

from px100_control.client import arm as arm_module
from px100_control.client import core as core_module
from px100_control.client import gripper as gripper_module
from px100_control.client import manipulator as manipulator_module
from px100_control.client import robot as robot_module
import pytest

REQ = inspect.Parameter.empty
INFO = 20  # rclpy LoggingSeverity.INFO

MANIPULATOR = [
    ('__init__', [('self', REQ), ('robot_model', REQ), ('group_name', 'arm'),
                  ('gripper_name', 'gripper'), ('robot_name', None), ('moving_time', 2.0),
                  ('accel_time', 0.3), ('gripper_pressure', 0.5),
                  ('gripper_pressure_lower_limit', 150), ('gripper_pressure_upper_limit', 350),
                  ('topic_joint_states', 'joint_states'), ('logging_level', INFO),
                  ('node_name', 'robot_manipulation'), ('node', None),
                  ('iterative_update_fk', True), ('args', None)]),
    ('get_node', [('self', REQ)]),
]
MT = [('moving_time', None), ('accel_time', None), ('blocking', True)]
ARM = [
    ('__init__', [('self', REQ), ('core', REQ), ('robot_model', REQ), ('group_name', 'arm'),
                  ('moving_time', 2.0), ('accel_time', 0.3), ('iterative_update_fk', True)]),
    ('set_trajectory_time', [('self', REQ), ('moving_time', None), ('accel_time', None)]),
    ('set_joint_positions', [('self', REQ), ('joint_positions', REQ)] + MT),
    ('go_to_home_pose', [('self', REQ)] + MT),
    ('go_to_sleep_pose', [('self', REQ)] + MT),
    ('set_single_joint_position', [('self', REQ), ('joint_name', REQ), ('position', REQ)] + MT),
    ('set_ee_pose_matrix', [('self', REQ), ('T_sd', REQ), ('custom_guess', None),
                            ('execute', True)] + MT),
    ('set_ee_pose_components', [('self', REQ), ('x', 0), ('y', 0), ('z', 0), ('roll', 0),
                                ('pitch', 0), ('yaw', None), ('custom_guess', None),
                                ('execute', True)] + MT),
    ('set_ee_cartesian_trajectory', [('self', REQ), ('x', 0), ('y', 0), ('z', 0), ('roll', 0),
                                     ('pitch', 0), ('yaw', 0), ('moving_time', None),
                                     ('wp_moving_time', 0.2), ('wp_accel_time', 0.1),
                                     ('wp_period', 0.05)]),
    ('get_joint_commands', [('self', REQ)]),
    ('get_single_joint_command', [('self', REQ), ('joint_name', REQ)]),
    ('get_ee_pose_command', [('self', REQ)]),
    ('get_ee_pose', [('self', REQ)]),
    ('capture_joint_positions', [('self', REQ)]),
    ('get_joint_positions', [('self', REQ)]),
    ('get_joint_velocities', [('self', REQ)]),
    ('get_joint_efforts', [('self', REQ)]),
    ('get_number_of_joints', [('self', REQ)]),
    ('set_relative_ee_position_wrt_to_base_frame', [('self', REQ)]),  # keyword-only below
    # private helpers old scripts reach for
    ('publish_positions', [('self', REQ), ('positions', REQ)] + MT),
    ('check_joint_limits', [('self', REQ), ('positions', REQ)]),
    ('check_single_joint_limit', [('self', REQ), ('joint_name', REQ), ('position', REQ)]),
]
GRIPPER = [
    ('__init__', [('self', REQ), ('core', REQ), ('gripper_name', 'gripper'),
                  ('gripper_pressure', 0.5), ('gripper_pressure_lower_limit', 150),
                  ('gripper_pressure_upper_limit', 350)]),
    ('release', [('self', REQ), ('delay', 1.0)]),
    ('grasp', [('self', REQ), ('delay', 1.0)]),
    ('open', [('self', REQ), ('delay', 1.0)]),
    ('close', [('self', REQ), ('delay', 1.0)]),
    ('set_pressure', [('self', REQ), ('pressure', REQ)]),
    ('gripper_controller', [('self', REQ), ('effort', REQ), ('delay', REQ)]),
    ('gripper_state', [('self', REQ)]),
    ('get_gripper_position', [('self', REQ)]),
    ('get_gripper_velocity', [('self', REQ)]),
    ('get_gripper_effort', [('self', REQ)]),
    ('get_finger_position', [('self', REQ)]),
]
#: interbotix_xs_modules.xs_robot.gripper.InterbotixGripperXS (humble/jazzy)
GRIPPER_XS = [
    ('__init__', [('self', REQ), ('robot_model', REQ), ('gripper_name', REQ),
                  ('robot_name', None), ('gripper_pressure', 0.5),
                  ('gripper_pressure_lower_limit', 150), ('gripper_pressure_upper_limit', 350),
                  ('topic_joint_states', 'joint_states'), ('logging_level', INFO),
                  ('node_name', 'robot_manipulation'), ('start_on_init', True)]),
    ('start', [('self', REQ)]),
    ('run', [('self', REQ)]),
    ('shutdown', [('self', REQ)]),
]
CT = [('cmd_type', REQ), ('name', REQ)]
CORE = [
    ('__init__', [('self', REQ), ('robot_model', REQ), ('robot_name', None),
                  ('topic_joint_states', 'joint_states'), ('logging_level', INFO),
                  ('node_name', 'interbotix_robot_manipulation'), ('node', None),
                  ('args', None)]),
    ('get_node', [('self', REQ)]),
    ('robot_set_operating_modes', [('self', REQ)] + CT + [
        ('mode', REQ), ('profile_type', 'velocity'), ('profile_velocity', 0),
        ('profile_acceleration', 0)]),
    ('robot_set_motor_pid_gains', [('self', REQ)] + CT + [
        ('kp_pos', REQ), ('ki_pos', 0), ('kd_pos', 0), ('k1', 0), ('k2', 0), ('kp_vel', 100),
        ('ki_vel', 1920)]),
    ('robot_set_motor_registers', [('self', REQ)] + CT + [('reg', REQ), ('value', REQ)]),
    ('robot_get_motor_registers', [('self', REQ)] + CT + [('reg', REQ)]),
    ('robot_get_robot_info', [('self', REQ)] + CT),
    ('robot_torque_enable', [('self', REQ)] + CT + [('enable', REQ)]),
    ('robot_reboot_motors', [('self', REQ)] + CT + [('enable', REQ), ('smart_reboot', False)]),
    ('robot_write_commands', [('self', REQ), ('group_name', REQ), ('commands', REQ)]),
    ('robot_write_joint_command', [('self', REQ), ('joint_name', REQ), ('command', REQ)]),
    # ROS 1 (noetic) names the third argument 'type' and scripts pass it as type=...: both
    # are accepted, so traj_type has a default here (a call without either raises TypeError)
    ('robot_write_trajectory', [('self', REQ)] + CT + [('traj_type', None), ('raw_traj', None)]),
    ('robot_get_joint_states', [('self', REQ)]),
    ('robot_get_single_joint_state', [('self', REQ), ('name', REQ)]),
]
ROBOT = [
    ('robot_startup', [('node', None), ('node_name', 'interbotix_robot_manipulation'),
                       ('namespace', None)]),
    ('robot_shutdown', [('node', None)]),
    ('create_interbotix_global_node', [('node_name', 'interbotix_robot_manipulation'),
                                       ('namespace', None)]),
    ('get_interbotix_global_node', []),
    ('interbotix_is_up', []),
]
NODE = [
    ('__init__', [('self', REQ), ('node_name', 'interbotix_robot_manipulation'),
                  ('namespace', None)]),
    ('wait_until_future_complete', [('self', REQ), ('future', REQ), ('timeout_sec', None)]),
] + [(f'log{level}', [('self', REQ), ('message', REQ)])
     for level in ('debug', 'info', 'warn', 'error', 'fatal')]

CASES = (
    [(manipulator_module.InterbotixManipulatorXS, m, p) for m, p in MANIPULATOR]
    + [(arm_module.InterbotixArmXSInterface, m, p) for m, p in ARM]
    + [(gripper_module.InterbotixGripperXSInterface, m, p) for m, p in GRIPPER]
    + [(gripper_module.InterbotixGripperXS, m, p) for m, p in GRIPPER_XS]
    + [(core_module.InterbotixRobotXSCore, m, p) for m, p in CORE]
    + [(robot_module, m, p) for m, p in ROBOT]
    + [(robot_module.InterbotixRobotNode, m, p) for m, p in NODE]
)


def _id(case):
    owner, name, _ = case
    return f'{getattr(owner, "__name__", owner)}.{name}'


@pytest.mark.parametrize('case', CASES, ids=[_id(c) for c in CASES])
def test_signature_matches_interbotix(case):
    """Leading parameters have Interbotix's names, order and defaults; extras are optional."""
    owner, name, expected = case
    func = getattr(owner, name)
    params = list(inspect.signature(func).parameters.values())
    positional = [p for p in params
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    got = [(p.name, p.default) for p in positional[:len(expected)]]
    assert got == expected, f'{_id(case)}: {got} != {expected}'
    for extra in params[len(expected):]:
        if extra.kind in (extra.VAR_POSITIONAL, extra.VAR_KEYWORD):
            continue
        assert extra.default is not inspect.Parameter.empty, \
            f'{_id(case)}: extra parameter {extra.name} must be optional'


def test_noetic_relative_move_is_keyword_only():
    """set_relative_ee_position_wrt_to_base_frame takes keyword-only dx, dy, dz (noetic)."""
    sig = inspect.signature(
        arm_module.InterbotixArmXSInterface.set_relative_ee_position_wrt_to_base_frame)
    kw = {p.name: p.default for p in sig.parameters.values() if p.kind == p.KEYWORD_ONLY}
    assert kw == {'dx': 0, 'dy': 0, 'dz': 0, 'custom_guess': None, 'execute': True,
                  'moving_time': None, 'accel_time': None, 'blocking': True}


def test_standalone_gripper_takes_the_ros1_init_node():
    """Noetic's InterbotixGripperXS: init_node (7th positional, or keyword); .dxl is .core."""
    sig = inspect.signature(gripper_module.InterbotixGripperXS.__init__)
    assert sig.parameters['init_node'].default is True
    assert isinstance(gripper_module.InterbotixGripperXS.dxl, property)


def test_import_layouts():
    """The issue's import line and Interbotix's module layout both resolve to the same class."""
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
    from px100_control.client.arm import InterbotixManipulatorXS as FromArm
    from px100_control.client.robot import InterbotixException
    assert FromArm is InterbotixManipulatorXS
    assert callable(robot_startup) and callable(robot_shutdown)
    assert issubclass(InterbotixException, Exception)


def test_mr_descriptions_match_reference():
    """mr_descriptions.px100 equals Interbotix's M and Slist (reference section 5)."""
    import numpy as np

    from px100_control.client import mr_descriptions
    d = mr_descriptions.px100
    M = np.eye(4)
    M[:3, 3] = [0.248575, 0.0, 0.1931]
    S = np.array([[0, 0, 1, 0, 0, 0], [0, 1, 0, -0.0931, 0, 0], [0, 1, 0, -0.1931, 0, 0.035],
                  [0, 1, 0, -0.1931, 0, 0.135]], dtype=float).T
    np.testing.assert_allclose(d.M, M, atol=1e-9)
    np.testing.assert_allclose(d.Slist, S, atol=1e-9)
    with pytest.raises(AttributeError):
        getattr(mr_descriptions, 'no_such_robot')


def test_pwm_to_effort_mapping():
    """Gripper PWM maps linearly to N*m (XL430: 885 PWM = 1.4 N*m); pressure 0.5 = 250 PWM."""
    assert gripper_module.pwm_to_effort(885) == pytest.approx(1.4)
    assert gripper_module.pwm_to_effort(-250) == pytest.approx(-250 / 885 * 1.4)
    assert gripper_module.pwm_to_effort(5000) == pytest.approx(1.4)
    assert gripper_module.effort_to_pwm(gripper_module.pwm_to_effort(150)) == pytest.approx(150)
