"""
Plots of a recorded run: joint positions and setpoints, tracking error, end-effector path, GIF.

:func:`extract_series` pulls the time series out of a bag (``joint_states``, ``commands/
joint_setpoints``, ``trajectory/feedback``, ``ee_pose`` of one robot namespace); the plot
functions draw them with matplotlib's Agg backend (no display needed) and return the file they
wrote. Times are seconds from the start of the bag, positions in rad (m for prismatic joints),
the end-effector path in m in the robot's base frame. :func:`plot_object_paths` draws the
simulated objects' paths (``world/markers``) next to the end effector's.
"""
from dataclasses import dataclass, field
import os
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
from px100_control.bag.reader import BagReader
from px100_control.errors import BagError

JOINT_STATE = 'sensor_msgs/msg/JointState'
POSE_STAMPED = 'geometry_msgs/msg/PoseStamped'
STRING = 'std_msgs/msg/String'


@dataclass
class BagSeries:
    """
    Time series of one robot in a bag (times [s] from the bag start).

    ``q`` is (N, J) with NaN where a joint was missing from a message.
    """

    namespace: str
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    names: List[str] = field(default_factory=list)
    q: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    setpoints: Dict[str, Tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    feedback: Dict[str, Tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    ee_t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    ee_xyz: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    urdf_xml: Optional[str] = None
    start_ns: int = 0

    def positions_at(self, i: int) -> Dict[str, float]:
        """Return {joint: position} of joint_states sample i (NaN entries left out)."""
        return {n: float(v) for n, v in zip(self.names, self.q[i]) if np.isfinite(v)}


def _namespaces(topics: Dict[str, str]) -> List[str]:
    return sorted({name[:-len('/joint_states')] for name, type_name in topics.items()
                   if name.endswith('/joint_states') and type_name == JOINT_STATE})


def _joint_series(raw_msgs, start_ns) -> Dict[str, Tuple[np.ndarray, np.ndarray]]:
    per: Dict[str, Tuple[list, list]] = {}
    for t_ns, msg in raw_msgs:
        t = (t_ns - start_ns) * 1e-9
        for name, value in zip(msg.name, msg.position):
            ts, vs = per.setdefault(name, ([], []))
            ts.append(t)
            vs.append(value)
    return {n: (np.array(ts), np.array(vs, dtype=float)) for n, (ts, vs) in per.items()}


def extract_series(reader: BagReader, namespace: Optional[str] = None) -> BagSeries:
    """
    Return the joint/setpoint/end-effector series of one robot namespace of a bag.

    :param namespace: e.g. '/px100' (default: the first namespace with joint_states)
    :raises BagError: the namespace has no joint_states in the bag
    """
    spaces = _namespaces(reader.topics)
    if namespace is None:
        namespace = spaces[0] if spaces else ''
    namespace = '/' + namespace.strip('/') if namespace.strip('/') else ''
    js_topic = f'{namespace}/joint_states'
    series = BagSeries(namespace=namespace)
    wanted = {js_topic: 'js', f'{namespace}/commands/joint_setpoints': 'sp',
              f'{namespace}/trajectory/feedback': 'fb', f'{namespace}/ee_pose': 'ee',
              f'{namespace}/robot_description': 'desc'}
    present = [t for t in wanted if t in reader.topics]
    if js_topic not in reader.topics:
        return series
    msgs: Dict[str, list] = {k: [] for k in wanted.values()}
    for raw, msg in reader.iter_decoded(present):
        msgs[wanted[raw.topic]].append((raw.log_time_ns, msg))
    js = msgs['js']
    if not js:
        return series
    series.start_ns = start = min(m[0] for v in msgs.values() for m in v)
    names: List[str] = []
    for _, m in js:
        for n in m.name:
            if n not in names:
                names.append(n)
    q = np.full((len(js), len(names)), np.nan)
    index = {n: i for i, n in enumerate(names)}
    for k, (_, m) in enumerate(js):
        for n, v in zip(m.name, m.position):
            q[k, index[n]] = v
    series.t = np.array([(t - start) * 1e-9 for t, _ in js])
    series.names, series.q = names, q
    series.setpoints = _joint_series(msgs['sp'], start)
    series.feedback = _joint_series(msgs['fb'], start)
    if msgs['ee']:
        series.ee_t = np.array([(t - start) * 1e-9 for t, _ in msgs['ee']])
        series.ee_xyz = np.array([[m.pose.position.x, m.pose.position.y, m.pose.position.z]
                                  for _, m in msgs['ee']])
    if msgs['desc']:
        series.urdf_xml = msgs['desc'][-1][1].data
    return series


def hold_values(t_query: np.ndarray, t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """
    Return v held from its last sample at or before each t_query (NaN before the first).

    Example Input: t_query [0, 1.5, 3], t [1, 2], v [10, 20]. Output: [nan, 10, 20]
    """
    idx = np.searchsorted(t, t_query, side='right') - 1
    out = np.full(len(t_query), np.nan)
    ok = idx >= 0
    out[ok] = v[idx[ok]]
    return out


def tracking_errors(series: BagSeries) -> Dict[str, Tuple[np.ndarray, np.ndarray]]:
    """
    Return {joint: (t, setpoint - measured)} at the joint_states samples.

    Only samples after the joint's first setpoint count; the latest setpoint is held between
    setpoint messages.
    """
    out = {}
    for name, (ts, vs) in series.setpoints.items():
        if name not in series.names or len(ts) == 0:
            continue
        held = hold_values(series.t, ts, vs)
        err = held - series.q[:, series.names.index(name)]
        ok = np.isfinite(err)
        out[name] = (series.t[ok], err[ok])
    return out


def _pyplot():
    import matplotlib  # optional: plots only (matplotlib takes seconds to import)
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt  # optional: after use('Agg')
    return plt


def _grid(n: int) -> Tuple[int, int]:
    cols = 1 if n <= 3 else 2
    return int(np.ceil(n / cols)), cols


def plot_joints(series: BagSeries, path: str, title: str = '') -> str:
    """Draw each joint's measured position and its setpoints over time; return path."""
    plt = _pyplot()
    if not series.names:
        raise BagError('no joint_states to plot')
    rows, cols = _grid(len(series.names))
    fig, axes = plt.subplots(rows, cols, figsize=(6.5 * cols, 2.2 * rows + 0.8), sharex=True,
                             squeeze=False)
    for k, name in enumerate(series.names):
        ax = axes[k // cols][k % cols]
        ax.plot(series.t, series.q[:, k], color='tab:blue', lw=1.4, label='measured')
        if name in series.feedback:
            ts, vs = series.feedback[name]
            ax.plot(ts, vs, color='tab:green', lw=1.0, ls='--', label='trajectory feedback')
        if name in series.setpoints:
            ts, vs = series.setpoints[name]
            ax.step(ts, vs, where='post', color='tab:orange', lw=1.0, label='setpoint')
        unit = 'm' if 'finger' in name else 'rad'
        ax.set_ylabel(f'{name} [{unit}]', fontsize=8)
        ax.grid(True, alpha=0.3)
        if k == 0:
            ax.legend(fontsize=7, loc='best')
    n = len(series.names)
    for k in range(n, rows * cols):
        axes[k // cols][k % cols].set_visible(False)
    for col in range(min(cols, n)):
        last = max(k for k in range(n) if k % cols == col)
        ax = axes[last // cols][col]
        ax.xaxis.set_tick_params(labelbottom=True)
        ax.set_xlabel('time [s]')
    fig.suptitle(title or f'{series.namespace or "/"}: joint positions and setpoints')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def plot_tracking_error(series: BagSeries, path: str, title: str = '') -> str:
    """Draw setpoint - measured per joint over time; return path."""
    plt = _pyplot()
    errors = tracking_errors(series)
    if not errors:
        raise BagError('no setpoints (commands/joint_setpoints) to compute a tracking error')
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for name, (ts, err) in errors.items():
        rms = float(np.sqrt(np.mean(err ** 2))) if len(err) else float('nan')
        ax.plot(ts, err, lw=1.0, label=f'{name} (rms {rms:.4g}, max {np.max(np.abs(err)):.4g})')
    ax.axhline(0.0, color='k', lw=0.6)
    ax.set_xlabel('time [s]')
    ax.set_ylabel('setpoint - measured [rad or m]')
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc='best')
    ax.set_title(title or f'{series.namespace or "/"}: tracking error')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def ee_path(series: BagSeries, tree=None, ee_link: str = 'ee_gripper_link'
            ) -> Tuple[np.ndarray, np.ndarray, str]:
    """
    Return (t, (N, 3) xyz [m], source) of the end-effector: ee_pose, else FK of joint_states.

    :param tree: a TfTree of the robot (for the FK fallback)
    """
    if len(series.ee_t):
        return series.ee_t, series.ee_xyz, 'ee_pose'
    if tree is None or not series.names:
        return np.zeros(0), np.zeros((0, 3)), ''
    link = _find_link(tree, ee_link)
    xyz = np.array([tree.link_poses(series.positions_at(i))[link][:3, 3]
                    for i in range(len(series.t))])
    return series.t, xyz, 'forward kinematics of joint_states'


def _find_link(tree, name: str) -> str:
    for link in tree.links:
        if link == name or link.endswith('/' + name):
            return link
    return tree.links[-1]


def plot_ee_path(t: np.ndarray, xyz: np.ndarray, path: str, title: str = '',
                 source: str = '') -> str:
    """Draw the end-effector path in 3D (start and end marked); return path."""
    plt = _pyplot()
    if len(xyz) == 0:
        raise BagError('no end-effector data (no ee_pose and no joint_states)')
    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection='3d')
    sc = ax.scatter(xyz[:, 0], xyz[:, 1], xyz[:, 2], c=t, cmap='viridis', s=4)
    ax.plot(xyz[:, 0], xyz[:, 1], xyz[:, 2], color='gray', lw=0.6, alpha=0.6)
    ax.scatter(*xyz[0], color='tab:green', s=50, marker='o', label='start')
    ax.scatter(*xyz[-1], color='tab:red', s=50, marker='X', label='end')
    _equal_axes(ax, xyz)
    ax.set_xlabel('x [m]')
    ax.set_ylabel('y [m]')
    ax.set_zlabel('z [m]')
    fig.colorbar(sc, ax=ax, shrink=0.6, label='time [s]')
    ax.legend(fontsize=8, loc='upper left')
    ax.set_title(title or 'end-effector path' + (f' ({source})' if source else ''), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def plot_object_paths(ee_t: np.ndarray, ee_xyz: np.ndarray, world, path: str,
                      title: str = '', targets: Optional[Dict[str, Sequence[float]]] = None,
                      verdicts: Optional[Dict[str, str]] = None) -> str:
    """
    Draw the objects' paths next to the end effector's: top view (x, y) and height z vs time.

    :param ee_t, ee_xyz: end-effector times [s] and positions [m] (may be empty)
    :param world: :class:`px100_control.bag.world.ObjectPaths` (same time origin)
    :param targets: optional name -> target position [m], drawn as crosses
    :param verdicts: optional name -> verdict text, shown in the legend
    :raises BagError: no object paths
    """
    names = world.objects()
    if not names:
        raise BagError('no object paths (no world/markers with objects)')
    plt = _pyplot()
    fig, (top, side) = plt.subplots(1, 2, figsize=(13, 5.5),
                                    gridspec_kw={'width_ratios': [1, 1.4]})
    if len(ee_xyz):
        top.plot(ee_xyz[:, 0], ee_xyz[:, 1], color='gray', lw=0.8, alpha=0.7,
                 label='end effector')
        side.plot(ee_t, ee_xyz[:, 2], color='gray', lw=0.8, alpha=0.7, label='end effector')
    cycle = plt.rcParams['axes.prop_cycle'].by_key()['color']
    for k, name in enumerate(names):
        t, xyz = world.paths[name]
        c = _object_colour(world.rgba.get(name), cycle[k % len(cycle)])
        label = name + (f' ({verdicts[name]})' if verdicts and name in verdicts else '')
        top.plot(xyz[:, 0], xyz[:, 1], color=c, lw=1.6, label=label)
        top.scatter(*xyz[0, :2], color=c, marker='o', s=30)
        top.scatter(*xyz[-1, :2], color=c, marker='s', s=30)
        side.plot(t, xyz[:, 2], color=c, lw=1.6, label=label)
        if targets and name in targets:
            tx, ty, tz = (float(v) for v in targets[name])
            top.scatter(tx, ty, color=c, marker='x', s=80, lw=2)
            side.axhline(tz, color=c, ls=':', lw=0.8)
    t_held, held = world.held
    for i, name in enumerate(held):     # shade the times an object is held
        if name and i + 1 < len(t_held):
            side.axvspan(t_held[i], t_held[i + 1], color='gold', alpha=0.15, lw=0)
        elif name:
            side.axvspan(t_held[i], side.get_xlim()[1], color='gold', alpha=0.15, lw=0)
    top.scatter([0], [0], color='k', marker='+', s=60, label='robot base')
    top.set_aspect('equal', adjustable='datalim')
    top.set_xlabel('x [m]')
    top.set_ylabel('y [m]')
    top.set_title('top view (o start, s end, x target)', fontsize=10)
    top.grid(True, alpha=0.3)
    top.legend(fontsize=7, loc='best')
    side.set_xlabel('time [s]')
    side.set_ylabel('z [m]')
    side.set_title('height (shaded: an object is held)', fontsize=10)
    side.grid(True, alpha=0.3)
    side.legend(fontsize=7, loc='best')
    fig.suptitle(title or 'object paths and end-effector path (base frame)')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def plot_ee_and_objects_3d(ee_xyz: np.ndarray, world, path: str, title: str = '',
                           targets: Optional[Dict[str, Sequence[float]]] = None,
                           verdicts: Optional[Dict[str, str]] = None) -> str:
    """
    Draw the end-effector path and each object's path in 3D, each object in its scene colour.

    :param ee_xyz: end-effector positions [m] (N, 3), may be empty
    :param world: :class:`px100_control.bag.world.ObjectPaths` (colours from world/markers)
    :param targets: optional name -> target position [m], drawn as crosses in the object's colour
    :param verdicts: optional name -> verdict text, shown in the legend
    """
    plt = _pyplot()
    fig = plt.figure(figsize=(8, 7))
    ax = fig.add_subplot(projection='3d')
    if len(ee_xyz):
        ax.plot(ee_xyz[:, 0], ee_xyz[:, 1], ee_xyz[:, 2], color='gray', lw=1.0,
                label='end effector')
    cycle = plt.rcParams['axes.prop_cycle'].by_key()['color']
    for k, name in enumerate(world.objects()):
        _, xyz = world.paths[name]
        c = _object_colour(world.rgba.get(name), cycle[k % len(cycle)])
        label = name + (f' ({verdicts[name]})' if verdicts and name in verdicts else '')
        ax.plot(xyz[:, 0], xyz[:, 1], xyz[:, 2], lw=2.0, color=c, label=label)
        if targets and name in targets:
            ax.scatter(*(float(v) for v in targets[name]), marker='x', s=60, color=c,
                       linewidths=2)
    ax.set_xlabel('x [m]')
    ax.set_ylabel('y [m]')
    ax.set_zlabel('z [m]')
    _few_ticks(ax)
    ax.set_title(title or 'end effector and objects (x: targets)', fontsize=10)
    ax.legend(loc='upper left', fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def label_phases(ax, phases: Sequence[Tuple[float, str]], fontsize: float = 7.0,
                 gap_px: float = 4.0) -> list:
    """
    Write phase labels (time [s], text) on ``ax`` in as many rows as keep them apart.

    Each label goes into the first row where it starts ``gap_px`` right of the previous
    label's end (widths measured by the renderer at the figure's present layout: lay the figure
    out first). The rows run top-down over the axes' height, the x axis is time.
    :return: the Text artists
    """
    renderer = ax.figure.canvas.get_renderer()
    to_px = ax.transData
    ends: List[float] = []                  # right end [px] of the last label in each row
    placed = []
    for t, label in sorted(phases, key=lambda p: p[0]):
        text = ax.text(t, 0.0, label, fontsize=fontsize, color='dimgray', ha='left',
                       va='center', clip_on=False)
        x0 = to_px.transform((t, 0.0))[0]
        width = text.get_window_extent(renderer).width
        row = next((r for r, end in enumerate(ends) if x0 >= end + gap_px), len(ends))
        if row == len(ends):
            ends.append(0.0)
        ends[row] = x0 + width
        placed.append((text, row))
    rows = max(1, len(ends))
    for text, row in placed:
        text.set_y(row)
    ax.set_ylim(rows - 0.5, -0.5)
    ax.set_yticks([])
    return [text for text, _ in placed]


def _object_colour(rgba, fallback: str):
    """Return an object's own colour (rgba 0..1; opaque, darkened if too light to see on white)."""
    if rgba is None or len(rgba) < 3:
        return fallback
    rgb = np.clip(np.asarray(rgba[:3], dtype=float), 0.0, 1.0)
    if rgb.min() > 0.8:                  # a white object on a white page
        rgb = rgb * 0.6
    return tuple(float(v) for v in rgb)


def _equal_axes(ax, pts: np.ndarray, pad: float = 0.02) -> None:
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    center, half = (lo + hi) / 2.0, max(float(np.max(hi - lo)) / 2.0, 0.05) + pad
    ax.set_xlim(center[0] - half, center[0] + half)
    ax.set_ylim(center[1] - half, center[1] + half)
    ax.set_zlim(max(0.0, center[2] - half) if lo[2] >= 0 else center[2] - half,
                center[2] + half)


def _few_ticks(ax, count: int = 4, fontsize: float = 7.0) -> None:
    """Give each axis of a 3D plot at most ``count`` ticks in a small font (none overlap)."""
    from matplotlib.ticker import MaxNLocator  # optional: plots only
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(count))
        axis.set_tick_params(labelsize=fontsize)


def animation_frames(series: BagSeries, fps: float, max_frames: int) -> List[int]:
    """Return the joint_states sample index shown in each GIF frame (real time at fps)."""
    if len(series.t) == 0:
        return []
    duration = float(series.t[-1] - series.t[0])
    count = int(min(max_frames, max(1, np.floor(duration * fps) + 1)))
    times = np.linspace(series.t[0], series.t[-1], count)
    idx = np.searchsorted(series.t, times, side='right') - 1
    return [int(max(0, i)) for i in idx]


def animate_arm(series: BagSeries, tree, path: str, fps: float = 10.0,
                max_frames: int = 150, ee_link: str = 'ee_gripper_link', world=None) -> str:
    """
    Write a GIF of the arm (links as a stick figure, the end-effector trail) from joint_states.

    :param tree: TfTree of the robot (link poses from joint positions)
    :param world: optional :class:`px100_control.bag.world.ObjectPaths` (same time origin as
        ``series``): the table's top, the fixtures and the objects are drawn in their scene
        colours, the objects where they were at each frame's time
    :raises BagError: no joint_states, or pillow is not installed
    """
    plt = _pyplot()
    try:
        from PIL import Image  # optional: pillow writes the GIF
    except ImportError:
        raise BagError('cannot write a GIF: pillow is not installed') from None
    frames = animation_frames(series, fps, max_frames)
    if not frames:
        raise BagError('no joint_states to animate')
    edges = tree.edges()
    ee = _find_link(tree, ee_link)
    poses = [tree.link_poses(series.positions_at(i)) for i in frames]
    pts = np.array([p[:3, 3] for pose in poses for p in pose.values()])
    fig = plt.figure(figsize=(5.5, 5.0))
    ax = fig.add_subplot(projection='3d')
    bodies = [xyz for name, (_, xyz) in (world.paths.items() if world else ())
              if world.kinds.get(name) != 'table']
    _equal_axes(ax, np.vstack([pts, np.zeros((1, 3))] + bodies))
    ax.set_xlabel('x [m]', fontsize=8)
    ax.set_ylabel('y [m]', fontsize=8)
    ax.set_zlabel('z [m]', fontsize=8)
    _few_ticks(ax)
    moving = _draw_world(ax, world) if world is not None else []
    lines = [ax.plot([], [], [], color='tab:blue', lw=3, marker='o', ms=3, zorder=3)[0]
             for _ in edges]
    trail, = ax.plot([], [], [], color='tab:orange', lw=1, zorder=3)
    title = ax.set_title('', fontsize=9)
    trail_pts: List[np.ndarray] = []

    def draw(k):
        pose, t = poses[k], series.t[frames[k]]
        for line, (a, b) in zip(lines, edges):
            p, c = pose[a][:3, 3], pose[b][:3, 3]
            line.set_data_3d([p[0], c[0]], [p[1], c[1]], [p[2], c[2]])
        for dot, (ts, xyz) in moving:
            i = max(0, int(np.searchsorted(ts, t, side='right')) - 1)
            dot._offsets3d = ([xyz[i, 0]], [xyz[i, 1]], [xyz[i, 2]])
        if k == 0:
            trail_pts.clear()
        trail_pts.append(pose[ee][:3, 3])
        arr = np.array(trail_pts)
        trail.set_data_3d(arr[:, 0], arr[:, 1], arr[:, 2])
        title.set_text(f'{series.namespace or "arm"}  t = {t:6.2f} s')
        return lines + [trail, title]

    # what moves is drawn over a background rendered once (axes, ticks, table, fixtures):
    # blitting, 4x faster than a full redraw per frame; same stacking (computed_zorder off)
    dots = [dot for dot, _ in moving]
    animated = dots + lines + [trail, title]
    for artist in animated:
        artist.set_animated(True)
    canvas = fig.canvas
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for k in range(len(frames)):          # each frame rendered once (Animation.save: twice)
        draw(k)
        canvas.restore_region(background)
        for dot in dots:
            dot.do_3d_projection()
        for artist in animated:
            ax.draw_artist(artist)
        images.append(Image.fromarray(np.array(np.asarray(canvas.buffer_rgba())[:, :, :3])))
    plt.close(fig)
    _write_gif(images, path, fps)
    return path


def _write_gif(images: list, path: str, fps: float) -> None:
    """
    Write RGB PIL images as a looping GIF at fps, on one palette.

    The palette is the commonest colours of the first, middle and last frames, at least 8
    levels apart (the plot's flat colours do not change between frames, only where they are;
    antialiased edges take the nearest); no dithering, so flat areas stay exact.
    """
    from PIL import Image  # optional: pillow writes the GIF
    picks = [images[0], images[len(images) // 2], images[-1]]
    strip = Image.new('RGB', (picks[0].width, picks[0].height * len(picks)))
    for i, im in enumerate(picks):
        strip.paste(im, (0, i * im.height))
    counts = sorted(strip.getcolors(maxcolors=strip.width * strip.height), reverse=True)
    chosen = np.full((256, 3), -99)
    n = 0
    for _, rgb in counts:
        # Pillow maps a colour through a cache of 8-level cells: a rarer colour in the cell of
        # a commoner one (252 by the page's 255) would take the commoner's pixels
        if n == 0 or np.abs(chosen[:n] - rgb).max(axis=1).min() >= 8:
            chosen[n], n = rgb, n + 1
            if n == 256:
                break
    palette = Image.new('P', (1, 1))
    palette.putpalette(chosen[:n].ravel().tolist())
    frames = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    frames[0].save(path, save_all=True, append_images=frames[1:],
                   duration=int(round(1000.0 / fps)), loop=0)


def _draw_world(ax, world) -> list:
    """
    Draw the world's bodies on a 3D axes: the table's top as a surface, the rest as dots.

    Dot areas follow the bodies' footprints (roughly, at the axes' scale); return
    [(dot, (t, xyz))] of the movable objects.
    """
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # optional: plots only
    moving = []
    ax.computed_zorder = False         # the table under everything, the arm over the bodies
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    points_per_m = 0.55 * 72.0 * ax.figure.get_figwidth() / (x1 - x0)   # the axes' scale
    for name, (ts, xyz) in world.paths.items():
        colour = _object_colour(world.rgba.get(name), 'tab:gray')
        scale = world.shapes.get(name, ('box', (0.02, 0.02, 0.02)))[1]
        if world.kinds.get(name) == 'table':
            (cx, cy, cz), (sx, sy, sz) = xyz[-1], scale
            lo_x, hi_x = max(x0, cx - sx / 2), min(x1, cx + sx / 2)
            lo_y, hi_y = max(y0, cy - sy / 2), min(y1, cy + sy / 2)
            top = cz + sz / 2
            ax.add_collection3d(Poly3DCollection(
                [[(lo_x, lo_y, top), (hi_x, lo_y, top), (hi_x, hi_y, top), (lo_x, hi_y, top)]],
                facecolors=[colour], alpha=0.45, edgecolors='none', zorder=0))
            continue
        side = float(np.sqrt(scale[0] * scale[1])) * points_per_m     # footprint's side
        area = max(9.0, side ** 2)
        dot = ax.scatter([xyz[0, 0]], [xyz[0, 1]], [xyz[0, 2]], color=[colour], s=area,
                         marker='s', depthshade=False, label=name, zorder=2)
        if world.kinds.get(name) == 'objects':
            moving.append((dot, (ts, xyz)))
    return moving


def default_output_dir(bag_path: str) -> str:
    """Return ``<bag dir>_plots`` next to the bag."""
    base = os.path.abspath(bag_path)
    if os.path.isfile(base):
        base = os.path.splitext(base)[0]
    return base.rstrip('/') + '_plots'
