"""
Camera cost side by side, in one run: rendering, the depth noise + back-projection, the filter.

The default camera (a D415 at 640 x 480) over the pick_place scene with the arm at sleep,
MuJoCo's offscreen renderer (``MUJOCO_GL=egl``, software OpenGL on a machine without a GPU),
timed in interleaved rounds (colour, depth, cloud, filter, colour, ...) so a busy machine slows
every stage alike; the median of each stage is reported in ms, with the frame rate one core
could sustain for colour + depth and the share of a core a given rate costs. The filter runs
Interbotix's defaults on the points of the table in front of the arm. Bounded: ``--rounds`` (20;
5 with ``--quick``) rounds, each stage well under a second; the whole run fails after
``--timeout`` s (120). Writes ``benchmarks/results/camera.json``.

``--node``: the camera node's effect on the physics: the ``sim_driver`` process at real time
(100 Hz joint_states), first alone, then with the ``camera`` process (5 Hz, 640 x 480): the
physics real-time factor (simulated s of joint_states stamps per wall s), the received
joint_states period jitter p99, the camera's frame rate as received and its CPU share.
Usage (venv + install sourced): ``python benchmarks/bench_camera.py [--quick] [--node]``.
"""
import argparse
import json
import os
import signal
import statistics
import sys
import time

os.environ.setdefault('MUJOCO_GL', 'egl')

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from px100_control.models.registry import load_robot  # noqa: E402
from px100_control.perception.camera import (back_project, CameraSpec, noisy_depth,  # noqa: E402
                                             transform_points)
from px100_control.perception.cloud_filter import FilterParams, run_pipeline  # noqa: E402
from px100_control.sim.camera_render import posed_model  # noqa: E402
from px100_control.sim.scene import load_scene  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def _node_window(seconds: float, camera: bool) -> dict:
    """Return the real-time factor and jitter of sim_driver, with or without the camera."""
    from bench_sim_driver import _cpu_seconds, _Listener, _window
    from px100_control.tools.processes import NodeProcess
    from sensor_msgs.msg import Image
    listener = _Listener()
    frames = []
    listener.node.create_subscription(Image, '/px100/camera/color/image_raw',
                                      lambda m: frames.append(time.monotonic()), 5)
    procs = [NodeProcess('sim_driver', ['--ros-args', '-p', 'publish_rate:=100.0'])]
    if camera:
        procs.append(NodeProcess('camera'))
    try:
        if not listener.wait(listener.js, 50, 60.0) or (camera and not listener.wait(
                frames, 3, 90.0)):
            return {'error': 'no joint_states or frames', 'log': procs[-1].output()[-2000:]}
        cpu0 = _cpu_seconds(procs[-1].pid)
        n0 = len(frames)
        samples = _window(listener.js, seconds)
        cpu1 = _cpu_seconds(procs[-1].pid)
        wall = samples[-1][0] - samples[0][0]
        dev = np.abs(np.diff([s[0] for s in samples]) - 0.01) * 1e3
        return {'camera': camera, 'real_time_factor': round((samples[-1][1] - samples[0][1])
                                                            / wall, 4),
                'received_jitter_p99_ms': round(float(np.percentile(dev, 99)), 2),
                'camera_fps': round((len(frames) - n0) / seconds, 2) if camera else None,
                'last_process_cpu_share': round((cpu1 - cpu0) / seconds, 2),
                'load_average': os.getloadavg()[0]}
    finally:
        for proc in reversed(procs):
            proc.stop()
        listener.close()


def _scene(camera: CameraSpec):
    robot = load_robot('px100')
    return posed_model(robot, load_scene('pick_place', robot), camera)


def main(argv=None) -> int:
    """Run the rounds and print/write the medians."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('--quick', action='store_true', help='5 rounds')
    parser.add_argument('--rounds', type=int, default=None)
    parser.add_argument('--timeout', type=float, default=120.0, help='fail after this [s]')
    parser.add_argument('--node', action='store_true',
                        help="also the camera node's effect on sim_driver's real-time factor")
    args = parser.parse_args(argv)
    rounds = args.rounds or (5 if args.quick else 20)
    signal.signal(signal.SIGALRM, lambda *_: sys.exit(f'bench_camera: over {args.timeout} s'))
    signal.alarm(int(args.timeout + (300 if args.node else 0)))   # --node: two windows + starts
    camera = CameraSpec()
    model, data = _scene(camera)
    renderer = mujoco.Renderer(model, camera.height, camera.width)
    rng = np.random.default_rng(0)
    T = camera.optical_pose()
    params = FilterParams(x_filter_min=-1, x_filter_max=1, y_filter_min=-1, y_filter_max=1,
                          z_filter_min=0.1, z_filter_max=2.0)
    times = {'colour': [], 'depth': [], 'cloud': [], 'filter': []}
    clusters = 0
    for k in range(rounds + 1):                     # round 0 warms up (context, caches)
        t0 = time.perf_counter()
        renderer.disable_depth_rendering()
        renderer.update_scene(data, camera=camera.name)
        color = renderer.render()
        t1 = time.perf_counter()
        renderer.enable_depth_rendering()
        renderer.update_scene(data, camera=camera.name)
        depth = renderer.render()
        t2 = time.perf_counter()
        points, colors = back_project(camera.intrinsics(), noisy_depth(camera, depth, rng), color)
        base = transform_points(T, points)
        near = ((base[:, 0] > 0.08) & (base[:, 0] < 0.26) & (np.abs(base[:, 1]) < 0.1)
                & (base[:, 2] > -0.02) & (base[:, 2] < 0.06))
        t3 = time.perf_counter()
        result = run_pipeline(points[near], colors[near], params, rng)
        t4 = time.perf_counter()
        clusters = len(result.clusters)
        if k:
            for key, dt in zip(times, (t1 - t0, t2 - t1, t3 - t2, t4 - t3)):
                times[key].append(1e3 * dt)
    renderer.close()
    median = {k: statistics.median(v) for k, v in times.items()}
    pair = median['colour'] + median['depth']
    out = {'rounds': rounds, 'size': [camera.width, camera.height], 'median_ms': median,
           'colour_plus_depth_ms': pair, 'max_rate_one_core_hz': 1e3 / pair,
           'core_share_at_5hz': 5 * (pair + median['cloud']) / 1e3, 'clusters': clusters,
           'load_average': os.getloadavg()}
    print(f'camera 640x480, {rounds} rounds, load {out["load_average"][0]:.2f}:')
    for key, value in median.items():
        print(f'  {key:7s} {value:7.1f} ms')
    if args.node:
        seconds = 5.0 if args.quick else 20.0
        out['node'] = [_node_window(seconds, camera) for camera in (False, True)]
        for row in out['node']:
            print(f'  sim_driver {"with" if row.get("camera") else "without"} the camera: {row}')
    print(f'  colour + depth {pair:.1f} ms -> at most {1e3 / pair:.1f} Hz on one core; '
          f'5 Hz with the cloud costs {100 * out["core_share_at_5hz"]:.0f} % of a core; '
          f'{clusters} clusters')
    os.makedirs(os.path.join(HERE, 'results'), exist_ok=True)
    with open(os.path.join(HERE, 'results', 'camera.json'), 'w') as f:
        json.dump(out, f, indent=1)
    return 0


if __name__ == '__main__':
    sys.exit(main())
