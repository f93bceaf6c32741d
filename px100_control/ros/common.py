"""
What every px100_control node shares: robot namespace, common parameters, QoS, clean shutdown.

Every node lives in the robot's namespace and uses relative names, as Interbotix and ROS 2
drivers do (``/px100/sim_driver`` publishes ``/px100/joint_states``). The namespace is the
node's ROS namespace (``-r __ns:=/other``, launch's ``namespace``); a node started without one
takes ``/<robot_name>`` (parameter, default ``px100``), and ``robot_name`` defaults to the
namespace. So ``-r __ns:=/other`` moves every topic, service and parameter, relative remaps
(``-r joint_states:=js``) apply, and two robots differ only by namespace. ``robot_name`` also
prefixes the tf frames (``<robot_name>/base_link``); ``robot_name:=''`` with no namespace keeps
the node in ``/`` with unprefixed frames.
"""
import argparse
import contextlib
import itertools
import os
import re
import signal
import sys
from typing import Iterator, List, Optional, Sequence

from px100_control.errors import Px100Error
from px100_control.models.registry import load_robot
from px100_control.models.robot_model import RobotModel
from px100_control.parameters import COMMON, NodeSchema
from px100_control.ros.parameter_schema import parameter_descriptor
from px100_control.tools.exit_watchdog import exit_watchdog
import rclpy
from rclpy import executors
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidHandle
from rclpy.executors import ExternalShutdownException
import rclpy.logging
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.type_description_service import START_TYPE_DESCRIPTION_SERVICE_PARAM
from rclpy.utilities import remove_ros_args

try:
    from rclpy.experimental import EventsExecutor
except ImportError:             # rclpy older than Jazzy's 7.1: make_executor falls back
    EventsExecutor = None

#: latched topics (robot_description, world/markers)
LATCHED_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)


#: robot_name (and namespace) of a node started with neither
DEFAULT_ROBOT_NAME = 'px100'


def _override(parameter_overrides, name: str):
    for p in parameter_overrides or ():
        if getattr(p, 'name', None) == name:
            return p.value
    return None


#: the hidden node that keeps a context's DDS participant while robot_node_placement's probe
#: is replaced by the node it placed (a leading underscore hides it from ``ros2 node list``)
PLACEMENT_ANCHOR = '_px100_placement'
_ANCHORS = itertools.count()


@contextlib.contextmanager
def robot_node_placement(node_name: str, node_kwargs: dict) -> Iterator[dict]:
    """
    Yield ``node_kwargs`` for ``Node.__init__`` with the robot namespace as the default.

    Use as ``with robot_node_placement(NAME, kwargs) as placed: super().__init__(NAME,
    **placed)``. A ``namespace`` given by the caller is kept; otherwise the namespace is
    ``/<robot_name>``, robot_name taken from ``parameter_overrides``, else from the command line
    and params files as the node will see them (read through a short-lived probe node of the
    same name, without parameter services or rosout), else ``px100``. A ``__ns`` remap wins over
    all of this (rcl applies it over the namespace argument).

    While the probe is replaced by the node, a hidden anchor node (PLACEMENT_ANCHOR, its own
    name, no global arguments) keeps the context's DDS participant: rmw_fastrtps destroys it
    with a context's last node, so destroying a first node's probe destroyed the participant
    and the node built a new one. Fast DDS 2.14 (the Jazzy wheels) can deadlock destroying a
    participant while one of its discovery callbacks runs: a node process hung at start-up in
    the probe's destroy_node (seen in the suite; reproduced by hand: 3 hangs in about 1,700
    participant destructions, six processes at a time). The probe itself cannot stay: it has
    the node's name, so with a ``__ns`` remap both would be one node in the graph.
    """
    kwargs = dict(node_kwargs)
    if kwargs.get('namespace'):
        yield kwargs
        return
    name = _override(kwargs.get('parameter_overrides'), 'robot_name')
    if name is not None:
        name = str(name).strip('/')
        kwargs['namespace'] = f'/{name}' if name else ''
        yield kwargs
        return
    context = kwargs.get('context')
    anchor = Node(f'{PLACEMENT_ANCHOR}_{next(_ANCHORS)}', context=context,
                  use_global_arguments=False, enable_rosout=False, start_parameter_services=False,
                  parameter_overrides=[Parameter(START_TYPE_DESCRIPTION_SERVICE_PARAM,
                                                 value=False)])
    try:
        probe = Node(node_name, context=context, cli_args=kwargs.get('cli_args'),
                     use_global_arguments=kwargs.get('use_global_arguments', True),
                     enable_rosout=False, start_parameter_services=False,
                     allow_undeclared_parameters=True,
                     automatically_declare_parameters_from_overrides=True)
        try:
            remapped = probe.get_namespace() != '/'     # a __ns remap places the node
            if probe.has_parameter('robot_name'):
                name = probe.get_parameter('robot_name').value
        finally:
            probe.destroy_node()
        if not remapped:
            name = DEFAULT_ROBOT_NAME if name is None else str(name).strip('/')
            kwargs['namespace'] = f'/{name}' if name else ''
        yield kwargs
    finally:
        anchor.destroy_node()


