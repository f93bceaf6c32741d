"""
`replay` through real nodes.

The recorded bytes arrive in order with their recorded spacing (scaled by --rate), latched
topics stay latched, --topics/--remap/--start-offset/--loop work, and bad input gives one error
line and exit status 1.
"""
from bag_ros_support import RawListener, wait_until
from bag_support import decode, joint_state, mcap_path, string, T0_NS
from px100_control.bag import metadata as md
from px100_control.bag.writer import BagWriter
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String

pytestmark = pytest.mark.ros
START_TIMEOUT = 90.0
SP = '/px100/commands/joint_setpoints'
UNKNOWN = '/px100/unknown'
N = 50
PERIOD_NS = 20_000_000  # 50 Hz for 1 s


@pytest.fixture(scope='module')
def replay_bag(tmp_path_factory):
    """
    Return (bag dir, setpoint bytes): 1 s of 50 Hz setpoints, a latched string, an odd type.

    The odd type is not installed (not /tf: setup.sh builds tf2_msgs now).
    """
    bag_dir = str(tmp_path_factory.mktemp('replay') / 'bag')
    sent = []
    with BagWriter(bag_dir) as bag:
        bag.add_topic(SP, 'sensor_msgs/msg/JointState', [md.qos_profile()])
        bag.add_topic('/px100/robot_description', 'std_msgs/msg/String',
                      [md.qos_profile(durability='transient_local', depth=1)])
        bag.add_topic(UNKNOWN, 'nosuch_msgs/msg/Thing', [md.qos_profile(depth=100)],
                      msgdef='int32 x\n')
        bag.write('/px100/robot_description', string('<robot name="r"/>'), T0_NS)
        for i in range(N):
            t = T0_NS + i * PERIOD_NS
            data = joint_state(t, ['waist'], [0.01 * i])
            bag.write(SP, data, t)
            sent.append(data)
            bag.write(UNKNOWN, bytes([0, 1, 0, 0, i, 0, 0, 0]), t)
    return bag_dir, sent


def _replay(node_process, *args):
    proc = node_process('replay', *args, '--wait-for-subscribers', '60')
    assert proc.proc.wait(START_TIMEOUT + 60) == 0, proc.output()
    return proc.output()


def test_replay_bytes_timing_and_latched_topic(
        rclpy_context, spin_node, node_process, replay_bag):
    """Every setpoint arrives once, in order, byte-identical, 0.98 s apart end to end."""
    bag_dir, sent = replay_bag
    listener = spin_node(RawListener([(SP, JointState), ('/px100/robot_description', String)],
                                     context=rclpy_context))
    out = _replay(node_process, bag_dir)
    assert wait_until(lambda: listener.count(SP) >= N, 10.0)
    got = listener.got[SP]
    assert [d for _, d in got] == sent
    span = got[-1][0] - got[0][0]
    assert span == pytest.approx(0.98, abs=0.15), span
    gaps = [b[0] - a[0] for a, b in zip(got, got[1:])]
    assert sorted(gaps)[len(gaps) // 2] == pytest.approx(0.02, abs=0.008)
    assert f"'{UNKNOWN}' has type 'nosuch_msgs/msg/Thing', which is not installed" in out
    assert '[replay] done: 51 messages' in out  # the unknown type is not replayed
    assert listener.count('/px100/robot_description') == 1
    assert 'no subscriber' not in out


def test_rate_topics_remap_offset(rclpy_context, spin_node, node_process, replay_bag):
    """--rate 2 halves the spacing; --remap renames; --start-offset skips the first 0.5 s."""
    bag_dir, sent = replay_bag
    listener = spin_node(RawListener([('/other', JointState)], context=rclpy_context))
    _replay(node_process, bag_dir, '--topics', 'commands/joint_setpoints', '--remap',
            'commands/joint_setpoints:=/other', '--rate', '2', '--start-offset', '0.5')
    assert wait_until(lambda: listener.count('/other') >= 25, 10.0)
    got = listener.got['/other']
    assert [d for _, d in got] == sent[25:]
    assert got[-1][0] - got[0][0] == pytest.approx(0.24, abs=0.1)


def test_latched_topic_reaches_a_subscriber(rclpy_context, spin_node, node_process,
                                            replay_bag):
    """A transient-local subscriber gets the replayed robot_description."""
    bag_dir, _ = replay_bag
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)
    listener = spin_node(RawListener([('/px100/robot_description', String)], qos=latched,
                                     context=rclpy_context))
    _replay(node_process, bag_dir, '--topics', '/px100/robot_description')
    assert wait_until(lambda: listener.count('/px100/robot_description') == 1, 10.0)
    sent = string('<robot name="r"/>')
    got = listener.got['/px100/robot_description'][0][1]
    # rmw_fastrtps pads a raw-published payload with zeros to a multiple of 4 bytes
    assert got[:len(sent)] == sent and set(got[len(sent):]) <= {0} and len(got) % 4 == 0
    assert decode(got, 'std_msgs/msg/String').data == '<robot name="r"/>'


