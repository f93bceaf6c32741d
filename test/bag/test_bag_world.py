"""
The world in messages and bags: marker fields, object /tf, paths, verdicts, record/replay/inspect.

Pure parts on their own; the recorder and the replayer through real rclpy nodes with a publisher
of world/markers and world/held_object as the sim_driver's (QoS included).
"""
from collections import namedtuple
import math
import os
import time

from bag_ros_support import RawListener, wait_until
from bag_support import joint_state, T0_NS
import numpy as np
from px100_control.bag import metadata as md
from px100_control.bag.reader import BagReader
from px100_control.bag.world import (extract_object_paths, marker_scale, object_frame,
                                     object_tf_entries, placement_verdict, world_markers)
from px100_control.bag.writer import BagWriter
from px100_control.errors import InvalidInputError
import pytest

Info = namedtuple('Info', 'name kind shape size rgba mass')
BODIES = [Info('table', 'table', 'box', (0.6, 0.8, 0.02), (0.6, 0.5, 0.4, 1.0), 0.0),
          Info('pedestal', 'fixture', 'cylinder', (0.03, 0.05), (0.5, 0.5, 0.5, 1.0), 0.0),
          Info('red_cube', 'object', 'box', (0.025, 0.025, 0.025), (1.0, 0.0, 0.0, 1.0), 0.03),
          Info('ball', 'object', 'sphere', (0.015,), (0.0, 0.0, 1.0, 1.0), 0.02)]
QY = (0.0, 0.0, math.sin(0.25), math.cos(0.25))


def _poses(t):
    """Object poses at time t [s]: the cube rises and moves in y, the ball stays."""
    return {'table': ((0.2, 0.0, -0.01), (0.0, 0.0, 0.0, 1.0)),
            'pedestal': ((0.15, -0.15, 0.025), (0.0, 0.0, 0.0, 1.0)),
            'red_cube': ((0.2, 0.1 - 0.1 * t, 0.0125 + 0.05 * math.sin(math.pi * t / 2)), QY),
            'ball': ((0.1, 0.15, 0.015), (0.0, 0.0, 0.0, 1.0))}


def test_marker_scale_is_full_extents():
    """Box size as is; cylinder (r, h) -> (2r, 2r, h); sphere r -> 2r x 3; bad sizes named."""
    assert marker_scale('box', (0.1, 0.2, 0.3)) == (0.1, 0.2, 0.3)
    assert marker_scale('cylinder', (0.02, 0.05)) == (0.04, 0.04, 0.05)
    assert marker_scale('sphere', (0.015,)) == (0.03, 0.03, 0.03)
    assert marker_scale('sphere', 0.015) == (0.03, 0.03, 0.03)
    with pytest.raises(InvalidInputError, match="shape 'cone'"):
        marker_scale('cone', (0.1,))
    with pytest.raises(InvalidInputError, match="shape 'box' with size"):
        marker_scale('box', (0.1, 0.2))


def test_world_markers_ids_ns_and_tf_frames():
    """One marker per body, ids in scene order, ns by kind; /tf only for the movable objects."""
    markers = world_markers(BODIES, _poses(0.0), 'px100/base_link')
    assert [(m.ns, m.id, m.name, m.shape) for m in markers] == [
        ('table', 0, 'table', 'box'), ('fixtures', 1, 'pedestal', 'cylinder'),
        ('objects', 2, 'red_cube', 'box'), ('objects', 3, 'ball', 'sphere')]
    assert markers[2].orientation == QY and markers[2].position == (0.2, 0.1, 0.0125)
    assert markers[1].scale == (0.06, 0.06, 0.05)
    tf = object_tf_entries(markers, 'px100')
    assert [(p, c) for p, c, _, _ in tf] == [
        ('px100/base_link', 'px100/objects/red_cube'), ('px100/base_link', 'px100/objects/ball')]
    assert tf[0][2] == (0.2, 0.1, 0.0125) and tf[0][3] == QY
    assert object_frame('', 'x') == 'objects/x'


def test_held_filter_takes_a_grasp_at_once_and_a_loss_once_it_lasts():
    """A few steps without contact while carrying are no release; a real release is (0.2 s)."""
    from px100_control.bag.world import HeldFilter
    f = HeldFilter(grace=0.2)
    ms = 1_000_000
    assert f.update('', 0) == ''
    assert f.update('cyl', 10 * ms) == 'cyl'            # a grasp: at once
    for t in (40, 70, 100):                              # 60 ms lost mid-carry (seen in a run)
        assert f.update('' if t < 100 else 'cyl', t * ms) == 'cyl'
    assert f.update('', 200 * ms) == 'cyl'               # released: still 'cyl' for 0.2 s
    assert f.update('', 399 * ms) == 'cyl'
    assert f.update('', 400 * ms) == ''
    assert f.update('cube', 410 * ms) == 'cube'
    f.reset()
    assert f.held == '' and f.update('', 420 * ms) == ''


