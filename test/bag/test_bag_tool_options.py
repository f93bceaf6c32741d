"""The command lines of record and replay (plain argparse), and --remap taken out of argv."""
import argparse

from px100_control.bag.tool_options import (add_record_arguments, add_replay_arguments,
                                            extract_remaps)


def test_record_options():
    """The ros2 bag record options and their defaults."""
    parser = argparse.ArgumentParser()
    add_record_arguments(parser)
    o = parser.parse_args([])
    assert (o.topics, o.all, o.robot_only, o.output, o.tf_rate, o.compression,
            o.flush_period, o.no_tf) == ([], False, None, None, 50.0, 'zstd', 1.0, False)
    o = parser.parse_args(['joint_states', '/diagnostics', '-a', '--duration', '2.5',
                           '--max-messages', '10', '--compression', 'none', '-o', 'out'])
    assert (o.topics, o.all, o.duration, o.max_messages, o.compression, o.output) == (
        ['joint_states', '/diagnostics'], True, 2.5, 10, 'none', 'out')


def test_replay_options_and_remaps_taken_out_before_rclpy():
    """--remap values leave argv before rclpy sees them; --ros-args stays untouched."""
    argv, remaps = extract_remaps(['replay', 'bag', '--remap', 'a:=b', 'c:=d', '-r', '2',
                                   '--remap=e:=f', '-m', 'g', '--ros-args', '-r', 'x:=y'])
    assert remaps == ['a:=b', 'c:=d', 'e:=f', 'g']
    assert argv == ['replay', 'bag', '-r', '2', '--ros-args', '-r', 'x:=y']
    parser = argparse.ArgumentParser()
    add_replay_arguments(parser)
    o = parser.parse_args(argv[1:argv.index('--ros-args')])
    assert (o.bag, o.rate, o.loop, o.delay, o.min_subscribers, o.send_commands) == (
        'bag', 2.0, False, 0.0, 1, False)
