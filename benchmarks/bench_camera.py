"""
Camera cost side by side, in one run: rendering, the cloud, the filter, the physics beside it.

1. In this process, timed in interleaved rounds (colour, depth, cloud, filter, ..., physics
   step, colour, ...) so a busy machine slows every stage alike; the median round of each:
   the default camera (a D415 at 640 x 480) over the pick_place scene with the arm at sleep,
   MuJoCo's offscreen renderer (``MUJOCO_GL=egl``: software OpenGL on a machine without a GPU);
   colour + depth per frame as ``mujoco.Renderer`` draws them (one pass each) and in the
   product's single pass (``CameraRenderer``: both read from one frame; the pair is its peer),
   the two-pass pair at 320 x 240 (the peer: how the cost scales), the depth
   noise + back-projection of the cloud, Interbotix's filter (defaults) per call on the whole
   cloud as pc_filter gets it and on the workspace in front of the arm only (the peer), and
   the 1 kHz physics step of the same scene (ArmSimulator: PID + servo + MuJoCo), so a frame
   reads as a number of physics steps. Ratios are printed against the peers.
2. Processes (``--no-node`` skips them): the installed ``sim_driver`` at ``real_time_factor``
   0 (as fast as possible, default scene) with and without the ``camera`` process (5 Hz,
   640 x 480) beside it, in alternating windows: simulated seconds per wall
   second read from /clock (bench_sim_driver's probe), the camera's frames received and its
   CPU share; then at real time (100 Hz joint_states) with the camera: the physics real-time
   factor from the joint_states stamps. Load average with every figure.

Bounded (benchmarks/bound.py): BOUND_S s with --quick / without. Writes
``benchmarks/results/camera.json``. Usage (venv + install sourced):
``python benchmarks/bench_camera.py [--quick] [--no-node]``.
"""
import argparse
import json
import os
import statistics
import sys
import time

os.environ.setdefault('MUJOCO_GL', 'egl')

import bound  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from px100_control.models.registry import load_robot  # noqa: E402
from px100_control.perception.camera import (back_project, CameraSpec, noisy_depth,  # noqa: E402
                                             transform_points)
from px100_control.perception.cloud_filter import FilterParams, run_pipeline  # noqa: E402
from px100_control.sim.camera_render import CameraRenderer, posed_model  # noqa: E402
from px100_control.sim.scene import load_scene  # noqa: E402
from px100_control.sim.simulator import ArmSimulator  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
RESULTS = os.path.join(HERE, 'results', 'camera.json')
BOUND_S = (300.0, 900.0)
#: physics steps per timed physics stage of a round (1 ms simulated each)
STEPS = 200


def _frame_ms(renderer, data, name: str) -> tuple:
    """Render colour then depth; return (colour, depth, ms colour, ms depth)."""
    t0 = time.perf_counter()
    renderer.disable_depth_rendering()
    renderer.update_scene(data, camera=name)
    color = renderer.render()
    t1 = time.perf_counter()
    renderer.enable_depth_rendering()
    renderer.update_scene(data, camera=name)
    depth = renderer.render()
    return color, depth, 1e3 * (t1 - t0), 1e3 * (time.perf_counter() - t1)


def rounds(n: int) -> dict:
    """Return the median [ms] of each stage over ``n`` interleaved runs (part 1)."""
    robot = load_robot('px100')
    scene = load_scene('pick_place', robot)
    camera, small = CameraSpec(), CameraSpec(name='small', width=320, height=240)
    model, data = posed_model(robot, scene, camera)
    model_s, data_s = posed_model(robot, scene, small)
    renderer = mujoco.Renderer(model, camera.height, camera.width)
    renderer_s = mujoco.Renderer(model_s, small.height, small.width)
    one_pass = CameraRenderer(model, camera)
    sim = ArmSimulator(robot, scene=scene)
    rng = np.random.default_rng(0)
    T = camera.optical_pose()
    times = {k: [] for k in ('colour', 'depth', 'one_pass', 'colour_depth_320x240', 'cloud',
                             'filter', 'filter_workspace', 'physics_step')}
    clusters = {}
    for k in range(n + 1):                          # round 0 warms up (context, caches)
        color, depth, ms_c, ms_d = _frame_ms(renderer, data, camera.name)
        _, _, ms_cs, ms_ds = _frame_ms(renderer_s, data_s, small.name)
        t0 = time.perf_counter()
        one_pass.render(data)
        ms_one = 1e3 * (time.perf_counter() - t0)
        t0 = time.perf_counter()
        points, colors = back_project(camera.intrinsics(), noisy_depth(camera, depth, rng), color)
        t1 = time.perf_counter()
        full = run_pipeline(points, colors, FilterParams(), rng)
        t2 = time.perf_counter()
        base = transform_points(T, points)
        near = ((base[:, 0] > 0.08) & (base[:, 0] < 0.26) & (np.abs(base[:, 1]) < 0.1)
                & (base[:, 2] > -0.02) & (base[:, 2] < 0.06))
        t3 = time.perf_counter()
        work = run_pipeline(points[near], colors[near], FilterParams(), rng)
        t4 = time.perf_counter()
        for _ in range(STEPS):
            sim.step()
        t5 = time.perf_counter()
        clusters = {'filter': len(full.clusters), 'filter_workspace': len(work.clusters)}
        if k:
            for key, ms in (('colour', ms_c), ('depth', ms_d), ('one_pass', ms_one),
                            ('colour_depth_320x240', ms_cs + ms_ds),
                            ('cloud', 1e3 * (t1 - t0)), ('filter', 1e3 * (t2 - t1)),
                            ('filter_workspace', 1e3 * (t4 - t3)),
                            ('physics_step', 1e3 * (t5 - t4) / STEPS)):
                times[key].append(ms)
        bound.stage(f'round {k} of {n}')
    renderer.close()
    renderer_s.close()
    one_pass.close()
    median = {k: round(statistics.median(v), 3) for k, v in times.items()}
    return {'rounds': n, 'median_ms': median, 'clusters': clusters,
            'load_average': os.getloadavg()}