def test_loop_repeats_until_stopped(rclpy_context, spin_node, node_process, replay_bag):
    """--loop replays again and again; SIGINT ends it with exit status 0."""
    bag_dir, sent = replay_bag
    listener = spin_node(RawListener([(SP, JointState)], context=rclpy_context))
    proc = node_process('replay', bag_dir, '--topics', SP, '--loop', '-r', '4',
                        '--wait-for-subscribers', '60')
    assert wait_until(lambda: listener.count(SP) >= 2 * N + 5, START_TIMEOUT + 30)
    assert proc.stop(30.0) == 0, proc.output()
    got = [d for _, d in listener.got[SP]]
    assert got[:2 * N] == sent + sent


@pytest.mark.parametrize('args, message', [
    (['{bag}', '--topics', UNKNOWN], "type 'nosuch_msgs/msg/Thing', which is not installed"),
    (['{bag}', '--topics', '/nope'], "no topic '/nope'"),
    (['{bag}', '--remap', '/nope:=/x'], 'cannot remap /nope'),
    (['{bag}', '--remap', 'bad'], 'not of the form from:=to'),
    (['{bag}', '--rate', '0'], 'rate must be a finite number > 0'),
    (['{bag}', '--start-offset', '9'], 'beyond the end of the bag'),
    (['{empty}'], 'empty file'),
    (['{truncated}'], 'truncated'),
])
def test_bad_input(replay_bag, tmp_path, capsys, args, message):
    """One error line naming the problem, exit status 1, no traceback (main() in-process)."""
    from px100_control.ros.replayer_node import main
    bag_dir, _ = replay_bag
    empty = tmp_path / 'e.mcap'
    empty.write_bytes(b'')
    truncated = tmp_path / 't.mcap'
    with open(mcap_path(bag_dir), 'rb') as f:
        truncated.write_bytes(f.read()[:3000])
    args = [a.format(bag=bag_dir, empty=str(empty), truncated=str(truncated)) for a in args]
    assert main(['replay', *args]) == 1
    err = capsys.readouterr().err
    assert 'replay: error: ' in err and message in err, err
    assert 'Traceback' not in err


def test_replay_executable_bad_input(node_process, tmp_path):
    """The installed executable: a missing bag is one error line and exit status 1."""
    proc = node_process('replay', str(tmp_path / 'missing'))
    assert proc.proc.wait(START_TIMEOUT) == 1
    out = proc.output()
    assert 'replay: error: ' in out and 'no such bag' in out, out
    assert 'Traceback' not in out


def test_inspect_executable_bad_input(node_process, tmp_path):
    """The inspect executable: a missing bag is one error line and exit status 1."""
    proc = node_process('inspect', str(tmp_path / 'missing'))
    assert proc.proc.wait(START_TIMEOUT) == 1
    assert 'inspect: error:' in proc.output() and 'Traceback' not in proc.output()
