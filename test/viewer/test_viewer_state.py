"""
The viewer's engine without ROS: state, markers, trail, throttle, bag timeline, robot, guard.

Also the cost with no browser, the arm taken from the URDF and the page's refusal to share.
"""
import os
import sys
from types import SimpleNamespace as NS

from px100_control.errors import BagError
from px100_control.viewer.state import apply_markers, interpolate_joint_path, \
    markdown_literal, RateLimit, Throttle, Trail, ViewerState
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), 'bag'))


def _marker(ns, id_, kind, scale, pos, rgba=(1, 0, 0, 1), action=0, text=''):
    return NS(ns=ns, id=id_, type=kind, action=action, text=text,
              scale=NS(x=scale[0], y=scale[1], z=scale[2]),
              pose=NS(position=NS(x=pos[0], y=pos[1], z=pos[2]),
                      orientation=NS(x=0.0, y=0.0, z=0.0, w=1.0)),
              color=NS(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]))


def test_markers_become_bodies_and_follow_actions():
    """CUBE/CYLINDER/SPHERE become bodies with ROS Marker sizes; DELETE and DELETEALL apply."""
    bodies = apply_markers({}, [
        _marker('objects', 1, 1, (0.03, 0.04, 0.05), (0.2, 0, 0.02), text='cube'),
        _marker('fixtures', 2, 3, (0.08, 0.08, 0.04), (0.1, 0.1, 0.02), text='bin'),
        _marker('objects', 3, 2, (0.02, 0.02, 0.02), (0, 0, 0), text='ball'),
        _marker('objects', 4, 9, (1, 1, 1), (0, 0, 0), text='text marker')])
    assert {b.name: (b.shape, b.size) for b in bodies.values()} == {
        'cube': ('box', (0.03, 0.04, 0.05)), 'bin': ('cylinder', (0.04, 0.04)),
        'ball': ('sphere', (0.01,))}
    bodies = apply_markers(bodies, [_marker('objects', 1, 1, (1, 1, 1), (0, 0, 0), action=2)])
    assert sorted(b.name for b in bodies.values()) == ['ball', 'bin']
    assert apply_markers(bodies, [_marker('', 0, 0, (1, 1, 1), (0, 0, 0), action=3)]) == {}


def test_trail_is_bounded_and_throttle_counts_time():
    """The trail keeps at most max_points, one per min_step; a throttle uses the given time."""
    trail = Trail(max_points=10, min_step=0.01)
    for k in range(100):
        trail.add((0.001 * k, 0.0, 0.0))      # 1 mm steps: one point per 10
    assert len(trail.points) == 10
    for k in range(100):
        trail.add((1.0 + 0.02 * k, 0.0, 0.0))
    assert len(trail.points) == 10 and trail.points[-1][0] == pytest.approx(2.98)
    th = Throttle(0.1)
    assert th.due(5.0)
    th.mark(5.0)
    assert not th.due(5.05) and th.due(5.11)
    with pytest.raises(ValueError, match='at least 2'):
        Trail(max_points=1)


def test_rate_limit_draws_arrivals_at_once_within_the_rate():
    """50 Hz arrivals, 30 Hz limit: 3 of 5 drawn when they arrive; bursts stay bounded."""
    limit = RateLimit(30.0)
    drawn = []
    for k in range(250):                          # 5 s of 50 Hz messages
        now = 100.0 + 0.02 * k
        if limit.due(now):
            limit.mark(now)
            drawn.append(now)
    per_second = [sum(1 for t in drawn if s <= t - 100.0 < s + 1) for s in range(1, 5)]
    assert all(29 <= n <= 31 for n in per_second), per_second
    gaps = {round(b - a, 3) for a, b in zip(drawn[5:], drawn[6:])}
    assert gaps <= {0.02, 0.04}, gaps
    idle = [limit.due(200.0 + 1e-3 * k) and limit.mark(200.0 + 1e-3 * k) is None
            for k in range(10)]                   # after a pause: at most `burst` at once
    assert sum(idle) == 2


def test_goal_path_interpolates_from_the_current_joints():
    """A one-point goal on a subset of joints: a joint-space line from the measured state."""
    path = interpolate_joint_path({'a': 0.0, 'b': 1.0}, ['a'], [[1.0]], samples_per_segment=4)
    assert [round(q['a'], 3) for q in path] == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert all(q['b'] == 1.0 for q in path)


