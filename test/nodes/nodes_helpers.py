"""Test-side rclpy clients of the trajectory_server and ik_service (real nodes over DDS)."""
import itertools
import threading
import time

from action_msgs.msg import GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

#: seconds a node process may take to come up on a loaded 2-core machine
STARTUP_TIMEOUT = 90.0
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)
NAMES = {v: k[7:] for k, v in vars(GoalStatus).items() if k.startswith('STATUS_')}
_SEQ = itertools.count(1)


def unique_stamp() -> Time:
    """Return a stamp unique within this test process (wall time + a counter)."""
    ns = time.time_ns() + next(_SEQ)
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def duration(t: float) -> Duration:
    """Return a Duration message of t seconds."""
    return Duration(sec=int(t), nanosec=int(round((t - int(t)) * 1e9)))


def wait_for(predicate, timeout: float, period: float = 0.01) -> bool:
    """Poll predicate until true or timeout [s]; return its last value."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period)
    return bool(predicate())


class TrajectoryClient(Node):
    """Publish goals, follow trajectory/status, /diagnostics and joint_states, call cancel."""

    def __init__(self, **kwargs):
        kwargs.setdefault('namespace', '/px100')   # the robot's: names below are relative
        super().__init__('test_trajectory_client', **kwargs)
        self.lock = threading.Lock()
        self.history = {}  # (sec, nanosec) -> [status names in arrival order]
        self.diagnostics = []
        self.joint_state = None
        self.setpoints = []
        self.pub = self.create_publisher(JointTrajectory, 'trajectory/goal', 10)
        self.create_subscription(GoalStatusArray, 'trajectory/status', self._on_status,
                                 LATCHED)
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, 50)
        self.create_subscription(JointState, 'joint_states', self._on_js, 10)
        self.create_subscription(JointState, 'commands/joint_setpoints', self._on_sp, 100)
        self.cancel_client = self.create_client(CancelGoal, 'trajectory/cancel')

    def _on_status(self, msg):
        with self.lock:
            for st in msg.status_list:
                key = (st.goal_info.stamp.sec, st.goal_info.stamp.nanosec)
                seq = self.history.setdefault(key, [])
                name = NAMES[st.status]
                if not seq or seq[-1] != name:
                    seq.append(name)

    def _on_diag(self, msg):
        with self.lock:
            self.diagnostics.extend(msg.status)

    def _on_js(self, msg):
        with self.lock:
            self.joint_state = (time.monotonic(), dict(zip(msg.name, msg.position)))

    def _on_sp(self, msg):
        with self.lock:
            self.setpoints.append((time.monotonic(), dict(zip(msg.name, msg.position)),
                                   dict(zip(msg.name, msg.velocity))))

    def send(self, names, points, stamp=None) -> Time:
        """
        Publish a goal; points = [(time_from_start, positions[, velocities])]; return its id.

        The publisher is matched with the server first so the message is not lost.
        """
        wait_for(lambda: self.pub.get_subscription_count() > 0, 10.0)
        stamp = stamp or unique_stamp()
        msg = JointTrajectory()
        msg.header.stamp = stamp
        msg.joint_names = list(names)
        for p in points:
            pt = JointTrajectoryPoint()
            pt.time_from_start = duration(p[0])
            pt.positions = [float(x) for x in p[1]]
            if len(p) > 2:
                pt.velocities = [float(x) for x in p[2]]
            msg.points.append(pt)
        self.pub.publish(msg)
        return stamp

    def statuses(self, stamp):
        """Return the status names seen for a goal so far."""
        with self.lock:
            return list(self.history.get((stamp.sec, stamp.nanosec), []))

    def wait_terminal(self, stamp, timeout: float):
        """Wait for SUCCEEDED/CANCELED/ABORTED of a goal; return its name or None."""
        terminal = ('SUCCEEDED', 'CANCELED', 'ABORTED')
        ok = wait_for(lambda: any(s in terminal for s in self.statuses(stamp)), timeout)
        return self.statuses(stamp)[-1] if ok else None

    def wait_status(self, stamp, name: str, timeout: float) -> bool:
        """Wait until a goal has reached the status called name."""
        return wait_for(lambda: name in self.statuses(stamp), timeout)

    def diagnostics_for(self, stamp):
        """Return the /diagnostics statuses whose hardware_id is this goal's id."""
        gid = f'{stamp.sec}.{stamp.nanosec:09d}'
        with self.lock:
            return [d for d in self.diagnostics if d.hardware_id == gid]

    def last_diagnostic(self, stamp, timeout: float = 5.0):
        """Wait for and return the last /diagnostics status of a goal (None if none came)."""
        wait_for(lambda: self.diagnostics_for(stamp), timeout)
        found = self.diagnostics_for(stamp)
        return found[-1] if found else None

    def measured(self):
        """Return the latest joint_states as {name: position} (or None)."""
        with self.lock:
            return None if self.joint_state is None else dict(self.joint_state[1])

    def setpoint_count(self) -> int:
        """Return how many setpoints this client saw."""
        with self.lock:
            return len(self.setpoints)

    def cancel(self, stamp=None, uuid=None, timeout: float = 5.0):
        """Call trajectory/cancel; return the response (None on timeout)."""
        assert self.cancel_client.wait_for_service(timeout_sec=timeout)
        req = CancelGoal.Request()
        if stamp is not None:
            req.goal_info.stamp = stamp
        if uuid is not None:
            req.goal_info.goal_id.uuid = list(uuid)
        fut = self.cancel_client.call_async(req)
        wait_for(fut.done, timeout)
        return fut.result() if fut.done() else None


