"""
viewer cost and latency: CPU share of the viewer process and joint_states -> page latency.

The installed ``viewer`` process (rate 30 Hz, the default) is fed by this process over Fast DDS:
``robot_description`` (px100, latched) and ``joint_states`` at 50 Hz, the arm sweeping, each
message stamped with the wall clock (``time.time()``) at publish. Measured:

- ``cpu_no_browser``: the viewer's CPU share (user + system, /proc) with no page open;
- ``cpu_one_browser``: the same with one headless Chromium tab (Playwright, Debian's
  ``chromium``) showing the page (the browser's own CPU is not counted);
- ``latency``: in the page, a MutationObserver on the status panel records the wall clock
  (``performance.timeOrigin + performance.now()``) at which each new joint_states stamp appears
  in the DOM; latency = that time - the stamp (same machine, same clock). This covers the
  subscription, the viewer's rate limit, viser's websocket and the page's React update; the
  3D scene is updated in the same websocket message batch. Measured twice: with the 3D canvas
  drawn (Chromium draws WebGL on the CPU here, SwiftShader, and competes for the cores) and with
  it hidden (the viewer -> viser -> websocket -> React pipeline alone);
- ``latency_websocket_ms``: joint_states stamp -> the status text arriving on viser's websocket
  at a Python client (no browser): the viewer's own share of the latency.

Goal (issue #16): at most 20 % of a core, p50 at most 50 ms. The load average is recorded: on a
shared 2-core machine the figures vary with what else runs. Writes
``benchmarks/results/viewer.json``. Usage (venv + install sourced): ``python
benchmarks/bench_viewer.py [--quick] [--idle SECONDS]``.
"""
import argparse
import asyncio
import json
import math
import os
import sys
import threading
import time

import bound
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: the run's bound [s] with --quick and without: past it the run fails naming its stage
BOUND_S = (180.0, 420.0)
RESULTS = os.path.join(ROOT, 'benchmarks', 'results', 'viewer.json')
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
os.environ.setdefault('ROS_DOMAIN_ID', str(10 + os.getpid() % 90))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)

PORT = int(os.environ.get('PX100_VIEWER_BENCH_PORT', '8138'))
RATE_HZ = 50.0
CHROMIUM_ARGS = ['--no-sandbox', '--disable-gpu', '--use-gl=swiftshader',
                 '--enable-unsafe-swiftshader', '--no-first-run',
                 '--disable-background-networking', '--disable-component-update',
                 '--disable-sync', '--disable-dev-shm-usage']
OBSERVER_JS = """() => {
  window.__px100 = [];
  const re = /state t = [0-9.]+ s at ([0-9]+):([0-9]+):([0-9.]+)/;
  let last = '';
  const note = () => {
    const m = re.exec(document.body.textContent);
    if (m && m[0] !== last) {
      last = m[0];
      const day = new Date();      // the stamp as local clock time: today at h:m:s.ms
      day.setHours(parseInt(m[1]), parseInt(m[2]), 0, 0);
      window.__px100.push([performance.timeOrigin + performance.now(),
                           day.getTime() / 1000 + parseFloat(m[3])]);
    }
  };
  new MutationObserver(note).observe(document.body,
      {subtree: true, childList: true, characterData: true});
}"""


def _cpu_seconds(pid: int) -> float:
    """Return user + system CPU seconds of a process (from /proc)."""
    with open(f'/proc/{pid}/stat') as f:
        fields = f.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


class Feeder:
    """Publish robot_description and 50 Hz joint_states (wall-clock stamps) from a thread."""

    def __init__(self):
        import rclpy
        from rclpy.node import Node
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import String

        from px100_control.models.registry import load_robot
        from px100_control.models.urdf_prefix import prefix_urdf
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.node = Node('viewer_bench_feeder', context=self.ctx)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        self.model = load_robot('px100')
        self.pub_desc = self.node.create_publisher(String, '/px100/robot_description', latched)
        self.pub_desc.publish(String(data=prefix_urdf(self.model.urdf_xml, 'px100')))
        self.pub = self.node.create_publisher(JointState, '/px100/joint_states', 10)
        self.JointState = JointState
        self.names = list(self.model.joint_names) + ['gripper', 'left_finger', 'right_finger']
        self.running = True
        self.sent = 0
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        period = 1.0 / RATE_HZ
        t0 = time.monotonic()
        k = 0
        while self.running:
            k += 1
            s = math.sin(0.5 * k * period)
            msg = self.JointState()
            msg.name = self.names
            msg.position = [0.8 * s, -0.3 + 0.3 * s, 0.3 * s, 0.4 * s, 0.0, 0.025, -0.025]
            now = time.time()
            msg.header.stamp.sec = int(now)
            msg.header.stamp.nanosec = int((now - int(now)) * 1e9)
            self.pub.publish(msg)
            self.sent += 1
            delay = t0 + k * period - time.monotonic()
            if delay > 0:
                time.sleep(delay)

    def close(self):
        """Stop publishing."""
        self.running = False
        self.thread.join(2.0)
        self.node.destroy_node()
        self.ctx.try_shutdown()


