"""The viewer's pure engine: state, markers, trail, throttle, bag timeline, no-browser cost."""
import os
import sys
from types import SimpleNamespace as NS

from px100_control.errors import BagError
from px100_control.viewer.state import apply_markers, interpolate_joint_path, Throttle, Trail, \
    ViewerState
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
    assert lines[0] == 'state t = 12.500000 s'
    assert 'last error: ik: unreachable by 0.12 m' in lines
    assert 'trajectory: goal 3.000: SUCCEEDED' in lines


def test_bag_timeline_gives_the_state_at_a_time(tmp_path):
    """A recorded run read back: joints at t, the URDF, the trail over the last seconds."""
    from bag_support import arm_trajectory, write_run_bag

    from px100_control.viewer.bag_view import load_bag, state_at
    from px100_control.viewer.scene import UrdfKinematics
    bag = str(tmp_path / 'run')
    write_run_bag(bag, seconds=2.0)
    tl = load_bag(bag)
    assert tl.namespace == 'px100' and 1.9 < tl.duration < 2.1
    st = ViewerState()
    kin = UrdfKinematics(tl.urdf_xml)
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
    """render() is a no-op while no browser is connected (a viewer alone costs ~nothing)."""
    from px100_control.viewer.scene import ViewerScene
    from viewer_support import PORT_BASE
    scene = ViewerScene(port=PORT_BASE + 4, read_only=True)
    try:
        st = ViewerState()
        scene.attach(st)
        st.set_joints(['waist'], [0.1], 1.0)
        assert not scene.has_clients()
        assert scene.render(st, 0.0) is False
        assert scene.render(st, 0.0, force=True) is True
        assert scene.render(st, 0.0, force=True) is False     # nothing changed since
    finally:
        scene.close()