def init_robot_node(node: Node, node_name: str, node_kwargs: dict) -> None:
    """Run ``Node.__init__`` of ``node`` (a Node subclass), placed by robot_node_placement."""
    with robot_node_placement(node_name, node_kwargs) as placed:
        Node.__init__(node, node_name, **placed)


def declare_robot_parameters(node: Node) -> RobotModel:
    """Declare robot_model/robot_name (default: the namespace) and return the RobotModel."""
    robot_model, name = COMMON
    model_name = node.declare_parameter('robot_model', robot_model.default,
                                        parameter_descriptor(robot_model)).value
    node.declare_parameter('robot_name', node.get_namespace().strip('/'),
                           parameter_descriptor(name))
    return load_robot(model_name)


def robot_name(node: Node) -> str:
    """Return the node's robot_name parameter ('' for none)."""
    return str(node.get_parameter('robot_name').value).strip('/')


def robot_topic(node: Node, name: str) -> str:
    """
    Return the name to create a topic or service ``name`` of the robot with.

    Relative (``name`` itself), so it resolves in the node's namespace (the robot namespace)
    and remaps apply; an absolute ``/x`` or private ``~/x`` name is returned unchanged.
    """
    return name


def frame_id(node: Node, frame: str) -> str:
    """Return the tf frame name ``<robot_name>/<frame>`` (``frame`` when robot_name is '')."""
    ns = robot_name(node)
    return f'{ns}/{frame}' if ns else frame


def parse_cli(description: str, args: Optional[Sequence[str]] = None,
              add_arguments=None, schemas: Sequence[NodeSchema] = (), example_args: str = ''
              ) -> (argparse.Namespace, List[str]):
    """
    Parse a node's command line: ``--help`` (with the nodes' parameters), own options, ROS args.

    :param schemas: the parameter schemas of the nodes this executable runs (``--help``)
    :param example_args: the executable's own arguments in the ``example:`` line of ``--help``
        (``BAG`` for replay); the line runs as printed once they are filled in
    :raises SystemExit: status 1 with one line ``<prog>: error: <reason>`` when rcl refuses the
        ROS arguments (argparse's own errors: status 2, as usual)
    :return: (parsed options, the full argv to hand to ``rclpy.init(args=...)``)
    """
    argv = list(sys.argv if args is None else args)
    prog = argv[0].rsplit('/', 1)[-1] if argv else 'px100_control'
    own = f'{prog} {example_args}'.strip()
    epilog = ("ROS arguments (ROS 2's forms, after the options): --ros-args -p name:=value "
              '--params-file FILE -r __ns:=/arm1 -r from:=to; an empty string is '
              '-p "name:=\'\'" (rcl reads values as YAML)\n'
              f'example: {own} --ros-args -r __ns:=/arm1 -p robot_model:=px150\n'
              'Nodes run in the robot namespace (/<robot_name>, default /px100) with relative '
              'names.')
    for schema in schemas:
        epilog += '\n\n' + schema.help_text()
    parser = argparse.ArgumentParser(
        prog=prog, description=description,
        epilog=epilog, formatter_class=argparse.RawDescriptionHelpFormatter)
    if add_arguments is not None:
        add_arguments(parser)
    try:
        own = remove_ros_args(argv)[1:]
    except Exception as exc:  # noqa: B902 - rcl's argument errors are one line, no traceback
        reason = ros_args_error(exc)
        if reason is None:
            raise
        parser.exit(1, f'{parser.prog}: error: {reason}\n')
    options = parser.parse_args(own)
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
    kind = (kind or os.environ.get('PX100_EXECUTOR') or 'events').strip().lower()
    if kind not in EXECUTOR_KINDS:
        raise ValueError(f'PX100_EXECUTOR must be one of {", ".join(EXECUTOR_KINDS)}, '
                         f'not {kind!r}')
    if kind == 'events':
        if EventsExecutor is not None:
            return EventsExecutor(context=context)
        kind = 'single'
    if kind == 'single':
        return executors.SingleThreadedExecutor(context=context)
    return executors.MultiThreadedExecutor(context=context)


