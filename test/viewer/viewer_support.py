"""Test-side helpers of the viewer tests: a watcher node over DDS and page/pixel helpers."""
import os
import threading
import time
import urllib.request

from action_msgs.msg import GoalStatusArray
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
import numpy as np
from px100_control.ros.action_events import EVENT_QOS
from px100_control.ros.viewer_calls import ARM_ACTION, goal_request, SEND_GOAL
from px100_control_msgs.srv import ComputeIK
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

#: first port of the viewer tests (they use PORT_BASE .. PORT_BASE + 9 and PORT_BASE + 20 ..
#: PORT_BASE + 31; test_clean_shutdown takes 8140..8149)
PORT_BASE = int(os.environ.get('PX100_VIEWER_TEST_PORT', '8130'))
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)
NAMES = {4: 'SUCCEEDED', 5: 'CANCELED', 6: 'ABORTED', 1: 'ACCEPTED', 2: 'EXECUTING'}
#: how often [ms] a page wait reads the page: on a timer, not at animation frames (playwright's
#: default), which a starved software-rendered page draws seldom
POLL_MS = 100
#: the page size of the tests: viser's control panel (about 335 px wide) stands at its right,
#: the arm in the middle of the canvas left of it; Chromium's software WebGL draws every pixel of
#: the canvas at every frame (about 1 core at 1000x700, half of that at this size)
VIEWPORT = {'width': 780, 'height': 440}
#: viser's control panel and its margin: this many pixels at the right of a page [px]
PANEL_WIDTH = 340


def canvas_clip(viewport) -> dict:
    """Return the canvas part of a page of that size (left of viser's panel) for pixel checks."""
    return {'x': 0, 'y': 40, 'width': viewport['width'] - PANEL_WIDTH,
            'height': viewport['height'] - 40}


#: the canvas part of a VIEWPORT page
CANVAS_CLIP = canvas_clip(VIEWPORT)
#: the page height the pixel-count thresholds are stated for: the scene's picture scales with
#: the canvas height (a fixed vertical field of view), areas with its square
REFERENCE_HEIGHT = 700
#: sim_driver (or bringup) owns the clock (/clock, at real time) and the nodes follow it: a
#: driver slowed by a busy machine slows the time its setpoints are planned in, so it is never
#: "behind". Not faster than real time: trajectory_server's own scheduling stalls (0.3-0.85 s
#: seen on 2 busy cores) would count real_time_factor times as much simulated time, and at 3x
#: they aborted goals ('tracking error ... at t = 1.908 s')
DRIVER_CLOCK = ['-p', 'use_sim_time:=true', '-p', 'publish_clock:=true']


