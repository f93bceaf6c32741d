"""The viewer's switches: bringup --viewer, the client's in-process bringup, viewer --bag."""
import os
import sys

import pytest
from viewer_support import dark_pixels, open_page, pixels, POLL_MS, PORT_BASE, wait_canvas, \
    wait_for, wait_http, wait_page_text

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), 'bag'))


def _arm_drawn(img) -> str:
    """Return '' if the canvas shows the arm (its dark links), else what it shows."""
    n = dark_pixels(img)
    return '' if n > pixels(3000) else f'{n} dark pixels: no arm'


def test_bringup_viewer_option_serves_the_page_with_the_scene(browser, node_process, spin_node,
                                                              rclpy_context):
    """``bringup --viewer`` serves the page; it shows sim_driver's scene (world/markers)."""
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from visualization_msgs.msg import MarkerArray
    port = PORT_BASE + 5
    proc = node_process('bringup', '--viewer', '--no-camera', '--ros-args', '-p', f'port:={port}')
    counts = []
    listener = Node('viewer_scene_listener', context=rclpy_context)
    listener.create_subscription(
        MarkerArray, '/px100/world/markers', lambda m: counts.append(len(m.markers)),
        QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                   reliability=ReliabilityPolicy.RELIABLE))
    spin_node(listener)
    assert wait_http(f'http://127.0.0.1:{port}', 90.0), proc.output()[-2000:]
    assert wait_for(lambda: counts, 30.0), 'sim_driver publishes no world/markers'
    assert counts[-1] > 0, 'the default scene has no bodies'
    page = open_page(browser, f'http://127.0.0.1:{port}')
    try:
        wait_page_text(page, f'world: {counts[-1]} bodies', 60.0,
                       log=lambda: proc.output()[-3000:])
    finally:
        page.close()
    assert proc.alive()


def test_in_process_bringup_viewer_keyword_and_env(rclpy_context, monkeypatch):
    """InProcessBringup(viewer=True) and PX100_VIEWER=1 add the viewer node and its page."""
    from px100_control.client.inprocess import InProcessBringup, viewer_wanted
    monkeypatch.setenv('PX100_VIEWER', '1')
    assert viewer_wanted() is True and viewer_wanted(False) is False
    monkeypatch.setenv('PX100_VIEWER', '0')
    assert viewer_wanted() is False
    port = PORT_BASE + 6
    bringup = InProcessBringup(robot_name='px100_inproc', viewer=True,
                               parameters={'port': port})
    bringup.start(context=rclpy_context)
    try:
        names = sorted(n.get_name() for n in bringup.nodes)
        assert names == ['ik_service', 'robot_state_publisher', 'sim_driver', 'trajectory_server',
                         'viewer']
        assert wait_http(f'http://127.0.0.1:{port}', 30.0)
    finally:
        bringup.stop()


def test_viewer_bag_option_plays_a_bag_with_a_time_slider(browser, node_process, tmp_path):
    """``viewer --bag BAG``: the recorded arm in the page; the time slider changes the state."""
    from bag_support import write_run_bag
    bag = str(tmp_path / 'run')
    write_run_bag(bag, seconds=2.0)
    port = PORT_BASE + 7
    proc = node_process('viewer', '--bag', bag, '--port', str(port))
    assert wait_http(f'http://127.0.0.1:{port}', 60.0), proc.output()[-2000:]
    page = open_page(browser, f'http://127.0.0.1:{port}')
    try:
        assert page.locator('[role=slider]').count() == 2        # time and speed only
        assert page.locator('button', has_text='Home').count() == 0
        wait_canvas(page, _arm_drawn, 30.0)
        before = page.inner_text('body')
        label = page.locator('label', has_text='time [s]').first
        thumb = page.locator(f'[id="{label.get_attribute("for")}"] [role=slider]')
        box = thumb.bounding_box()
        x, y = box['x'] + box['width'] / 2, box['y'] + box['height'] / 2
        page.mouse.move(x, y)
        page.mouse.down()
        page.mouse.move(x + 40, y, steps=5)
        page.mouse.up()
        page.wait_for_function(
            "(s) => parseFloat(document.querySelector(s).getAttribute('aria-valuenow')) > 0.2",
            arg=f'[id="{label.get_attribute("for")}"] [role=slider]', timeout=30000,
            polling=POLL_MS)
        page.wait_for_function(
            '(b) => document.body.innerText.match(/state t = [0-9.]+ s at [0-9:.]+/)[0] !== '
            'b.match(/state t = [0-9.]+ s at [0-9:.]+/)[0]', arg=before, timeout=30000,
            polling=POLL_MS)
    finally:
        page.close()


