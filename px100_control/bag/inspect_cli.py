"""
``ros2 run px100_control inspect BAG``: print a bag's summary and write plots of the run.

Prints the files, time span and, per topic, type, message count, rate and QoS, then the
calls: per service and action, the requests and responses (goals, cancels, results) counted
from their ``_service_event`` topics (:mod:`px100_control.bag.calls`). Unless
``--no-plots``, writes into ``--output`` (default ``<bag>_plots``): ``joints.png`` (joint
positions and setpoints over time), ``tracking_error.png`` (setpoint - measured),
``ee_path.png`` (the end-effector path in 3D: ee_pose, else forward kinematics),
``object_paths.png`` (when the bag has ``world/markers``: the objects' paths, top view and
height vs time, next to the end effector's) and ``arm.gif``
(an animation of the arm from joint_states through the URDF recorded in the bag, else the
``--robot-model``'s). Needs no ROS graph (and no ROS install). A missing, empty, truncated or
corrupt bag, or an unknown topic: one clear error line and exit status 1.
"""
import argparse
import datetime
import os
import sys
from typing import List, Optional

from px100_control.bag import plots
from px100_control.bag.calls import format_calls, summarise_calls
from px100_control.bag.plots import default_output_dir
from px100_control.bag.reader import BagReader, BagSummary
from px100_control.bag.tf import TfTree
from px100_control.bag.world import extract_object_paths
from px100_control.errors import BagError, Px100Error
from px100_control.models.registry import load_robot
from px100_control.models.urdf_writer import urdf_from_model


def format_summary(summary: BagSummary) -> str:
    """Return the printable summary of a bag (what ``ros2 bag info`` shows, plus rates)."""
    size = sum(os.path.getsize(f) for f in summary.files if os.path.exists(f))
    start = datetime.datetime.fromtimestamp(summary.start_ns * 1e-9, datetime.timezone.utc)
    lines = [
        f'bag:        {summary.path}',
        f"files:      {', '.join(os.path.basename(f) for f in summary.files)} "
        f'({size / 1e6:.2f} MB, metadata.yaml: '
        f"{'yes' if summary.has_metadata_yaml else 'missing - run bag_reindex'})",
        f'duration:   {summary.duration_s:.3f} s',
        f"start:      {start.isoformat(timespec='milliseconds') if summary.start_ns else '-'}",
        f'messages:   {summary.message_count}',
        f'topics:     {len(summary.topics)}',
    ]
    if summary.topics:
        width = max(len(t) for t in summary.topics)
        tw = max(len(t.type_name) for t in summary.topics.values())
        lines.append(f"  {'topic':<{width}}  {'type':<{tw}}  {'count':>7}  {'rate [Hz]':>9}  qos")
        for name in sorted(summary.topics):
            t = summary.topics[name]
            qos = t.offered_qos_profiles[0] if t.offered_qos_profiles else {}
            q = f"{qos.get('reliability', '?')}, {qos.get('durability', '?')}" if qos else '-'
            lines.append(f'  {name:<{width}}  {t.type_name:<{tw}}  {t.message_count:>7}  '
                         f'{t.rate_hz:>9.2f}  {q}')
    return '\n'.join(lines)


def _tf_tree(series, robot_model: Optional[str], robot_name: str):
    if series.urdf_xml:
        try:
            return TfTree(series.urdf_xml)
        except Px100Error as exc:
            print(f'inspect: the recorded robot_description is not usable ({exc}); '
                  f'using the {robot_model} model', file=sys.stderr)
    model = load_robot(robot_model or 'px100')
    urdf = model.urdf_xml
    if not urdf:
        urdf = urdf_from_model(model)
    return TfTree(urdf, f'{robot_name}/' if robot_name else '')


