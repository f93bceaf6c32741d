"""
The viewer beside the robot's nodes: faults isolated in one process, another robot's URDF.

Real rclpy nodes over Fast DDS: the client's in-process bringup (sim_driver, ik_service,
trajectory_server and the viewer in one executor); a wx250s bringup process in another namespace
with a viewer node left at its default robot_model (px100), and a headless Chromium on its page.
"""
import threading
import time

from sensor_msgs.msg import JointState
from viewer_support import DRIVER_CLOCK, open_page, PORT_BASE, VIEWPORT, wait_for, wait_http, \
    Watcher

HOME = ('waist', 'shoulder', 'elbow', 'wrist_angle'), (0.0, 0.0, 0.0, 0.0)


class _Rosout:
    """Collect /rosout lines (rcl_interfaces/Log) of one node, from the start (transient)."""

    def __init__(self, node, logger: str):
        from rcl_interfaces.msg import Log
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        self.lines, self.lock = [], threading.Lock()
        qos = QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(Log, '/rosout', self._on_log, qos)
        self.logger = logger

    def _on_log(self, msg):
        if msg.name == self.logger:
            with self.lock:
                self.lines.append((msg.level, msg.msg))

    def errors(self, text: str):
        """Return the ERROR lines containing text."""
        with self.lock:
            return [m for level, m in self.lines if level >= 40 and text in m]


def test_viewer_faults_never_stop_the_nodes_in_its_process(rclpy_context, spin_node,
                                                           monkeypatch):
    """
    A viewer fault in a shared executor is logged; the robot's nodes go on.

    Faults are injected into the viewer's callbacks (robot loading, every joint_states
    message): they are logged with their reason; joint_states keep flowing and a goal succeeds.
    """
    from px100_control.client.inprocess import InProcessBringup
    from px100_control.ros.peers import live_peers
    from px100_control.viewer.scene import ViewerScene
    from px100_control.viewer.state import ViewerState
    from rclpy.node import Node

    def broken_set_joints(self, names, positions, stamp):
        raise RuntimeError('injected fault in set_joints')

    def broken_load_robot(self, state):
        raise KeyError('injected fault in load_robot')

    monkeypatch.setattr(ViewerState, 'set_joints', broken_set_joints)
    monkeypatch.setattr(ViewerScene, 'load_robot', broken_load_robot)
    ns = 'px100_fault'
    log_node = Node('viewer_fault_log', context=rclpy_context)
    rosout = _Rosout(log_node, f'{ns}.viewer')
    watcher = Watcher(ns=f'/{ns}', context=rclpy_context)
    spin_node(log_node, watcher)
    counts = []
    watcher.create_subscription(JointState, f'/{ns}/joint_states',
                                lambda m: counts.append(time.monotonic()), 10)
    bringup = InProcessBringup(robot_name=ns, viewer=True,
                               parameters={'port': PORT_BASE + 20})
    bringup.start(context=rclpy_context)
    try:
        viewer = next(n for n in bringup.nodes if n.get_name() == 'viewer')
        assert wait_http(viewer.url, 30.0)
        assert wait_for(lambda: rosout.errors('RuntimeError: injected fault in set_joints'),
                        60.0), 'the joint_states fault was not logged'
        assert wait_for(lambda: rosout.errors("KeyError: 'injected fault in load_robot'"),
                        30.0), 'the robot_description fault was not logged'
        line = rosout.errors('set_joints')[0]
        assert line.startswith('on_joint_states failed: RuntimeError') and '(at ' in line
        assert wait_for(lambda: viewer.guard.faults > 10, 30.0)   # one per joint_states
        assert 'injected fault' in viewer.state.last_error
        # the robot's nodes in the same executor go on
        n0, t0 = len(counts), time.monotonic()
        assert wait_for(lambda: len(counts) - n0 > 20, 10.0, 0.01), \
            f'{len(counts) - n0} joint_states in {time.monotonic() - t0:.2f} s'
        key = watcher.send_goal(HOME[0], (0.4, -1.2, 1.0, 0.5), moving_time=3.0)
        assert watcher.wait_goal(key, 60.0) == 'SUCCEEDED'
        assert abs(watcher.position('waist') - 0.4) < 0.05
        assert bringup.thread.is_alive()
        # the viewer, which only shows the action's goals, is no second trajectory server (the
        # trajectory_server's action node is)
        peers = live_peers(watcher, f'/{ns}')
        assert peers['trajectory_servers'] == [f'/{ns}/trajectory_actions'], peers
    finally:
        bringup.stop()