def test_viewer_bag_option_refuses_a_bag_without_robot(node_process, tmp_path):
    """A bag without robot_description: one error line and exit status 1."""
    from bag_support import write_run_bag
    bag = str(tmp_path / 'nodesc')
    write_run_bag(bag, seconds=0.2, with_description=False)
    proc = node_process('viewer', '--bag', bag, '--port', str(PORT_BASE + 8))
    proc.proc.wait(60)
    assert proc.proc.returncode == 1
    assert 'robot_description' in proc.output()


def test_other_host_is_read_only_unless_asked(rclpy_context):
    """A host other than 127.0.0.1/localhost gives a read-only viewer unless also asked."""
    from px100_control.ros.viewer_node import ViewerNode
    from rclpy.parameter import Parameter
    for remote, expected in ((False, True), (True, False)):
        node = ViewerNode(context=rclpy_context, parameter_overrides=[
            Parameter('host', value='127.0.0.2'), Parameter('port', value=PORT_BASE + 9),
            Parameter('allow_remote_control', value=remote)])
        try:
            assert node.read_only is expected
            assert (node.scene.gizmo is None) is expected
        finally:
            node.destroy_node()
    # refused by the declared range (parameters.VIEWER), naming the parameter
    with pytest.raises(Exception, match='rate out of range Min: 1.0, Max: 60.0'):
        ViewerNode(context=rclpy_context, parameter_overrides=[
            Parameter('rate', value=500.0), Parameter('port', value=PORT_BASE + 9)])


def test_read_only_viewer_shows_a_replayed_bag(browser, node_process, tmp_path):
    """``replay BAG`` into the graph: a read-only viewer draws the recorded run live."""
    from bag_support import write_run_bag
    bag = str(tmp_path / 'run')
    write_run_bag(bag, seconds=2.0)
    port = PORT_BASE + 3
    node_process('viewer', '--ros-args', '-p', f'port:={port}', '-p', 'read_only:=true')
    assert wait_http(f'http://127.0.0.1:{port}', 60.0)
    node_process('replay', bag, '--loop')
    page = open_page(browser, f'http://127.0.0.1:{port}')      # waits for joint_states
    try:
        # the recorded stamps (1.7e9 s) reach the page as clock time, and they advance
        page.wait_for_function(
            '() => /state t = [0-9.]+ s at [0-9]{2}:[0-9]{2}:[0-9]{2}[.][0-9]{3}/'
            '.test(document.body.innerText)', timeout=45000, polling=POLL_MS)
        assert '17000000' not in page.inner_text('body')
        first = page.inner_text('body')
        page.wait_for_function(
            '(b) => document.body.innerText.match(/state t = [0-9.]+ s at [0-9:.]+/)[0] !== '
            'b.match(/state t = [0-9.]+ s at [0-9:.]+/)[0]', arg=first, timeout=30000,
            polling=POLL_MS)
        assert page.locator('[role=slider]').count() == 0
        wait_canvas(page, _arm_drawn, 30.0)
    finally:
        page.close()


def test_a_busy_port_gives_the_bound_url(node_process, tmp_path):
    """
    A port held by another socket: viser binds the next free one, and that URL is printed.

    Both the live viewer (its log line) and ``viewer --bag`` name the port really bound, and
    the page answers there.
    """
    import re
    import socket

    from bag_support import write_run_bag
    busy = PORT_BASE + 25
    holder = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    holder.bind(('127.0.0.1', busy))
    holder.listen(1)
    bag = str(tmp_path / 'run')
    write_run_bag(bag, seconds=0.5)
    try:
        live = node_process('viewer', '--ros-args', '-p', f'port:={busy}')
        played = node_process('viewer', '--bag', bag, '--port', str(busy))
        for proc, pattern in ((live, r'viewer on http://127\.0\.0\.1:(\d+) '),
                              (played, r'\(\d+\.\d s\) on http://127\.0\.0\.1:(\d+)')):
            assert wait_for(lambda: re.search(pattern, proc.output()), 60.0), \
                proc.output()[-2000:]
            port = int(re.search(pattern, proc.output()).group(1))
            assert port != busy and f'port {busy} is busy: serving on {port}' in proc.output()
            assert wait_http(f'http://127.0.0.1:{port}', 30.0)
    finally:
        holder.close()
