"""
Lifecycle of the Interbotix-compatible client: one global node spun in a background thread.

Mirrors ``interbotix_common_modules.common_robot.robot`` (humble/jazzy): a global
:class:`InterbotixRobotNode` named ``interbotix_robot_manipulation``, :func:`robot_startup`
(spin it in a daemon thread; executor from :func:`px100_control.ros.common.make_executor`)
and :func:`robot_shutdown` (stop, destroy, ``rclpy`` shutdown).

Differences from Interbotix (documented, on purpose):

- ROS 1 style scripts never call ``robot_startup()``. Here the node starts spinning as soon as a
  robot is constructed (:func:`ensure_spinning`), so such scripts work unchanged; calling
  ``robot_startup()`` afterwards only marks the startup as requested (a second call still raises
  ``InterbotixException('Startup has already been requested.')``).
- ``robot_shutdown()`` also stops the nodes that an in-process bringup started
  (``bringup=True`` / ``PX100_BRINGUP=1``), is safe to call twice, and resets the module so a new
  robot can be constructed afterwards in the same process. It also runs at interpreter exit for
  scripts that never call it.
- Ctrl-C (SIGINT) in a script: rclpy is initialised without its signal handlers (they would
  invalidate the context under the running script), and the client's handler cancels the goals
  of every robot of this process (trajectory_server decelerates them to rest where they are),
  puts joints in velocity / current / pwm mode back in position mode (they hold), stops a
  gripper whose fingers are moving (one squeezing an object keeps its grasp, so nothing is
  dropped), prints one line saying so and where the bag is, and exits with status
  130 (SystemExit: ``with`` blocks and atexit still close bags and stop nodes) without a
  traceback. A second Ctrl-C during that exits at once.
"""
import atexit
import os
import signal
import sys
import threading
import time
from typing import Dict, Optional
import weakref

from px100_control.ros.common import make_executor, spin_once
import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions


class InterbotixException(Exception):
    """Raised by the client on errors that a script cannot recover from (e.g. missing nodes)."""


class InterbotixRobotNode(Node):
    """The client's ROS node (default name ``interbotix_robot_manipulation``)."""

    def __init__(self, node_name: str = 'interbotix_robot_manipulation',
                 namespace: Optional[str] = None, *args, **kwargs) -> None:
        self.node_name = node_name
        self.namespace = namespace
        super().__init__(node_name, *args, namespace=namespace, **kwargs)
        #: time.monotonic() at creation: how long this node has been discovering the graph
        self.created_monotonic = time.monotonic()
        self.get_logger().info('Initialized InterbotixRobotNode!')

    def wait_until_future_complete(self, future, timeout_sec: Optional[float] = None) -> None:
        """
        Block until ``future`` is done or ``timeout_sec`` [s] passed (None or < 0: forever).

        While the node spins in the background this polls at 20 Hz; otherwise it spins the node.
        """
        if not interbotix_is_up():
            rclpy.spin_until_future_complete(self, future, timeout_sec=timeout_sec)
            return
        start = time.monotonic()
        while not future.done():
            if timeout_sec is not None and timeout_sec >= 0 and \
                    time.monotonic() - start >= timeout_sec:
                return
            time.sleep(0.05)

    def logdebug(self, message: str, **kwargs):
        """Log at DEBUG."""
        self.get_logger().debug(message, **kwargs)

    def loginfo(self, message: str, **kwargs):
        """Log at INFO."""
        self.get_logger().info(message, **kwargs)

    def logwarn(self, message: str, **kwargs):
        """Log at WARN."""
        self.get_logger().warning(message, **kwargs)

    def logerror(self, message: str, **kwargs):
        """Log at ERROR."""
        self.get_logger().error(message, **kwargs)

    def logfatal(self, message: str, **kwargs):
        """Log at FATAL."""
        self.get_logger().fatal(message, **kwargs)

    def sleep_for(self, seconds: float) -> None:
        """Sleep ``seconds`` of the node's clock (wall time unless use_sim_time)."""
        if seconds > 0:
            clock = self.get_clock()
            if clock.clock_type == rclpy.clock.ClockType.ROS_TIME and \
                    clock.ros_time_is_active:
                clock.sleep_for(Duration(seconds=seconds))
            else:
                time.sleep(seconds)


class _Runtime:
    """Module state: the global node, its executor thread, and the in-process bringup."""

    def __init__(self):
        self.lock = threading.RLock()
        self.node: Optional[Node] = None
        self.owns_context = False
        self.executor = None  # make_executor()
        self.thread = None  # SpinThread
        self.spun_nodes = []
        self.startup_requested = False
        #: in-process bringups by robot_name (px100_control.client.inprocess)
        self.bringups: Dict[str, object] = {}
        self.robots = []
        self.interrupted = False
        self.handler_installed = False


