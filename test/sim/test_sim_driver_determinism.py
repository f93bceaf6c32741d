"""
The sim_driver node, run twice with the same scene and the same commands: identical worlds.

test_world_determinism.py checks the engine; this checks the node around it (setpoint parsing,
the physics thread's chunks, the world publisher's contact queries, DDS). Same commands means
commands at the same simulated instants: a driver at ``real_time_factor`` 0 on its own clock
applies a setpoint when it arrives, so wall-clock timing would choose the instant. Here the
test is the clock, as fast as the driver answers: the driver follows ``/clock``
(``use_sim_time``), the test advances it 20 ms at a time, waits for the joint_states sample of
that instant, sends the setpoints due then and waits until the driver holds them (read under
its lock), then advances again. The script is test_world_determinism's pick and place of the
green cube (minimum-jerk setpoints at 50 Hz). Both runs must publish bit-identical
joint_states and world/markers at identical stamps, and the cube must really be carried.
"""
import threading
import time

import numpy as np
from px100_control.control.trajectory import minimum_jerk_scaling
from px100_control.models.registry import load_robot
from px100_control.ros.common import make_executor
from px100_control.ros.sim_driver_node import SimDriverNode
from px100_control.ros.world_msgs import markers_of
import pytest
import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from test_world_determinism import _script, ARM, TARGET
from visualization_msgs.msg import MarkerArray

pytestmark = pytest.mark.ros

TICK_NS = 20_000_000            # the clock step [ns] (one joint_states sample per step)
T0_NS = 1_000_000_000           # the first /clock value (the driver's simulated time 0)
#: the probe keeps every message (joint_states is volatile, the world topics transient local)
KEEP_ALL = {durability: QoSProfile(depth=10000, reliability=ReliabilityPolicy.RELIABLE,
                                   durability=durability)
            for durability in (DurabilityPolicy.VOLATILE, DurabilityPolicy.TRANSIENT_LOCAL)}


def _commands(model, start):
    """Return ({tick: [(names, position, effort)]}, ticks): the script as setpoints at 50 Hz."""
    out, tick = {}, 0
    q0 = np.array(model.sleep, dtype=float)
    for duration, q1, effort in _script(model, start):
        if effort is not None:
            out.setdefault(tick, []).append((['gripper'], [], [effort]))
        n = int(round(duration * 1e9 / TICK_NS))
        for k in range(n):
            if q1 is not None:
                s = float(minimum_jerk_scaling((k + 1) * TICK_NS * 1e-9, duration)[0])
                out.setdefault(tick + k, []).append((ARM, list(q0 + s * (q1 - q0)), []))
        if q1 is not None:
            q0 = q1
        tick += n
    return out, tick + 25                # then half a second to settle


def _holds(sim, names, position, effort) -> bool:
    """Return True when the driver's simulator holds this setpoint."""
    if effort:
        return sim.g_mode == 'effort' and sim.g_command == effort[0]
    return all(sim.q_ref[sim.names.index(n)] == min(max(v, sim.lower[i]), sim.upper[i])
               for i, (n, v) in enumerate(zip(names, position)))


