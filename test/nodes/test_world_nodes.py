"""
sim_driver's world over DDS: world/markers, world/held_object, world/reset, reset, scene.

The real rclpy node with the real MuJoCo scene, talked to by a probe node in a private domain;
bad scenes are refused with the loader's reason (as a parameter: the node keeps running; at
start: the executable exits non-zero and says why).
"""
import threading
import time

from px100_control.ros.common import LATCHED_QOS
from px100_control.ros.sim_driver_node import SimDriverNode
from px100_control.ros.world_msgs import markers_of
import pytest
import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

pytestmark = pytest.mark.ros

#: the probe keeps every message (LATCHED_QOS keeps the last only: on a busy machine the marker
#: published at a reset could be replaced by the next one before the probe's callback ran)
PROBE_QOS = QoSProfile(depth=200, durability=LATCHED_QOS.durability,
                       reliability=LATCHED_QOS.reliability)

#: one cube 20 mm above the table: it falls when the simulation runs
FALLING = """name: falling
table: {size: [0.5, 0.6, 0.03], position: [0.15, 0.0, -0.015]}
objects:
  - {name: cube, shape: box, size: [0.025, 0.025, 0.025], mass: 0.03,
     rgba: [0.9, 0.1, 0.1, 1.0], position: [0.2, 0.0, 0.0325]}
"""


