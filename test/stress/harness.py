"""
Stress harness: the real px100 nodes as processes, a probe node that fuzzes and watches them.

- :class:`Graph` starts ``sim_driver``, ``ik_service`` and ``trajectory_server`` (or any other
  executable) as child processes, restarts the ones that died and counts the deaths.
- :class:`Probe` is one rclpy node in its own context and executor thread. It publishes to every
  input topic, calls every service and the trajectory action, and watches every output: each
  ``joint_states`` and ``commands/joint_setpoints`` message is checked (known, unique names;
  lengths; finite values; positions within the URDF limits; setpoint velocities within the
  velocity limits) and the receive times give publish rates. Setpoints the probe itself
  published (fuzz input to the driver) are recognised by their content and not counted as the
  nodes' output.
- :func:`fuzz` drives one hypothesis campaign: each generated message is sent, then the harness
  waits for the node's answer to it (the service response, the action status naming the goal, or
  the driver's next joint_states) before the next one, so a failure is pinned on the input that
  caused it and hypothesis can shrink it.

Units: s, rad, m. Everything here talks to the nodes over DDS only (the public contract).
"""
import array
import bisect
from collections import defaultdict, deque
from dataclasses import dataclass, field
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from typing import Callable, Dict, List, Optional

from action_msgs.msg import GoalStatusArray
from action_msgs.srv import CancelGoal
from control_msgs.action import FollowJointTrajectory
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from px100_control.ros.common import make_executor
from px100_control.ros.ik_services import SERVICE_QOS
from px100_control_msgs.srv import ComputeCartesianPath, ComputeIK
from rcl_interfaces.srv import (GetParameters, ListParameters, SetParameters,
                                SetParametersAtomically)
import rclpy
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, qos_profile_action_status_default, QoSProfile,
                       ReliabilityPolicy)
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger

#: the environment mark of a process shared by the stress modules (package scope):
#: test/conftest.py stops any other process a test module leaves running
SHARED_PROCESS_ENV = {'PX100_TEST_LIFETIME': 'package'}

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)
RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
SENSOR = QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)
ARM_ACTION = 'arm_controller/follow_joint_trajectory'


def stress_size(reduced: int, full: int = 10_000) -> int:
    """Return the campaign size: ``full`` with PX100_STRESS=full, else ``reduced``."""
    mode = os.environ.get('PX100_STRESS', '').strip().lower()
    if mode == 'full':
        return full
    if mode.isdigit():
        return int(mode)
    return reduced


def full_mode() -> bool:
    """Return True when PX100_STRESS=full."""
    return os.environ.get('PX100_STRESS', '').strip().lower() == 'full'


def stamp_text(stamp) -> str:
    """Return the request/goal id text of a stamp, as the contract defines it."""
    return f'{stamp.sec}.{stamp.nanosec:09d}'


def _brief(value, depth: int = 0):
    """Return value with long sequences cut to their first items and their length."""
    if hasattr(value, 'get_fields_and_field_types') and depth < 6:
        fields = ', '.join(f'{f}={_brief(getattr(value, f), depth + 1)}'
                           for f in value.get_fields_and_field_types())
        return f'{type(value).__name__}({fields})'
    if isinstance(value, (str, bytes)):
        return repr(value if len(value) <= 40 else value[:40]) + (
            f'...(len {len(value)})' if len(value) > 40 else '')
    try:
        n = len(value)
    except TypeError:
        return repr(value)
    items = [_brief(v, depth + 1) for v in list(value[:4])]
    more = f', ...(len {n})' if n > 4 else ''
    return '[' + ', '.join(items) + more + ']'


def short(msg, limit: int = 600) -> str:
    """Return a readable description of a (possibly megabyte-sized) message, cut to limit."""
    text = _brief(msg)
    return text if len(text) <= limit else text[:limit] + f'... ({len(text)} chars)'


