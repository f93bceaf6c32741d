"""
sim_driver over DDS: the real rclpy node, talked to by a probe node in a private domain.

Most tests run the node in-process (``spin_node`` fixture); the rate test runs the installed
executable as a process, the way ``ros2 run px100_control sim_driver`` does.
"""
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
import numpy as np
from px100_control.models.registry import load_robot
from px100_control.ros.common import LATCHED_QOS
from px100_control.ros.sim_driver_node import SimDriverNode
import pytest
import rclpy
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger

pytestmark = pytest.mark.ros

ARM = ['waist', 'shoulder', 'elbow', 'wrist_angle']
NAMES = ARM + ['gripper', 'left_finger', 'right_finger']


def stamp_s(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


class Probe:
    """A test node: records what sim_driver publishes and sends it commands."""

    def __init__(self, context, description=False, light=False):
        self.node = rclpy.create_node('sim_probe', context=context)
        self.lock = threading.Lock()
        self.js, self.ee, self.diag, self.clock, self.desc = [], [], [], [], []
        n = self.node
        n.create_subscription(JointState, '/px100/joint_states', self._keep(self.js), 100)
        n.create_subscription(Clock, '/clock', self._keep(self.clock), 100)
        if not light:
            n.create_subscription(PoseStamped, '/px100/ee_pose', self._keep(self.ee), 100)
            n.create_subscription(DiagnosticArray, '/diagnostics', self._keep(self.diag), 100)
        if description:
            n.create_subscription(String, '/px100/robot_description', self._keep(self.desc),
                                  LATCHED_QOS)
        self.pub = n.create_publisher(JointState, '/px100/commands/joint_setpoints', 10)
        self.torque = n.create_client(SetBool, '/px100/sim/torque_enable')
        self.reset = n.create_client(Trigger, '/px100/reset')

    def _keep(self, store):
        def cb(msg):
            with self.lock:
                store.append((time.monotonic(), msg))
        return cb

    def wait(self, predicate, timeout=10.0, what='condition', seen=None):
        """Wait (the lock held for each check) until predicate(); fail with seen() if given."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                if predicate():
                    return
            time.sleep(0.02)
        with self.lock:
            shown = f': {seen()}' if seen is not None else ''
        raise AssertionError(f'timed out ({timeout} s) waiting for {what}{shown}')

    def last_js(self) -> JointState:
        with self.lock:
            return self.js[-1][1]

    def send(self, names, position=(), velocity=(), effort=()):
        msg = JointState(name=list(names), position=[float(x) for x in position],
                         velocity=[float(x) for x in velocity],
                         effort=[float(x) for x in effort])
        self.pub.publish(msg)

    def call(self, client, request, timeout=5.0):
        assert client.wait_for_service(timeout_sec=timeout), client.srv_name
        future = client.call_async(request)
        deadline = time.monotonic() + timeout
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert future.done(), f'{client.srv_name} did not answer'
        return future.result()

    def wait_connected(self, timeout=10.0):
        deadline = time.monotonic() + timeout
        while self.pub.get_subscription_count() < 1 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert self.pub.get_subscription_count() >= 1, 'sim_driver does not subscribe'


def start(spin_node, rclpy_context, description=False, light=False, samples=3, **params):
    driver = SimDriverNode(context=rclpy_context, parameter_overrides=[
        Parameter(k, value=v) for k, v in params.items()])
    probe = Probe(rclpy_context, description, light)
    spin_node(driver, probe.node)
    probe.wait(lambda: len(probe.js) >= samples, what='joint_states')
    probe.wait_connected()
    return driver, probe


def test_publishes_joint_states_pose_and_description(spin_node, rclpy_context):
    """joint_states (Interbotix order, pos/vel/effort), ee_pose (FK) and a latched URDF."""
    driver, probe = start(spin_node, rclpy_context, description=True)
    model = load_robot('px100')
    js = probe.last_js()
    assert list(js.name) == NAMES
    assert len(js.position) == len(js.velocity) == len(js.effort) == 7
    np.testing.assert_allclose(js.position[:4], model.sleep, atol=2e-3)
    assert js.position[5] == pytest.approx(0.019494, abs=1e-4)
    assert js.position[6] == pytest.approx(-js.position[5])
    probe.wait(lambda: probe.ee and probe.desc, what='ee_pose and robot_description')
    with probe.lock:
        pose = probe.ee[-1][1]
        urdf = probe.desc[-1][1].data
    assert pose.header.frame_id == 'px100/base_link'
    T = model.fk(model.sleep)
    np.testing.assert_allclose([pose.pose.position.x, pose.pose.position.y,
                                pose.pose.position.z], T[:3, 3], atol=3e-3)
    assert '<link name="px100/base_link"' in urdf and 'name="waist"' in urdf


def test_tracks_setpoints_within_one_milliradian(spin_node, rclpy_context):
    """Position setpoints are reached and held within 1 mrad (default gains, own fast clock)."""
    driver, probe = start(spin_node, rclpy_context, real_time_factor=0.0)
    target = [0.5, 0.2, -0.3, 0.4]
    probe.send(ARM, target)
    probe.wait(lambda: np.abs(np.array(probe.js[-1][1].position[:4]) - target).max() < 0.01,
               timeout=60, what='the setpoint')
    t0 = stamp_s(probe.last_js())
    probe.wait(lambda: stamp_s(probe.js[-1][1]) > t0 + 4.0, timeout=60, what='4 s sim time')
    js = probe.last_js()
    err = np.abs(np.array(js.position[:4]) - target)
    assert err.max() < 1e-3, err
    assert np.abs(js.velocity[:4]).max() < 1e-2
    assert abs(js.effort[1]) > 0.05            # the shoulder holds against gravity


def test_bad_messages_are_refused_while_publishing_continues(spin_node, rclpy_context):
    """NaN, inf, unknown names, mismatches, duplicates, out-of-limit: refused with a reason."""
    driver, probe = start(spin_node, rclpy_context)
    held = list(probe.last_js().position[:4])
    bad = [
        ((ARM, [0.0, float('nan'), 0.0, 0.0]), 'NaN'),
        ((['waist'], [float('inf')]), 'inf'),
        ((['waist', 'forearm_roll'], [0.0, 0.0]), 'forearm_roll'),
        ((ARM, [0.0, 0.1]), 'names but 2 position'),
        ((['waist', 'waist'], [0.1, 0.2]), 'duplicate'),
        ((['shoulder'], [2.5]), 'outside its limits'),
        ((['elbow'], [0.1], [9.0]), 'exceeds its limit'),
        ((['waist'], [], [], [0.3]), 'only for the gripper'),
        (([], []), 'no joint'),
    ]
    n_js = len(probe.js)
    for k, (args, words) in enumerate(bad):
        probe.send(*args)
        probe.wait(lambda: len(probe.diag) > k, what=f'diagnostic for {words}')
        with probe.lock:
            status = probe.diag[k][1].status[0]
        assert status.level == status.ERROR
        assert words in status.message, (words, status.message)
        assert 'refused' in status.message
    probe.wait(lambda: len(probe.js) > n_js + 20, timeout=10.0,   # they kept coming meanwhile
               what='20 more joint_states', seen=lambda: f'{len(probe.js) - n_js} more')
    js = probe.last_js()
    np.testing.assert_allclose(js.position[:4], held, atol=2e-3)   # nothing executed
    probe.send(['waist'], [0.3])                   # and it still obeys a valid setpoint
    probe.wait(lambda: abs(probe.js[-1][1].position[0] - 0.3) < 0.01, what='valid setpoint')


def test_torque_off_makes_the_arm_fall_and_reset_recovers(spin_node, rclpy_context):
    """
    torque_enable(false): the arm falls under gravity; reset: back at the sleep pose.

    No scene (the default one's table would catch the falling arm before its joint limit). The
    driver's own clock as fast as it can go: what is checked is where the arm goes, not when.
    """
    driver, probe = start(spin_node, rclpy_context, scene='', real_time_factor=0.0)
    probe.send(ARM, [0.0, 0.0, 0.0, 0.0])
    probe.wait(lambda: np.abs(probe.js[-1][1].position[:4]).max() < 2e-3, timeout=30,
               what='home pose')
    assert probe.call(probe.torque, SetBool.Request(data=False)).success
    probe.wait(lambda: probe.js[-1][1].position[1] > 1.0, timeout=30, what='the arm falling')
    js = probe.last_js()
    assert js.velocity[1] > 0.0 or js.position[1] == pytest.approx(1.8675, abs=1e-3)
    assert all(e == 0.0 for e in js.effort[:4])  # nothing drives the joints
    assert probe.call(probe.reset, Trigger.Request()).success
    probe.wait(lambda: abs(probe.js[-1][1].position[1] + 1.88) < 1e-3, what='sleep pose')
    assert probe.call(probe.torque, SetBool.Request(data=True)).success


def test_gripper_effort_and_object_grasp(spin_node, rclpy_context):
    """Gripper effort closes the fingers; an object_width stops them: a grasp in joint_states."""
    driver, probe = start(spin_node, rclpy_context, object_width=0.034)
    probe.send(['gripper'], effort=[-0.4])
    probe.wait(lambda: probe.js[-1][1].position[5] < 0.0171, timeout=30, what='the grasp')
    time.sleep(0.3)
    js = probe.last_js()
    assert js.position[5] == pytest.approx(0.017, abs=1e-5)   # 34 mm object: fingers at 17 mm
    assert js.velocity[4] == pytest.approx(0.0, abs=1e-6)
    assert js.effort[4] == pytest.approx(-0.4)                  # and the servo keeps squeezing


def _parameter_setter(probe):
    """Return set_param(name, value) -> SetParametersResult, through sim_driver's service."""
    from rclpy.parameter_client import AsyncParameterClient
    client = AsyncParameterClient(probe.node, '/px100/sim_driver')
    assert client.wait_for_services(timeout_sec=10.0)

    def set_param(name, value):
        future = client.set_parameters([Parameter(name, value=value)])
        deadline = time.monotonic() + 10
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.01)
        return future.result().results[0]
    return set_param


def test_parameters_are_validated_live(spin_node, rclpy_context):
    """Gains change live; nonsense is refused with a reason (through the parameter service)."""
    driver, probe = start(spin_node, rclpy_context)
    set_param = _parameter_setter(probe)
    ok = set_param('gains.shoulder.p', 30.0)
    assert ok.successful, ok.reason
    assert driver.sim.gains('shoulder').p == 30.0
    assert set_param('gains.elbow.i', 100).successful       # an int is taken as a number
    assert driver.sim.gains('elbow').i == 100.0
    # below 0 (NaN, -inf too): the declared range (parameters.SIM_DRIVER's gains group)
    for name, value, words in [('gains.shoulder.p', -1.0,
                                'gains.shoulder.p out of range Min: 0.0, Max: inf'),
                               ('gains.shoulder.d', float('nan'), 'gains.shoulder.d out of range'),
                               ('gains.elbow.i', -3, 'gains.elbow.i out of range. Min: 0'),
                               ('gains.elbow.i_clamp', float('inf'), 'finite'),
                               ('gains.elbow.u_clamp', float('-inf'), 'u_clamp out of'),
                               ('gains.wrist_angle.p', 'stiff', 'number'),
                               ('gains.waist.d', 50.0, 'unstable'),
                               ('object_width', 0.2, 'wider'),
                               ('publish_rate', 0.0, 'publish_rate out of range Min: 0.1'),
                               ('real_time_factor', 5.0, 'own clock')]:
        result = set_param(name, value)
        assert not result.successful, name
        assert words in result.reason, (name, result.reason)
    assert driver.sim.gains('shoulder').p == 30.0
    assert set_param('dynamics_divider', 2).successful
    assert driver.sim.config.dynamics_divider == 2


def test_control_rate_this_machine_cannot_follow_is_refused(spin_node, rclpy_context):
    """
    A control_rate whose physics would need most of a core is refused with the measured cost.

    (One step takes about 44 us here: 100 kHz would need 4.4 cores.) A far-behind clock is
    caught up by at most a publish period plus MAX_CHUNK of physics, the rest dropped.
    """
    from px100_control.sim.stepper import MAX_CHUNK
    driver, probe = start(spin_node, rclpy_context)
    stepper = driver.stepper
    set_param = _parameter_setter(probe)
    probe.wait(lambda: stepper.step_cost is not None, what='a measured physics step')
    result = set_param('control_rate', 100000.0)
    assert not result.successful and 'could not keep up' in result.reason, result.reason
    assert stepper.dt_ns == 1_000_000
    assert set_param('control_rate', 2000.0).successful
    assert stepper.dt_ns == 500_000
    with driver._lock:
        start_ns = stepper.start_ns
        steps = stepper.capped_steps(10 * 10 ** 9)
        assert steps == int(stepper.max_chunk_s * 2000) == int((MAX_CHUNK + 0.01) * 2000)
        assert stepper.start_ns - start_ns == 10 * 10 ** 9 - steps * 500_000
        stepper.start_ns = start_ns
    n = len(probe.js)
    probe.wait(lambda: len(probe.js) - n >= 50, timeout=10.0,   # 0.5 s at 100 Hz: not stopped
               what='50 more joint_states', seen=lambda: f'{len(probe.js) - n} more')


def test_slow_publish_rate_drops_no_simulated_time(spin_node, rclpy_context):
    """At publish_rate 1 Hz a sample (or a setpoint between two) integrates up to a second."""
    # one sample at 1 Hz is the flow this test needs (it waits for each next one itself)
    driver, probe = start(spin_node, rclpy_context, publish_rate=1.0, samples=1)
    with driver._lock:
        start_ns = driver.stepper.start_ns
    for _ in range(2):   # a setpoint 0.8 s after a sample catches the physics up 0.8 s
        n = len(probe.js)
        probe.wait(lambda: len(probe.js) > n, what='the next sample')
        time.sleep(0.8)
        probe.send(['waist'], [0.0])
    time.sleep(0.3)
    with driver._lock:
        assert driver.stepper.start_ns == start_ns, 'simulated time was dropped'
        assert driver.stepper.sim_ns >= 2 * 10 ** 9


def test_fast_mode_publishes_sim_clock(spin_node, rclpy_context):
    """real_time_factor 0: the driver owns /clock; joint_states are stamped with it."""
    driver, probe = start(spin_node, rclpy_context, light=True, real_time_factor=0.0)
    probe.wait(lambda: len(probe.clock) > 5, what='/clock')
    probe.wait(lambda: stamp_s(probe.js[-1][1]) > 1.0, timeout=60, what='1 s of sim time')
    with probe.lock:
        clocks = [c.clock.sec + c.clock.nanosec * 1e-9 for _, c in probe.clock]
        js_stamp = stamp_s(probe.js[-1][1])
    assert all(b > a for a, b in zip(clocks, clocks[1:]))     # monotonic
    ticks = np.diff(clocks) / 0.004                             # clock_rate 250 Hz
    assert np.allclose(ticks, np.round(ticks), atol=1e-6) and ticks.min() == pytest.approx(1)
    # joint_states carry simulated time (from 0), not the wall clock
    assert js_stamp < 1e5 and abs(js_stamp - clocks[-1]) < 1.0


def test_follows_an_external_clock_with_use_sim_time(spin_node, rclpy_context):
    """use_sim_time: the driver integrates exactly the /clock time it is given, stamps with it."""
    from rclpy.qos import QoSProfile
    driver = SimDriverNode(context=rclpy_context, parameter_overrides=[
        Parameter('use_sim_time', value=True)])
    probe = Probe(rclpy_context, light=True)
    clock_pub = probe.node.create_publisher(Clock, '/clock', QoSProfile(depth=10))
    spin_node(driver, probe.node)
    sim_t = 100.0

    def tick(seconds):
        nonlocal sim_t
        for _ in range(int(round(seconds / 0.005))):
            sim_t += 0.005
            sec = int(sim_t)
            clock_pub.publish(Clock(clock=rclpy.time.Time(
                seconds=sec, nanoseconds=int(round((sim_t - sec) * 1e9))).to_msg()))
            time.sleep(0.002)          # 2.5x faster than the wall clock

    def caught_up():
        """Return the driver's simulated time [s] once it has taken in the last /clock."""
        last_ns = int(round(sim_t * 1e9))
        probe.wait(lambda: abs(driver.get_clock().now().nanoseconds - last_ns) < 1000,
                   timeout=30, what='the driver clock at the last /clock')
        with driver._lock:
            driver.physics.catch_up()          # what a setpoint arriving now would do
            return driver.sim_time_ns() * 1e-9

    tick(1.0)
    probe.wait(lambda: probe.js and stamp_s(probe.js[-1][1]) > 100.5, timeout=30,
               what='joint_states on the external clock')
    driver_t0 = caught_up()
    tick(1.0)
    probe.wait(lambda: stamp_s(probe.js[-1][1]) > 101.9, timeout=30, what='1 s more')
    time.sleep(0.3)            # the clock is now frozen: nothing more may be integrated
    assert caught_up() - driver_t0 == pytest.approx(1.0, abs=0.0015)   # 1 s, to a step
    js_stamp = stamp_s(probe.last_js())
    assert 101.9 < js_stamp <= sim_t + 1e-6


def test_register_unit_gains(spin_node, rclpy_context):
    """gains_units dynamixel: gains.<joint>.p/i/d are XL430 registers, mapped to SI."""
    driver = SimDriverNode(context=rclpy_context, parameter_overrides=[
        Parameter('gains_units', value='dynamixel'),
        Parameter('gains.shoulder.p', value=640), Parameter('gains.shoulder.i', value=0),
        Parameter('gains.shoulder.d', value=4000)])
    spin_node(driver)
    g = driver.sim.gains('shoulder')
    assert g.p == pytest.approx(5.156, abs=1e-3) and g.d == pytest.approx(0.2578, abs=1e-4)


def test_installed_executable_publishes_at_the_parameter_rate(node_process, rclpy_context,
                                                              spin_node):
    """
    `sim_driver --ros-args -p publish_rate:=25.0` publishes at 25 Hz within 5 %.

    The published rate is read from the stamps (samples per second of their own time). The
    samples stamped within 8 s of wall time (at real_time_factor 1 the stamps are the system
    clock) are counted once delivered, within 15 % (a starved driver skips ahead): arrivals
    per wall second are not, since on a loaded machine delivery stalls (CI: 14.6 Hz arrived in
    8 s with the stamps at 25 Hz, the rest queued behind a starved probe).
    """
    proc = node_process('sim_driver', '--ros-args', '-p', 'publish_rate:=25.0')
    probe = Probe(rclpy_context)
    spin_node(probe.node)
    probe.wait(lambda: len(probe.js) >= 5, timeout=30, what='joint_states from the process')
    with probe.lock:
        start_n, start_t, start_wall = len(probe.js), time.monotonic(), time.time()
    time.sleep(8.0)
    end_t, end_wall = time.monotonic(), time.time()
    probe.wait(lambda: stamp_s(probe.js[-1][1]) >= end_wall, timeout=30,
               what='the samples stamped until the end of the window')
    with probe.lock:
        msgs = probe.js[start_n:]
        arrived = sum(1 for t, _ in msgs if t <= end_t)
    stamps = np.array([stamp_s(m) for _, m in msgs])
    rate_stamps = (len(stamps) - 1) / (stamps[-1] - stamps[0])
    in_window = int(np.count_nonzero((stamps >= start_wall) & (stamps < end_wall)))
    rate_wall = in_window / (end_wall - start_wall)
    evidence = {'stamped per wall s': rate_wall, 'arrived per wall s in the window':
                arrived / (end_t - start_t),
                'late': [line for line in proc.output().splitlines() if 'late' in line]}
    assert rate_stamps == pytest.approx(25.0, rel=0.05), (rate_stamps, evidence)
    assert rate_wall == pytest.approx(25.0, rel=0.15), evidence
    assert proc.alive(), proc.output()
    assert np.all(np.isfinite(stamps))