def test_held_filter_keeps_a_grasp_while_both_pads_touch_it_on_the_table():
    """Lifted, then resting again between closed pads (squeeze settling, set down): held."""
    from px100_control.bag.world import HeldFilter
    f = HeldFilter(grace=0.2)
    ms = 1_000_000
    assert f.update('', 0, gripped=['cyl']) == ''       # squeezed on the table: not yet held
    assert f.update('cyl', 10 * ms, gripped=['cyl']) == 'cyl'
    for t in range(20, 1000, 10):                        # settled on the table for 1 s
        assert f.update('', t * ms, gripped=['cyl']) == 'cyl'
    assert f.update('cube', 1000 * ms, gripped=['cyl', 'cube']) == 'cyl'
    assert f.update('', 1010 * ms, gripped=[]) == 'cyl'  # fingers open: lost after the grace
    assert f.update('', 1209 * ms, gripped=[]) == 'cyl'
    assert f.update('', 1210 * ms, gripped=[]) == ''
    assert f.update('', 1220 * ms, gripped=['cyl']) == ''   # touched on the table: not held


def test_placement_verdicts():
    """Placed within the tolerance; dropped when lifted but elsewhere; not picked otherwise."""
    start, target = (0.2, 0.1, 0.0125), (0.2, -0.1, 0.0125)
    p = placement_verdict('a', start, (0.205, -0.097, 0.0125), target, heights=[0.05])
    assert p.verdict == 'placed' and p.error == pytest.approx(math.hypot(0.005, 0.003))
    assert p.lift == pytest.approx(0.0375)
    assert placement_verdict('a', start, (0.2, 0.0, 0.0125), target,
                             heights=[0.0125, 0.06]).verdict == 'dropped'
    assert placement_verdict('a', start, (0.203, 0.1, 0.0125), target,
                             heights=[0.0125, 0.015]).verdict == 'not picked'
    assert placement_verdict('a', start, (0.2, 0.1, 0.0125), target).verdict == 'not picked'
    # just outside the tolerance is not placed
    assert placement_verdict('a', start, (0.2, -0.0889, 0.0125), target, heights=[0.1],
                             tolerance=0.011).verdict == 'dropped'
    with pytest.raises(InvalidInputError, match='non-finite'):
        placement_verdict('a', start, (math.nan, 0, 0), target)


def _marker_array_cdr(t_ns, markers):
    from px100_control.ros.world_msgs import marker_array
    from rclpy.serialization import serialize_message
    sec, ns = divmod(t_ns, 10**9)
    from builtin_interfaces.msg import Time
    return serialize_message(marker_array(markers, Time(sec=sec, nanosec=ns)))


def _string_cdr(text):
    from rclpy.serialization import serialize_message
    from std_msgs.msg import String
    return serialize_message(String(data=text))


def _world_bag(bag_dir, seconds=2.0):
    """Write a synthetic run: joint_states at 50 Hz, world/markers at 30 Hz, held changes."""
    latched = md.qos_profile(durability='transient_local', depth=1)
    with BagWriter(bag_dir) as bag:
        bag.add_topic('/px100/joint_states', 'sensor_msgs/msg/JointState', [md.qos_profile()])
        bag.add_topic('/px100/world/markers', 'visualization_msgs/msg/MarkerArray', [latched])
        bag.add_topic('/px100/world/held_object', 'std_msgs/msg/String', [latched])
        bag.write('/px100/world/held_object', _string_cdr(''), T0_NS)
        for i in range(int(seconds * 50)):
            t_ns = T0_NS + i * 20_000_000
            bag.write('/px100/joint_states', joint_state(
                t_ns, ['waist', 'shoulder', 'elbow', 'wrist_angle'], [0.1 * i / 50, 0, 0, 0]),
                t_ns)
        for i in range(int(seconds * 30)):
            t = i / 30
            t_ns = T0_NS + int(t * 1e9) + 1000
            bag.write('/px100/world/markers', _marker_array_cdr(
                t_ns, world_markers(BODIES, _poses(t), 'px100/base_link')), t_ns)
        bag.write('/px100/world/held_object', _string_cdr('red_cube'), T0_NS + 300_000_000)
        bag.write('/px100/world/held_object', _string_cdr(''), T0_NS + 1_700_000_000)


