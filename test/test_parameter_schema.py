"""The parameter schemas: config files checked against them, descriptors and --help from them."""
import glob
import math
import os

from px100_control import parameters as ps
import pytest
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIGS = sorted(glob.glob(os.path.join(ROOT, 'config', '*.yaml')))
#: the schemas each executable's --help prints (bag tools have no ROS parameters)
HELP_SCHEMAS = {
    'sim_driver': [ps.SIM_DRIVER], 'ik_service': [ps.IK_SERVICE],
    'trajectory_server': [ps.TRAJECTORY_SERVER], 'record': [ps.RECORDER],
    'replay': [ps.REPLAYER], 'viewer': [ps.VIEWER],
    'bringup': [ps.SIM_DRIVER, ps.IK_SERVICE, ps.TRAJECTORY_SERVER, ps.STATE_PUBLISHER,
                ps.VIEWER, ps.CAMERA],
    'camera': [ps.CAMERA],
    'state_publisher': [ps.STATE_PUBLISHER],
    'inspect': [], 'bag_reindex': [], 'pc_filter': [ps.PC_FILTER],
}


def test_there_are_config_files():
    """The check below covers real files."""
    assert any(p.endswith('px100.yaml') for p in CONFIGS)


@pytest.mark.parametrize('path', CONFIGS, ids=os.path.basename)
def test_config_files_follow_the_schemas(path):
    """Every parameter of config/*.yaml is known to its node and valid."""
    assert ps.check_params_file(path) == []


def test_config_px100_covers_every_parameter_of_the_three_nodes():
    """config/px100.yaml documents every parameter (robot_name: the namespace by default)."""
    with open(os.path.join(ROOT, 'config', 'px100.yaml')) as f:
        data = yaml.safe_load(f)
    for schema in (ps.SIM_DRIVER, ps.IK_SERVICE, ps.TRAJECTORY_SERVER):
        given = set(data['/**']['ros__parameters']) | set(
            data['/**/' + schema.node]['ros__parameters'])
        missing = [n for n in schema.names if n not in given and n != 'robot_name']
        assert not missing, f'{schema.node}: {missing}'


def test_bad_params_files_are_refused_with_the_reason():
    """Unknown node, unknown parameter, wrong type, out of range, bad choice: each named."""
    data = {
        '/**': {'ros__parameters': {'robot_model': 'px100', 'publish_rate': 5.0}},
        '/**/sim_driver': {'ros__parameters': {'control_rate': 5.0, 'publish_clock': 'yes',
                                               'gains': {'waist': {'q': 1.0}}}},
        '/**/ik_service': {'ros__parameters': {'method': 'magic', 'tol_position': 0.0,
                                               'max_iterations': 1.5}},
        '/**/trajectory_server': {'ros__parameters': {'hold_after': 0.01}},
        '/**/nobody': {'ros__parameters': {'x': 1}},
        'broken': {'x': 1},
    }
    problems = '\n'.join(ps.check_params(data, source='f.yaml'))
    for text in ("/**: every node has no parameter 'publish_rate'",
                 'control_rate = 5.0 is not 10 <= value <= 100000',
                 'publish_clock must be true or false',
                 'gains are gains.<joint>.<field>',
                 'method must be one of auto, analytic, dls, newton',
                 'tol_position = 0.0 is not 0 < value',
                 'max_iterations must be an integer',
                 'hold_after = 0.01 is not 0.05 <= value',
                 "no px100_control node is called 'nobody'",
                 'broken: expected exactly one key ros__parameters'):
        assert text in problems, problems