def wait_for(predicate, timeout: float, period: float = 0.05) -> bool:
    """Poll predicate until true or timeout [s]; return its last value."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period)
    return bool(predicate())


def wait_http(url: str, timeout: float) -> bool:
    """Wait until url answers HTTP 200."""
    def ok():
        try:
            with urllib.request.urlopen(url, timeout=2.0) as r:
                return r.status == 200
        except OSError:
            return False
    return wait_for(ok, timeout, 0.25)


class Watcher(Node):
    """
    Follow the robot and the calls; send goals and a world.

    Follows joint_states, ee_pose, compute_ik's requests and the trajectory action's status;
    sends goals as calls of the trajectory action's goal service.

    The world is a real visualization_msgs/MarkerArray on ``world/markers`` (transient local,
    the contract of docs/ros_interfaces.md) from this node, independent of sim_driver.
    """

    def __init__(self, ns: str = '/px100', **kwargs):
        super().__init__('viewer_test_watcher', **kwargs)
        self.ns = ns
        self.lock = threading.Lock()
        self.joints = {}
        self.ee = None
        self.ik_requests = []
        self.status = {}
        self.js_at = None            # time.monotonic() of the last joint_states
        self.diagnostics = []        # the last /diagnostics lines: 'name: level message'
        self.cli_goal = self.create_client(SEND_GOAL,
                                           f'{ns}/{ARM_ACTION}/_action/send_goal')
        self.pub_markers = self.create_publisher(MarkerArray, f'{ns}/world/markers', LATCHED)
        self.pub_held = self.create_publisher(String, f'{ns}/world/held_object', LATCHED)
        self.create_subscription(JointState, f'{ns}/joint_states', self._on_js, 10)
        self.create_subscription(PoseStamped, f'{ns}/ee_pose', self._on_ee, 10)
        self.create_subscription(ComputeIK.Event, f'{ns}/compute_ik/_service_event',
                                 self._on_ik, EVENT_QOS)
        self.create_subscription(GoalStatusArray, f'{ns}/{ARM_ACTION}/_action/status',
                                 self._on_status, LATCHED)
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics, 20)

    def _on_js(self, msg):
        with self.lock:
            self.joints = dict(zip(msg.name, msg.position))
            self.js_at = time.monotonic()

    def _on_diagnostics(self, msg):
        with self.lock:
            self.diagnostics += [f'{s.name}: {s.level} {s.message}' for s in msg.status]
            del self.diagnostics[:-8]

    def evidence(self) -> str:
        """Return what the watcher saw: joints, joint_states age, goal statuses, diagnostics."""
        with self.lock:
            age = 'never' if self.js_at is None else f'{time.monotonic() - self.js_at:.2f} s ago'
            joints = {k: round(v, 3) for k, v in self.joints.items()}
            goals = [f'{k.hex()[:8]} {v}' for k, v in list(self.status.items())[-5:]]
            diags = list(self.diagnostics)
        return (f'joints {joints} (last joint_states {age}); last goals {goals}; '
                f'diagnostics {diags}')

    def _on_ee(self, msg):
        p = msg.pose.position
        with self.lock:
            self.ee = (p.x, p.y, p.z)

    def _on_ik(self, msg):
        if msg.info.event_type != 1 or not msg.request:   # REQUEST_RECEIVED
            return
        target = msg.request[0].target
        p = target.pose.position
        with self.lock:
            self.ik_requests.append((target.header.frame_id, (p.x, p.y, p.z)))

    def _on_status(self, msg):
        with self.lock:
            for st in msg.status_list:
                key = bytes(st.goal_info.goal_id.uuid)
                self.status[key] = NAMES.get(st.status, str(st.status))

    def position(self, name: str):
        """Return the last measured position of the named joint (None before any state)."""
        with self.lock:
            return self.joints.get(name)

    def send_goal(self, names, positions, moving_time: float = 1.5):
        """Send a one-point goal to the trajectory action; return its goal id (bytes)."""
        assert self.cli_goal.wait_for_service(timeout_sec=20.0), 'no trajectory action'
        request = goal_request('', names, positions, moving_time)
        self.cli_goal.call_async(request)
        return bytes(request.goal_id.uuid)

    def wait_goal(self, key, timeout: float = 20.0):
        """Wait for a terminal status of a goal; return its name or None."""
        done = ('SUCCEEDED', 'CANCELED', 'ABORTED')
        wait_for(lambda: self.status.get(key) in done, timeout)
        return self.status.get(key)

    def publish_world(self, frame: str = 'px100/base_link', held: str = ''):
        """Publish a table, a red cube, a green cylinder and a blue ball as world/markers."""
        bodies = [('table', 'table', Marker.CUBE, (0.5, 0.6, 0.02), (0.2, 0.0, -0.011),
                   (0.72, 0.6, 0.45, 1.0)),
                  ('objects', 'red_cube', Marker.CUBE, (0.03, 0.03, 0.03), (0.2, 0.08, 0.015),
                   (0.9, 0.1, 0.1, 1.0)),
                  ('fixtures', 'bin', Marker.CYLINDER, (0.08, 0.08, 0.04), (0.15, -0.15, 0.02),
                   (0.1, 0.7, 0.2, 1.0)),
                  ('objects', 'ball', Marker.SPHERE, (0.03, 0.03, 0.03), (0.25, -0.05, 0.015),
                   (0.95, 0.8, 0.1, 1.0))]
        arr = MarkerArray()
        for i, (ns, name, kind, scale, pos, rgba) in enumerate(bodies):
            m = Marker()
            m.header.frame_id = frame
            m.header.stamp = self.get_clock().now().to_msg()
            m.ns, m.id, m.type, m.action, m.text = ns, i, kind, Marker.ADD, name
            m.scale.x, m.scale.y, m.scale.z = scale
            m.pose.position.x, m.pose.position.y, m.pose.position.z = pos
            m.pose.orientation.w = 1.0
            m.color.r, m.color.g, m.color.b, m.color.a = rgba
            arr.markers.append(m)
        self.pub_markers.publish(arr)
        self.pub_held.publish(String(data=held))


def canvas_pixels(page) -> np.ndarray:
    """Return the canvas part of a page screenshot as an (h, w, 3) uint8 array."""
    import io

    from PIL import Image
    png = page.screenshot(clip=canvas_clip(page.viewport_size), timeout=90000)
    return np.asarray(Image.open(io.BytesIO(png)).convert('RGB'))


def pixels(n: float, viewport=None) -> int:
    """Return a pixel count stated for a REFERENCE_HEIGHT page, scaled to the viewport's area."""
    height = (viewport or VIEWPORT)['height']
    return max(1, round(n * (height / REFERENCE_HEIGHT) ** 2))