class _Frames:
    """Count the camera's frames (its colour camera_info: one small message per frame)."""

    def __init__(self):
        import threading

        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from sensor_msgs.msg import CameraInfo
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.node = rclpy.create_node('bench_camera_frames', context=self.ctx)
        self.count = 0
        self.node.create_subscription(CameraInfo, '/px100/camera/color/camera_info',
                                      self._on_info, 5)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def _on_info(self, msg):
        self.count += 1

    def close(self):
        self.executor.shutdown(timeout_sec=2.0)
        self.thread.join(timeout=5.0)
        self.node.destroy_node()
        self.ctx.try_shutdown()


def _unthrottled(seconds: float, camera: bool) -> dict:
    """Return sim_driver's simulated s per wall s at real_time_factor 0, camera on or off."""
    from bench_sim_driver import _ClockProbe, _cpu_seconds
    from px100_control.tools.processes import NodeProcess
    probe, frames = _ClockProbe(), _Frames()
    procs = [NodeProcess('sim_driver', ['--ros-args', '-p', 'real_time_factor:=0.0'])]
    if camera:
        procs.append(NodeProcess('camera'))
    try:
        deadline = time.monotonic() + 90.0
        first = probe.read(1.0)
        while (first is None or first[1] < 1.0 or (camera and frames.count < 3)) and \
                time.monotonic() < deadline:
            time.sleep(0.5)
            first = probe.read(1.0)
        if first is None or (camera and frames.count < 3):
            return {'error': 'no /clock or no camera frames',
                    'log': procs[-1].output()[-2000:]}
        start, n0, cpu0 = probe.read(5.0), frames.count, _cpu_seconds(procs[-1].pid)
        time.sleep(seconds)
        end, cpu1 = probe.read(5.0), _cpu_seconds(procs[-1].pid)
        wall = end[0] - start[0]
        return {'camera': camera, 'sim_s_per_wall_s': round((end[1] - start[1]) / wall, 2),
                'camera_fps': round((frames.count - n0) / seconds, 2) if camera else None,
                'camera_cpu_share': round((cpu1 - cpu0) / seconds, 2) if camera else None,
                'load_average_1min': round(os.getloadavg()[0], 2)}
    finally:
        for proc in reversed(procs):
            proc.stop()
        frames.close()
        probe.close()


def _real_time(seconds: float) -> dict:
    """Return sim_driver's real-time factor at real time with the camera beside it."""
    from bench_sim_driver import _Listener, _window
    from px100_control.tools.processes import NodeProcess
    listener = _Listener()
    procs = [NodeProcess('sim_driver', ['--ros-args', '-p', 'publish_rate:=100.0']),
             NodeProcess('camera')]
    try:
        if not listener.wait(listener.js, 50, 60.0):
            return {'error': 'no joint_states', 'log': procs[0].output()[-2000:]}
        time.sleep(5.0)                             # the camera's first frames (model build)
        samples = _window(listener.js, seconds)
        wall = samples[-1][0] - samples[0][0]
        return {'real_time_factor': round((samples[-1][1] - samples[0][1]) / wall, 4),
                'load_average_1min': round(os.getloadavg()[0], 2)}
    finally:
        for proc in reversed(procs):
            proc.stop()
        listener.close()


def nodes(quick: bool) -> dict:
    """Return part 2: unthrottled sim_driver with and without the camera, alternated."""
    seconds, alternations = (5.0, 1) if quick else (15.0, 2)
    runs = {'off': [], 'on': []}
    for k in range(alternations):
        for key in ('off', 'on'):
            bound.log(f'sim_driver unthrottled, camera {key}, window {k + 1}')
            runs[key].append(_unthrottled(seconds, key == 'on'))
    out = dict(runs)
    good = {key: [r['sim_s_per_wall_s'] for r in rows if 'error' not in r]
            for key, rows in runs.items()}
    if good['off'] and good['on']:
        out['on_vs_off'] = round(statistics.median(good['on'])
                                 / statistics.median(good['off']), 3)
    bound.log('sim_driver at real time with the camera')
    out['real_time_with_camera'] = _real_time(seconds)
    return out