def test_checks_match_the_values_the_nodes_know():
    """Choices in the schema are the engines' own lists (no drift)."""
    from px100_control.control.trajectory import PROFILES
    from px100_control.control.pid import GAIN_FIELDS
    from px100_control.sim.simulator import MODES
    from px100_control.kinematics.solve import METHODS
    assert tuple(ps.IK_SERVICE['method'].choices) == tuple(METHODS)
    assert tuple(ps.TRAJECTORY_SERVER['profile'].choices) == tuple(PROFILES)
    assert tuple(ps.GAIN_FIELDS_DOC) == tuple(GAIN_FIELDS)
    assert ps.SIM_DRIVER.group('gains.').fields == tuple(GAIN_FIELDS)
    assert ps.SIM_DRIVER.group('operating_mode.').spec.choices == ('',) + tuple(MODES)


def test_per_joint_groups_in_a_params_file():
    """torque_enable.<joint>, operating_mode.<joint>, gains.<joint>.<field> are accepted."""
    good = {'/**/sim_driver': {'ros__parameters': {
        'torque_enable': {'waist': False, 'gripper': True},
        'operating_mode': {'elbow': 'duty', 'waist': ''},
        'gains': {'waist': {'p': 800, 'i': 0.0, 'd': 0.5}}, 'gains_units': 'dynamixel'}}}
    assert ps.check_params(good) == []
    bad = {'/**/sim_driver': {'ros__parameters': {
        'torque_enable': {'waist': 'off', 'elbow': {'x': True}},
        'operating_mode': {'elbow': 'pwm'},
        'gains': {'waist': {'p': -1.0, 'd': float('inf')}, 'shoulder': 3.0}}}}
    problems = ps.check_params(bad, source='f.yaml')
    expected = ["torque_enable.waist must be true or false, not 'off'",
                'torque_enable.elbow.x: torque_enable are torque_enable.<joint>',
                "operating_mode.elbow must be one of '', position, velocity, torque, duty, "
                "not 'pwm'",
                'gains.waist.p = -1.0 is not 0 <= value',
                'gains.waist.d must be finite, not inf',
                'gains.shoulder: gains are gains.<joint>.<field> with field one of p, i, d']
    assert len(problems) == len(expected), problems
    for problem, words in zip(problems, expected):
        assert problem.startswith('f.yaml: /**/sim_driver: ') and words in problem, problem
    assert ps.SIM_DRIVER.get('gains.waist.p').accepts_integer
    assert ps.SIM_DRIVER.get('torque_enable.gripper').default is True
    assert ps.SIM_DRIVER.get('publish_rate') is ps.SIM_DRIVER['publish_rate']
    assert ps.SIM_DRIVER.get('nothing.waist') is None


def test_engine_checks_take_the_schema_ranges():
    """The engines' own checks refuse just outside the schema's bounds (one source)."""
    from px100_control.control.ik_requests import parameter_error
    from px100_control.sim.driver_parameters import core_error, CORE_PARAMS
    from px100_control.viewer.controls import check_settings
    for spec in ps.IK_SERVICE.params:
        if spec.kind == 'double' and spec.low is not None:
            below = spec.low if spec.above_low else spec.low - 1e-9
            assert parameter_error(spec.name, below, 4).startswith(spec.name)
            assert parameter_error(spec.name, spec.default, 4) is None
    core = {n: ps.SIM_DRIVER[n].default for n in CORE_PARAMS}
    for name in ('control_rate', 'publish_rate', 'clock_rate', 'object_width', 'world_rate',
                 'dynamics_divider', 'real_time_factor'):
        spec = ps.SIM_DRIVER[name]
        step = 1 if spec.kind == 'integer' else 1e-6
        values = dict(core, publish_rate=min(core['publish_rate'], spec.high))
        assert core_error(dict(values, **{name: spec.high})) is None, name
        assert name in core_error(dict(values, **{name: spec.high * (1 + step)})), name
        assert name in core_error(dict(values, **{name: spec.low - step})), name
    view = ps.VIEWER
    check_settings(view['rate'].low, view['trail_length'].high, view['port'].high)
    with pytest.raises(ValueError, match='trail_length'):
        check_settings(view['rate'].low, view['trail_length'].low - 1, view['port'].high)