class WorldProbe:
    """Records world/markers and world/held_object; calls the reset services."""

    def __init__(self, context, ns='/px100'):
        self.node = rclpy.create_node('world_probe', context=context)
        self.lock = threading.Lock()
        self.markers, self.held = [], []
        self.node.create_subscription(MarkerArray, f'{ns}/world/markers',
                                      self._keep(self.markers), PROBE_QOS)
        self.node.create_subscription(String, f'{ns}/world/held_object',
                                      self._keep(self.held), PROBE_QOS)
        self.world_reset = self.node.create_client(Trigger, f'{ns}/world/reset')
        self.reset = self.node.create_client(Trigger, f'{ns}/reset')

    def _keep(self, store):
        def cb(msg):
            with self.lock:
                store.append((time.monotonic(), msg))
        return cb

    def wait(self, predicate, timeout=20.0, what='condition', seen=None):
        """Wait (the lock held for each check) until predicate(); fail with seen() if given."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            with self.lock:
                if predicate():
                    return
            time.sleep(0.01)
        with self.lock:
            shown = f': {seen()}' if seen is not None else ''
        raise AssertionError(f'timed out ({timeout} s) waiting for {what}{shown}')

    def last(self):
        with self.lock:
            return {m.name: m for m in markers_of(self.markers[-1][1])}

    def call(self, client, timeout=20.0):
        assert client.wait_for_service(timeout_sec=timeout)
        future = client.call_async(Trigger.Request())
        end = time.monotonic() + timeout
        while not future.done() and time.monotonic() < end:
            time.sleep(0.01)
        assert future.done()
        return future.result()


@pytest.fixture
def falling_scene(tmp_path):
    path = tmp_path / 'falling.yaml'
    path.write_text(FALLING)
    return str(path)


def _driver(context, **params):
    overrides = [Parameter(k, value=v) for k, v in params.items()]
    return SimDriverNode(context=context, parameter_overrides=overrides)


def _start(context, spin_node, **params):
    driver = _driver(context, **params)
    probe = WorldProbe(context)
    spin_node(driver, probe.node)
    return driver, probe


def test_default_scene_markers_and_held_object(rclpy_context, spin_node):
    """pick_place: one marker per body, ns/frame/shape/colour as contracted, ~30 Hz, held ''."""
    driver, probe = _start(rclpy_context, spin_node)
    probe.wait(lambda: len(probe.markers) >= 20, what='20 world/markers messages')
    probe.wait(lambda: probe.held, what='world/held_object')
    msg = probe.markers[-1][1]
    infos = {o.name: o for o in driver.sim.objects()}
    assert {'red_cube', 'green_cube', 'blue_cylinder'} <= set(infos)
    assert sorted(m.text for m in msg.markers) == sorted(infos)
    for m in msg.markers:
        info = infos[m.text]
        assert m.header.frame_id == 'px100/base_link'
        assert m.ns == {'object': 'objects', 'fixture': 'fixtures', 'table': 'table'}[info.kind]
        assert m.type == {'box': 1, 'sphere': 2, 'cylinder': 3}[info.shape]
        assert [m.color.r, m.color.g, m.color.b, m.color.a] == pytest.approx(list(info.rgba))
    ids = {m.text: m.id for m in msg.markers}
    assert ids == {m.text: m.id for m in probe.markers[0][1].markers}
    assert len(set(ids.values())) == len(ids)
    poses = driver.sim.object_poses()
    for name, m in probe.last().items():
        if m.ns == 'objects':
            assert m.position == pytest.approx(tuple(poses[name][0]), abs=2e-3)
    # the rate on the messages' stamps (the driver's sample times) over 2 s: this process's
    # scheduling does not count; markers at every joint_states sample (100 Hz) or a stalled
    # driver still fall outside the bounds
    probe.wait(lambda: len(probe.markers) >= 61, what='61 world/markers messages',
               seen=lambda: len(probe.markers))
    with probe.lock:
        stamps = [m.markers[0].header.stamp for _, m in probe.markers[-60:]]
    times = [s.sec + 1e-9 * s.nanosec for s in stamps]
    rate = (len(times) - 1) / (times[-1] - times[0])
    assert 15.0 < rate < 45.0, (rate, times[0], times[-1])
    assert probe.held[-1][1].data == ''


def test_world_reset_and_reset_restore_the_objects(rclpy_context, spin_node, falling_scene):
    """A cube that fell 20 mm is back at its initial pose after world/reset and after reset."""
    driver, probe = _start(rclpy_context, spin_node, scene=falling_scene)
    z0 = 0.0325
    probe.wait(lambda: probe.markers and
               markers_of(probe.markers[-1][1])[-1].position[2] < 0.014,
               what='the cube to fall onto the table')
    for client, word in ((probe.world_reset, 'initial poses'), (probe.reset, 'objects')):
        with probe.lock:
            n = len(probe.markers)
        res = probe.call(client)
        assert res.success and word in res.message, res.message
        # a marker sent before the reset may still arrive after its reply: wait for the reset's
        probe.wait(lambda: any(abs(markers_of(msg)[-1].position[2] - z0) < 1e-3
                               for _, msg in probe.markers[n:]),
                   what=f'a marker at z0 = {z0} after the reset',
                   seen=lambda: [round(markers_of(msg)[-1].position[2], 4)
                                 for _, msg in probe.markers[n:]][-20:])
        with probe.lock:
            after = [markers_of(msg)[-1].position[2] for _, msg in probe.markers[n:]]
        # published at once from the initial pose (the cube then falls again)
        assert max(after) == pytest.approx(z0, abs=1e-3), after
        probe.wait(lambda: markers_of(probe.markers[-1][1])[-1].position[2] < 0.014,
                   what='the cube to fall again')
    assert driver.sim.joint_state().position[:4] == pytest.approx(
        list(driver.model.sleep), abs=0.02)


def test_scene_parameter_change_and_bad_scenes(rclpy_context, spin_node, falling_scene,
                                               tmp_path):
    """A good scene loads live; bad ones are refused with the loader's reason, node runs on."""
    driver, probe = _start(rclpy_context, spin_node, scene='')
    probe.wait(lambda: probe.markers, what='world/markers (empty scene)')
    assert probe.markers[-1][1].markers == []
    result = driver.set_parameters([Parameter('scene', value=falling_scene)])[0]
    assert result.successful, result.reason
    probe.wait(lambda: probe.markers and [m.text for m in probe.markers[-1][1].markers]
               == ['table', 'cube'], what='the new scene on world/markers')
    bad_key = tmp_path / 'bad_key.yaml'
    bad_key.write_text(FALLING.replace('mass: 0.03', 'mass: 0.03, colour: red'))
    nan = tmp_path / 'nan.yaml'
    nan.write_text(FALLING.replace('0.0325]', '.nan]'))
    overlap = tmp_path / 'overlap.yaml'
    overlap.write_text(FALLING + '  - {name: cube2, shape: box, size: [0.025, 0.025, 0.025], '
                       'mass: 0.03, position: [0.21, 0.0, 0.0325]}\n')
    far = tmp_path / 'far.yaml'
    far.write_text(FALLING.replace('position: [0.2, 0.0, 0.0325]',
                                   'position: [0.2, 0.0, 0.0325]}\n  - {name: far, shape: '
                                   'sphere, size: [0.01], mass: 0.01, position: [0.9, 0.0, 0.01]'))
    cases = [(str(tmp_path / 'missing.yaml'), 'missing.yaml'), ('no_such_scene', 'no_such_scene'),
             (str(bad_key), 'colour'), (str(nan), 'position'), (str(overlap), 'overlap'),
             (str(far), 'reach')]
    for value, word in cases:
        result = driver.set_parameters([Parameter('scene', value=value)])[0]
        assert not result.successful, value
        assert result.reason.startswith('scene') and word in result.reason, result.reason
    assert driver.get_parameter('scene').value == falling_scene
    with probe.lock:
        n = len(probe.markers)
    probe.wait(lambda: len(probe.markers) > n + 5, what='markers still flowing')
    assert [m.text for m in probe.markers[-1][1].markers] == ['table', 'cube']


def test_bad_scene_at_start_exits_with_the_reason(node_process, tmp_path):
    """sim_driver -p scene:=<bad> exits 1 and prints the loader's reason; no traceback."""
    bad = tmp_path / 'bad.yaml'
    bad.write_text(FALLING.replace('mass: 0.03', 'mass: -1'))
    for value, word in ((str(bad), 'mass'), ('no_such_scene', 'no_such_scene')):
        proc = node_process('sim_driver', '--ros-args', '-p', f'scene:={value}')
        code = proc.proc.wait(120)
        out = proc.output()
        assert code == 1, out
        assert 'sim_driver: error:' in out and word in out, out
        assert 'Traceback' not in out, out
