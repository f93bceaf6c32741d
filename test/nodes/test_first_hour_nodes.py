"""
What a new user and a ROS user tripped over in their first hour (issue 28, items 2-6 and 8).

Each check runs the installed executables (as ``ros2 run`` resolves them) or constructs the real
nodes, and reads what a user reads: exit status, the lines printed, parameters over the
parameter services, topics over DDS.
"""
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time

from nodes_helpers import STARTUP_TIMEOUT, wait_for
from px100_control.tools.processes import executable_path, NodeProcess
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CLOCK_WARNING = 'no /clock arrived'


def _run_all(commands, timeout=120.0):
    """Run argv lists at once (each exits at start); return [(status, output)] in order."""
    procs = [subprocess.Popen(c, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              cwd=ROOT) for c in commands]
    return [(p.wait(timeout), p.stdout.read()) for p in procs]


def _one_line_error(status, out, prog, *words):
    lines = out.strip().splitlines()
    assert status == 1, (status, out)
    assert 'Traceback' not in out and len(lines) == 1, out
    assert lines[0].startswith(f'{prog}: error: '), out
    for w in words:
        assert w in lines[0], (w, out)


def test_bad_ros_arguments_and_parameters_are_one_line():
    """Bad ROS arguments and a refused parameter: one line naming it, status 1."""
    results = _run_all([
        [executable_path('sim_driver'), '--ros-args', '-p', 'scene:='],
        [executable_path('bringup'), '--ros-args', '--no-such-flag'],
        [executable_path('record'), '--ros-args', '-r', 'a'],
        [executable_path('trajectory_server'), '--ros-args', '-p', 'rate:=-5.0'],
        # the px100 file with another arm (the launch files' former default)
        [executable_path('ik_service'), '--ros-args', '--params-file',
         os.path.join(ROOT, 'config', 'px100.yaml'), '-p', 'robot_model:=px150'],
    ])
    _one_line_error(*results[0], 'sim_driver', "'-p scene:='", '''-p "scene:=''"''')
    _one_line_error(*results[1], 'bringup', "unknown ROS arguments ['--no-such-flag']")
    _one_line_error(*results[2], 'record', "remap rule: '-r a'")
    _one_line_error(*results[3], 'trajectory_server', 'rate')
    _one_line_error(*results[4], 'ik_service', 'nominal_pose needs 5 finite values')


def test_malformed_scene_names_every_wrong_field(tmp_path):
    """A scene with five wrong fields: sim_driver prints each on its line, exits 1."""
    bad = tmp_path / 'bad_scene.yaml'
    bad.write_text('objects:\n'
                   '  - {name: a, shape: cone, size: [0.02], position: [0.2, 0.0, 0.01]}\n'
                   '  - {name: b, mass: -1, size: [0.02, 0.02, 0.02], colour: red,\n'
                   '     position: [0.2, 0.1]}\n')
    [(status, out)] = _run_all([[executable_path('sim_driver'), '--ros-args', '-p',
                                 f'scene:={bad}']])
    lines = out.strip().splitlines()
    assert status == 1 and 'Traceback' not in out, out
    assert lines[0] == f'sim_driver: error: scene {bad}: 5 problems:', out
    for words in ("objects[0] (a).shape must be one of ['box', 'cylinder', 'sphere'], not 'cone'",
                  'objects[0] (a).mass is missing', "objects[1]: unknown key(s) ['colour']",
                  'objects[1] (b).mass must be positive', 'objects[1] (b).position needs 3'):
        assert sum(words in line for line in lines[1:]) == 1, (words, out)
    assert len(lines) == 6, out


