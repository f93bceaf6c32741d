"""
In-process bringup: sim_driver, ik_service and trajectory_server spun inside the client process.

``InterbotixManipulatorXS(..., bringup=True)`` (or env ``PX100_BRINGUP=1``) uses this so a
script is the only command to run. The nodes come from :func:`px100_control.ros.bringup.
create_nodes` (the same ones ``ros2 run px100_control bringup`` starts), live in the client's
rclpy context, and spin in their own executor thread (rclpy's EventsExecutor by default, see
:func:`px100_control.ros.common.make_executor`); :func:`robot_shutdown` stops them.
``viewer=True`` (or env ``PX100_VIEWER=1``) adds the browser viewer node
(http://127.0.0.1:8080; ``parameters={'port': N}`` to change).
"""
import os
import signal
import subprocess
import sys
import tempfile
from typing import List, Optional

from px100_control.client.robot import SpinThread
from px100_control.ros.common import make_executor
from rclpy.parameter import Parameter


#: parameters the client sets on the nodes it starts itself:
#: - ik_service 'strict': the whole pose or nothing, which is what Interbotix's IK guarantees
#:   (eomg/ev), so a refusal carries ik_service's reason; in 'pitch' mode (the nodes' default,
#:   e.g. the bringup executable) a 4-DOF arm is answered with the roll-flipped "over the top"
#:   configuration when no upright one is in the limits, which the client refuses itself: it
#:   checks every answer against the target (eomg/ev), so either mode moves the arm the same;
#: - trajectory_server path_tolerance 0.5 rad (default 0.2) and goal_time_tolerance 2 s
#:   (default 1): the simulated servos track a move within ~0.02 rad and settle in a fraction of
#:   a second, but on a loaded machine the simulation can fall behind the clock for a moment and
#:   the tight defaults abort moves that then complete fine; blocked joints and a dead driver
#:   are still detected (tracking, settling and state timeouts).
NODE_PARAMETERS = {'ik_service': {'orientation_mode': 'strict'},
                   'trajectory_server': {'path_tolerance': 0.5, 'goal_time_tolerance': 2.0}}


#: the bringup (in-process or process) whose driver publishes /clock (real_time_factor != 1):
#: one per client process, as /clock is one topic for the whole graph; later ones follow it
_clock_owner = None


def _driver_clock(bringup) -> dict:
    """
    Return the sim_driver parameters that set its clock, taking the clock if nobody has it.

    real_time_factor != 1: the first bringup's driver owns the clock (its speed, /clock); the
    drivers of the later ones follow /clock (use_sim_time). real_time_factor 1: {} (wall time).
    """
    global _clock_owner
    if bringup.real_time_factor == 1.0:
        return {}
    if _clock_owner is None or _clock_owner is bringup:
        _clock_owner = bringup
        return {'real_time_factor': bringup.real_time_factor}
    return {'use_sim_time': True}


def _release_clock(bringup) -> None:
    """Let a later bringup own the clock once ``bringup`` stopped."""
    global _clock_owner
    if _clock_owner is bringup:
        _clock_owner = None


class InProcessBringup:
    """
    The robot's nodes running in this process.

    With ``real_time_factor`` != 1 the first such bringup's driver owns the clock (it publishes
    /clock); the drivers of later ones in this process (a second arm) follow that clock
    (use_sim_time) instead of publishing a second time base on the same topic, so every node
    sees one simulated time. They run at the owner's speed.

    :param robot_model: robot model parameter of every node
    :param robot_name: namespace parameter of every node
    :param real_time_factor: simulation speed (sim_driver parameter ``real_time_factor``, when
        the driver declares it)
    :param parameters: extra {name: value} parameters given to every node
    :param viewer: also run the browser viewer node (default: env ``PX100_VIEWER``)
    """

    def __init__(self, robot_model: str = 'px100', robot_name: str = 'px100',
                 real_time_factor: float = 1.0, parameters: Optional[dict] = None,
                 viewer: Optional[bool] = None, **kwargs):
        self.viewer = viewer_wanted(viewer)
        self.robot_model = robot_model
        self.robot_name = robot_name
        self.real_time_factor = float(real_time_factor)
        self.parameters = dict(parameters or {})
        self.kwargs = kwargs
        self.nodes: List = []
        self.executor = None
        self.thread = None  # robot.SpinThread

    def start(self, context=None) -> None:
        """Create the nodes and spin them in a background thread."""
        from px100_control.ros import bringup  # optional: the nodes (MuJoCo) load when used
        params = {'robot_model': self.robot_model, 'robot_name': self.robot_name}
        params.update(self.parameters)
        kwargs = dict(self.kwargs)
        if context is not None:
            kwargs.setdefault('context', context)
        if self.robot_name:
            # nodes in the robot's namespace: several robots per process (or graph) do not
            # share the node names (and parameter services) /sim_driver, ...
            kwargs.setdefault('namespace', '/' + self.robot_name.strip('/'))
        if self.real_time_factor == 1.0:
            kwargs.setdefault('parameter_overrides', _overrides(params))
            self.nodes = list(bringup.create_nodes(viewer=self.viewer, **kwargs))
        else:
            # the driver owns the clock (real_time_factor x wall time, published on /clock);
            # ik_service and trajectory_server follow it with use_sim_time; a driver started
            # while another bringup of this process owns the clock follows it too
            self.nodes = []
            try:
                classes = [(_node_class('sim_driver'), _driver_clock(self)),
                           (_node_class('ik_service'), {'use_sim_time': True}),
                           (_node_class('trajectory_server'), {'use_sim_time': True})]
                if self.viewer:
                    classes.append((_node_class('viewer'), {}))
                for cls, extra in classes:
                    node_kwargs = dict(kwargs)
                    node_kwargs['parameter_overrides'] = _overrides({**params, **extra})
                    self.nodes.append(cls(**node_kwargs))
            except BaseException:
                for node in self.nodes:
                    node.destroy_node()
                _release_clock(self)
                raise
        for node in self.nodes:
            for name, value in NODE_PARAMETERS.get(node.get_name(), {}).items():
                if node.has_parameter(name):
                    node.set_parameters([Parameter(name, value=value)])
        self.executor = make_executor(context=context)
        for n in self.nodes:
            self.executor.add_node(n)
        self.thread = SpinThread(self.executor, 'px100_bringup').start()

    def stop(self) -> None:
        """Stop spinning and destroy the nodes."""
        _release_clock(self)
        if self.thread is not None:
            self.thread.stop()
        for n in self.nodes:
            try:
                n.destroy_node()
            except Exception:  # noqa: B902 - already destroyed
                pass
        self.nodes = []
        self.executor = None
        self.thread = None