def start_node(processes, name: str, *params: str):
    """
    Start an installed executable with ``-p`` parameters; return the NodeProcess.

    ``bringup`` starts without its camera process (``--no-camera``): the node tests do not look
    at images, and a camera renders on ~0.3 core.
    """
    from px100_control.tools.processes import NodeProcess
    args = (['--no-camera'] if name == 'bringup' else []) + ['--ros-args']
    for p in params:
        args += ['-p', p]
    proc = NodeProcess(name, args)
    processes.append(proc)
    return proc


class IkClient(Node):
    """Send ik/request and ik/path_request; collect every reply by stamp (counting repeats)."""

    def __init__(self, name: str = 'test_ik_client', **kwargs):
        from diagnostic_msgs.msg import DiagnosticStatus
        from geometry_msgs.msg import PoseArray, PoseStamped
        kwargs.setdefault('namespace', '/px100')   # the robot's: names below are relative
        super().__init__(name, **kwargs)
        self.lock = threading.Lock()
        self.solutions = {}   # (sec, nanosec) -> [JointState]
        self.statuses = {}    # 'sec.nanosec' -> [DiagnosticStatus]
        self.paths = {}       # (sec, nanosec) -> [JointTrajectory]
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.pub = self.create_publisher(PoseStamped, 'ik/request', qos)
        self.pub_path = self.create_publisher(PoseArray, 'ik/path_request', 10)
        self.create_subscription(JointState, 'ik/solution', self._on_solution, qos)
        self.create_subscription(DiagnosticStatus, 'ik/status', self._on_status, qos)
        self.create_subscription(JointTrajectory, 'ik/path_solution', self._on_path, 10)

    def _on_solution(self, msg):
        with self.lock:
            self.solutions.setdefault((msg.header.stamp.sec, msg.header.stamp.nanosec),
                                      []).append(msg)

    def _on_status(self, msg):
        with self.lock:
            self.statuses.setdefault(msg.hardware_id, []).append(msg)

    def _on_path(self, msg):
        with self.lock:
            self.paths.setdefault((msg.header.stamp.sec, msg.header.stamp.nanosec),
                                  []).append(msg)

    def ready(self) -> bool:
        """Return True once the ik_service matched our request publisher and reply readers."""
        return (self.pub.get_subscription_count() > 0
                and self.count_publishers(self.resolve_topic_name('ik/status')) > 0
                and self.pub_path.get_subscription_count() > 0)

    def request(self, pose, frame_id: str = '', stamp=None) -> Time:
        """Publish one ik/request for a geometry_msgs/Pose; return its id stamp."""
        from geometry_msgs.msg import PoseStamped
        msg = PoseStamped()
        msg.header.stamp = stamp or unique_stamp()
        msg.header.frame_id = frame_id
        msg.pose = pose
        self.pub.publish(msg)
        return msg.header.stamp

    def request_path(self, poses, frame_id: str = '') -> Time:
        """Publish one ik/path_request; return its id stamp."""
        from geometry_msgs.msg import PoseArray
        msg = PoseArray()
        msg.header.stamp = unique_stamp()
        msg.header.frame_id = frame_id
        msg.poses = list(poses)
        self.pub_path.publish(msg)
        return msg.header.stamp

    def reply(self, stamp, timeout: float = 10.0):
        """Wait for the solution and status of a request; return (JointState, status)."""
        key, hw = (stamp.sec, stamp.nanosec), f'{stamp.sec}.{stamp.nanosec:09d}'

        def both():
            with self.lock:
                return key in self.solutions and hw in self.statuses
        assert wait_for(both, timeout), f'no reply to ik request {hw}'
        with self.lock:
            return self.solutions[key][0], self.statuses[hw][0]

    def path_reply(self, stamp, timeout: float = 20.0):
        """Wait for the path solution and status of a path request; return both."""
        key, hw = (stamp.sec, stamp.nanosec), f'{stamp.sec}.{stamp.nanosec:09d}'

        def both():
            with self.lock:
                return key in self.paths and hw in self.statuses
        assert wait_for(both, timeout), f'no reply to ik path request {hw}'
        with self.lock:
            return self.paths[key][0], self.statuses[hw][0]

    def counts(self, stamp):
        """Return (number of solutions, number of statuses) received for a request."""
        with self.lock:
            return (len(self.solutions.get((stamp.sec, stamp.nanosec), [])),
                    len(self.statuses.get(f'{stamp.sec}.{stamp.nanosec:09d}', [])))


def status_values(status) -> dict:
    """Return the KeyValue list of a DiagnosticStatus as a dict."""
    return {kv.key: kv.value for kv in status.values}