def joint_state_key(msg: JointState) -> tuple:
    """
    Return the identity of a JointState by content (bit-exact floats, NaN sign included).

    Serialised bytes cannot serve: CDR padding bytes are not initialised, so two serialisations
    of one message differ.
    """
    def cut(text):  # strings travel as C strings: nothing after a NUL arrives
        return text.split('\x00', 1)[0]
    return (msg.header.stamp.sec, msg.header.stamp.nanosec, cut(msg.header.frame_id),
            tuple(cut(n) for n in msg.name), array.array('d', msg.position).tobytes(),
            array.array('d', msg.velocity).tobytes(), array.array('d', msg.effort).tobytes())


# -- processes -------------------------------------------------------------------------------

class Graph:
    """
    The nodes under test, one child process each; restartable.

    :param factory: callable(name, *args) -> NodeProcess (the ``node_process`` fixture, or
        :class:`px100_control.tools.processes.NodeProcess` itself)
    """

    def __init__(self, factory: Callable, args: Dict[str, List[str]] = None):
        self.factory = factory
        self.args = dict(args or {})
        self.procs = {}
        self.deaths: List[dict] = []
        self.restarts = 0

    def start(self, name: str, *args: str):
        """Start (or restart) executable ``name``; extra args replace the remembered ones."""
        if args:
            self.args[name] = list(args)
        self.procs[name] = self.factory(name, *self.args.get(name, []))
        return self.procs[name]

    def alive(self) -> Dict[str, bool]:
        """Return {name: running}."""
        return {n: p.alive() for n, p in self.procs.items()}

    def dead(self) -> List[str]:
        """Return the names of processes that are not running."""
        return [n for n, up in self.alive().items() if not up]

    def record_deaths(self, cause: str = '') -> List[str]:
        """Record every dead process (name, exit code, last output, cause); return the names."""
        names = self.dead()
        for n in names:
            p = self.procs[n]
            self.deaths.append({'node': n, 'returncode': p.proc.poll(), 'cause': cause[:2000],
                                'output_tail': p.output()[-3000:]})
        return names

    def revive(self, probe: 'Probe' = None, cause: str = '') -> List[str]:
        """Restart every dead process (recording the death); wait for it if a probe is given."""
        names = self.record_deaths(cause)
        for n in names:
            self.restarts += 1
            self.start(n)
        if names and probe is not None:
            probe.wait_ready(names)
        return names

    def stop(self, name: str) -> None:
        """Stop one process with SIGINT."""
        self.procs[name].stop()

    def stop_all(self) -> None:
        """Stop every process with SIGINT (in reverse start order)."""
        for p in reversed(list(self.procs.values())):
            p.stop()


# -- checks ----------------------------------------------------------------------------------

@dataclass
class Limits:
    """Joint facts the monitor checks against (from the RobotModel)."""

    arm: tuple
    lower: dict
    upper: dict
    velocity: dict
    known: tuple
    fingers: dict = field(default_factory=dict)
    gripper: Optional[str] = None

    @classmethod
    def from_model(cls, model) -> 'Limits':
        """Build from a px100_control RobotModel."""
        arm = tuple(model.joint_names)
        lower = {n: float(v) for n, v in zip(arm, model.lower)}
        upper = {n: float(v) for n, v in zip(arm, model.upper)}
        vel = {n: float(v) for n, v in zip(arm, model.velocity_limits)}
        known = list(arm)
        fingers = {}
        gripper = None
        if model.gripper is not None:
            g = model.gripper
            gripper = g.joint
            known.append(g.joint)
            if len(g.fingers) >= 1:
                fingers[g.fingers[0]] = (g.finger_lower, g.finger_upper)
            if len(g.fingers) >= 2:
                fingers[g.fingers[1]] = (-g.finger_upper, -g.finger_lower)
            known.extend(g.fingers)
        return cls(arm, lower, upper, vel, tuple(known), fingers, gripper)

    def position_limits(self) -> dict:
        """Return {name: (lower, upper)} of every joint that has limits."""
        out = {n: (self.lower[n], self.upper[n]) for n in self.arm}
        out.update(self.fingers)
        return out

    def velocity_ranges(self) -> dict:
        """Return {name: (-v, v)}."""
        return {n: (-v, v) for n, v in self.velocity.items()}


