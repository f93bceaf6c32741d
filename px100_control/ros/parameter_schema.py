"""
The parameter schemas (:mod:`px100_control.parameters`) on a ROS node: descriptors and checks.

:func:`parameter_descriptor` turns a schema entry into an rcl_interfaces ParameterDescriptor
(description, FloatingPointRange / IntegerRange, constraints text, read-only flag), so ``ros2
param describe`` shows what the schema says; :func:`declare_schema` declares a node's parameters
from its schema and checks every later set against it. ``--help`` text:
:func:`px100_control.ros.common.parse_cli` prints :meth:`NodeSchema.help_text`.
"""
import math
from typing import Optional, Sequence

from px100_control.errors import InvalidInputError
from px100_control.parameters import NodeSchema, ParamSpec
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)

#: ParameterType of each schema kind
KINDS = {'double': ParameterType.PARAMETER_DOUBLE, 'integer': ParameterType.PARAMETER_INTEGER,
         'bool': ParameterType.PARAMETER_BOOL, 'string': ParameterType.PARAMETER_STRING,
         'double_array': ParameterType.PARAMETER_DOUBLE_ARRAY}
#: the largest value of an int64 parameter (an integer range open above)
INT64_MAX = 2**63 - 1


def parameter_descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """
    Return the ParameterDescriptor of a schema entry (ranges, constraints text, read-only).

    A 'double' that also takes integers (``accepts_integer``: register values such as
    ``gains.waist.p: 800``) is dynamically typed, with its range for both types: rclpy checks a
    double against ``floating_point_range`` and an integer against ``integer_range``.
    """
    d = ParameterDescriptor(name=spec.name, description=spec.description,
                            additional_constraints=spec.constraints(),
                            read_only=spec.read_only)
    if spec.accepts_integer:
        d.dynamic_typing = True
    else:
        d.type = KINDS[spec.kind]
    if spec.low is None and spec.high is None:
        return d
    low = spec.low if spec.low is not None else -math.inf
    high = spec.high if spec.high is not None else math.inf
    if spec.allow_inf:
        high = math.inf      # the schema's check keeps the finite upper bound
    if spec.kind == 'integer' or spec.accepts_integer:
        d.integer_range = [IntegerRange(
            from_value=-INT64_MAX - 1 if math.isinf(low) else math.ceil(low),
            to_value=INT64_MAX if math.isinf(high) else math.floor(high), step=0)]
    if spec.kind == 'double':
        d.floating_point_range = [FloatingPointRange(from_value=float(low),
                                                     to_value=float(high), step=0.0)]
    return d


def declare_schema(node, schema: NodeSchema, defaults: Optional[dict] = None,
                   skip: Sequence[str] = ('robot_model', 'robot_name')) -> None:
    """
    Declare a node's parameters from its schema and check every value set later against it.

    :param defaults: {name: default} for the parameters the node computes (spec default None)
    :param skip: names declared elsewhere (robot_model / robot_name by
        :func:`px100_control.ros.common.declare_robot_parameters`)
    :raises Px100Error: a value from the command line or a params file is not valid (the
        message names the parameter and the allowed values)
    """
    defaults = defaults or {}
    names = []
    for spec in schema.params:
        if spec.name in skip:
            continue
        default = defaults.get(spec.name, spec.default)
        node.declare_parameter(spec.name, default, parameter_descriptor(spec))
        names.append(spec.name)

    def _check(params):
        for p in params:
            if p.name in names:
                problem = schema[p.name].check(p.value)
                if problem:
                    return SetParametersResult(successful=False, reason=problem)
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(_check)
    bad = _check([node.get_parameter(n) for n in names]).reason
    if bad:
        raise InvalidInputError(f'{schema.node} parameters: {bad}')
