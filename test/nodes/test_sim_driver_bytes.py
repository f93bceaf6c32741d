"""
The sim_driver's serialized messages agree with rclpy: joint_states, /clock, world/markers.

The driver publishes CDR bytes written in place (px100_control.wire.cdr) when the running
middleware reads them back right; here they are read back and compared with the messages built
the slow way, for the default scene's markers too.
"""
from px100_control.bag.world import world_markers
from px100_control.models.registry import load_robot
from px100_control.ros import cdr
from px100_control.ros.sim_messages import StateMessages
from px100_control.ros.world_msgs import marker_array, raw_marker_writer, update_marker_array
from px100_control.sim.scene import load_scene
from px100_control.sim.simulator import ArmSimulator
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from visualization_msgs.msg import MarkerArray


def test_joint_states_and_clock_bytes_read_back_as_the_messages():
    """Full joint_states (position, velocity, effort) and /clock bytes deserialize exactly."""
    assert cdr.clock_matches_rclpy()
    sim = ArmSimulator(load_robot('px100'))
    sim.command(['waist', 'gripper'], [0.5, 0.3])
    sim.advance(37)
    sample = sim.joint_state()
    out = StateMessages(sample.name)
    assert out.raw
    stamp_ns = 12_345_678_901
    raw = out.joint_state(stamp_ns, sample)
    assert isinstance(raw, bytes)
    expected = JointState(name=list(sample.name), position=sample.position,
                          velocity=sample.velocity, effort=sample.effort)
    expected.header.stamp.sec, expected.header.stamp.nanosec = 12, 345_678_901
    assert deserialize_message(raw, JointState) == expected
    clock = Clock()
    clock.clock.sec, clock.clock.nanosec = 12, 345_678_901
    assert deserialize_message(out.clock(stamp_ns), Clock) == clock
    out.raw = False                                        # the message fallback says the same
    assert out.joint_state(stamp_ns, sample) == expected
    assert out.clock(stamp_ns) == clock


@pytest.mark.parametrize('scene', ['pick_place', 'shapes'])
def test_marker_bytes_are_the_restamped_moved_message(scene):
    """The default scene's world/markers bytes after a move equal the message updated in place."""
    model = load_robot('px100')
    sim = ArmSimulator(model, scene=load_scene(scene, model))
    bodies = sim.objects()
    poses = sim.object_poses()
    msg = marker_array(world_markers(bodies, poses, 'px100/base_link'),
                       deserialize_message(cdr.clock(0, 5), Clock).clock)
    movable = [i for i, b in enumerate(bodies) if b.kind == 'object']
    writer = raw_marker_writer(msg, movable)
    assert writer is not None and movable
    sim.command(['gripper'], effort=[0.4])
    sim.advance(300)                                       # the objects settle a little
    poses = sim.object_poses()
    stamp = deserialize_message(cdr.clock(3, 999_000_001), Clock).clock
    raw = writer.write(3, 999_000_001, [poses[bodies[i].name][0] + poses[bodies[i].name][1]
                                        for i in movable])
    update_marker_array(msg, stamp, [(i, poses[bodies[i].name]) for i in movable])
    # what a subscriber gets from the message (colours are float32 on the wire)
    assert deserialize_message(raw, MarkerArray) == deserialize_message(
        serialize_message(msg), MarkerArray)
