"""The command lines of record and replay (plain argparse), and --remap taken out of argv."""
import argparse

from px100_control.bag.recording import TopicSelection
from px100_control.bag.tool_options import (add_record_arguments, add_replay_arguments,
                                            extract_remaps, record_selection)


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


def test_record_selection_flags_as_ros2_bag_record():
    """-a: topics, services, actions; one flag: one kind; nothing: the robot view."""
    parser = argparse.ArgumentParser()
    add_record_arguments(parser)

    def selection(*argv):
        kw = record_selection(parser.parse_args(list(argv)))
        sel = TopicSelection('/px100', kw.pop('topics'), kw.pop('all_topics'),
                             kw.pop('robot_only'), kw.pop('all_services'), kw.pop('all_actions'),
                             kw.pop('include_hidden_topics'))
        assert kw == {}
        return (sel.all_topics, sel.all_services, sel.all_actions, sel.include_hidden,
                sel.robot_only)
    assert selection() == (True, False, False, False, True)
    assert selection('-a') == (True, True, True, False, False)
    assert selection('--all-topics') == (True, False, False, False, False)
    assert selection('--all-services') == (False, True, False, False, False)
    assert selection('--all-actions', '--robot-only') == (False, False, True, False, True)
    assert selection('--all-topics', '--include-hidden-topics') == (
        True, False, False, True, False)
    assert selection('joint_states') == (False, False, False, False, False)


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
