"""
The Interbotix driver interface of a real sim_driver process (xs_sdk's topics and services).

One sim_driver (installed executable, namespace /px100); a probe node in this process talks to
it the way Interbotix's Python module (interbotix_xs_modules xs_robot core.py, arm.py,
gripper.py at humble/jazzy) does: the same service clients, the same calls in the same order.
"""
import collections
import math
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
from interbotix_xs_msgs.msg import JointGroupCommand, JointSingleCommand, JointTrajectoryCommand
from interbotix_xs_msgs.srv import (MotorGains, OperatingModes, Reboot, RegisterValues,
                                    RobotInfo, TorqueEnable)
from nodes_helpers import start_node, wait_for
import numpy as np
import pytest
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectoryPoint

NS = '/px100'
ARM = ['waist', 'shoulder', 'elbow', 'wrist_angle']
SLEEP = [0.0, -1.88, 1.5, 0.8]
#: (client attribute, type, service) in the order Interbotix's core creates and waits for them
SERVICES = [('srv_set_op_modes', OperatingModes, 'set_operating_modes'),
            ('srv_set_pids', MotorGains, 'set_motor_pid_gains'),
            ('srv_set_reg', RegisterValues, 'set_motor_registers'),
            ('srv_get_reg', RegisterValues, 'get_motor_registers'),
            ('srv_get_info', RobotInfo, 'get_robot_info'),
            ('srv_torque', TorqueEnable, 'torque_enable'),
            ('srv_reboot', Reboot, 'reboot_motors')]


class Probe:
    """The test's node: Interbotix's clients and publishers, joint_states and /diagnostics."""

    def __init__(self, ctx, spinner):
        from rclpy.node import Node
        self.node = n = Node('xs_probe', context=ctx)
        self.lock = threading.Lock()
        self.js, self.diag, self.js_count = None, [], 0
        # (stamp [s] on the driver's clock, {name: position}): timings measured on the stamps
        # do not count this (loaded) process's or the transport's latency
        self.history = collections.deque(maxlen=6000)
        for attr, srv, name in SERVICES:
            setattr(self, attr, n.create_client(srv, f'{NS}/{name}'))
        self.pub_group = n.create_publisher(JointGroupCommand, f'{NS}/commands/joint_group', 10)
        self.pub_single = n.create_publisher(JointSingleCommand, f'{NS}/commands/joint_single',
                                             10)
        self.pub_traj = n.create_publisher(JointTrajectoryCommand,
                                           f'{NS}/commands/joint_trajectory', 10)
        n.create_subscription(JointState, f'{NS}/joint_states', self._js, 100)
        n.create_subscription(DiagnosticArray, '/diagnostics', self._diag, 50)
        spinner.add(n)

    def _js(self, msg):
        with self.lock:
            self.js = msg
            self.js_count += 1
            self.history.append((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9,
                                 dict(zip(msg.name, msg.position))))

    def _diag(self, msg):
        with self.lock:
            self.diag.extend(msg.status)

    def call(self, client, request, timeout=10.0):
        """Call a service; return the response (fails with the request on a timeout)."""
        future = client.call_async(request)
        assert wait_for(future.done, timeout), f'no reply from {client.srv_name}: {request}'
        return future.result()

    def position(self, name):
        with self.lock:
            return self.js.position[list(self.js.name).index(name)]

    def arm(self):
        return [self.position(j) for j in ARM]

    def mark(self) -> float:
        """Return the stamp [s] of the latest joint_states: take it before a command."""
        with self.lock:
            return self.history[-1][0]

    def samples(self, mark: float):
        """Return the joint_states from the one at ``mark`` on: [(stamp [s], {name: q})]."""
        with self.lock:
            return [h for h in self.history if h[0] >= mark]

    def motion(self, mark: float, target=None, names=ARM, eps=0.005, tol=0.03):
        """
        Return (start, arrival) stamps [s] of the motion after ``mark``.

        start: the first sample where a joint of ``names`` is eps [rad] from where it was at
        ``mark`` (None when none moved); arrival: the first sample with every joint within tol
        of ``target`` (None when none is, or no target).
        """
        got = self.samples(mark)
        base = got[0][1]
        start = next((t for t, q in got if max(abs(q[n] - base[n]) for n in names) > eps), None)
        arrival = None if target is None else next(
            (t for t, q in got if max(abs(q[n] - x) for n, x in zip(ARM, target)) < tol), None)
        return start, arrival

    def moving_time(self, mark: float, target, tol=0.03) -> float:
        """Return the driver-clock seconds from the motion's start to its arrival (0: no move)."""
        start, arrival = self.motion(mark, target, tol=tol)
        assert arrival is not None, f'no sample within {tol} of {target}: at {self.arm()}'
        return 0.0 if start is None else arrival - start

    def wait_arm(self, target, tol=0.03, timeout=8.0):
        """Wait until every arm joint is within tol [rad] of target; return the seconds."""
        t0 = time.monotonic()
        ok = wait_for(lambda: max(abs(a - b) for a, b in zip(self.arm(), target)) < tol,
                      timeout)
        assert ok, f'arm at {self.arm()}, commanded {target}'
        return time.monotonic() - t0

    def settle(self, tol=0.002, timeout=8.0):
        """Wait until the arm moves less than tol [rad] between two checks 0.2 s apart."""
        last = [self.arm(), time.monotonic()]

        def still():
            if time.monotonic() - last[1] < 0.2:
                return False
            now = self.arm()
            moved = max(abs(a - b) for a, b in zip(now, last[0]))
            last[:] = [now, time.monotonic()]
            return moved < tol
        assert wait_for(still, timeout), f'the arm keeps moving: {self.arm()}'

    def set_reg(self, cmd_type, name, reg, value):
        return self.call(self.srv_set_reg, RegisterValues.Request(
            cmd_type=cmd_type, name=name, reg=reg, value=int(value)))

    def refusals(self, what):
        with self.lock:
            return [s.message for s in self.diag if s.name.endswith(f'xs/{what}')]