async def _websocket_samples(port: int, seconds: float) -> list:
    """Return [(arrival [ms, wall clock], stamp [s])] of status texts read off viser's socket."""
    import re

    import msgspec
    import viser
    import websockets
    import zstandard
    # the panel's Markdown source, escaped by markdown_literal:
    # 'state t \= 12\.35 s at 10:34:00\.712' (the stamp as local clock time)
    pattern, out = re.compile(rb'state t \\?= [0-9.\\]+ s at ([0-9]+):([0-9]+):([0-9.\\]+)'), []
    inflate = zstandard.ZstdDecompressor()
    async with websockets.connect(f'ws://127.0.0.1:{port}', max_size=None,
                                  subprotocols=[f'viser-v{viser.__version__}']) as ws:
        # viser counts a client (and the viewer draws for it) once its camera is known
        await ws.send(msgspec.msgpack.encode({
            'type': 'ViewerCameraMessage', 'wxyz': [1.0, 0.0, 0.0, 0.0],
            'position': [0.3, -0.3, 0.2], 'fov': 1.0, 'near': 0.01, 'far': 100.0,
            'image_height': 700, 'image_width': 1000, 'look_at': [0.1, 0.0, 0.1],
            'up_direction': [0.0, 0.0, 1.0]}))
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                raw = await asyncio.wait_for(ws.recv(), 1.0)
            except asyncio.TimeoutError:
                continue
            arrival = 1e3 * time.time()
            # [8 bytes] inflated size, [8 bytes] compressed size, zstd msgpack, buffers
            size, packed = int.from_bytes(raw[:8], 'little'), int.from_bytes(raw[8:16], 'little')
            inner = inflate.decompress(raw[16:16 + packed], max_output_size=size)
            out += [(arrival, _clock_stamp(*m.groups())) for m in pattern.finditer(inner)]
    return out


def _clock_stamp(hours: bytes, minutes: bytes, seconds: bytes) -> float:
    """Return the epoch seconds of a local clock time of today (the page's stamp text)."""
    day = time.localtime()
    midnight = time.mktime((day.tm_year, day.tm_mon, day.tm_mday, 0, 0, 0, 0, 0, -1))
    return (midnight + 3600 * int(hours) + 60 * int(minutes)
            + float(seconds.replace(b'\\', b'')))


def _latency(samples) -> dict:
    lat = np.array([1e-3 * t_ms - stamp for t_ms, stamp in samples]) * 1e3
    if not len(lat):
        return {'samples': 0}
    return {'samples': int(len(lat)), 'p50': round(float(np.percentile(lat, 50)), 1),
            'p95': round(float(np.percentile(lat, 95)), 1), 'max': round(float(lat.max()), 1)}


def _cpu_share(pid: int, seconds: float, sleep=time.sleep) -> float:
    c0, w0 = _cpu_seconds(pid), time.monotonic()
    sleep(seconds)
    return (_cpu_seconds(pid) - c0) / (time.monotonic() - w0)


def _start_viewer():
    """Start the installed viewer process on PORT and wait for its page (robot loaded)."""
    import urllib.request

    from px100_control.tools.processes import NodeProcess
    viewer = NodeProcess('viewer', ['--ros-args', '-p', f'port:={PORT}'])
    deadline = time.monotonic() + 60.0
    while True:
        try:
            with urllib.request.urlopen(f'http://127.0.0.1:{PORT}', timeout=2.0):
                break
        except OSError:
            if time.monotonic() > deadline:
                viewer.stop()
                raise RuntimeError('viewer page did not come up: ' + viewer.output())
            time.sleep(0.5)
    time.sleep(3.0)               # robot loaded, joint_states flowing
    return viewer


def idle_cpu(window: float = 10.0) -> float:
    """Return the viewer's CPU share [fraction of a core] with 50 Hz joint_states, no browser."""
    feeder = Feeder()
    try:
        viewer = _start_viewer()
        try:
            return _cpu_share(viewer.pid, window)
        finally:
            viewer.stop()
    finally:
        feeder.close()


