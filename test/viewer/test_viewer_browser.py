"""
The viewer in a real browser: headless Chromium (Playwright) on the page of a real viewer node.

bringup (sim_driver, ik_service, trajectory_server) and two viewers (one with controls, one
read-only) run as installed executables over Fast DDS; this process watches the graph with an
rclpy node and publishes a world as a real MarkerArray. The browser's actions (slider drag,
gizmo drag) are checked where they must arrive: on joint_states and ee_pose. The nodes and
viewers run on sim_driver's clock (viewer_support.DRIVER_CLOCK).
"""
import threading
import time

import numpy as np
import pytest
from viewer_support import CANVAS_CLIP, canvas_pixels, colour_pixels, dark_pixels, \
    DRIVER_CLOCK, open_page, pixels, POLL_MS, PORT_BASE, wait_canvas, wait_for, wait_http, \
    wait_page_text, Watcher

PORT, PORT_RO = PORT_BASE + 1, PORT_BASE + 2
URL, URL_RO = f'http://127.0.0.1:{PORT}', f'http://127.0.0.1:{PORT_RO}'
HOME = ('waist', 'shoulder', 'elbow', 'wrist_angle'), (0.0, 0.0, 0.0, 0.0)
SLEEP = (0.0, -1.88, 1.5, 0.8)