def _finite(values) -> bool:
    return all(math.isfinite(v) for v in values)


#: how far a MEASURED position may lie beyond a URDF limit [rad or m]: MuJoCo's joint limits
#: are stiff but soft constraints (solref 0.002 s), so a joint driven into its stop sits a few
#: 1e-5 past it, as a real joint deflects into its hard stop; setpoints stay exact (1e-6)
MEASURED_LIMIT_TOL = 1e-3


def check_joint_message(msg: JointState, lim: Limits, *, setpoint: bool,
                        pos_tol: Optional[float] = None, vel_tol: float = 1e-6) -> List[str]:
    """
    Return what is wrong with a joint_states (setpoint=False) or setpoint message ([] if valid).

    joint_states must name known joints once, carry one finite position per name (and finite
    velocity/effort if any), arm and finger positions within limits. A setpoint may name a subset
    and leave arrays empty; its positions must be within limits and its velocities within the
    velocity limits.
    """
    if pos_tol is None:
        pos_tol = 1e-6 if setpoint else MEASURED_LIMIT_TOL
    problems = []
    names = list(msg.name)
    n = len(names)
    unknown = [x for x in names if x not in lim.known]
    if unknown:
        problems.append(f'unknown joint names {unknown[:5]}')
    if len(set(names)) != n:
        problems.append(f'duplicate joint names {names[:10]}')
    pos, vel, eff = list(msg.position), list(msg.velocity), list(msg.effort)
    for label, arr in (('position', pos), ('velocity', vel), ('effort', eff)):
        if arr and len(arr) != n:
            problems.append(f'{len(arr)} {label} values for {n} names')
        if not _finite(arr):
            problems.append(f'non-finite {label}: {arr[:10]}')
    if not setpoint and len(pos) != n:
        problems.append(f'joint_states without one position per joint ({len(pos)} for {n})')
    if problems:
        return problems
    limits = lim.position_limits()
    for name, p in zip(names, pos):
        if name in limits:
            lo, hi = limits[name]
            if p < lo - pos_tol or p > hi + pos_tol:
                problems.append(f'{name} position {p:.9g} outside [{lo:.9g}, {hi:.9g}]')
    if setpoint:
        for name, v in zip(names, vel):
            if name in lim.velocity and abs(v) > lim.velocity[name] * (1 + vel_tol):
                problems.append(f'{name} velocity {v:.9g} above limit {lim.velocity[name]:.9g}')
    return problems