def write_plots(reader: BagReader, out_dir: str, namespace: Optional[str] = None,
                robot_model: Optional[str] = None, gif: bool = True, fps: float = 10.0,
                max_frames: int = 150) -> List[str]:
    """
    Write the PNG plots (and the GIF) of a bag into out_dir; return the files written.

    Plots that the bag has no data for are skipped with a note on stderr.
    """
    series = plots.extract_series(reader, namespace)
    if not series.names:
        print(f'inspect: no joint_states in {reader.path}: no plots', file=sys.stderr)
        return []
    os.makedirs(out_dir, exist_ok=True)
    written = [plots.plot_joints(series, os.path.join(out_dir, 'joints.png'))]
    try:
        written.append(plots.plot_tracking_error(series,
                                                 os.path.join(out_dir, 'tracking_error.png')))
    except BagError as exc:
        print(f'inspect: no tracking-error plot: {exc}', file=sys.stderr)
    name = series.namespace.strip('/')
    model = robot_model or _recorded_model(reader) or 'px100'
    tree = None
    try:
        tree = _tf_tree(series, model, name)
    except Px100Error as exc:
        print(f'inspect: no URDF for forward kinematics ({exc})', file=sys.stderr)
    t, xyz, source = plots.ee_path(series, tree)
    if len(xyz):
        written.append(plots.plot_ee_path(t, xyz, os.path.join(out_dir, 'ee_path.png'),
                                          source=source))
    world = extract_object_paths(reader, series.namespace, series.start_ns)
    if world.objects():
        written.append(plots.plot_object_paths(t, xyz, world,
                                               os.path.join(out_dir, 'object_paths.png')))
    if gif and tree is not None:
        try:
            written.append(plots.animate_arm(series, tree, os.path.join(out_dir, 'arm.gif'),
                                             fps=fps, max_frames=max_frames,
                                             world=world if world.paths else None))
        except BagError as exc:
            print(f'inspect: no animation: {exc}', file=sys.stderr)
    return written


def _recorded_model(reader: BagReader) -> Optional[str]:
    info = reader.info or {}
    custom = info.get('custom_data') or {}
    return custom.get('robot_model') if isinstance(custom, dict) else None


def main(args=None) -> int:
    """Command line entry point; exit 0, or 1 with a one-line error for a bad bag."""
    parser = argparse.ArgumentParser(
        prog='inspect', description="Print a bag's summary (topics, counts, rates, duration) "
                                    'and write plots of the run (PNG, GIF).')
    parser.add_argument('bag', help='bag directory or .mcap file')
    parser.add_argument('-o', '--output', default=None,
                        help='folder for the plots (default <bag>_plots)')
    parser.add_argument('--no-plots', action='store_true', help='print the summary only')
    parser.add_argument('--no-gif', action='store_true', help='no arm animation')
    parser.add_argument('--namespace', default=None,
                        help='robot namespace to plot, e.g. /px100 (default: the first one)')
    parser.add_argument('--robot-model', default=None,
                        help='robot model for FK when the bag has no robot_description')
    parser.add_argument('--fps', type=float, default=10.0, help='GIF frame rate')
    parser.add_argument('--max-frames', type=int, default=150, help='GIF frame limit')
    parser.add_argument('--topics', nargs='+', default=None,
                        help='check that these topics are in the bag')
    options = parser.parse_args(sys.argv[1:] if args is None else args)
    try:
        with BagReader(options.bag) as reader:
            reader.check_topics(options.topics)
            summary = reader.summary()
            print(format_summary(summary))
            calls = format_calls(summarise_calls(reader))
            if calls:
                print(calls)
            if summary.message_count == 0:
                raise BagError(f'{summary.path}: the bag is empty (no messages)')
            if options.no_plots:
                return 0
            out_dir = options.output or default_output_dir(
                reader.bag_dir if reader.info is not None else reader.path)
            files = write_plots(reader, out_dir, options.namespace, options.robot_model,
                                gif=not options.no_gif, fps=options.fps,
                                max_frames=options.max_frames)
    except Px100Error as exc:
        print(f'inspect: error: {exc}', file=sys.stderr)
        return 1
    for f in files:
        print(f'wrote {f}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
