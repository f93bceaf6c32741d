"""The parameter schemas: config files checked against them, descriptors and --help from them."""
import glob
import math
import os

from px100_control.ros import parameter_schema as ps
import pytest
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIGS = sorted(glob.glob(os.path.join(ROOT, 'config', '*.yaml')))


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
        '/**/ik_service': {'ros__parameters': {'method': 'magic', 'tol_position': 0.0}},
        '/**/trajectory_server': {'ros__parameters': {'status_history': 1.5,
                                                      'hold_after': 0.01}},
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
                 'status_history must be an integer',
                 'hold_after = 0.01 is not 0.05 <= value',
                 "no px100_control node is called 'nobody'",
                 'broken: expected exactly one key ros__parameters'):
        assert text in problems, problems


def test_checks_match_the_values_the_nodes_know():
    """Choices in the schema are the engines' own lists (no drift)."""
    from px100_control.control.trajectory import PROFILES
    from px100_control.control.pid import GAIN_FIELDS
    from px100_control.kinematics.solve import METHODS
    assert tuple(ps.IK_SERVICE['method'].choices) == tuple(METHODS)
    assert tuple(ps.TRAJECTORY_SERVER['profile'].choices) == tuple(PROFILES)
    assert tuple(ps.GAIN_FIELDS_DOC) == tuple(GAIN_FIELDS)


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


@pytest.mark.parametrize('name,schemas', [
    ('sim_driver', [ps.SIM_DRIVER]), ('ik_service', [ps.IK_SERVICE]),
    ('trajectory_server', [ps.TRAJECTORY_SERVER]), ('record', [ps.RECORDER]),
    ('replay', [ps.REPLAYER]),
    ('bringup', [ps.SIM_DRIVER, ps.IK_SERVICE, ps.TRAJECTORY_SERVER])])
def test_help_prints_the_parameters(name, schemas):
    """`<exe> --help` lists every parameter with its default and constraints."""
    from px100_control.tools.processes import NodeProcess
    with NodeProcess(name, ['--help']) as proc:
        proc.proc.wait(60)
        out = proc.output()
    assert proc.proc.returncode == 0, out
    for schema in schemas:
        for spec in schema.params:
            assert spec.help_line().splitlines()[0] in out, (spec.name, out)


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
        d = node.describe_parameter('status_history')
        assert (d.integer_range[0].from_value, d.integer_range[0].to_value) == (1, 100000)
        assert node.describe_parameter('robot_model').read_only
        res = node.set_parameters([rclpy.parameter.Parameter('goal_tolerance', value=0.0),
                                   rclpy.parameter.Parameter('status_history', value=0),
                                   rclpy.parameter.Parameter('robot_model', value='wx250'),
                                   rclpy.parameter.Parameter('moving_time', value=3.0)])
        assert [r.successful for r in res] == [False, False, False, True]
        assert 'goal_tolerance' in res[0].reason and 'status_history' in res[1].reason
    finally:
        node.destroy_node()


def test_a_bad_value_at_start_names_the_parameter(rclpy_context):
    """A node given an out-of-range override refuses to start and says which and why."""
    from px100_control.ros.ik_service_node import IkServiceNode
    import rclpy.parameter
    with pytest.raises(Exception) as info:
        IkServiceNode(context=rclpy_context, namespace='/schema_test',
                      parameter_overrides=[rclpy.parameter.Parameter('method', value='magic')])
    assert 'method' in str(info.value)