def test_state_versions_status_and_terminal_goal():
    """Parts change version only when changed; a terminal status ends the path display."""
    st = ViewerState()
    st.fk = lambda q: ((q.get('a', 0.0), 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    st.set_joints(['a'], [0.0], 12.5)
    v = dict(st.version)
    st.set_held('')
    assert st.version == v
    st.set_goal(3.0, ['a'], [[0.5]])
    assert st.target == (0.5, 0.0, 0.0) and len(st.path) > 2
    st.set_goal_status(3.0, 'EXECUTING')
    assert st.path
    st.set_goal_status(3.0, 'SUCCEEDED')
    assert st.path == []
    st.set_error('ik: unreachable by 0.12 m')
    lines = st.status_lines()
    assert lines[0] == 'state t = 0.00 s at sim time 12.50 s'
    assert 'last error: ik: unreachable by 0.12 m' in lines
    assert 'trajectory: goal 1: SUCCEEDED' in lines


def test_status_shows_time_since_start_and_numbered_goals():
    """Seconds since the first joint_states and clock time, goals by number, not epoch floats."""
    import time
    st = ViewerState()
    assert st.status_lines()[0] == 'state: no joint_states yet'
    start = 1795767240.7        # wall-clock stamps, as sim_driver sends them
    st.set_joints(['a'], [0.0], start)
    st.set_joints(['a'], [0.1], start + 12.25)
    clock = time.strftime('%H:%M:%S', time.localtime(start + 12.25))
    assert st.status_lines()[0] == f'state t = 12.25 s at {clock}.950'
    for goal in (start + 1.0, start + 2.5, start + 1.0):
        st.set_goal_status(goal, 'SUCCEEDED')
        assert '1795767' not in ' '.join(st.status_lines())
    assert 'trajectory: goal 1: SUCCEEDED' in st.status_lines()
    st.set_goal_status(start + 2.5, 'ABORTED')
    assert 'trajectory: goal 2: ABORTED' in st.status_lines()


#: texts that are Markdown or HTML when not escaped (names and error texts reach the panel as is)
STATUS_TEXTS = ('ik: <lambda> failed', 'wrist_angle and shoulder_lift', '**bold** `code` [a](b)',
                '# heading', '1. item', '- item\n    code block', 'a & b &lt; c', r'back\slash',
                'state t = 1.5 s', '~~x~~ | y |', '<b>', 'error: {"x": [1, 2]} (!)')


def _rendered_text(markdown: str) -> str:
    """Render markdown as GFM-like CommonMark does; return its text, tags stripped."""
    import html
    import re
    markdown_it = pytest.importorskip('markdown_it')
    md = markdown_it.MarkdownIt('commonmark').enable(['table', 'strikethrough'])
    out = md.render(markdown)
    return html.unescape(re.sub(r'<[^>]*>', '', out)).strip()


def test_status_text_reaches_the_page_as_written():
    """markdown_literal: the rendered text is the text, on one line, for markup-like input."""
    for text in STATUS_TEXTS:
        assert _rendered_text(markdown_literal(text)) == ' '.join(text.split()), text
    # the check can fail: unescaped, most of these do not survive
    assert sum(_rendered_text(t) != ' '.join(t.split()) for t in STATUS_TEXTS) >= 8


def test_bag_timeline_gives_the_state_at_a_time(tmp_path):
    """A recorded run read back: joints at t, the URDF, the trail over the last seconds."""
    from bag_support import arm_trajectory, write_run_bag

    from px100_control.viewer.bag_view import load_bag, state_at
    from px100_control.viewer.robot import UrdfRobot
    bag = str(tmp_path / 'run')
    write_run_bag(bag, seconds=2.0)
    tl = load_bag(bag)
    assert tl.namespace == 'px100' and 1.9 < tl.duration < 2.1
    st = ViewerState()
    kin = UrdfRobot(tl.urdf_xml)
    st.fk = kin.ee_pose
    state_at(tl, st, 1.0)
    assert st.joints['waist'] == pytest.approx(arm_trajectory(1.0)[0], abs=0.02)
    assert len(st.trail.points) > 5
    state_at(tl, st, 0.0)
    assert len(st.trail.points) == 1
    with pytest.raises(BagError, match='robot_description'):
        write_run_bag(str(tmp_path / 'nodesc'), seconds=0.2, with_description=False)
        load_bag(str(tmp_path / 'nodesc'))


def test_scene_sends_nothing_without_a_browser():
    """
    No browser: render() sends nothing and no kinematics run (a viewer alone costs ~nothing).

    joint_states only store values; the end-effector pose (trail, gizmo) is computed once per
    drawn state, when a page is there (force stands for one here).
    """
    from px100_control.viewer.scene import ViewerScene
    from viewer_support import PORT_BASE
    scene = ViewerScene(port=PORT_BASE + 4, read_only=True)
    try:
        st = ViewerState()
        scene.attach(st)
        st.set_robot(_urdf('px100', 'px100'))
        scene.load_robot(st)
        assert st.robot_error == ''
        fk_calls = []
        fk = st.fk
        st.fk = lambda q: fk_calls.append(1) or fk(q)
        for k in range(50):
            st.set_joints(['waist', 'shoulder'], [0.01 * k, 0.1], 1.0 + 0.02 * k)
            assert scene.render(st, 0.0) is False
        assert not scene.has_clients()
        assert fk_calls == [] and len(st.trail.points) == 0
        assert scene.render(st, 0.0, force=True) is True
        assert len(fk_calls) == 1 and len(st.trail.points) == 1
        assert scene.render(st, 0.0, force=True) is False     # nothing changed since
        assert len(fk_calls) == 1
    finally:
        scene.close()


def _urdf(robot: str, namespace: str) -> str:
    from px100_control.models.registry import load_robot
    from px100_control.models.urdf_prefix import prefix_urdf
    return prefix_urdf(load_robot(robot).urdf_xml, namespace)


@pytest.mark.parametrize('robot', ['px100', 'wx250s', 'rrrr'])
def test_arm_joints_limits_and_kinematics_come_from_the_urdf(robot):
    """The URDF alone gives the arm joints, their limits and the end-effector pose."""
    import numpy as np

    from px100_control.models.registry import load_robot
    from px100_control.viewer.robot import UrdfRobot
    model = load_robot(robot)
    kin = UrdfRobot(_urdf(robot, 'arm2'))
    assert kin.base == 'arm2/base_link'
    assert kin.arm.joint_names == tuple(model.joint_names)
    np.testing.assert_allclose(kin.arm.lower, model.lower)
    np.testing.assert_allclose(kin.arm.upper, model.upper)
    rng = np.random.default_rng(1)
    for _ in range(10):
        q = rng.uniform(model.lower, model.upper)
        xyz, quat = kin.ee_pose(dict(zip(model.joint_names, q)))
        T = model.fk(q)
        np.testing.assert_allclose(xyz, T[:3, 3], atol=1e-9)
        # the quaternion's rotation is the model's (x, y, z, w)
        x, y, z, w = quat
        R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-9)
    with pytest.raises(ValueError, match='robot_description is not a usable URDF'):
        UrdfRobot('<robot name="broken"><link name=')


def test_home_and_sleep_from_the_model_only_when_it_matches_the_urdf():
    """robot_model px100 on a wx250s URDF: sliders stay the URDF's, Home zeros, no Sleep."""
    from px100_control.models.registry import load_robot
    from px100_control.viewer.controls import gripper_joint, model_matches, named_poses
    from px100_control.viewer.robot import UrdfRobot
    px100, wx250s = load_robot('px100'), load_robot('wx250s')
    kin = UrdfRobot(_urdf('wx250s', 'arm2'))
    assert not model_matches(kin.arm, px100) and model_matches(kin.arm, wx250s)
    poses = named_poses(kin.arm, px100)
    assert poses == {'home': (0.0,) * 6, 'sleep': None}
    poses = named_poses(kin.arm, wx250s)
    assert poses['sleep'] == pytest.approx(tuple(wx250s.sleep))
    assert gripper_joint(px100, kin.actuated) == 'gripper'
    rrrr = UrdfRobot(_urdf('rrrr', 'arm3'))
    assert gripper_joint(px100, rrrr.actuated) is None
    home = named_poses(rrrr.arm, px100)['home']       # zeros, clipped into the limits
    assert all(lo <= v <= hi for v, lo, hi in zip(home, rrrr.arm.lower, rrrr.arm.upper))


def test_guard_reports_a_fault_once_per_period_and_lets_interrupts_pass():
    """A guarded callback's exception becomes one report line (type, message, line)."""
    from px100_control.viewer.guard import Guard
    lines, now = [], [0.0]
    guard = Guard(lines.append, repeat_period=5.0, clock=lambda: now[0])

    def on_thing(x):
        if x < 0:
            raise RuntimeError(f'bad {x}')
        return 2 * x

    cb = guard.wrap(on_thing)
    assert cb(2) == 4 and lines == []
    assert cb(-1) is None and cb(-1) is None
    assert len(lines) == 1 and guard.faults == 2
    assert lines[0].startswith('on_thing failed: RuntimeError: bad -1 (at test_viewer_state.py:')
    cb(-2)                               # another fault: reported at once
    now[0] = 6.0
    cb(-1)                               # the first one again, after the period
    assert len(lines) == 3
    with pytest.raises(KeyboardInterrupt):
        guard.call('stop', lambda: (_ for _ in ()).throw(KeyboardInterrupt()))
    guard.report = lambda text: 1 / 0    # a failing report does not raise either
    assert guard.call('again', lambda: [][1]) is None


def test_page_cannot_be_shared():
    """The share tunnel is off: no Share button in the theme, a ShareUrlRequest is ignored."""
    import asyncio

    from px100_control.viewer.scene import ViewerScene
    from viewer_support import PORT_BASE
    from viser import _messages
    scene = ViewerScene(port=PORT_BASE + 24, read_only=False)
    try:
        server = scene.server
        assert server.request_share_url() is None
        websock = server._websock_server
        assert _messages.ShareUrlRequest not in websock._incoming_handlers
        # a page's request, through the server's own dispatch of client messages
        asyncio.run_coroutine_threadsafe(
            websock._handle_incoming_message(0, _messages.ShareUrlRequest()),
            server._event_loop).result(5.0)
        assert server._share_tunnel is None
        themes = [m for m in websock._broadcast_buffer.message_from_id.values()
                  if type(m).__name__ == 'ThemeConfigurationMessage']
        assert themes and themes[-1].show_share_button is False
    finally:
        scene.close()