def wait_canvas(page, check, timeout: float, period: float = 0.3) -> np.ndarray:
    """
    Read the canvas until ``check(img)`` returns '' (all well); return that picture.

    The software renderer draws the page's changes some frames later: the picture is read
    again (every ``period`` s) until it shows them, and the test fails with the last reason
    ``check`` gave at timeout [s].
    """
    deadline = time.monotonic() + timeout
    while True:
        img = canvas_pixels(page)
        reason = check(img)
        if not reason:
            return img
        if time.monotonic() > deadline:
            raise AssertionError(f'the canvas after {timeout:g} s: {reason}')
        page.wait_for_timeout(period * 1000)


def dark_pixels(img: np.ndarray) -> int:
    """Count near-black pixels (the arm's links; grid, ground and panel are light)."""
    return int((img.max(axis=2) < 90).sum())


def colour_pixels(img: np.ndarray, rgb, tol: int = 60) -> int:
    """Count pixels within tol of a colour (per channel)."""
    return int((np.abs(img.astype(int) - np.asarray(rgb)).max(axis=2) < tol).sum())


def page_text(page) -> str:
    """Return the page's text (its status panel), or why it could not be read."""
    try:
        return page.inner_text('body', timeout=5000)
    except Exception as exc:  # noqa: B902 - evidence for a failure: never raise from here
        return f'(page text unreadable: {exc})'


def wait_page_text(page, text: str, timeout: float, log=None) -> None:
    """
    Wait until the page's text includes ``text`` [timeout s]; else fail with the page's text.

    :param log: callable returning more evidence for the failure (a node's output)
    """
    try:
        page.wait_for_function('(t) => document.body.innerText.includes(t)', arg=text,
                               timeout=timeout * 1000, polling=POLL_MS)
    except Exception as exc:  # noqa: B902 - playwright's TimeoutError, page closed
        extra = f'\n-- log:\n{log()}' if log is not None else ''
        kind = type(exc).__name__
        raise AssertionError(f"'{text}' not on the page within {timeout:g} s ({kind}); the "
                             f'page says:\n{page_text(page)[:3000]}{extra}') from None


def open_page(browser, url: str, timeout: float = 60.0, viewport=None):
    """
    Open url in a new page, wait for viser's status panel; hide viser's notices.

    The notice of software WebGL (shown when the canvas starts, up to seconds after the panel)
    would cover the canvas's top left: notices are hidden by a style, whenever they come.

    :param viewport: the page size (default VIEWPORT)
    """
    page = browser.new_page(viewport=viewport or VIEWPORT)
    page.goto(url)
    page.add_style_tag(content='.mantine-Notification-root { display: none !important; }')
    page.wait_for_selector('text=state', timeout=timeout * 1000)
    # the first joint_states reached the page: 'state t = 0.00 s at 10:34:00.712'
    try:
        page.wait_for_function('() => /state t = [0-9.]+ s at /.test(document.body.innerText)',
                               timeout=timeout * 1000, polling=POLL_MS)
    except Exception as exc:  # noqa: B902 - playwright's TimeoutError
        raise AssertionError(f'no joint_states time on the page within {timeout:g} s '
                             f'({exc.__class__.__name__}); the page says:\n'
                             f'{page_text(page)[:3000]}') from None
    return page