def _overrides(values: dict) -> list:
    return [Parameter(k, value=v) for k, v in values.items()]


def viewer_wanted(viewer: Optional[bool] = None) -> bool:
    """Return viewer, or env ``PX100_VIEWER`` (1/true/yes/on) when it is None."""
    if viewer is not None:
        return bool(viewer)
    return os.environ.get('PX100_VIEWER', '').strip().lower() in ('1', 'true', 'yes', 'on')


def _node_class(name: str):
    """Return the node class of one of the bringup's executables."""
    if name == 'viewer':
        from px100_control.ros.viewer_node import ViewerNode  # optional: viser when asked
        return ViewerNode
    if name == 'sim_driver':
        from px100_control.ros.sim_driver_node import SimDriverNode  # optional: MuJoCo
        return SimDriverNode
    if name == 'ik_service':
        from px100_control.ros.ik_service_node import IkServiceNode  # optional: node modules
        return IkServiceNode
    from px100_control.ros.trajectory_server_node import TrajectoryServerNode  # optional: same
    return TrajectoryServerNode


class ProcessBringup:
    """
    The robot's nodes as three child processes of this one (``bringup='process'``).

    Same nodes, parameters and clock as :class:`InProcessBringup`, but each in its own Python
    process (``python -m px100_control.ros.<node>``), so they do not share this process's
    interpreter lock: more robust on a loaded machine. Output goes to log files
    (``log_paths``); stop() sends SIGINT and waits.
    """

    MODULES = (('sim_driver', 'px100_control.ros.sim_driver_node'),
               ('ik_service', 'px100_control.ros.ik_service_node'),
               ('trajectory_server', 'px100_control.ros.trajectory_server_node'))

    def __init__(self, robot_model: str = 'px100', robot_name: str = 'px100',
                 real_time_factor: float = 1.0, parameters: Optional[dict] = None,
                 viewer: Optional[bool] = None, **kwargs):
        self.robot_model = robot_model
        self.robot_name = robot_name
        self.real_time_factor = float(real_time_factor)
        self.parameters = dict(parameters or {})
        self.viewer = viewer_wanted(viewer)
        self.modules = self.MODULES
        self.procs: List = []
        self.log_paths: List[str] = []
        self._files: List = []

    def start(self, context=None) -> None:
        """Start the three node processes (returns at once; the client waits for them)."""
        # the folder holding the px100_control package (this file is px100_control/client/*.py)
        package_root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        env = os.environ.copy()
        env['PYTHONPATH'] = os.pathsep.join(
            [package_root] + [p for p in env.get('PYTHONPATH', '').split(os.pathsep) if p])
        common = {'robot_model': self.robot_model, 'robot_name': self.robot_name}
        common.update(self.parameters)
        self.modules = self.MODULES + ((('viewer', 'px100_control.ros.viewer_node'),)
                                       if self.viewer else ())
        for name, module in self.modules:
            params = dict(common, **NODE_PARAMETERS.get(name, {}))
            if self.real_time_factor != 1.0:
                params.update(_driver_clock(self) if name == 'sim_driver'
                              else {'use_sim_time': True})
            args = [sys.executable, '-m', module, '--ros-args']
            if self.robot_name:
                args += ['-r', f"__ns:=/{self.robot_name.strip('/')}"]
            for key, value in params.items():
                args += ['-p', f'{key}:={_ros_arg(value)}']
            log = tempfile.NamedTemporaryFile(prefix=f'px100_{name}_', suffix='.log',
                                              delete=False)
            self._files.append(log)
            self.log_paths.append(log.name)
            self.procs.append(subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT,
                                               env=env))

    def problems(self) -> str:
        """Return what went wrong with processes that exited (their last log lines), or ''."""
        out = []
        for (name, _), proc, path in zip(self.modules, self.procs, self.log_paths):
            if proc.poll() is not None:
                with open(path, encoding='utf-8', errors='replace') as f:
                    tail = f.read().strip().splitlines()[-3:]
                out.append(f'{name} exited with code {proc.returncode}: ' + ' | '.join(tail))
        return '; '.join(out)

    def stop(self, timeout: float = 10.0) -> None:
        """SIGINT every process and wait (SIGKILL after timeout)."""
        _release_clock(self)
        for proc in self.procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        for proc in self.procs:
            try:
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(5.0)
        for f in self._files:
            f.close()
        self.procs = []


def _ros_arg(value) -> str:
    """Return a parameter value as a --ros-args -p text (YAML)."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    return str(value)