def test_bag_object_paths_and_inspect_plot(tmp_path):
    """Object paths read back from a bag (no ROS graph); inspect writes object_paths.png."""
    from px100_control.bag.inspect_cli import main as inspect_main
    bag_dir = str(tmp_path / 'world')
    _world_bag(bag_dir)
    with BagReader(bag_dir) as reader:
        world = extract_object_paths(reader, '/px100')
    assert world.objects() == ['ball', 'red_cube']
    t, xyz = world.paths['red_cube']
    assert len(t) == 60 and t[0] == pytest.approx(1e-6, abs=1e-5)
    expected = np.array([_poses(tt)['red_cube'][0] for tt in np.arange(60) / 30])
    np.testing.assert_allclose(xyz, expected, atol=1e-12)
    assert world.held[1] == ['', 'red_cube', '']
    assert world.rgba['red_cube'] == (1.0, 0.0, 0.0, 1.0)
    out = str(tmp_path / 'plots')
    assert inspect_main([bag_dir, '-o', out, '--no-gif']) == 0
    png = os.path.join(out, 'object_paths.png')
    assert os.path.getsize(png) > 10_000
    # each object is drawn in its own colour: the red cube red, the blue ball blue
    from PIL import Image
    img = np.asarray(Image.open(png).convert('RGB')).astype(int)
    for rgb in ((255, 0, 0), (0, 0, 255)):
        assert (np.abs(img - rgb).max(axis=2) < 30).sum() > 200, f'no {rgb} path in the plot'


@pytest.mark.ros
def test_recorder_writes_world_topics_and_object_tf(rclpy_context, spin_node, tmp_path):
    """Recorded world/markers and held_object (latched QoS kept), /tf frames px100/objects/*."""
    from px100_control.ros.common import LATCHED_QOS
    from px100_control.ros.recorder import Recorder
    from rclpy.node import Node
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import get_typestore, Stores
    from std_msgs.msg import String
    from visualization_msgs.msg import MarkerArray
    node = spin_node(Node('fake_world', context=rclpy_context))
    pub_m = node.create_publisher(MarkerArray, '/px100/world/markers', LATCHED_QOS)
    pub_h = node.create_publisher(String, '/px100/world/held_object', LATCHED_QOS)
    bag_dir = str(tmp_path / 'rec')
    rec = Recorder(bag_dir, context=rclpy_context, tf_rate=1000.0).start()
    try:
        assert wait_until(lambda: pub_m.get_subscription_count() > 0
                          and pub_h.get_subscription_count() > 0, 60.0)
        pub_h.publish(String(data='red_cube'))
        for i in range(20):
            t_ns = T0_NS + i * 33_000_000
            from rclpy.serialization import deserialize_message
            pub_m.publish(deserialize_message(_marker_array_cdr(
                t_ns, world_markers(BODIES, _poses(i / 30), 'px100/base_link')), MarkerArray))
            time.sleep(0.01)
        time.sleep(0.5)
    finally:
        rec.stop()
    store = get_typestore(Stores.ROS2_JAZZY)
    got, qos = {}, {}
    with Reader(bag_dir) as reader:
        for conn in reader.connections:
            qos[conn.topic] = conn.ext.offered_qos_profiles
        for conn, _, raw in reader.messages():
            got.setdefault(conn.topic, []).append(
                store.deserialize_cdr(bytes(raw), conn.msgtype))
    assert len(got['/px100/world/markers']) == 20
    assert got['/px100/world/held_object'][0].data == 'red_cube'
    assert 'transient_local' in str(qos['/px100/world/markers']).lower()
    tfs = got['/tf']
    assert len(tfs) == 20
    frames = [(tr.header.frame_id, tr.child_frame_id) for tr in tfs[5].transforms]
    assert frames == [('px100/base_link', 'px100/objects/red_cube'),
                      ('px100/base_link', 'px100/objects/ball')]
    tr = tfs[5].transforms[0]
    x, y, z = _poses(5 / 30)['red_cube'][0]
    assert (tr.transform.translation.x, tr.transform.translation.y,
            tr.transform.translation.z) == pytest.approx((x, y, z), abs=1e-12)
    assert tr.header.stamp.sec * 10**9 + tr.header.stamp.nanosec == T0_NS + 5 * 33_000_000


@pytest.mark.ros
def test_replay_publishes_world_topics(rclpy_context, spin_node, node_process, tmp_path):
    """Replay publishes world/markers (every one, in order) and the latched held_object."""
    from std_msgs.msg import String
    from visualization_msgs.msg import MarkerArray
    bag_dir = str(tmp_path / 'world')
    _world_bag(bag_dir, seconds=1.0)
    listener = spin_node(RawListener([('/px100/world/markers', MarkerArray),
                                      ('/px100/world/held_object', String)],
                                     context=rclpy_context))
    proc = node_process('replay', bag_dir, '--topics', 'world/markers', 'world/held_object',
                        '--wait-for-subscribers', '60')
    assert proc.proc.wait(150) == 0, proc.output()
    assert wait_until(lambda: listener.count('/px100/world/markers') >= 30, 10.0)
    with BagReader(bag_dir) as reader:
        recorded = [bytes(m.data) for m in reader.iter_raw(['/px100/world/markers'])]
    from rclpy.serialization import deserialize_message
    # compared decoded: CDR padding bytes are not defined (serializers leave them as they are)
    received = [deserialize_message(d, MarkerArray)
                for _, d in listener.got['/px100/world/markers']]
    assert received == [deserialize_message(d, MarkerArray) for d in recorded]
    assert wait_until(lambda: listener.count('/px100/world/held_object') >= 1, 5.0)