@pytest.fixture(scope='module')
def driver(processes):
    proc = start_node(processes, 'sim_driver', "scene:=''")
    yield proc


@pytest.fixture(scope='module')
def probe(driver, ros_ctx, spinner):
    p = Probe(ros_ctx, spinner)
    if not p.srv_set_op_modes.wait_for_service(timeout_sec=30.0):
        # what this node's graph knows: was the driver's process not discovered at all, or
        # only its service not matched?
        nodes = p.node.get_node_names_and_namespaces()
        try:
            services = sorted(n for n, _ in p.node.get_service_names_and_types_by_node(
                'sim_driver', NS))
        except Exception as exc:  # noqa: B902 - rclpy's NodeNameNonExistentError
            services = f'none ({type(exc).__name__})'
        pytest.fail(f'no {NS}/set_operating_modes in 30 s; driver alive: {driver.alive()}; '
                    f"nodes seen: {nodes}; sim_driver's services seen: {services}\n"
                    '-- driver:\n' + driver.output()[-3000:])
    assert wait_for(lambda: p.js is not None, 10.0), driver.output()[-3000:]
    return p


def test_get_robot_info_arm_gripper_all(probe):
    """RobotInfo: the arm group and the gripper (as its left finger), as xs_sdk answers."""
    arm = probe.call(probe.srv_get_info, RobotInfo.Request(cmd_type='group', name='arm'))
    assert (arm.mode, arm.profile_type, arm.num_joints) == ('position', 'time', 4)
    assert list(arm.joint_names) == ARM and list(arm.joint_ids) == [1, 2, 3, 4]
    assert list(arm.joint_state_indices) == [0, 1, 2, 3] and list(arm.name) == ['arm']
    assert arm.joint_sleep_positions.tolist() == pytest.approx(SLEEP, abs=1e-6)
    assert arm.joint_lower_limits.tolist() == pytest.approx(
        [-(math.pi - 1e-5), -1.937315, -2.111848, -1.745329], abs=1e-5)
    assert arm.joint_upper_limits.tolist() == pytest.approx(
        [math.pi - 1e-5, 1.867502, 1.605703, 2.146755], abs=1e-5)
    assert arm.joint_velocity_limits.tolist() == pytest.approx([math.pi] * 4, abs=1e-5)
    grip = probe.call(probe.srv_get_info, RobotInfo.Request(cmd_type='single', name='gripper'))
    assert (grip.mode, grip.num_joints, list(grip.joint_names)) == ('pwm', 1, ['left_finger'])
    assert list(grip.joint_ids) == [5] and list(grip.joint_state_indices) == [5]
    assert grip.joint_lower_limits.tolist() == pytest.approx([0.015])
    assert grip.joint_upper_limits.tolist() == pytest.approx([0.037])
    assert grip.joint_sleep_positions.tolist() == pytest.approx([0.019494], abs=1e-6)
    every = probe.call(probe.srv_get_info, RobotInfo.Request(cmd_type='group', name='all'))
    assert every.num_joints == 5 and set(every.name) == {'all', 'arm'}


