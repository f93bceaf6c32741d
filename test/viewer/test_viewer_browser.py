"""
The viewer in a real browser: headless Chromium (Playwright) on the page of a real viewer node.

bringup (sim_driver, ik_service, trajectory_server) and two viewers (one with controls, one
read-only) run as installed executables over Fast DDS; this process watches the graph with an
rclpy node and publishes a world as a real MarkerArray. The browser's actions (slider drag,
gizmo drag) are checked where they must arrive: on joint_states and ee_pose.
"""
import threading
import time

import numpy as np
import pytest
from viewer_support import CANVAS_CLIP, canvas_pixels, colour_pixels, dark_pixels, open_page, \
    PORT_BASE, wait_for, wait_http, Watcher

PORT, PORT_RO = PORT_BASE + 1, PORT_BASE + 2
URL, URL_RO = f'http://127.0.0.1:{PORT}', f'http://127.0.0.1:{PORT_RO}'
HOME = ('waist', 'shoulder', 'elbow', 'wrist_angle'), (0.0, 0.0, 0.0, 0.0)


@pytest.fixture(scope='module')
def graph(browser, ros_context):
    """Start bringup and two viewers; yield a Watcher spinning in this process."""
    from px100_control.tools.processes import NodeProcess
    from rclpy.executors import SingleThreadedExecutor
    # no scene in sim_driver: the world on the page is this test's own MarkerArray
    procs = [NodeProcess('bringup', ['--no-camera', '--ros-args', '-p', "scene:=''"]),
             NodeProcess('viewer', ['--ros-args', '-p', f'port:={PORT}']),
             NodeProcess('viewer', ['--ros-args', '-p', f'port:={PORT_RO}',
                                    '-p', 'read_only:=true', '-r', '__node:=viewer_ro'])]
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
def page(browser, graph):
    """Yield the page of the viewer with controls (one tab for the module)."""
    pg = open_page(browser, URL)
    yield pg
    pg.close()


def _go_home(watcher):
    key = watcher.send_goal(*HOME, moving_time=1.5)
    assert watcher.wait_goal(key) == 'SUCCEEDED', watcher.evidence()


def test_page_connects_and_shows_the_arm_and_world(page, graph):
    """The page connects, draws the arm (dark links) and the MarkerArray world (colours)."""
    watcher, procs = graph
    for text in ('holding: nothing', 'world: 4 bodies'):
        end, error = time.monotonic() + 90.0, None
        while time.monotonic() < end:
            # again every 2 s, as a world publisher does at its rate: a message sent before the
            # viewer's subscription was matched on the publisher's side reaches no one
            watcher.publish_world()
            try:
                page.wait_for_function('(t) => document.body.innerText.includes(t)',
                                       arg=text, timeout=2000)
                error = None
                break
            except Exception as exc:  # playwright's TimeoutError: try again until the end
                error = exc
        if error is not None:
            pytest.fail(f"'{text}' not on the page in 90 s ({error.__class__.__name__}); page "
                        f'text: {page.evaluate("() => document.body.innerText")[:1500]!r}; '
                        f'viewer log: {procs[1].output()[-2000:]}')
    page.wait_for_timeout(1500)          # let the software renderer draw a few frames
    img = canvas_pixels(page)
    assert dark_pixels(img) > 3000, f'no arm on the canvas ({dark_pixels(img)} dark pixels)'
    assert colour_pixels(img, (230, 26, 26), 50) > 30, 'the red cube of world/markers is missing'
    assert colour_pixels(img, (26, 178, 51), 50) > 100, 'the green bin of world/markers is missing'