_RT = _Runtime()


def create_interbotix_global_node(node_name: str = 'interbotix_robot_manipulation',
                                  namespace: Optional[str] = None, *args,
                                  **kwargs) -> InterbotixRobotNode:
    """
    Initialise rclpy (if not already) and create the global node.

    :raises InterbotixException: a global node already exists
    """
    with _RT.lock:
        if _RT.node is not None:
            raise InterbotixException(
                'Tried to create an Interbotix global node but one already exists.')
        if not rclpy.ok():
            # no rclpy signal handlers: SIGINT would shut the context down under the script
            rclpy.init(args=args[0] if args else None,
                       signal_handler_options=SignalHandlerOptions.NO)
            _RT.owns_context = True
        _RT.node = InterbotixRobotNode(node_name=node_name, namespace=namespace, **kwargs)
        return _RT.node


def get_interbotix_global_node() -> Optional[InterbotixRobotNode]:
    """Return the global node, or None before one was created."""
    return _RT.node


def interbotix_is_up() -> bool:
    """Return True while the client's executor spins (after construction or robot_startup)."""
    return _RT.thread is not None and _RT.thread.is_alive()


class SpinThread:
    """
    Spin an executor in a daemon thread; stop it without racing its worker threads.

    rclpy's Executor.shutdown() destroys the executor's guard condition without waiting for
    callbacks already handed to a MultiThreadedExecutor's pool, which then fail ("cannot use
    Destroyable because destruction was requested"). Here the loop is spin_once() until an event
    is set; stop() ends the loop, drains the pool, and only then shuts the executor down.
    A loop still running at interpreter exit is stopped then (:func:`stop_all`): a daemon
    thread that wakes in rclpy's wait during finalization aborts the process (SIGABRT,
    "terminate called without an active exception") instead of letting it exit.
    """

    #: the loops started and not stopped yet
    _running = weakref.WeakSet()

    def __init__(self, executor, name: str):
        self.executor = executor
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> 'SpinThread':
        """Start spinning."""
        SpinThread._running.add(self)
        self.thread.start()
        return self

    @classmethod
    def stop_all(cls, timeout: float = 2.0) -> None:
        """Stop every loop still running (at exit: an owner interrupted before it stopped it)."""
        for spin in list(cls._running):
            try:
                spin.stop(timeout)
            except Exception:  # noqa: B902 - the context is gone already: the loop has ended
                pass

    def is_alive(self) -> bool:
        """Return True while the spin loop runs."""
        return self.thread.is_alive()

    def _run(self) -> None:
        try:
            while not self._stop.is_set() and self.executor.context.ok():
                spin_once(self.executor, 0.05)
        except (ExternalShutdownException, KeyboardInterrupt):
            pass
        except Exception:  # noqa: B902 - the context was shut down under the executor
            if rclpy.ok() and not self._stop.is_set():
                raise

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the loop, wait for running callbacks, shut the executor down."""
        SpinThread._running.discard(self)
        self._stop.set()
        if self.thread.is_alive():
            self.thread.join(timeout=timeout)
        pool = getattr(self.executor, '_executor', None)
        if pool is not None and hasattr(pool, 'shutdown'):
            pool.shutdown(wait=True)
        self.executor.shutdown(timeout_sec=timeout)


def ensure_spinning(node: Node) -> None:
    """
    Spin ``node`` in the client's background executor thread (start it if needed).

    Called by the robot constructor so scripts that never call robot_startup() (ROS 1 style)
    still receive joint states and replies. A node already added to another executor by its
    owner is left to that executor.
    """
    with _RT.lock:
        if node in _RT.spun_nodes:
            return
        if node.executor is not None and node.executor is not _RT.executor:
            return
        if _RT.executor is None:
            _RT.executor = make_executor(context=node.context)
        _RT.executor.add_node(node)
        _RT.spun_nodes.append(node)
        if _RT.thread is None or not _RT.thread.is_alive():
            _RT.thread = SpinThread(_RT.executor, 'interbotix_executor').start()


def robot_startup(node: Optional[Node] = None,
                  node_name: str = 'interbotix_robot_manipulation',
                  namespace: Optional[str] = None) -> None:
    """
    Start up the Interbotix Python API: spin the (global) node in a background thread.

    :param node: (optional) the node to spin; default the global node (created if missing)
    :raises InterbotixException: startup was already requested
    """
    with _RT.lock:
        if _RT.startup_requested:
            raise InterbotixException('Startup has already been requested.')
        if node is None:
            node = get_interbotix_global_node()
            if node is None:
                node = create_interbotix_global_node(node_name=node_name, namespace=namespace)
        _RT.startup_requested = True
        ensure_spinning(node)


def register_robot(robot) -> None:
    """Remember a constructed core (robot_shutdown() stops it, Ctrl-C cancels its goals)."""
    with _RT.lock:
        _RT.robots.append(robot)
    install_interrupt_handler()


def set_bringup(bringup, robot_name: Optional[str] = None) -> None:
    """Attach an in-process bringup (of robot ``robot_name``) that robot_shutdown() stops."""
    with _RT.lock:
        _RT.bringups[getattr(bringup, 'robot_name', '') if robot_name is None
                     else robot_name] = bringup


def get_bringup(robot_name: Optional[str] = None):
    """Return the in-process bringup of ``robot_name`` (None: the first one), or None."""
    if robot_name is None:
        return next(iter(_RT.bringups.values()), None)
    return _RT.bringups.get(robot_name)


def install_interrupt_handler() -> None:
    """
    Make Ctrl-C stop the robots safely (see the module docstring).

    Installed from the main thread only, and only over Python's default SIGINT handler (a
    handler the script installed itself is left alone).
    """
    with _RT.lock:
        if _RT.handler_installed or threading.current_thread() is not threading.main_thread():
            return
        if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
            return
        signal.signal(signal.SIGINT, _on_sigint)
        _RT.handler_installed = True


def interrupt_robots() -> str:
    """Cancel every robot's goals and hold it; return the one-line report."""
    parts = []
    for robot in list(_RT.robots):
        try:
            parts.append(robot.interrupt())
        except Exception as exc:  # noqa: B902 - report and go on with the other robots
            parts.append(f'{getattr(robot, "robot_name", "?")}: could not stop ({exc})')
    return '; '.join(p for p in parts if p)