def test_demo_refuses_a_bad_scene_in_one_line(tmp_path):
    """The demo checks --scene before any node starts: one usage line, exit 2, no traceback."""
    demo = os.path.join(ROOT, 'scripts', 'pick_and_place_demo.py')
    run = subprocess.run([sys.executable, demo, '--scene', 'no_such_scene', '--out',
                          str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and 'Traceback' not in run.stderr, run.stderr
    assert run.stderr.strip().splitlines()[-1].startswith(
        "pick_and_place_demo.py: error: --scene no_such_scene: unknown scene 'no_such_scene'"), \
        run.stderr


def _launch_params_file():
    """Return the launch files' default params_file, resolved as launch resolves it."""
    import xml.etree.ElementTree as ET
    from ament_index_python.packages import get_package_share_directory
    root = ET.parse(os.path.join(ROOT, 'launch', 'px100.launch.xml')).getroot()
    default = next(a.get('default') for a in root.findall('arg')
                   if a.get('name') == 'params_file')
    share = get_package_share_directory('px100_control')
    return default.replace('$(find-pkg-share px100_control)', share)


def test_launch_defaults_fit_every_registered_robot(ros_ctx):
    """
    ``ros2 launch px100_control px100.launch.py robot_model:=<r>`` for every robot file.

    The three nodes are built with what the launch files give them (their default params_file,
    then robot_model, robot_name, use_sim_time; publish_clock for the driver): each starts, and
    what depends on the robot (nominal_pose, PID gains, scene) comes from the robot.
    """
    from px100_control.models.registry import available_robots, load_robot
    from px100_control.ros.ik_service_node import IkServiceNode
    from px100_control.ros.sim_driver_node import SimDriverNode
    from px100_control.ros.trajectory_server_node import TrajectoryServerNode
    params_file = _launch_params_file()
    assert os.path.isfile(params_file), params_file
    failed = {}
    robots = available_robots()
    assert len(robots) >= 18, robots
    for robot in robots:
        args = ['--ros-args', '--params-file', params_file, '-p', f'robot_model:={robot}',
                '-p', f'robot_name:=fh_{robot}', '-p', 'use_sim_time:=false']
        try:
            nodes = [SimDriverNode(context=ros_ctx, namespace=f'/fh_{robot}',
                                   cli_args=args + ['-p', 'publish_clock:=false'])]
            nodes += [cls(context=ros_ctx, namespace=f'/fh_{robot}', cli_args=args)
                      for cls in (IkServiceNode, TrajectoryServerNode)]
        except Exception as exc:   # noqa: B902 - the reason is the finding
            failed[robot] = repr(exc)
            continue
        try:
            model = load_robot(robot)
            nominal = list(nodes[1].get_parameter('nominal_pose').value)
            assert nominal == [float(x) for x in model.home], (robot, nominal)
            for joint in model.joint_names:
                assert nodes[0].has_parameter(f'gains.{joint}.p'), (robot, joint)
        finally:
            for n in nodes:
                n.destroy_node()
    assert not failed, failed


class _Probe:
    """A test-side node (spun in a thread) with parameter clients and topic counters."""

    def __init__(self, ctx, ns):
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        self.node = Node('first_hour_probe', namespace=ns, context=ctx)
        self.counts = {}
        self.executor = SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def count(self, msg_type, topic, qos=10):
        """Count the messages on ``topic`` (self.counts[topic])."""
        self.counts[topic] = 0

        def cb(msg):
            self.counts[topic] += 1
        self.node.create_subscription(msg_type, topic, cb, qos)

    def call(self, srv_type, name, request, timeout=STARTUP_TIMEOUT):
        """Call a service; return the response (None on timeout)."""
        client = self.node.create_client(srv_type, name)
        if not client.wait_for_service(timeout_sec=timeout):
            return None
        future = client.call_async(request)
        wait_for(future.done, 30.0)
        return future.result()

    def close(self):
        """Stop spinning and destroy the node."""
        self.executor.shutdown(timeout_sec=2.0)
        self.thread.join(5.0)
        self.node.destroy_node()


@pytest.fixture
def probe(ros_ctx):
    """Yield a factory of probes in a namespace; they are closed after the test."""
    made = []

    def make(ns):
        made.append(_Probe(ros_ctx, ns))
        return made[-1]
    yield make
    for p in made:
        p.close()


def test_empty_scene_the_ros_way(probe):
    """``--ros-args -p "scene:=''"`` in a shell reaches sim_driver as '' (no objects)."""
    from rcl_interfaces.srv import GetParameters
    cmd = f'''exec {executable_path('sim_driver')} --ros-args -r __ns:=/fh_empty -p "scene:=''"'''
    proc = subprocess.Popen(['bash', '-c', cmd], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        reply = probe('/fh_empty').call(GetParameters, '/fh_empty/sim_driver/get_parameters',
                                        GetParameters.Request(names=['scene']))
        assert reply is not None and reply.values[0].string_value == '', reply
        assert proc.poll() is None
    finally:
        proc.send_signal(signal.SIGINT)
        out = proc.communicate(timeout=30)[0]
    assert proc.returncode == 0 and 'Traceback' not in out, out


def test_trajectory_server_rate_set_is_refused_with_the_reason(probe):
    """``ros2 param set .../trajectory_server rate 50`` is refused: read-only, and described so."""
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import DescribeParameters, GetParameters, SetParameters
    with NodeProcess('trajectory_server', ['--ros-args', '-r', '__ns:=/fh_rate']) as ts:
        p = probe('/fh_rate')
        value = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=50.0)
        reply = p.call(SetParameters, '/fh_rate/trajectory_server/set_parameters',
                       SetParameters.Request(parameters=[Parameter(name='rate', value=value)]))
        assert reply is not None, ts.output()
        assert not reply.results[0].successful
        assert 'read-only' in reply.results[0].reason, reply.results[0].reason
        desc = p.call(DescribeParameters, '/fh_rate/trajectory_server/describe_parameters',
                      DescribeParameters.Request(names=['rate']))
        assert desc.descriptors[0].read_only
        got = p.call(GetParameters, '/fh_rate/trajectory_server/get_parameters',
                     GetParameters.Request(names=['rate']))
        assert got.values[0].double_value == 200.0
    assert ts.returncode == 0, ts.output()


def test_use_sim_time_without_clock_warns(probe):
    """A node with use_sim_time and no /clock source says so within seconds (6 s)."""
    with NodeProcess('ik_service', ['--ros-args', '-r', '__ns:=/fh_noclock', '-p',
                                    'use_sim_time:=true']) as ik:
        assert ik.wait_for_output(CLOCK_WARNING, STARTUP_TIMEOUT), ik.output()
    assert ik.returncode == 0, ik.output()


def test_a_clock_source_still_starting_gets_time_before_a_warning(probe):
    """
    A /clock publisher that is there but silent for 4.5 s (a driver still loading): no warning.

    A launch starts every node at once; under load sim_driver's first /clock came more than 3 s
    after trajectory_server started, which warned that its time stood still (CI, no retries).
    Nor a warning when the node's discovery of that publisher is slow: a CI run at load 7 found
    none 3 s after the node was ready (a node now waits two checks, 6 s, for a publisher).
    """
    from rosgraph_msgs.msg import Clock
    p = probe('/fh_lateclock')
    pub = p.node.create_publisher(Clock, '/clock', 10)
    with NodeProcess('ik_service', ['--ros-args', '-r', '__ns:=/fh_lateclock', '-p',
                                    'use_sim_time:=true']) as ik:
        assert ik.wait_for_output('ik_service ready', STARTUP_TIMEOUT), ik.output()
        deadline = time.monotonic() + 4.5          # past the first check (3 s): silent source
        wait_for(lambda: time.monotonic() > deadline, 6.0)
        assert wait_for(lambda: pub.get_subscription_count() > 0, 1.0), \
            f'ik_service never subscribed to /clock in 5.5 s\n{ik.output()}'
        msg = Clock()
        msg.clock.sec = 1
        for _ in range(5):
            pub.publish(msg)
        deadline = time.monotonic() + 3.5          # past the second check (6 s)
        wait_for(lambda: time.monotonic() > deadline, 5.0)
        assert CLOCK_WARNING not in ik.output(), ik.output()
    assert ik.returncode == 0, ik.output()


def test_use_sim_time_as_launch_wires_it_runs_on_the_drivers_clock(probe):
    """
    The launch files' use_sim_time:=true: the driver publishes /clock, everyone follows it.

    sim_driver gets use_sim_time and publish_clock (as the launch files set them), the
    trajectory_server use_sim_time: /clock and joint_states flow, a goal succeeds, nobody warns.
    """
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState
    sim = ['--ros-args', '-r', '__ns:=/fh_simtime', '-p', 'use_sim_time:=true']
    with NodeProcess('sim_driver', sim + ['-p', 'publish_clock:=true']) as drv, \
            NodeProcess('trajectory_server', sim) as ts:
        p = probe('/fh_simtime')
        p.count(Clock, '/clock')
        p.count(JointState, 'joint_states')
        assert wait_for(lambda: p.counts['joint_states'] > 50 and p.counts['/clock'] > 50,
                        STARTUP_TIMEOUT), (p.counts, drv.output(), ts.output())
        assert ts.wait_for_output('trajectory_server ready', 30.0), ts.output()
        # the warning would come 3 s after the start: wait that long on the steady clock
        deadline = time.monotonic() + 4.0
        wait_for(lambda: time.monotonic() > deadline, 5.0)
        assert CLOCK_WARNING not in drv.output() + ts.output()
    assert drv.returncode == 0 and ts.returncode == 0, (drv.output(), ts.output())


def test_script_beside_the_bringup_executable_gets_no_mode_warning(tmp_path):
    """
    The README's live-view path: ``bringup`` running, a script connects and moves the arm.

    ik_service runs in its default 'pitch' mode there; the client checks every answer against
    the target itself, so it neither needs 'strict' nor tells the user to restart anything.
    """
    script = tmp_path / 'drive.py'
    script.write_text(
        'from px100_control.client import InterbotixManipulatorXS, robot_shutdown, '
        'robot_startup\n'
        "bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm', "
        "gripper_name='gripper', robot_name='fh_live')\n"
        'robot_startup()\n'
        'ok_reach = bot.arm.set_ee_pose_components(x=0.2, z=0.15, pitch=0.5)[1]\n'
        'ok_flip = bot.arm.set_ee_pose_components(x=0.2, z=0.15, roll=3.0, pitch=0.5)[1]\n'
        "print('RESULT', ok_reach, ok_flip)\n"
        'robot_shutdown()\n')
    with NodeProcess('bringup', ['--no-camera', '--ros-args', '-r', '__ns:=/fh_live']) as up:
        assert up.wait_for_output('trajectory_server ready', STARTUP_TIMEOUT), up.output()
        env = dict(os.environ, PX100_BRINGUP='0', PYTHONUNBUFFERED='1')
        out = subprocess.run(['python', str(script)], capture_output=True, text=True,
                             timeout=240, env=env, cwd=tempfile.gettempdir())
    text = out.stdout + out.stderr
    assert out.returncode == 0, text[-3000:]
    assert 'RESULT True False' in out.stdout, text[-3000:]
    assert 'orientation_mode' not in text, text[-3000:]
    assert up.returncode == 0, up.output()[-2000:]