class _Run:
    """One driver and a probe in a context of their own."""

    def __init__(self):
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.driver = SimDriverNode(context=self.ctx, parameter_overrides=[
            Parameter('use_sim_time', value=True), Parameter('scene', value='pick_place')])
        self.node = rclpy.create_node('determinism_probe', context=self.ctx)
        self.lock = threading.Lock()
        self.js, self.markers, self.held = [], [], []
        latched = DurabilityPolicy.TRANSIENT_LOCAL
        for kind, topic, store, durability in (
                (JointState, 'joint_states', self.js, DurabilityPolicy.VOLATILE),
                (MarkerArray, 'world/markers', self.markers, latched),
                (String, 'world/held_object', self.held, latched)):
            self.node.create_subscription(kind, f'/px100/{topic}', self._keep(store),
                                          KEEP_ALL[durability])
        self.clock = self.node.create_publisher(Clock, '/clock', 10)
        self.setpoints = self.node.create_publisher(JointState, '/px100/commands/joint_setpoints',
                                                    10)
        self.executor = make_executor(context=self.ctx, kind='single')
        for n in (self.driver, self.node):
            self.executor.add_node(n)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def _keep(self, store):
        def cb(msg):
            with self.lock:
                store.append(msg)
        return cb

    def _wait(self, predicate, what, timeout=20.0, again=None):
        end = time.monotonic() + timeout
        resend = time.monotonic() + 0.5
        while not predicate():
            now = time.monotonic()
            assert now < end, f'timed out waiting for {what() if callable(what) else what}'
            if again is not None and now > resend:     # (/clock is best effort)
                again()
                resend = now + 0.5
            time.sleep(0.001)

    def _stamp_seen(self, ns) -> bool:
        with self.lock:
            if not self.js:
                return False
            s = self.js[-1].header.stamp
        return s.sec * 1_000_000_000 + s.nanosec >= ns

    def tick_to(self, ns):
        """Publish /clock = ns and wait for the joint_states sample stamped there."""
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(ns, 1_000_000_000)
        self.clock.publish(msg)
        self._wait(lambda: self._stamp_seen(ns), f'joint_states at {ns} ns',
                   again=lambda: self.clock.publish(msg))

    def send(self, names, position, effort):
        """Publish a setpoint and wait until the driver holds it."""
        self.setpoints.publish(JointState(name=list(names), position=list(position),
                                          effort=list(effort)))

        def held():
            with self.driver._lock:
                return _holds(self.driver.sim, names, position, effort)
        self._wait(held, f'the driver to hold {names}')

    def close(self):
        self.executor.shutdown(timeout_sec=2.0)
        self.thread.join(5.0)
        self.driver.destroy_node()
        self.node.destroy_node()
        self.ctx.try_shutdown()


def _run_script(model):
    """Run the pick and place on a fresh driver; return what the probe received."""
    run = _Run()
    try:
        end = time.monotonic() + 20
        while run.setpoints.get_subscription_count() < 1 or run.clock.get_subscription_count() < 1:
            assert time.monotonic() < end, 'the driver does not subscribe'
            time.sleep(0.01)
        run.tick_to(T0_NS)
        with run.driver._lock:
            start = run.driver.sim.object_poses()['green_cube'][0]
        commands, ticks = _commands(model, start)
        for tick in range(ticks):
            for names, position, effort in commands.get(tick, ()):
                run.send(names, position, effort)
            run.tick_to(T0_NS + (tick + 1) * TICK_NS)
        # the last world/markers the driver published (its world publisher ran in the sample
        # just awaited, under the lock): markers and joint_states are separate topics, so it
        # may come after that sample (a wait for any marker within a world period of the end
        # took the one before it: CI, 3 workers)
        with run.driver._lock:
            last_ns = run.driver.world.last_stamp_ns

        def last_marker():
            with run.lock:
                s = run.markers[-1].markers[0].header.stamp if run.markers else None
            return None if s is None else s.sec * 1_000_000_000 + s.nanosec
        run._wait(lambda: (last_marker() or 0) >= last_ns,
                  lambda: f'world/markers stamped {last_ns} ns, last {last_marker()}')
        with run.lock:
            js = [(m.header.stamp.sec, m.header.stamp.nanosec, tuple(m.position),
                   tuple(m.velocity), tuple(m.effort)) for m in run.js]
            markers = [[(w.name, w.position, w.orientation) for w in markers_of(m)]
                       + [(m.markers[0].header.stamp.sec, m.markers[0].header.stamp.nanosec)]
                       for m in run.markers]
            held = [m.data for m in run.held]
        return js, markers, held, start
    finally:
        run.close()


def test_same_commands_at_the_same_instants_give_identical_worlds():
    """Two runs of the node: identical joint_states and object poses, stamp for stamp."""
    model = load_robot('px100')
    t0 = time.monotonic()
    first, second = _run_script(model), _run_script(model)
    js, markers, held, start = first
    assert len(js) > 400 and len(markers) > 150            # 8.5 s of simulated time
    assert js == second[0]
    assert markers == second[1]
    assert held == second[2]
    assert 'green_cube' in held                              # picked by contact ...
    end = {name: p for name, p, _ in markers[-1][:-1]}['green_cube']
    assert np.hypot(end[0] - TARGET[0], end[1] - TARGET[1]) < 0.01, end   # ... and placed
    assert np.hypot(end[0] - start[0], end[1] - start[1]) > 0.05
    print(f'two runs of {len(js)} samples in {time.monotonic() - t0:.1f} s')