def test_arm_on_the_page_moves_when_a_goal_executes(page, graph):
    """A goal sent by a script moves the arm drawn on the page (canvas pixels change)."""
    watcher, _ = graph
    before = canvas_pixels(page)
    key = watcher.send_goal(('waist', 'shoulder', 'elbow', 'wrist_angle'),
                            (0.6, -0.3, 0.3, 0.2), moving_time=1.5)
    assert watcher.wait_goal(key) == 'SUCCEEDED', watcher.evidence()
    page.wait_for_function("() => document.body.innerText.includes('SUCCEEDED')",
                           timeout=45000)
    page.wait_for_timeout(800)
    after = canvas_pixels(page)
    changed = int((np.abs(after.astype(int) - before.astype(int)).max(axis=2) > 40).sum())
    assert changed > 2000, f'only {changed} canvas pixels changed after the move'
    assert dark_pixels(after) > 3000


def test_dragging_a_joint_slider_moves_the_simulated_joint(page, graph):
    """A mouse drag of the waist slider in the browser moves waist on joint_states."""
    watcher, _ = graph
    _go_home(watcher)
    page.wait_for_timeout(2000)          # the sliders follow the robot again
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


def test_read_only_page_has_no_controls(browser, page, graph):
    """
    The read-only viewer shows the arm but no slider, button or gizmo.

    Run before the gizmo drag: no IK target is drawn yet (a frame, on every viewer), whose blue z
    axis the pixel check could take for the gizmo's arrow.
    """
    pg = open_page(browser, URL_RO)
    try:
        pg.wait_for_timeout(1500)
        assert pg.locator('[role=slider]').count() == 0
        assert pg.locator('button', has_text='Home').count() == 0
        assert pg.locator('text=Torque off').count() == 0
        img = canvas_pixels(pg)
        assert dark_pixels(img) > 3000
        assert _blue_arrow_tip(img) is None, 'a gizmo is drawn on the read-only page'
    finally:
        pg.close()
    # and the page with controls (the module's) does have them: the check above can fail
    assert page.locator('[role=slider]').count() == 4


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
    watcher, _ = graph
    # from the sleep pose, where the camera of the page sees the gizmo clear of the panel
    key = watcher.send_goal(HOME[0], (0.0, -1.88, 1.5, 0.8), moving_time=2.0)
    assert watcher.wait_goal(key) == 'SUCCEEDED', watcher.evidence()
    page.wait_for_timeout(2500)          # the gizmo follows the end effector again
    assert wait_for(lambda: watcher.ee is not None, 5.0)
    z0 = watcher.ee[2]
    n_requests = len(watcher.ik_requests)
    tip = _blue_arrow_tip(canvas_pixels(page))
    assert tip is not None, 'the gizmo is not on the canvas'
    x, y = tip[0] + CANVAS_CLIP['x'], tip[1] + CANVAS_CLIP['y'] + 10
    page.mouse.move(x, y)
    page.mouse.down()
    for k in range(1, 11):
        page.mouse.move(x, y - 3 * k)
        page.wait_for_timeout(50)
    page.mouse.up()
    assert wait_for(lambda: len(watcher.ik_requests) > n_requests, 10.0), \
        'the gizmo drag made no compute_ik call'
    frame, target = watcher.ik_requests[-1]
    assert frame == 'px100/base_link'
    assert target[2] > z0 + 0.01, f'IK target z {target[2]:.3f} not above {z0:.3f}'
    assert wait_for(lambda: watcher.ee[2] > z0 + 0.01, 15.0), \
        f'end effector z {watcher.ee[2]:.3f} did not rise from {z0:.3f}'


def test_closed_tab_and_dead_viewer_never_stop_the_graph(browser, graph):
    """Closing a tab and killing a viewer (SIGKILL) leave the robot's nodes working."""
    watcher, procs = graph
    pg = open_page(browser, URL_RO)
    pg.close()
    procs[2].proc.kill()
    procs[2].proc.wait(10)
    assert procs[1].alive()
    key = watcher.send_goal(*HOME, moving_time=3.0)
    assert watcher.wait_goal(key) == 'SUCCEEDED', watcher.evidence()
    t0 = time.monotonic()
    watcher.joints = {}
    assert wait_for(lambda: watcher.position('waist') is not None, 5.0)
    assert time.monotonic() - t0 < 5.0


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
        page.wait_for_function('(t) => document.body.innerText.includes(t)', arg=text,
                               timeout=45000)
