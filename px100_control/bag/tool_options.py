"""
The command-line options of ``record`` and ``replay`` (those of ``ros2 bag record`` / ``play``).

Plain argparse, no ROS: the nodes' ``main`` hands these to ``parse_cli``. Durations are
seconds, rates Hz; relative topic names are taken under ``/<robot_name>/`` by the nodes.
"""
from typing import List, Sequence, Tuple


def add_record_arguments(parser) -> None:
    """Add the options of ``record`` to an argparse parser."""
    parser.add_argument('topics', nargs='*', metavar='TOPIC',
                        help='topics to record (relative names are under the robot namespace, '
                             '/<robot_name>/)')
    parser.add_argument('-a', '--all', action='store_true',
                        help='record all topics (hidden _topics excepted), services and '
                             'actions, as ros2 bag record -a')
    parser.add_argument('--all-topics', action='store_true',
                        help='record all topics (hidden _topics excepted)')
    parser.add_argument('--all-services', action='store_true',
                        help='record all services via their <service>/_service_event topics')
    parser.add_argument('--all-actions', action='store_true',
                        help='record all actions: their service events, feedback and status')
    parser.add_argument('--include-hidden-topics', action='store_true',
                        help='with --all-topics, record the hidden _topics too')
    parser.add_argument('--robot-only', action='store_true', default=None,
                        help='only the robot namespace (all of it), /diagnostics, /tf and '
                             '/tf_static (the default when nothing else is asked for)')
    parser.add_argument('-o', '--output', default=None,
                        help='bag directory to create (default rosbag2_<date>-<time>)')
    parser.add_argument('--duration', type=float, default=None,
                        help='stop after this many seconds')
    parser.add_argument('--max-messages', type=int, default=None,
                        help='stop after this many messages')
    parser.add_argument('--idle-timeout', type=float, default=None,
                        help='stop when no message arrived for this many seconds')
    parser.add_argument('--no-tf', action='store_true',
                        help='do not write /tf from joint_states')
    parser.add_argument('--tf-rate', type=float, default=50.0, help='highest /tf rate [Hz]')
    parser.add_argument('--no-robot-description', action='store_true',
                        help='do not write the model URDF when no robot_description is '
                             'published')
    parser.add_argument('--compression', choices=('zstd', 'lz4', 'none'), default='zstd',
                        help='chunk compression (default zstd)')
    parser.add_argument('--flush-period', type=float, default=1.0,
                        help='write a chunk at least this often [s]: what a SIGKILL can lose')


def record_selection(options) -> dict:
    """
    Return the recorder's selection keywords of parsed ``record`` options.

    ``-a`` is all three kinds (topics, service events, actions); ``--all-topics``,
    ``--all-services``, ``--all-actions`` one each; none of them (and no TOPIC): the robot view.
    """
    return {'topics': options.topics, 'robot_only': options.robot_only,
            'all_topics': options.all or options.all_topics,
            'all_services': options.all or options.all_services,
            'all_actions': options.all or options.all_actions,
            'include_hidden_topics': options.include_hidden_topics}


def add_replay_arguments(parser) -> None:
    """Add the options of ``replay`` to an argparse parser (``--remap``: see extract_remaps)."""
    parser.add_argument('bag', help='bag directory (or .mcap file)')
    parser.add_argument('-r', '--rate', type=float, default=1.0,
                        help='playback speed factor (default 1.0)')
    parser.add_argument('-l', '--loop', action='store_true', help='replay again and again')
    parser.add_argument('--topics', nargs='+', default=None, metavar='TOPIC',
                        help='topics to replay (default: all); relative names are under '
                             '/<robot_name>/')
    parser.add_argument('--remap', '-m', nargs='*', default=None, metavar='FROM:=TO',
                        help='publish topic FROM on TO')
    parser.add_argument('--start-offset', type=float, default=0.0,
                        help='skip this many seconds of the bag at the start')
    parser.add_argument('--delay', type=float, default=0.0,
                        help='wait this many seconds before publishing')
    parser.add_argument('--wait-for-subscribers', type=float, default=0.0, metavar='S',
                        help='wait up to S seconds for a subscriber on every topic')
    parser.add_argument('--min-subscribers', type=int, default=1, metavar='N',
                        help='with --wait-for-subscribers: wait for N subscribers per topic')
    parser.add_argument('--no-progress', action='store_true',
                        help='no progress line on stderr')
    parser.add_argument('--send-commands', action='store_true',
                        help='also replay goals and setpoints into a namespace where a live '
                             'driver or trajectory_server runs (default: skip them there)')


def extract_remaps(argv: Sequence[str]) -> Tuple[List[str], List[str]]:
    """
    Return (argv without them, [from:=to, ...]) of the ``--remap``/``-m`` options.

    rcl would take a bare ``from:=to`` for a (deprecated) node remap rule, so the values are
    taken out of the command line before it reaches rclpy.
    """
    out, remaps, i = [], [], 0
    argv = list(argv)
    while i < len(argv):
        arg = argv[i]
        if arg == '--ros-args':
            out.extend(argv[i:])
            break
        if arg in ('--remap', '-m') or arg.startswith('--remap='):
            if arg.startswith('--remap='):
                remaps.append(arg.split('=', 1)[1])
            i += 1
            first = i
            while i < len(argv) and not argv[i].startswith('-') and (
                    ':=' in argv[i] or (i == first and not arg.startswith('--remap='))):
                remaps.append(argv[i])  # a value without ':=' is refused with a clear error
                i += 1
            continue
        out.append(arg)
        i += 1
    return out, remaps