def _on_sigint(signum, frame) -> None:
    """SIGINT: stop the robots, print one line, exit 130 (a second Ctrl-C: at once)."""
    if _RT.interrupted:
        os._exit(130)
    _RT.interrupted = True
    report = interrupt_robots() or 'no robot was running'
    print(f'Interrupted (Ctrl-C): {report}', file=sys.stderr, flush=True)
    raise SystemExit(130)


def robot_shutdown(node: Optional[Node] = None) -> None:
    """
    Stop spinning, destroy the client node(s), stop an in-process bringup, shut rclpy down.

    Safe to call when nothing is up and to call twice; afterwards a new robot may be created.
    :param node: (optional) the node to shut down; default the global node
    """
    _play_out(list(_RT.robots))
    with _RT.lock:
        for robot in _RT.robots:
            try:
                robot._teardown()
            except Exception:  # noqa: B902 - shutting down anyway
                pass
        _RT.robots = []
        if _RT.thread is not None:
            _RT.thread.stop()
        nodes = list(_RT.spun_nodes)
        if node is not None and node not in nodes:
            nodes.append(node)
        if _RT.node is not None and _RT.node not in nodes:
            nodes.append(_RT.node)
        for n in nodes:
            try:
                n.destroy_node()
            except Exception:  # noqa: B902 - already destroyed
                pass
        for bringup in list(_RT.bringups.values()):
            bringup.stop()
        if _RT.owns_context:
            rclpy.try_shutdown()
        _RT.node = None
        _RT.owns_context = False
        _RT.executor = None
        _RT.thread = None
        _RT.spun_nodes = []
        _RT.startup_requested = False
        _RT.bringups = {}
        _RT.interrupted = False
        if _RT.handler_installed and threading.current_thread() is threading.main_thread():
            if signal.getsignal(signal.SIGINT) is _on_sigint:
                signal.signal(signal.SIGINT, signal.default_int_handler)
            _RT.handler_installed = False


#: longest time [s] robot_shutdown lets a last velocity / current / pwm command of the arm
#: play out in a simulation this script started (env PX100_SHUTDOWN_PLAY_OUT; 0: none)
PLAY_OUT_S = 5.0


def _play_out(robots) -> None:
    """Let each robot's last effort command play out before its simulation stops."""
    if _RT.interrupted:
        return          # Ctrl-C: stop now
    try:
        limit = float(os.environ.get('PX100_SHUTDOWN_PLAY_OUT', PLAY_OUT_S))
    except ValueError:
        limit = PLAY_OUT_S
    for robot in robots:
        try:
            line = robot.play_out(limit) if hasattr(robot, 'play_out') else ''
        except Exception as exc:  # noqa: B902 - shutting down anyway
            line = f'robot_shutdown: no play-out ({exc})'
        if line:
            print(line, flush=True)


def _at_exit() -> None:
    """Shut down cleanly at interpreter exit when a script never called robot_shutdown()."""
    if _RT.node is not None or _RT.bringups or _RT.thread is not None:
        try:
            robot_shutdown()
        except Exception:  # noqa: B902 - interpreter is exiting
            pass
    SpinThread.stop_all()


atexit.register(_at_exit)