def test_spec_check_bounds():
    """Inclusive and exclusive bounds, inf only where allowed, NaN never."""
    rtf = ps.SIM_DRIVER['real_time_factor']
    assert rtf.check(math.inf) is None and rtf.check(0.0) is None
    assert rtf.check(2e6) and rtf.check(math.nan) and rtf.check(-1.0)
    tol = ps.IK_SERVICE['tol_position']
    assert tol.check(1e-12) is None and tol.check(0.0) and tol.check(math.inf)
    assert ps.SIM_DRIVER['dynamics_divider'].check(2.0)     # integer wanted
    assert ps.SIM_DRIVER['gains_units'].check('si') is None


def test_client_documents_the_schema_default_state_timeout():
    """The client's docs quote trajectory_server's state_timeout default from the schema."""
    with open(os.path.join(ROOT, 'px100_control', 'client', 'core.py')) as f:
        text = f.read()
    default = ps.TRAJECTORY_SERVER['state_timeout'].default
    assert f'state_timeout, {default:g} s by default' in text


def test_config_px100_states_the_defaults():
    """config/px100.yaml holds the schema defaults (it documents them; copies change them)."""
    with open(os.path.join(ROOT, 'config', 'px100.yaml')) as f:
        data = yaml.safe_load(f)
    for schema in (ps.SIM_DRIVER, ps.IK_SERVICE, ps.TRAJECTORY_SERVER):
        values = dict(data['/**']['ros__parameters'],
                      **data['/**/' + schema.node]['ros__parameters'])
        for name, default in schema.defaults().items():
            assert values[name] == default, (schema.node, name, values[name], default)


def test_help_covers_every_executable():
    """HELP_SCHEMAS names every executable setup.py installs (the test below runs each)."""
    from px100_control.entry_points import TARGETS
    assert set(HELP_SCHEMAS) == set(TARGETS)


@pytest.mark.slow                  # one process start per executable
@pytest.mark.parametrize('name', sorted(HELP_SCHEMAS))
def test_help_prints_the_parameters(name):
    """`<exe> --help` lists every parameter and parameter group with default and constraints."""
    from px100_control.tools.processes import NodeProcess
    with NodeProcess(name, ['--help']) as proc:
        proc.proc.wait(60)
        out = proc.output()
    assert proc.proc.returncode == 0, out
    assert out.startswith('usage: ' + name), out
    for schema in HELP_SCHEMAS[name]:
        assert f'parameters of {schema.node} ' in out
        for spec in list(schema.params) + [g.spec for g in schema.groups]:
            assert spec.help_line().splitlines()[0] in out, (spec.name, out)
    if name == 'sim_driver':
        for line in ('gains.<joint>.<field> (double or integer, default the servo',
                     'torque_enable.<joint> (bool, default true)',
                     "operating_mode.<joint> (string, default '') [one of '', position"):
            assert line in out, out


@pytest.mark.ros
def test_descriptors_of_a_running_node(rclpy_context):
    """Declared descriptors carry description, range and read-only (ros2 param describe)."""
    from px100_control.ros.trajectory_server_node import TrajectoryServerNode
    from rcl_interfaces.msg import ParameterType
    import rclpy.parameter
    node = TrajectoryServerNode(context=rclpy_context, namespace='/schema_test')
    try:
        for spec in ps.TRAJECTORY_SERVER.params:
            d = node.describe_parameter(spec.name)
            assert d.description == spec.description
            assert d.read_only == spec.read_only
            assert node.get_parameter(spec.name).value == (
                spec.default if spec.default is not None else 'schema_test')
        d = node.describe_parameter('goal_tolerance')
        assert d.type == ParameterType.PARAMETER_DOUBLE
        assert d.floating_point_range[0].from_value == 0.0
        assert d.additional_constraints == '0 < value'
        d = node.describe_parameter('action_monitor_rate')
        assert (d.floating_point_range[0].from_value,
                d.floating_point_range[0].to_value) == (0.1, 1000.0)
        assert node.describe_parameter('robot_model').read_only
        res = node.set_parameters([rclpy.parameter.Parameter('goal_tolerance', value=0.0),
                                   rclpy.parameter.Parameter('stop_deceleration', value=0.0),
                                   rclpy.parameter.Parameter('robot_model', value='wx250'),
                                   rclpy.parameter.Parameter('moving_time', value=3.0)])
        assert [r.successful for r in res] == [False, False, False, True]
        assert 'goal_tolerance' in res[0].reason and 'stop_deceleration' in res[1].reason
    finally:
        node.destroy_node()