@pytest.fixture(scope='module')
def graph(browser, ros_context):
    """Start bringup and two viewers; yield a Watcher spinning in this process."""
    from px100_control.tools.processes import NodeProcess
    from rclpy.executors import SingleThreadedExecutor
    # no scene in sim_driver: the world on the page is this test's own MarkerArray
    procs = [NodeProcess('bringup', ['--no-camera', '--ros-args', '-p', "scene:=''",
                                     *DRIVER_CLOCK]),
             NodeProcess('viewer', ['--ros-args', '-p', f'port:={PORT}',
                                    '-p', 'use_sim_time:=true']),
             NodeProcess('viewer', ['--ros-args', '-p', f'port:={PORT_RO}',
                                    '-p', 'read_only:=true', '-p', 'use_sim_time:=true',
                                    '-r', '__node:=viewer_ro'])]
    watcher = Watcher(context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(watcher)
    thread = threading.Thread(target=ex.spin, daemon=True)
    thread.start()
    try:
        watcher.publish_world()
        for url in (URL, URL_RO):
            assert wait_http(url, 90.0), f'no viewer page on {url}: ' + procs[1].output()[-2000:]
        assert wait_for(lambda: watcher.position('waist') is not None, 90.0), 'no joint_states'
        yield watcher, procs
    finally:
        ex.shutdown(timeout_sec=2.0)
        thread.join(5.0)
        watcher.destroy_node()
        killed = []
        for p in procs:
            p.stop()
            if p.killed:
                killed.append(p.name)
        assert not killed, f'processes ignored SIGINT and were killed: {killed}'


@pytest.fixture(scope='module')
def ros_context():
    """Yield an rclpy Context for the module."""
    rclpy = pytest.importorskip('rclpy')
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    ctx.try_shutdown()


@pytest.fixture(scope='module')
def ro_page(browser, graph):
    """Yield a page of the read-only viewer: one tab for the module, closed by a test."""
    pg = open_page(browser, URL_RO)
    yield pg
    if not pg.is_closed():
        pg.close()


@pytest.fixture(scope='module')
def page(browser, graph):
    """Yield the page of the viewer with controls (one tab for the module)."""
    pg = open_page(browser, URL)
    yield pg
    pg.close()


def _go_home(watcher):
    key = watcher.send_goal(*HOME, moving_time=1.5)
    assert watcher.wait_goal(key) == 'SUCCEEDED', watcher.evidence()


#: the page's joint sliders all show positions within tol of the given ones (in slider order)
SLIDERS_AT = """([q, tol]) => {
  const s = [...document.querySelectorAll('[role=slider]')];
  return s.length === q.length &&
      s.every((e, k) => Math.abs(parseFloat(e.getAttribute('aria-valuenow')) - q[k]) < tol);
}"""


def _wait_sliders(page, positions, timeout: float = 30.0) -> None:
    """Wait until the page's sliders follow the robot to positions (waist .. wrist_angle)."""
    try:
        page.wait_for_function(SLIDERS_AT, arg=[list(positions), 0.02], timeout=timeout * 1000,
                               polling=POLL_MS)
    except Exception:  # noqa: B902 - playwright's TimeoutError
        values = page.evaluate("() => [...document.querySelectorAll('[role=slider]')]"
                               ".map(e => e.getAttribute('aria-valuenow'))")
        raise AssertionError(f'the sliders show {values}, not {positions}') from None


def _goal_evidence(watcher, procs) -> str:
    """Return the watcher's evidence and the end of bringup's log (a goal's end reason)."""
    return f'{watcher.evidence()}\n-- bringup log:\n{procs[0].output()[-3000:]}'


def test_read_only_page_has_no_controls(ro_page, graph):
    """
    The read-only viewer shows the arm but no slider, button or gizmo.

    Run first, before the module's page with controls is opened (one WebGL page at a time) and
    before the gizmo drag: no IK target is drawn yet (a frame, on every viewer), whose blue z
    axis the pixel check could take for the gizmo's arrow. That the page with controls does
    show its four sliders and its buttons (the checks here can fail) is in
    test_page_connects_and_shows_the_arm_and_world.
    """
    # the arm is drawn: the robot is loaded, and with it a page's sliders, buttons, gizmo
    img = wait_canvas(ro_page, lambda im: '' if dark_pixels(im) > pixels(3000) else
                      f'{dark_pixels(im)} dark pixels: no arm', 60.0)
    assert ro_page.locator('[role=slider]').count() == 0
    assert ro_page.locator('button', has_text='Home').count() == 0
    assert ro_page.locator('text=Torque off').count() == 0
    assert _blue_arrow_tip(img) is None, 'a gizmo is drawn on the read-only page'


def test_closed_tab_and_dead_viewer_never_stop_the_graph(ro_page, graph):
    """Closing a tab and killing a viewer (SIGKILL) leave the robot's nodes working."""
    watcher, procs = graph
    ro_page.close()                      # the module's tab on the read-only viewer
    procs[2].proc.kill()
    procs[2].proc.wait(10)
    assert procs[1].alive()
    key = watcher.send_goal(*HOME, moving_time=3.0)
    assert watcher.wait_goal(key) == 'SUCCEEDED', _goal_evidence(watcher, procs)
    t0 = time.monotonic()
    watcher.joints = {}
    assert wait_for(lambda: watcher.position('waist') is not None, 5.0)
    assert time.monotonic() - t0 < 5.0


def test_page_connects_and_shows_the_arm_and_world(page, graph):
    """
    The page connects, draws the arm (dark links) and the MarkerArray world (colours).

    It has the controls: four joint sliders and the Home button.
    """
    watcher, procs = graph
    for text in ('holding: nothing', 'world: 4 bodies'):
        end, error = time.monotonic() + 90.0, None
        while time.monotonic() < end:
            # again every 2 s, as a world publisher does at its rate: a message sent before the
            # viewer's subscription was matched on the publisher's side reaches no one
            watcher.publish_world()
            try:
                page.wait_for_function('(t) => document.body.innerText.includes(t)',
                                       arg=text, timeout=2000, polling=POLL_MS)
                error = None
                break
            except Exception as exc:  # playwright's TimeoutError: try again until the end
                error = exc
        if error is not None:
            pytest.fail(f"'{text}' not on the page in 90 s ({error.__class__.__name__}); page "
                        f'text: {page.evaluate("() => document.body.innerText")[:1500]!r}; '
                        f'viewer log: {procs[1].output()[-2000:]}')
    assert page.locator('[role=slider]').count() == 4
    assert page.locator('button', has_text='Home').count() == 1

    def drawn(img):
        found = {'dark pixels (the arm)': (dark_pixels(img), pixels(3000)),
                 'red pixels (the cube of world/markers)':
                     (colour_pixels(img, (230, 26, 26), 50), pixels(30)),
                 'green pixels (the bin of world/markers)':
                     (colour_pixels(img, (26, 178, 51), 50), pixels(100))}
        return '; '.join(f'{k}: {n} <= {least}' for k, (n, least) in found.items()
                         if n <= least)
    wait_canvas(page, drawn, 30.0)


def test_arm_on_the_page_moves_when_a_goal_executes(page, graph):
    """A goal sent by a script moves the arm drawn on the page (canvas pixels change)."""
    watcher, procs = graph
    before = canvas_pixels(page)
    key = watcher.send_goal(('waist', 'shoulder', 'elbow', 'wrist_angle'),
                            (0.6, -0.3, 0.3, 0.2), moving_time=1.5)
    assert watcher.wait_goal(key) == 'SUCCEEDED', _goal_evidence(watcher, procs)
    wait_page_text(page, 'SUCCEEDED', 45.0)

    def moved(img):
        changed = int((np.abs(img.astype(int) - before.astype(int)).max(axis=2) > 40).sum())
        if changed <= pixels(2000):
            return f'only {changed} canvas pixels changed after the move'
        return '' if dark_pixels(img) > pixels(3000) else f'{dark_pixels(img)} dark pixels'
    wait_canvas(page, moved, 30.0)


def test_dragging_a_joint_slider_moves_the_simulated_joint(page, graph):
    """A mouse drag of the waist slider in the browser moves waist on joint_states."""
    watcher, _ = graph
    _go_home(watcher)
    _wait_sliders(page, HOME[1])         # the sliders follow the robot
    label = page.locator('label', has_text='waist').first
    thumb = page.locator(f'[id="{label.get_attribute("for")}"] [role=slider]')
    box = thumb.bounding_box()
    x, y = box['x'] + box['width'] / 2, box['y'] + box['height'] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for k in range(1, 9):
        page.mouse.move(x + 2.5 * k, y)
        page.wait_for_timeout(40)
    page.mouse.up()
    target = float(thumb.get_attribute('aria-valuenow'))
    assert target > 0.3, f'the drag did not move the slider (value {target})'
    assert wait_for(lambda: abs(watcher.position('waist') - target) < 0.03, 15.0), \
        f'waist is {watcher.position("waist"):.3f} rad, slider {target:.3f}'


def _blue_arrow_tip(img: np.ndarray):
    """Return (x, y) in the canvas clip of the gizmo's z arrow tip (topmost blue pixel) or None."""
    b = img.astype(int)
    mask = (b[:, :, 2] > 180) & (b[:, :, 0] < 110) & (b[:, :, 2] - b[:, :, 0] > 120) & \
        (b[:, :, 2] - b[:, :, 1] > 50)
    mask[:, :80] = False                 # viser's axes triad in the bottom-left corner
    ys, xs = np.nonzero(mask)
    if not len(ys):
        return None
    k = int(np.argmin(ys))
    return int(xs[k]), int(ys[k])


def test_dragging_the_gizmo_moves_the_arm_through_ik(page, graph):
    """A mouse drag of the gizmo's z arrow calls compute_ik; the arm's end effector rises."""
    watcher, procs = graph
    # from the sleep pose, where the camera of the page sees the gizmo clear of the panel
    key = watcher.send_goal(HOME[0], SLEEP, moving_time=2.0)
    assert watcher.wait_goal(key) == 'SUCCEEDED', _goal_evidence(watcher, procs)
    # the sliders and the gizmo follow the end effector again (one render moves both): the
    # sliders at sleep, then the gizmo's arrow drawn at one place in two pictures
    _wait_sliders(page, SLEEP)
    tips = []

    def gizmo_still(img):
        tips.append(_blue_arrow_tip(img))
        if tips[-1] is None:
            return 'the gizmo is not on the canvas'
        if len(tips) < 2 or tips[-2] is None or \
                max(abs(a - b) for a, b in zip(tips[-1], tips[-2])) > 1:
            return f'the gizmo moves: its arrow tip at {tips[-2:]}'
        return ''
    wait_canvas(page, gizmo_still, 30.0)
    assert wait_for(lambda: watcher.ee is not None, 5.0)
    z0 = watcher.ee[2]
    n_requests = len(watcher.ik_requests)
    x, y = tips[-1][0] + CANVAS_CLIP['x'], tips[-1][1] + CANVAS_CLIP['y'] + 10
    page.mouse.move(x, y)
    page.mouse.down()
    for k in range(1, 11):
        page.mouse.move(x, y - 3 * k)
        page.wait_for_timeout(50)
    page.mouse.up()
    # IK requests are throttled: the first may come from the drag's first steps, the later ones
    # from the whole 30 px
    assert wait_for(lambda: any(t[2] > z0 + 0.01 for _, t in watcher.ik_requests[n_requests:]),
                    15.0), \
        f'no gizmo compute_ik call above z {z0:.3f}: {watcher.ik_requests[n_requests:]}'
    frame, target = watcher.ik_requests[-1]
    assert frame == 'px100/base_link'
    assert wait_for(lambda: watcher.ee[2] > z0 + 0.01, 15.0), \
        f'end effector z {watcher.ee[2]:.3f} did not rise from {z0:.3f}; {watcher.evidence()}'


def test_buttons_act_through_the_ros_interfaces(page, graph):
    """Sleep sends a goal; Close/Open gripper move the fingers; torque and scene reset answer."""
    watcher, procs = graph
    page.get_by_role('button', name='Sleep').click()
    assert wait_for(lambda: abs(watcher.position('shoulder') + 1.88) < 0.05, 20.0), \
        (f'shoulder {watcher.position("shoulder"):.3f} did not reach the sleep pose; '
         f'{watcher.evidence()}\n-- bringup:\n{procs[0].output()[-3000:]}')
    finger0 = watcher.position('left_finger')
    page.get_by_role('button', name='Close gripper').click()
    assert wait_for(lambda: watcher.position('left_finger') < finger0 - 0.003, 15.0), \
        (f"left_finger {watcher.position('left_finger'):.4f} m, was {finger0:.4f} m; "
         + watcher.evidence())
    closed = watcher.position('left_finger')
    page.get_by_role('button', name='Open gripper').click()
    assert wait_for(lambda: watcher.position('left_finger') > closed + 0.005, 15.0), \
        (f"left_finger {watcher.position('left_finger'):.4f} m, closed {closed:.4f} m; "
         + watcher.evidence())
    for name, text in (('Torque off', 'viewer: torque off: done'),
                       ('Torque on', 'viewer: torque on: done'),
                       ('Reset scene', 'scene reset: done')):
        page.get_by_role('button', name=name).click()
        wait_page_text(page, text, 45.0)