def spin_once(executor, timeout_sec: float) -> None:
    """
    Spin the executor once (``timeout_sec`` [s]), past rclpy's race with another thread.

    A subscription (or publisher) destroyed in another thread while a Python executor builds
    its wait set makes ``spin_once`` raise ``InvalidHandle`` from the entity's QoS event
    handler (ros2/rclpy#1284, in Jazzy's rclpy 7): the exception ended the spinning thread,
    and its node received nothing more. That wait set is dropped here; the next call builds one
    without the destroyed entity. No message is lost: they wait in the DDS readers.
    """
    try:
        executor.spin_once(timeout_sec=timeout_sec)
    except InvalidHandle:
        pass


#: signals received since :func:`install_stop_signals` (SIGINT / SIGTERM numbers)
_STOP_SIGNALS: List[int] = []


def _on_stop_signal(signum, frame) -> None:
    _STOP_SIGNALS.append(signum)


def install_stop_signals() -> None:
    """
    Make SIGINT and SIGTERM stop a node's main loop without raising anywhere else.

    Call in the main thread before ``rclpy.init``, and init with
    ``signal_handler_options=SignalHandlerOptions.NO`` (:func:`init_ros` does): these handlers
    only note the signal (:func:`stop_requested`); the main loop sees it within one
    ``spin_once`` timeout, shuts the executor down (running callbacks finish), destroys the
    nodes and only then shuts the context down. rclpy's own handlers would shut the context
    down at once, inside the signal, while the executor still runs timer callbacks: a timer
    publishing a setpoint then failed with "publisher's context is invalid" ([FATAL] in the
    EventsExecutor, seen on Ctrl-C during a move under ``ros2 launch``). Python's default
    SIGINT handler would raise KeyboardInterrupt at an arbitrary point, e.g. inside a callback
    that rclpy's C++ EventsExecutor runs, where pybind11 turns it into std::terminate. A second
    SIGINT (``ros2 launch`` sends one to the process group and one of its own) or SIGTERM is
    noted the same way, so the teardown (closing a bag, destroying entities) runs to its end.
    """
    del _STOP_SIGNALS[:]
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _on_stop_signal)