def script_env() -> dict:
    """Return this environment with the repository on PYTHONPATH (for helper scripts)."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = os.environ.copy()
    env['PYTHONPATH'] = root + os.pathsep + env.get('PYTHONPATH', '')
    return env


def _window_stats(ts, t0: float, t1: float) -> dict:
    """Return {'rate': Hz, 'max_gap': s, 'count': n} of sorted receive times ts in [t0, t1]."""
    if not len(ts):
        return {'rate': 0.0, 'max_gap': t1 - t0, 'count': 0}
    gap = max(ts[0] - t0, t1 - ts[-1])
    for a, b in zip(ts, ts[1:]):
        if b - a > gap:
            gap = b - a
    return {'rate': len(ts) / max(t1 - t0, 1e-9), 'max_gap': gap, 'count': len(ts)}


class RateMeter:
    """Receive times [s, monotonic] of one topic; rates and gaps over a time window."""

    def __init__(self, keep: int = 200_000):
        self.times = deque(maxlen=keep)
        self.lock = threading.Lock()

    def tick(self) -> None:
        """Record one message now."""
        with self.lock:
            self.times.append(time.monotonic())

    def count(self) -> int:
        """Return how many messages were seen."""
        with self.lock:
            return len(self.times)

    def stats(self, t0: float, t1: float) -> dict:
        """Return {'rate': Hz, 'max_gap': s, 'count': n} over [t0, t1]."""
        with self.lock:
            ts = [t for t in self.times if t0 <= t <= t1]
        return _window_stats(ts, t0, t1)


class WatchedRates(RateMeter):
    """
    Receive times of one topic recorded by ``rate_watcher.py`` (a separate, listen-only process).

    Same interface as :class:`RateMeter`; the file of float64 times is read incrementally.
    """

    def __init__(self, path: str):
        super().__init__()
        self.path = path
        self.times = array.array('d')
        self._file = None
        self._rest = b''

    def _update(self) -> None:
        if self._file is None:
            if not os.path.exists(self.path):
                return
            self._file = open(self.path, 'rb')
        data = self._rest + self._file.read()
        whole = len(data) - len(data) % 8
        self.times.frombytes(data[:whole])
        self._rest = data[whole:]

    def tick(self) -> None:
        raise TypeError('the watcher process records these times')

    def count(self) -> int:
        """Return how many messages the watcher saw."""
        with self.lock:
            self._update()
            return len(self.times)

    def stats(self, t0: float, t1: float) -> dict:
        """Return {'rate': Hz, 'max_gap': s, 'count': n} over [t0, t1]."""
        with self.lock:
            self._update()
            lo = bisect.bisect_left(self.times, t0)
            hi = bisect.bisect_right(self.times, t1)
            ts = self.times[lo:hi]
        return _window_stats(ts, t0, t1)

    def close(self) -> None:
        """Close the file."""
        if self._file is not None:
            self._file.close()


# -- probe -----------------------------------------------------------------------------------

class Probe:
    """
    The test's own ROS node: fuzz publisher, service caller and output monitor.

    :param lim: joint facts for the checks
    :param robot_name: namespace of the nodes' topics
    """

    NODES = ('sim_driver', 'ik_service', 'trajectory_server')

    def __init__(self, lim: Limits, robot_name: str = 'px100', node_name: str = 'stress_probe'):
        self.lim = lim
        self.ns = f'/{robot_name}'
        self.ctx = rclpy.Context()
        # no rclpy SIGINT handler: Ctrl-C must interrupt a campaign (and stop the nodes)
        rclpy.init(context=self.ctx, signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node(node_name, context=self.ctx)
        # the project's executor (rclpy's EventsExecutor): a Python MultiThreadedExecutor here
        # took enough CPU on 2 cores to delay joint_states reception by over a second
        self.executor = make_executor(context=self.ctx)
        self.executor.add_node(self.node)
        self._spinning = threading.Event()
        self._spinning.set()
        self.cond = threading.Condition()
        self.own_setpoints = set()
        self.own_joint_states = set()
        self.violations: List[dict] = []
        self.setpoints_seen = 0
        self.joint_states_seen = 0
        #: receive times per topic; joint_states and ee_pose as seen by the rate watcher
        #: process (the probe's own view, 'probe/<topic>', includes its own stalls)
        self.rates = defaultdict(RateMeter)
        self._watcher_dir = tempfile.mkdtemp(prefix='px100_rates_')
        self._watcher = subprocess.Popen(
            [sys.executable, os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                          'rate_watcher.py'), '--dir', self._watcher_dir,
             '--robot-name', robot_name],
            stdout=subprocess.DEVNULL, env=dict(script_env(), **SHARED_PROCESS_ENV))
        for name in ('joint_states', 'ee_pose'):
            self.rates[name] = WatchedRates(os.path.join(self._watcher_dir, f'{name}.f64'))
        #: the watcher's own 100 Hz heartbeat: its gaps are stalls of the machine, not a node's
        self.heartbeat = WatchedRates(os.path.join(self._watcher_dir, 'heartbeat.f64'))
        #: status per action goal id: its UUID in hex (also its /diagnostics hardware_id)
        self.goal_status: Dict[str, int] = {}
        self.goal_history: Dict[str, List[int]] = defaultdict(list)
        self.status_msgs = 0
        self.status_seen_goals: Dict[str, int] = defaultdict(int)
        self.diagnostics: List[DiagnosticStatus] = []
        #: diagnostics received per hardware_id (a goal or request id)
        self.diag_seen: Dict[str, int] = defaultdict(int)
        self.last_joint_state: Optional[JointState] = None
        self._setpoint_log: Optional[list] = None
        #: valid probe goals ended and those the server aborted for tracking (see goal_works)
        self.goals_checked = 0
        self.tracking_aborts: List[str] = []
        n = self.node
        t = self.topic
        n.create_subscription(JointState, t('joint_states'), self._on_joint_states, SENSOR)
        n.create_subscription(JointState, t('commands/joint_setpoints'), self._on_setpoints,
                              RELIABLE)
        n.create_subscription(JointState, t('trajectory/feedback'), self._on_feedback, RELIABLE)
        n.create_subscription(PoseStamped, t('ee_pose'), self._on_ee_pose, SENSOR)
        # goals are the trajectory action's: their statuses are on its status topic
        n.create_subscription(GoalStatusArray, t(ARM_ACTION + '/_action/status'),
                              self._on_status, qos_profile_action_status_default)
        n.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics, RELIABLE)
        self.pub_setpoints = n.create_publisher(JointState, t('commands/joint_setpoints'),
                                                RELIABLE)
        self.pub_joint_states = n.create_publisher(JointState, t('joint_states'), RELIABLE)
        self.cli_ik = n.create_client(ComputeIK, t('compute_ik'), qos_profile=SERVICE_QOS)
        self.cli_path = n.create_client(ComputeCartesianPath, t('compute_cartesian_path'),
                                        qos_profile=SERVICE_QOS)
        # rclpy 7.1's EventsExecutor does not serve action clients: the action client lives on
        # a helper node spun by a SingleThreadedExecutor (as the client's, client/calls.py)
        self.action_node = Node(node_name + '_actions', context=self.ctx)
        self.arm = ActionClient(self.action_node, FollowJointTrajectory, t(ARM_ACTION))
        self.action_executor = SingleThreadedExecutor(context=self.ctx)
        self.action_executor.add_node(self.action_node)
        self.cli_torque = n.create_client(SetBool, t('sim/torque_enable'))
        self.cli_reset = n.create_client(Trigger, t('reset'))
        self.cli_cancel = n.create_client(CancelGoal, t(ARM_ACTION + '/_action/cancel_goal'))
        self._param_clients = {}
        self.thread = threading.Thread(target=self._spin, args=(self.executor,), daemon=True)
        self.thread.start()
        self.action_thread = threading.Thread(target=self._spin, args=(self.action_executor,),
                                              daemon=True)
        self.action_thread.start()

    def _spin(self, executor) -> None:
        while self._spinning.is_set() and self.ctx.ok():
            executor.spin_once(timeout_sec=0.05)

    def topic(self, name: str) -> str:
        """Return the robot topic ``/<robot_name>/<name>``."""
        return f'{self.ns}/{name}'

    def close(self) -> None:
        """Stop the executor and the rate watcher; shut the context down."""
        if self._watcher.poll() is None:
            self._watcher.send_signal(signal.SIGINT)
            try:
                self._watcher.wait(timeout=10.0)
            except subprocess.TimeoutExpired:
                self._watcher.kill()
                self._watcher.wait()
        for meter in [*self.rates.values(), self.heartbeat]:
            if isinstance(meter, WatchedRates):
                meter.close()
        shutil.rmtree(self._watcher_dir, ignore_errors=True)
        self._spinning.clear()
        self.thread.join(timeout=5.0)
        self.action_thread.join(timeout=5.0)
        self.executor.shutdown(timeout_sec=2.0)
        self.action_executor.shutdown(timeout_sec=2.0)
        self.action_node.destroy_node()
        self.node.destroy_node()
        self.ctx.try_shutdown()

    # monitor callbacks
    def _violation(self, where: str, problems: List[str], msg) -> None:
        with self.cond:
            self.violations.append({'topic': where, 'problems': problems, 'message': short(msg),
                                    'time': time.monotonic()})

    def _on_joint_states(self, msg: JointState) -> None:
        if self.own_joint_states and joint_state_key(msg) in self.own_joint_states:
            return
        self.rates['probe/joint_states'].tick()
        problems = check_joint_message(msg, self.lim, setpoint=False)
        if problems:
            self._violation('joint_states', problems, msg)
        with self.cond:
            self.joint_states_seen += 1
            self.last_joint_state = msg
            self.cond.notify_all()

    def _on_setpoints(self, msg: JointState) -> None:
        if joint_state_key(msg) in self.own_setpoints:
            return
        log = self._setpoint_log
        if log is not None:
            log.append((msg.header.stamp.sec, msg.header.stamp.nanosec, tuple(msg.name),
                        tuple(round(v, 12) for v in msg.position)))
        self.rates['commands/joint_setpoints'].tick()
        problems = check_joint_message(msg, self.lim, setpoint=True)
        if problems:
            self._violation('commands/joint_setpoints', problems, msg)
        with self.cond:
            self.setpoints_seen += 1

    def _on_feedback(self, msg: JointState) -> None:
        self.rates['trajectory/feedback'].tick()
        problems = check_joint_message(msg, self.lim, setpoint=True)
        if problems:
            self._violation('trajectory/feedback', problems, msg)

    def _on_ee_pose(self, msg: PoseStamped) -> None:
        self.rates['probe/ee_pose'].tick()
        p, o = msg.pose.position, msg.pose.orientation
        if not _finite([p.x, p.y, p.z, o.x, o.y, o.z, o.w]):
            self._violation('ee_pose', ['non-finite pose'], msg)

    def _on_status(self, msg: GoalStatusArray) -> None:
        with self.cond:
            self.status_msgs += 1
            for s in msg.status_list:
                gid = bytes(s.goal_info.goal_id.uuid).hex()
                self.status_seen_goals[gid] = self.status_msgs
                if self.goal_status.get(gid) != s.status:
                    self.goal_history[gid].append(s.status)
                self.goal_status[gid] = s.status
            self.cond.notify_all()

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        with self.cond:
            self.diagnostics.extend(msg.status)
            del self.diagnostics[:-5000]
            for st in msg.status:
                self.diag_seen[st.hardware_id] += 1
            self.cond.notify_all()

    # waiting
    def wait_for(self, predicate: Callable[[], bool], timeout: float) -> bool:
        """Wait until predicate() (evaluated under the lock) is true; False on timeout."""
        with self.cond:
            return self.cond.wait_for(predicate, timeout)

    def wait_joint_states(self, count: int = 2, timeout: float = 1.0) -> bool:
        """Wait until ``count`` more joint_states arrived."""
        with self.cond:
            target = self.joint_states_seen + count
        return self.wait_for(lambda: self.joint_states_seen >= target, timeout)

    def wait_ready(self, nodes=NODES, timeout: float = 20.0) -> None:
        """
        Wait until the given nodes are up and matched with the probe.

        :raises TimeoutError: naming what is missing
        """
        deadline = time.monotonic() + timeout
        checks = {
            'sim_driver': lambda: (self.wait_joint_states(3, 0.2)
                                   and self.rates['joint_states'].count() >= 3   # the watcher
                                   and self.cli_torque.service_is_ready()
                                   and self.cli_reset.service_is_ready()
                                   and self.pub_setpoints.get_subscription_count() > 0),
            'ik_service': lambda: (self.cli_ik.service_is_ready()
                                   and self.cli_path.service_is_ready()),
            'trajectory_server': lambda: (self.arm.server_is_ready()
                                          and self.cli_cancel.service_is_ready()),
        }
        pending = [n for n in nodes if n in checks]
        while pending and time.monotonic() < deadline:
            pending = [n for n in pending if not checks[n]()]
            if pending:
                time.sleep(0.05)
        if pending:
            raise TimeoutError(f'nodes not ready after {timeout} s: {pending}')
        # discovery of the probe's subscriptions by the nodes' publishers
        time.sleep(0.3)

    # sending
    def record_setpoints(self, on: bool) -> list:
        """Start (on) or stop keeping the identity of every node setpoint; return the log."""
        log = self._setpoint_log or []
        self._setpoint_log = [] if on else None
        return log

    def publish_joint_state(self, msg: JointState) -> None:
        """Publish a measurement as the probe, as if a second driver (not checked as output)."""
        self.own_joint_states.add(joint_state_key(msg))
        self.pub_joint_states.publish(msg)

    def publish_setpoint(self, msg: JointState) -> None:
        """Publish a setpoint as the probe (not checked as node output)."""
        self.own_setpoints.add(joint_state_key(msg))
        self.pub_setpoints.publish(msg)

    def send_goal(self, goal, timeout: float):
        """
        Send a FollowJointTrajectory goal; return its ClientGoalHandle (None on timeout).

        Sent from the executor's thread: rclpy 7.1.6's ActionClient registers a request's
        future after sending it, so a reply taken in between is dropped (ros2/rclpy#1123).
        """
        task = self.action_executor.create_task(lambda: self.arm.send_goal_async(goal))
        done = threading.Event()
        task.add_done_callback(lambda _: task.result().add_done_callback(lambda _: done.set()))
        if not done.wait(timeout):
            return None
        return task.result().result()

    def goal_result(self, handle, timeout: float):
        """Return the GetResult response of an accepted goal (None on timeout)."""
        task = self.action_executor.create_task(handle.get_result_async)
        done = threading.Event()
        task.add_done_callback(lambda _: task.result().add_done_callback(lambda _: done.set()))
        if not done.wait(timeout):
            return None
        return task.result().result()

    def call(self, client, request, timeout: float = 2.0):
        """Call a service; return the response or None on timeout."""
        future = client.call_async(request)
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout):
            client.remove_pending_request(future)
            return None
        return future.result()

    def param_client(self, node: str, kind: str):
        """Return a client for ``/<robot_name>/<node>/<kind>`` (set_parameters, ...)."""
        types = {'set_parameters': SetParameters, 'get_parameters': GetParameters,
                 'set_parameters_atomically': SetParametersAtomically,
                 'list_parameters': ListParameters}
        key = (node, kind)
        if key not in self._param_clients:
            self._param_clients[key] = self.node.create_client(
                types[kind], f'{self.ns}/{node}/{kind}')
        return self._param_clients[key]

    def list_parameters(self, node: str, timeout: float = 5.0) -> List[str]:
        """Return the names of a node's parameters."""
        cli = self.param_client(node, 'list_parameters')
        cli.wait_for_service(timeout_sec=timeout)
        res = self.call(cli, ListParameters.Request(), timeout)
        return list(res.result.names) if res is not None else []

    def get_parameters(self, node: str, names: List[str], timeout: float = 2.0):
        """Return {name: ParameterValue} of a node."""
        cli = self.param_client(node, 'get_parameters')
        cli.wait_for_service(timeout_sec=timeout)
        res = self.call(cli, GetParameters.Request(names=list(names)), timeout)
        return dict(zip(names, res.values)) if res is not None else None

    def new_violations(self, since: int) -> List[dict]:
        """Return the violations recorded after index ``since``."""
        with self.cond:
            return self.violations[since:]


# -- campaigns -------------------------------------------------------------------------------

@dataclass
class Campaign:
    """Counters of one fuzz campaign (one topic or service)."""

    target: str
    tried: int = 0
    answered: int = 0
    unanswered: List[str] = field(default_factory=list)
    failures: List[str] = field(default_factory=list)
    seconds: float = 0.0
    send_seconds: float = 0.0
    slowest: list = field(default_factory=list)
    #: the inputs during whose handling joint_states went silent longest: (gap s, input)
    stalls: list = field(default_factory=list)
    rates: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """Return the figures as plain data."""
        return {'target': self.target, 'tried': self.tried, 'answered': self.answered,
                'unanswered': len(self.unanswered), 'unanswered_examples':
                self.unanswered[:5], 'failures': self.failures[:5], 'seconds':
                round(self.seconds, 2), 'send_seconds': round(self.send_seconds, 2),
                'slowest_answers': self.slowest, 'worst_stalls': self.stalls,
                'rates': self.rates}


class FuzzFailure(AssertionError):
    """A node died, stalled or let an invalid value through on a fuzzed input."""


def fuzz(strategy, send: Callable, count: int, graph: Graph, probe: Probe, target: str,
         *, derandomize: bool = True, shrink: bool = True) -> Campaign:
    """
    Run ``count`` hypothesis examples of ``strategy`` through ``send(msg) -> answered``.

    After each example the processes must be alive and no new violation recorded; otherwise
    :class:`FuzzFailure` is raised, hypothesis shrinks the input (dead nodes are restarted
    before every example) and the minimal failing input is re-raised. Unanswered inputs (no
    reply within the bound) are counted, not raised: the caller decides what to require.
    """
    from hypothesis import given, HealthCheck, Phase, settings

    camp = Campaign(target)
    phases = (Phase.explicit, Phase.generate) + ((Phase.shrink,) if shrink else ())

    @settings(max_examples=count, deadline=None, database=None, derandomize=derandomize,
              suppress_health_check=list(HealthCheck), phases=phases, print_blob=False)
    @given(strategy)
    def one(msg):
        graph.revive(probe, cause=f'died before an input to {target}')
        mark = len(probe.violations)
        camp.tried += 1
        ts = time.monotonic()
        answered = send(msg)
        dt = time.monotonic() - ts
        camp.send_seconds += dt
        if len(camp.slowest) < 3 or dt > camp.slowest[-1][0]:
            camp.slowest.append((round(dt, 3), short(msg, 300)))
            camp.slowest.sort(key=lambda x: -x[0])
            del camp.slowest[3:]
        gap = probe.rates['joint_states'].stats(ts, time.monotonic())['max_gap']
        if gap > 0.2 and (len(camp.stalls) < 3 or gap > camp.stalls[-1][0]):
            camp.stalls.append((round(gap, 3), short(msg, 300)))
            camp.stalls.sort(key=lambda x: -x[0])
            del camp.stalls[3:]
        if answered:
            camp.answered += 1
        elif answered is not None:
            camp.unanswered.append(short(msg, 300))
        dead = graph.dead()
        if dead:
            # give the process a moment to flush its traceback before recording it
            time.sleep(0.2)
            graph.revive(probe, cause=f'{target}: {short(msg, 1500)}')
            raise FuzzFailure(f'{dead} died on this {target} input: {short(msg)}')
        bad = probe.new_violations(mark)
        if bad:
            raise FuzzFailure(f'invalid output after this {target} input: {bad[:3]}; '
                              f'input: {short(msg)}')

    t0 = time.monotonic()
    try:
        one()
    except FuzzFailure as exc:
        camp.failures.append(str(exc))
        raise
    finally:
        t1 = time.monotonic()
        camp.seconds = t1 - t0
        # the watcher's view (the nodes' rate), and the probe's own (with its own stalls)
        for name in ('joint_states', 'ee_pose', 'probe/joint_states'):
            camp.rates[name] = probe.rates[name].stats(t0, t1)
    return camp