def test_joint_group_follows_the_time_profile(probe):
    """A JointGroupCommand moves the arm along Profile_Velocity ms (here 1000 ms)."""
    probe.set_reg('group', 'arm', 'Profile_Velocity', 1000)
    try:
        start = probe.arm()
        target = [0.3, -0.5, 0.4, 0.2]
        mark = probe.mark()
        probe.pub_group.publish(JointGroupCommand(name='arm', cmd=target))
        assert wait_for(lambda: abs(probe.position('elbow') - start[2]) > 0.01, 5.0), \
            probe.arm()
        probe.wait_arm(target)
        # timed on the driver's stamps from the motion's start: a jump would be whole at once,
        # the default 2 s profile a fifth of the way at 0.5 s
        begin, arrival = probe.motion(mark, target)
        stamps, shoulder = zip(*[(t, q['shoulder']) for t, q in probe.samples(mark)])
        frac = (np.interp(begin + 0.5, stamps, shoulder) - start[1]) / (target[1] - start[1])
        arrived = arrival - begin   # within 0.03 rad: a little before the 1 s profile
        # halfway in time, the trapezoid is halfway in position (tracking lag allowed)
        assert 0.25 < frac < 0.75, (frac, begin, arrival)
        assert 0.8 < arrived < 2.5, (arrived, begin, arrival)
    finally:   # the module's later tests expect the default profile
        probe.set_reg('group', 'arm', 'Profile_Velocity', 2000)


def test_velocity_mode_then_back_to_position(probe):
    """set_operating_modes velocity on one joint: rad/s commands; position again holds."""
    probe.settle()
    probe.call(probe.srv_set_op_modes, OperatingModes.Request(
        cmd_type='single', name='waist', mode='velocity'))
    info = probe.call(probe.srv_get_info, RobotInfo.Request(cmd_type='single', name='waist'))
    assert (info.mode, info.profile_type) == ('velocity', 'velocity')
    start = probe.position('waist')
    mark = probe.mark()
    probe.pub_single.publish(JointSingleCommand(name='waist', cmd=0.5))
    assert wait_for(lambda: probe.position('waist') > start + 0.25, 5.0), probe.position('waist')
    probe.pub_single.publish(JointSingleCommand(name='waist', cmd=0.0))
    # on the driver's stamps, from the first sample that moved to the first 0.25 rad on
    begin, _ = probe.motion(mark, names=['waist'])
    moved = [(t, q['waist']) for t, q in probe.samples(mark) if t >= begin]
    (t0, q0), (t1, q1) = moved[0], next(m for m in moved if m[1] > start + 0.25)
    speed = (q1 - q0) / (t1 - t0)
    assert 0.3 < speed < 0.55, (speed, t0, q0, t1, q1)
    probe.call(probe.srv_set_op_modes, OperatingModes.Request(
        cmd_type='single', name='waist', mode='position', profile_type='time',
        profile_velocity=2000, profile_acceleration=300))
    probe.pub_group.publish(JointGroupCommand(name='arm', cmd=[0.0, 0.0, 0.0, 0.0]))
    probe.wait_arm([0.0] * 4)
    assert not probe.refusals(''), probe.refusals('')


def test_operating_mode_parameter_is_reported(probe):
    """operating_mode.<joint> set as a parameter (ros2 param, the client): RobotInfo says so."""
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    client = probe.node.create_client(SetParameters, f'{NS}/sim_driver/set_parameters')
    assert client.wait_for_service(timeout_sec=30.0), f'no {client.srv_name} in 30 s'

    def set_mode(value):
        param = Parameter(name='operating_mode.elbow', value=ParameterValue(
            type=ParameterType.PARAMETER_STRING, string_value=value))
        reply = probe.call(client, SetParameters.Request(parameters=[param]))
        assert reply.results[0].successful, reply.results[0].reason
        return probe.call(probe.srv_get_info, RobotInfo.Request(cmd_type='single',
                                                                name='elbow')).mode
    assert set_mode('velocity') == 'velocity'
    assert set_mode('') == 'position'
    probe.node.destroy_client(client)