def ignore_further_interrupts() -> None:
    """
    After a node's teardown: SIGINT is ignored while the interpreter finalises.

    Python's finalisation puts handlers set from Python back to SIG_DFL, so a second Ctrl-C
    arriving then would kill the process (exit -2) after a clean teardown; SIG_IGN survives
    it. SIGTERM keeps its default, so a launcher escalating to SIGTERM still ends a process
    whose finalisation hangs.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def stop_requested() -> bool:
    """Return True once SIGINT or SIGTERM arrived (after :func:`install_stop_signals`)."""
    return bool(_STOP_SIGNALS)


def keep_spinning(context=None) -> bool:
    """Return True while the context is up and no stop signal arrived."""
    return rclpy.ok(context=context) and not _STOP_SIGNALS


def shutting_down(context=None) -> bool:
    """Return True when an exception is explained by a stop signal or a shut-down context."""
    return bool(_STOP_SIGNALS) or not rclpy.ok(context=context)


def shutdown_executor(executor) -> None:
    """Shut an executor down (wait for running callbacks) before its nodes are destroyed."""
    if executor is None:
        return
    try:
        executor.shutdown(timeout_sec=2.0)
    except Exception:   # noqa: BLE001 -- teardown goes on: nodes and context still get freed
        pass


#: the hidden node that keeps a process's DDS participant while its nodes are destroyed
TEARDOWN_KEEPER = '_px100_teardown'
#: how long [s] the participant's own destruction may take before the process exits anyway
#: with its status (:mod:`px100_control.tools.exit_watchdog`; it takes milliseconds)
TEARDOWN_BOUND_S = 3.0


def destroy_nodes(nodes, status: int) -> None:
    """
    Destroy ``nodes`` (last first) and shut rclpy down: the end of a node process.

    rmw_fastrtps destroys the DDS participant with the context's last node, and Fast DDS 2.14
    can deadlock there (docs/guide.md, known limits). So a hidden keeper node holds the
    participant while the nodes' own teardown runs (bags closed, renderers freed, each node's
    endpoints and name withdrawn from the graph), and only the keeper's destruction, the
    participant's, runs under :func:`exit_watchdog`: hung for TEARDOWN_BOUND_S, the process
    ends with ``status`` (the exit status it was about to return) and a line on stderr.
    """
    keeper = None
    try:
        keeper = Node(f'{TEARDOWN_KEEPER}_{os.getpid()}', use_global_arguments=False,
                      enable_rosout=False, start_parameter_services=False,
                      parameter_overrides=[Parameter(START_TYPE_DESCRIPTION_SERVICE_PARAM,
                                                     value=False)])
    except Exception:  # noqa: B902 - the context is shut down already: no participant to keep
        keeper = None
    for node in reversed(list(nodes)):
        node.destroy_node()
    if keeper is None:
        rclpy.try_shutdown()
        return
    with exit_watchdog(TEARDOWN_BOUND_S, status):
        keeper.destroy_node()
        rclpy.try_shutdown()


#: how long [s, steady] a node with use_sim_time waits for /clock before it warns
CLOCK_WAIT_S = 3.0


#: how many ``wait`` periods a node waits for a /clock publisher the graph already has (one
#: still starting: a driver loading its model on a loaded machine) before it warns
CLOCK_SOURCE_PATIENCE = 10

#: how many ``wait`` periods a node waits when it sees no /clock publisher at all: discovery
#: of a running one took more than 3 s on a loaded machine (CI, load 7 on 2 cores)
CLOCK_DISCOVERY_PATIENCE = 2


def warn_without_clock(node: Node, wait: float = CLOCK_WAIT_S) -> None:
    """
    Warn once when ``node`` follows ``/clock`` (use_sim_time) and none arrived.

    Without a /clock publisher a node with use_sim_time sees time 0 forever: its timers on the
    node clock never fire (joint_states stay silent) and nothing says why. The check runs on
    the steady clock every ``wait`` s: with no /clock publisher in the graph it warns after
    CLOCK_DISCOVERY_PATIENCE checks (discovery takes time); one that is there but silent (still
    starting, as when a launch starts every node at once) gets CLOCK_SOURCE_PATIENCE checks.
    ``sim_driver`` with ``publish_clock:=true`` is the usual /clock source.
    """
    if not (node.has_parameter('use_sim_time') and node.get_parameter('use_sim_time').value):
        return
    timer, checks = None, []

    def check():
        if node.get_clock().now().nanoseconds != 0:
            timer.cancel()
            return
        checks.append(1)
        patience = (CLOCK_SOURCE_PATIENCE if node.count_publishers('/clock') > 0
                    else CLOCK_DISCOVERY_PATIENCE)
        if len(checks) < patience:
            return
        timer.cancel()
        waited = wait * len(checks)
        node.get_logger().warning(
            f"use_sim_time is true but no /clock arrived in {waited:g} s: this node's time "
            'stands still. Start sim_driver with --ros-args -p publish_clock:=true (launch: '
            'use_sim_time:=true does this) or another /clock source')

    timer = node.create_timer(wait, check, clock=Clock(clock_type=ClockType.STEADY_TIME))


def ros_args_error(exc: BaseException) -> Optional[str]:
    """
    Return a one-line reason when ``exc`` is rcl or rclpy refusing the ROS arguments (else None).

    rclpy raises RCLError / UnknownROSArgsError / RCLInvalidROSArgsError (module
    ``rclpy._rclpy_pybind11``) with rcl's source locations appended; the line keeps rcl's words
    and the rule it could not parse. An empty value (``-p scene:=``: the shell ate ``''``) gets
    the form rcl accepts, ``-p "scene:=''"``. rclpy's parameter exceptions (a value out of its
    descriptor's range or of the wrong type, raised while a node declares it) are kept as
    they read.
    """
    if type(exc).__module__ == 'rclpy.exceptions' and 'Parameter' in type(exc).__name__:
        return ' '.join(str(exc).split())   # a -p value out of a descriptor's range or type
    if type(exc).__module__ != 'rclpy._rclpy_pybind11':
        return None
    text = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    if type(exc).__name__ == 'UnknownROSArgsError':
        return f'unknown ROS arguments {text} (see --help)'
    text = text.replace('failed to initialize rcl: ', '')
    text = re.sub(r'(, at /\S+:\d+)+$', '', text).replace('. Error: error not set', '')
    empty = re.search(r"'-p ([^'\s]+):='", text)
    if empty:
        text += f' (an empty value is written -p "{empty.group(1)}:=\'\'")'
    return f'invalid ROS arguments: {text}'


def init_ros(argv: Sequence[str], **kwargs) -> Optional[str]:
    """
    ``rclpy.init(args=argv)``; return the one-line reason when rcl refuses the ROS arguments.

    Without rclpy's signal handlers unless ``signal_handler_options`` says otherwise: a stop
    signal is the main loop's to handle (:func:`install_stop_signals`). rcl's own "Failed to
    parse global arguments" log line is silenced during the call, so a bad argument is exactly
    the one line the caller prints.
    """
    rclpy.logging.set_logger_level('rcl', rclpy.logging.LoggingSeverity.FATAL)
    try:
        kwargs.setdefault('signal_handler_options', SignalHandlerOptions.NO)
        rclpy.init(args=list(argv), **kwargs)
    except Exception as exc:  # noqa: B902 - only rcl's argument errors are answered here
        reason = ros_args_error(exc)
        if reason is None:
            raise
        return reason
    finally:
        rclpy.logging.set_logger_level('rcl', rclpy.logging.LoggingSeverity.UNSET)
    return None


def prog_name(argv: Sequence[str]) -> str:
    """Return the program name of an argv for error lines (``sim_driver``)."""
    return os.path.basename(argv[0]) if argv else 'px100_control'


def run_nodes(build, argv, executor_kind: Optional[str] = None, done=None) -> int:
    """
    Init rclpy, build nodes, spin them until SIGINT/SIGTERM/shutdown or ``done()``, tear down.

    Bad ROS arguments (rcl's parse errors) and a node refusing its parameters, robot or scene
    (:class:`~px100_control.errors.Px100Error`) end the process with one line ``<prog>: error:
    <reason>`` on stderr and status 1, no traceback.

    :param build: callable() -> list of nodes (called after ``rclpy.init``)
    :param argv: full argv for ``rclpy.init`` (ROS arguments included)
    :param executor_kind: :func:`make_executor` kind (None: env ``PX100_EXECUTOR`` / events)
    :param done: optional callable(nodes) -> bool, True to stop spinning
    :return: 0, or 1 after such an error (a stop signal during construction is not an error;
        other errors propagate)
    """
    install_stop_signals()
    bad_args = init_ros(argv)
    if bad_args:
        print(f'{prog_name(argv)}: error: {bad_args}', file=sys.stderr)
        return 1
    nodes: List[Node] = []
    executor = None
    status = 1              # the exit status, until the nodes ran and stopped as they should
    try:
        try:
            # the executor first: built after a signal shut the context down, its __init__
            # fails half way and its __del__ prints a traceback
            executor = make_executor(kind=executor_kind)
            nodes = list(build())
        except Px100Error as exc:
            print(f'{prog_name(argv)}: error: {exc}', file=sys.stderr)
            return 1
        except Exception as exc:  # noqa: B902 - a signal may interrupt construction anywhere
            if shutting_down():
                status = 0
                return 0
            reason = ros_args_error(exc)
            if reason is None:
                raise
            print(f'{prog_name(argv)}: error: {reason}', file=sys.stderr)
            return 1
        for node in nodes:
            executor.add_node(node)
            warn_without_clock(node)
        # spin_once in a loop, not spin(): rclpy 7.1's EventsExecutor.spin() does not return
        # when SIGINT shuts the context down
        while keep_spinning() and not (done is not None and done(nodes)):
            spin_once(executor, 0.1)
        status = 0
    except (KeyboardInterrupt, ExternalShutdownException):
        status = 0
    except Exception:
        if not shutting_down():
            raise
        status = 0
    finally:
        shutdown_executor(executor)
        destroy_nodes(nodes, status)
        ignore_further_interrupts()
    return 0


def spin_node(node_factory, args=None, description: str = '', add_arguments=None,
              schema: Optional[NodeSchema] = None) -> int:
    """
    Run one node the Jazzy way: init, spin until SIGINT/SIGTERM/shutdown, destroy, shutdown.

    :param node_factory: callable(options) -> Node; it spins in :func:`make_executor`'s executor
    :param schema: the node's parameter schema (printed by ``--help``)
    """
    options, argv = parse_cli(description, args, add_arguments,
                              (schema,) if schema is not None else ())
    return run_nodes(lambda: [node_factory(options)], argv)