def test_viewer_takes_another_robot_from_its_urdf(browser, rclpy_context, spin_node,
                                                  node_process):
    """
    The page's arm is the URDF's: a wx250s under a viewer left at robot_model px100.

    A wx250s in /arm2: the sliders are its six joints, Sleep is hidden (px100's pose does not
    fit), Home moves the wx250s. No Share button on the page (a plain viser page has one).
    """
    import viser

    from px100_control.models.registry import load_robot
    from px100_control.ros.viewer_node import ViewerNode
    from rclpy.parameter import Parameter
    wx250s = load_robot('wx250s')
    # the wx250s on its driver's clock (the viewer follows it)
    nodes = node_process('bringup', '--no-camera', '--ros-args', '-r', '__ns:=/arm2', '-p',
                         'robot_model:=wx250s', '-p', 'robot_name:=arm2', *DRIVER_CLOCK)
    viewer = ViewerNode(context=rclpy_context, namespace='/arm2', parameter_overrides=[
        Parameter('robot_name', value='arm2'), Parameter('port', value=PORT_BASE + 21),
        Parameter('use_sim_time', value=True)])
    watcher = Watcher(ns='/arm2', context=rclpy_context)
    spin_node(viewer, watcher)
    bare = viser.ViserServer(host='127.0.0.1', port=PORT_BASE + 22, verbose=False)
    try:
        assert viewer.model.name == 'px100'
        assert wait_for(lambda: viewer.arm is not None, 60.0), viewer.state.robot_error
        assert viewer.arm.joint_names == tuple(wx250s.joint_names)
        assert viewer.poses['sleep'] is None and viewer.poses['home'] == (0.0,) * 6
        assert wait_for(lambda: watcher.cli_goal.service_is_ready(), 60.0)
        assert wait_for(lambda: watcher.position('waist') is not None, 60.0)
        # 2 s: the wx250s's shoulder swings 1.9 rad from sleep (1 s aborted once under CI load)
        key = watcher.send_goal(wx250s.joint_names, (0.5, 0.0, 0.0, 0.0, 0.0, 0.0),
                                moving_time=2.0)
        assert watcher.wait_goal(key, 60.0) == 'SUCCEEDED', nodes.output()[-3000:]
        page = open_page(browser, viewer.url)
        try:
            assert page.locator('[role=slider]').count() == 6
            for name in ('forearm_roll', 'wrist_rotate'):
                assert page.locator('label', has_text=name).count() == 1
            assert page.get_by_role('button', name='Home').is_visible()
            assert page.get_by_role('button', name='Sleep', exact=True).count() == 0 or \
                not page.get_by_role('button', name='Sleep', exact=True).is_visible()
            assert page.locator('svg.tabler-icon-share').count() == 0
            page.get_by_role('button', name='Home').click()
            assert wait_for(lambda: abs(watcher.position('waist')) < 0.02, 20.0), \
                f"waist {watcher.position('waist'):.3f} rad did not go Home (0)"
        finally:
            page.close()
        plain = browser.new_page(viewport=VIEWPORT)
        try:
            plain.goto(f'http://127.0.0.1:{bare.get_port()}')
            plain.wait_for_selector('svg.tabler-icon-share', timeout=60000)
        finally:
            plain.close()
    finally:
        bare.stop()