def report(out: dict) -> None:
    """Print the figures and their ratios against the peers."""
    m = out['median_ms']
    pair = m['colour'] + m['depth']
    print(f"camera 640x480, {out['rounds']} rounds, load {out['load_average'][0]:.2f} on "
          f'{os.cpu_count()} cores (median ms):')
    for key, value in m.items():
        print(f'  {key:22s} {value:8.3f}')
    print(f'  colour + depth {pair:.1f} ms per frame = {pair / m["physics_step"]:.0f} physics '
          f'steps (1 ms simulated each); {pair / m["colour_depth_320x240"]:.2f}x the 320x240 '
          f'frame')
    print(f'  one pass (CameraRenderer) {m["one_pass"]:.1f} ms: the two-pass pair / one pass '
          f'{pair / m["one_pass"]:.2f}x; at 5 Hz with the cloud '
          f'{0.5 * (m["one_pass"] + m["cloud"]):.0f} % of a core')
    print(f'  filter {m["filter"]:.1f} ms per call on the whole cloud '
          f'({out["clusters"]["filter"]} clusters) = {m["filter"] / m["filter_workspace"]:.1f}x '
          f'the workspace crop ({out["clusters"]["filter_workspace"]} clusters); '
          f'{m["filter"] / pair:.2f}x a frame')
    node = out.get('node')
    if node:
        for key in ('off', 'on'):
            for row in node[key]:
                print(f'  sim_driver unthrottled, camera {key}: {row}')
        print(f'  camera on / off (simulated s per wall s): {node.get("on_vs_off")}')
        print(f'  sim_driver at real time with the camera: {node["real_time_with_camera"]}')


def markdown(out: dict) -> str:
    """Return the figures as a Markdown table (run_all.py's section)."""
    m = out['median_ms']
    pair = m['colour'] + m['depth']
    rows = ['| camera (640 x 480, D415 defaults) | figure |', '| --- | --- |',
            f'| colour + depth per frame | {pair:.1f} ms ({m["colour"]:.1f} + {m["depth"]:.1f}); '
            f'{pair / m["colour_depth_320x240"]:.2f}x a 320 x 240 frame; '
            f'{pair / m["physics_step"]:.0f} physics steps |',
            f'| one pass (the camera node\'s) / the two-pass pair | {m["one_pass"]:.1f} ms; '
            f'{pair / m["one_pass"]:.2f}x faster |',
            f'| cloud (noise + back-projection) | {m["cloud"]:.1f} ms |',
            f'| filter per call, whole cloud / workspace crop | {m["filter"]:.0f} / '
            f'{m["filter_workspace"]:.0f} ms ({m["filter"] / m["filter_workspace"]:.1f}x) |']
    node = out.get('node') or {}
    for key in ('off', 'on'):
        for row in node.get(key, []):
            rows.append(f'| sim_driver unthrottled, camera {key} | '
                        f'{row.get("sim_s_per_wall_s", row.get("error"))} x real time '
                        f'(load {row.get("load_average_1min")}) |')
    if 'on_vs_off' in node:
        rows.append(f'| camera on / off, unthrottled physics | {node["on_vs_off"]} |')
    if node.get('real_time_with_camera'):
        rows.append(f'| sim_driver at real time with the camera | '
                    f'{node["real_time_with_camera"].get("real_time_factor")} x |')
    rows.append(f'| load average at the rounds | {out["load_average"][0]:.1f} on '
                f'{os.cpu_count()} cores |')
    return '\n'.join(rows)


def run(quick: bool = False, node: bool = True, n_rounds: int = 0) -> dict:
    """Return the figures (run_all.py's entry point) and write camera.json."""
    out = rounds(n_rounds or (5 if quick else 20))
    if node:
        out['node'] = nodes(quick)
    out['markdown'] = markdown(out)
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)
    with open(RESULTS, 'w') as f:
        json.dump(out, f, indent=1)
    return out


def main(argv=None) -> int:
    """Run the parts, print the figures and ratios, write camera.json."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('--quick', action='store_true', help='5 rounds, short windows')
    parser.add_argument('--rounds', type=int, default=0)
    parser.add_argument('--no-node', action='store_true', help='skip part 2 (the processes)')
    bound.add_argument(parser, *BOUND_S)
    args = parser.parse_args(argv)
    with bound.bounded('bench_camera', bound.seconds(args, args.quick)):
        out = run(args.quick, not args.no_node, args.rounds)
    report(out)
    print(out['markdown'])
    print(f'wrote {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