def run(quick: bool = False, log=print, viewport=(1000, 700)) -> dict:
    """Measure the viewer's CPU share without and with a browser, and the page latency."""
    from playwright.sync_api import sync_playwright
    window = 5.0 if quick else 15.0
    load0 = os.getloadavg()[0]
    figures = {'rate_hz': RATE_HZ, 'viewer_rate_hz': 30.0, 'window_s': window,
               'viewport': list(viewport)}
    feeder = Feeder()
    try:
        viewer = _start_viewer()
    except BaseException:
        feeder.close()
        raise
    try:
        figures['cpu_no_browser'] = round(_cpu_share(viewer.pid, window), 4)
        log(f"viewer CPU, no browser: {100 * figures['cpu_no_browser']:.1f} % of a core")
        ws = asyncio.run(_websocket_samples(PORT, window))[10:]   # after the connect replay
        figures['latency_websocket_ms'] = _latency(ws)
        log('latency joint_states -> status text on the websocket (a Python client, no '
            f"browser): {figures['latency_websocket_ms']}")
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path='/usr/bin/chromium',
                                        args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={'width': viewport[0], 'height': viewport[1]})
            page.goto(f'http://127.0.0.1:{PORT}')
            page.wait_for_function('() => /state t = .* s at /.test(document.body.innerText)',
                                   timeout=60000)
            page.wait_for_timeout(2000)
            page.evaluate(OBSERVER_JS)
            figures['cpu_one_browser'] = round(_cpu_share(
                viewer.pid, window, lambda t: page.wait_for_timeout(1e3 * t)), 4)
            dom = page.evaluate('() => window.__px100')
            # the same page with its 3D canvas hidden: the pipeline without software-WebGL
            # drawing (Chromium here renders WebGL on the CPU, SwiftShader)
            page.add_style_tag(content='canvas { display: none !important; }')
            page.evaluate(OBSERVER_JS)
            page.wait_for_timeout(1e3 * window)
            hidden = page.evaluate('() => window.__px100')
            browser.close()
        log(f"viewer CPU, one browser: {100 * figures['cpu_one_browser']:.1f} % of a core")
        figures['latency_ms'] = _latency(dom)
        figures['page_updates_hz'] = round(len(dom) / window, 1)
        figures['latency_dom_canvas_hidden_ms'] = _latency(hidden)
        figures['page_dom_updates_canvas_hidden_hz'] = round(len(hidden) / window, 1)
        log("latency joint_states -> status text in the page's DOM, canvas hidden: "
            f"{figures['latency_dom_canvas_hidden_ms']}, "
            f"{figures['page_dom_updates_canvas_hidden_hz']} Hz")
        log("latency joint_states -> status text in the page's DOM: "
            f"{figures['latency_ms']}, {figures['page_updates_hz']} Hz")
    finally:
        viewer.stop()
        feeder.close()
    figures['load_average_1min'] = [round(load0, 2), round(os.getloadavg()[0], 2)]
    figures['cpu_count'] = os.cpu_count()
    figures['quick'] = quick
    lat = figures.get('latency_ms', {})
    hid = figures.get('latency_dom_canvas_hidden_ms', {})
    wsl = figures.get('latency_websocket_ms', {})
    figures['markdown'] = '\n'.join([
        '| viewer (50 Hz joint_states, page rate 30 Hz) | figure | goal |',
        '| --- | --- | --- |',
        f"| CPU, no browser | {100 * figures['cpu_no_browser']:.1f} % of a core | - |",
        f"| CPU, one browser | {100 * figures['cpu_one_browser']:.1f} % of a core | <= 20 % |",
        f"| latency joint_states -> page (status text in the DOM) p50 / p95 | {lat.get('p50')} / "
        f"{lat.get('p95')} ms ({lat.get('samples')} samples, {figures.get('page_updates_hz')} "
        'Hz) | p50 <= 50 ms |',
        f"| joint_states -> status text on viser's websocket (Python client, no browser) p50 / "
        f"p95 | {wsl.get('p50')} / {wsl.get('p95')} ms ({wsl.get('samples')} samples) | |",
        f"| the same, 3D canvas hidden (no software-WebGL drawing) p50 / p95 | {hid.get('p50')} / "
        f"{hid.get('p95')} ms ({hid.get('samples')} samples, "
        f"{figures.get('page_dom_updates_canvas_hidden_hz')} Hz) | |",
        f"| load average (1 min) before / after | {figures['load_average_1min']} "
        f'on {os.cpu_count()} cores | |'])
    return figures


def main(argv=None) -> int:
    """Run the benchmark, print the figures and write benchmarks/results/viewer.json."""
    parser = argparse.ArgumentParser(description='viewer CPU share and page latency')
    parser.add_argument('--quick', action='store_true', help='short windows')
    parser.add_argument('--viewport', default='1000x700', help='page size WxH [px]')
    parser.add_argument('--idle', type=float, default=None, metavar='SECONDS',
                        help='only the CPU share with no browser over SECONDS (printed, '
                             'not written)')
    bound.add_argument(parser, *BOUND_S)
    args = parser.parse_args(argv)
    if args.idle is not None:
        load0 = os.getloadavg()[0]
        share = idle_cpu(args.idle)
        print(f'viewer CPU, no browser, 50 Hz joint_states, {args.idle:.0f} s: '
              f'{100 * share:.1f} % of a core (load average {load0:.2f} -> '
              f'{os.getloadavg()[0]:.2f})')
        return 0
    with bound.bounded('bench_viewer', bound.seconds(args, args.quick)):
        figures = run(args.quick, log=bound.log,
                      viewport=tuple(int(v) for v in args.viewport.split('x')))
    print(figures['markdown'])
    os.makedirs(os.path.dirname(RESULTS), exist_ok=True)
    with open(RESULTS, 'w') as f:
        json.dump({k: v for k, v in figures.items() if k != 'markdown'}, f, indent=2)
    print(f'wrote {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