def _interbotix_startup(probe):
    """InterbotixManipulatorXS(robot_model='px100') construction: core, arm, gripper."""
    for attr, _, _ in SERVICES:                             # core: wait for every service
        assert getattr(probe, attr).wait_for_service(timeout_sec=10.0), attr
    assert wait_for(lambda: probe.js is not None, 5.0)      # core: first joint_states
    js_index_map = {n: i for i, n in enumerate(probe.js.name)}
    group = probe.call(probe.srv_get_info, RobotInfo.Request(cmd_type='group', name='arm'))
    assert group.num_joints == 4                            # arm: == Slist columns of px100
    assert group.profile_type == 'time' and group.mode == 'position'   # else it warns
    joint_commands = [probe.js.position[js_index_map[n]] for n in group.joint_names]
    grip = probe.call(probe.srv_get_info, RobotInfo.Request(cmd_type='single', name='gripper'))
    assert grip.mode in ('pwm', 'current')                  # gripper: else it warns
    finger = js_index_map[grip.joint_names[0]]
    assert finger == grip.joint_state_indices[0]
    return group, grip, finger, joint_commands


def _set_trajectory_time(probe, cache, moving_time, accel_time):
    """arm.set_trajectory_time: write only what differs from the cached values."""
    if moving_time is not None and moving_time != cache[0]:
        cache[0] = moving_time
        probe.set_reg('group', 'arm', 'Profile_Velocity', int(moving_time * 1000))
    if accel_time is not None and accel_time != cache[1]:
        cache[1] = accel_time
        probe.set_reg('group', 'arm', 'Profile_Acceleration', int(accel_time * 1000))


def _gripper(probe, grip, finger, effort):
    """gripper.release / grasp: pwm effort, stopped (0.0) once the finger passes its limit."""
    probe.pub_single.publish(JointSingleCommand(name='gripper', cmd=float(effort)))
    lower, upper = grip.joint_lower_limits[0], grip.joint_upper_limits[0]
    if effort > 0:
        reached = wait_for(lambda: probe.js.position[finger] >= upper - 0.002, 3.0)
    else:
        reached = wait_for(lambda: probe.js.position[finger] <= lower + 0.002, 3.0)
    assert reached, f'finger at {probe.js.position[finger]} after pwm {effort}'
    probe.pub_single.publish(JointSingleCommand(name='gripper', cmd=0.0))


def test_interbotix_module_call_sequence(probe):
    """Replay what InterbotixManipulatorXS does on construction and a typical script."""
    group, grip, finger, joint_commands = _interbotix_startup(probe)
    cache = [2.0, 0.3]                                   # moving_time, accel_time defaults
    _set_trajectory_time(probe, cache, 2.0, 0.3)         # construction: equal, writes nothing
    regs = probe.call(probe.srv_get_reg, RegisterValues.Request(
        cmd_type='group', name='arm', reg='Profile_Velocity'))
    assert list(regs.values) == [2000] * 4
    mark = probe.mark()
    probe.pub_group.publish(JointGroupCommand(name='arm', cmd=[0.0] * 4))   # go_to_home_pose
    probe.wait_arm([0.0] * 4)
    home = probe.moving_time(mark, [0.0] * 4)   # driver-clock seconds: no latency in them
    assert home < 2.0 + 0.5, home
    _set_trajectory_time(probe, cache, 1.5, None)        # set_joint_positions(.., 1.5)
    target = [0.4, -0.3, 0.2, 0.3]
    mark = probe.mark()
    probe.pub_group.publish(JointGroupCommand(name='arm', cmd=target))
    probe.wait_arm(target)
    moving = probe.moving_time(mark, target)   # the profile ends 1.5 s after the start
    assert 1.0 < moving < 1.5 + 0.3, moving
    probe.pub_single.publish(JointSingleCommand(name='waist', cmd=-0.4))  # set_single_joint
    assert wait_for(lambda: abs(probe.position('waist') + 0.4) < 0.03, 6.5), probe.arm()
    _gripper(probe, grip, finger, 250.0)                 # gripper.release()
    _gripper(probe, grip, finger, -250.0)                # gripper.grasp()
    # set_ee_cartesian_trajectory: 200/100 ms waypoints, then the arm's own timing back
    _set_trajectory_time(probe, cache, 0.2, 0.1)
    start = probe.arm()
    msg = JointTrajectoryCommand(cmd_type='group', name='arm')
    msg.traj.joint_names = ARM
    for k in range(21):
        point = JointTrajectoryPoint(positions=[start[0], start[1] + 0.01 * k, start[2],
                                                start[3]])
        point.time_from_start.nanosec = int(k * 0.05 * 1e9) % 1_000_000_000
        point.time_from_start.sec = int(k * 0.05)
        msg.traj.points.append(point)
    probe.pub_traj.publish(msg)
    probe.wait_arm([start[0], start[1] + 0.2, start[2], start[3]], timeout=4.0)
    _set_trajectory_time(probe, cache, 1.5, 0.3)
    probe.pub_group.publish(JointGroupCommand(name='arm', cmd=list(group.joint_sleep_positions)))
    probe.wait_arm(SLEEP)                                 # go_to_sleep_pose
    probe.call(probe.srv_torque, TorqueEnable.Request(cmd_type='group', name='arm',
                                                      enable=False))
    probe.call(probe.srv_torque, TorqueEnable.Request(cmd_type='group', name='arm',
                                                      enable=True))
    probe.call(probe.srv_reboot, Reboot.Request(cmd_type='single', name='gripper', enable=True))
    probe.call(probe.srv_set_op_modes, OperatingModes.Request(
        cmd_type='single', name='gripper', mode='pwm'))
    probe.call(probe.srv_set_pids, MotorGains.Request(cmd_type='group', name='arm', kp_pos=800,
                                                      kd_pos=3600, kp_vel=100, ki_vel=1920))
    gains = probe.call(probe.srv_get_reg, RegisterValues.Request(
        cmd_type='single', name='elbow', reg='Position_P_Gain'))
    assert list(gains.values) == [800]
    _set_trajectory_time(probe, cache, 2.0, None)
    assert not probe.refusals(''), probe.refusals('')