@pytest.mark.ros
def test_per_joint_groups_on_a_running_driver(rclpy_context, tmp_path):
    """
    A params file with torque_enable / operating_mode / gains groups starts a real sim_driver.

    The members carry the schema's descriptors; a negative gain is refused by name.
    """
    from px100_control.ros.sim_driver_node import SimDriverNode
    from rcl_interfaces.msg import ParameterType
    import rclpy.parameter
    path = tmp_path / 'groups.yaml'
    data = {'/**/sim_driver': {'ros__parameters': {
        'torque_enable': {'waist': False}, 'operating_mode': {'elbow': 'velocity'},
        'gains': {'wrist_angle': {'i': 0}}}}}
    path.write_text(yaml.safe_dump(data))
    assert ps.check_params_file(str(path)) == []
    node = SimDriverNode(context=rclpy_context, namespace='/schema_test',
                         cli_args=['--ros-args', '--params-file', str(path)])
    try:
        assert node.get_parameter('torque_enable.waist').value is False
        assert node.get_parameter('torque_enable.elbow').value is True
        assert node.get_parameter('operating_mode.elbow').value == 'velocity'
        assert node.sim.modes.get('elbow') == 'velocity'
        assert node.get_parameter('gains.wrist_angle.i').value == 0     # an integer, taken
        d = node.describe_parameter('gains.waist.p')
        assert d.dynamic_typing and d.description == ps.SIM_DRIVER.group('gains.').spec.description
        assert d.floating_point_range[0].from_value == 0.0
        assert d.floating_point_range[0].to_value == math.inf
        assert d.integer_range[0].from_value == 0
        assert d.additional_constraints == '0 <= value'
        d = node.describe_parameter('torque_enable.gripper')
        assert d.type == ParameterType.PARAMETER_BOOL and 'coasts' in d.description
        d = node.describe_parameter('operating_mode.waist')
        assert d.type == ParameterType.PARAMETER_STRING
        assert d.additional_constraints == "one of '', position, velocity, torque, duty"
        res = node.set_parameters([rclpy.parameter.Parameter('gains.waist.p', value=-1.0),
                                   rclpy.parameter.Parameter('gains.waist.i', value=-2),
                                   rclpy.parameter.Parameter('operating_mode.waist',
                                                             value='current'),
                                   rclpy.parameter.Parameter('torque_enable.waist', value=True)])
        assert [r.successful for r in res] == [False, False, False, True], res
        assert 'gains.waist.p' in res[0].reason and 'gains.waist.i' in res[1].reason
        assert 'operating_mode.waist must be' in res[2].reason
        assert node.get_parameter('torque_enable.waist').value is True
    finally:
        node.destroy_node()


@pytest.mark.ros
def test_a_bad_value_at_start_names_the_parameter(rclpy_context):
    """A node given an out-of-range override refuses to start and says which and why."""
    from px100_control.ros.ik_service_node import IkServiceNode
    import rclpy.parameter
    with pytest.raises(Exception) as info:
        IkServiceNode(context=rclpy_context, namespace='/schema_test',
                      parameter_overrides=[rclpy.parameter.Parameter('method', value='magic')])
    assert 'method' in str(info.value)