BAD = [
    ('commands/joint_group', lambda p: p.pub_group.publish(
        JointGroupCommand(name='arm', cmd=[0.1, 0.2])), 'Number of commands (2)'),
    ('commands/joint_group', lambda p: p.pub_group.publish(
        JointGroupCommand(name='legs', cmd=[0.1])), "'legs' joint/group does not exist"),
    ('commands/joint_group', lambda p: p.pub_group.publish(
        JointGroupCommand(name='arm', cmd=[0.1, float('nan'), 0.0, 0.0])), 'NaN'),
    ('commands/joint_group', lambda p: p.pub_group.publish(
        JointGroupCommand(name='arm', cmd=[0.0, 2.5, 0.0, 0.0])), 'outside its limits'),
    ('commands/joint_single', lambda p: p.pub_single.publish(
        JointSingleCommand(name='tail', cmd=0.1)), "'tail' joint/group does not exist"),
    ('commands/joint_single', lambda p: p.pub_single.publish(
        JointSingleCommand(name='gripper', cmd=2000.0)), 'pwm 2000'),
    ('commands/joint_trajectory', lambda p: p.pub_traj.publish(
        JointTrajectoryCommand(cmd_type='group', name='arm')), 'fewer than 2 points'),
    ('set_operating_modes', lambda p: p.srv_set_op_modes.call_async(OperatingModes.Request(
        cmd_type='group', name='arm', mode='current', profile_type='time')),
     'no current sensing'),
    ('set_operating_modes', lambda p: p.srv_set_op_modes.call_async(OperatingModes.Request(
        cmd_type='group', name='arm', mode='torque', profile_type='time')),
     "Invalid command for argument 'mode'"),
    ('set_motor_registers', lambda p: p.srv_set_reg.call_async(RegisterValues.Request(
        cmd_type='group', name='arm', reg='Goal_Current', value=5)), "'Goal_Current'"),
    ('get_motor_registers', lambda p: p.srv_get_reg.call_async(RegisterValues.Request(
        cmd_type='group', name='arm', reg='Bogus', value=5)), "'Bogus'"),
    ('torque_enable', lambda p: p.srv_torque.call_async(TorqueEnable.Request(
        cmd_type='grp', name='arm', enable=False)), "argument 'cmd_type'"),
]


@pytest.mark.parametrize('what,send,reason', BAD, ids=[f'{b[0]}:{b[2][:20]}' for b in BAD])
def test_bad_input_is_refused_and_nothing_moves(probe, what, send, reason):
    """Each refusal: an error on /diagnostics naming why, the arm still, the node answering."""
    probe.settle()
    before_arm, before = probe.arm(), len(probe.refusals(what))
    send(probe)
    assert wait_for(lambda: len(probe.refusals(what)) > before, 5.0), probe.refusals('')
    assert reason in probe.refusals(what)[-1], probe.refusals(what)[-1]
    count = probe.js_count      # 30 more samples (0.3 s): a wrongly accepted move would show
    assert wait_for(lambda: probe.js_count >= count + 30, 5.0)
    assert max(abs(a - b) for a, b in zip(probe.arm(), before_arm)) < 0.01
    info = probe.call(probe.srv_get_info, RobotInfo.Request(cmd_type='group', name='arm'))
    assert info.mode == 'position' and info.num_joints == 4
