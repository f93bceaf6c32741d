"""
The perception examples (examples/perception/, one per Interbotix perception demo), end to end.

Each runs as a user runs it: ``bringup`` with the example's scene and the camera without its
pose (``publish_pose:=false``: the ArmTag must place it), ``pc_filter`` with the examples'
crop box, then the script in its own process; only faster, on the simulation's clock (SPEED
times real time, ``use_sim_time``; the perception demo test runs on wall time). Afterwards every
object must rest where the script meant to put it (within ``TOLERANCE`` of one of the spots of
its kind, one object per spot; the tray for pick_place), read from the simulator's
``world/markers``. Scripts differ from Interbotix's API only in their import lines: checked on
the source. Each end-to-end run takes 30-50 s at SPEED 2, 55-85 s at real time (marked slow:
not in the quick tier).
"""
import ast
import os
import subprocess
import sys
import threading

import numpy as np
from pc_support import STARTUP_TIMEOUT, wait_for
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXAMPLES = os.path.join(ROOT, 'examples', 'perception')
FILTER = os.path.join(ROOT, 'config', 'perception_demos_filter.yaml')
#: how far [m] an object may rest from the spot the script set it down on
TOLERANCE = 0.015
TRAY = ((0.08, -0.16), 0.04)           # pick_place: centre, half inner width [m]
YELLOW_LINE = [(0.06, -0.13), (0.11, -0.13)]
BLUE_LINE = [(0.06, 0.13), (0.11, 0.13)]
#: script -> (scene, {object name: the spots it may end on})
CASES = {
    'pick_place': ('perception_pick_place', None),
    'color_sorter': ('color_sorter', {'red_block': [(0.06, -0.13)],
                                      'yellow_block': [(0.12, -0.13)],
                                      'blue_block': [(0.06, 0.13)],
                                      'purple_block': [(0.12, 0.13)]}),
    'block_organizer': ('block_organizer', {'yellow_1': YELLOW_LINE, 'yellow_2': YELLOW_LINE,
                                            'blue_1': BLUE_LINE, 'blue_2': BLUE_LINE}),
    'size_organizer': ('size_organizer', {'large_can': [(0.03, -0.13)],
                                          'medium_can': [(0.07, -0.13)],
                                          'small_can': [(0.11, -0.13)]}),
    'chessboard_cleanup': ('chessboard_cleanup', {'white_1': YELLOW_LINE,
                                                  'white_2': YELLOW_LINE,
                                                  'black_1': BLUE_LINE, 'black_2': BLUE_LINE}),
}
#: trajectory_server's tolerances as the client's in-process bringup sets them (NODE_PARAMETERS:
#: on a loaded machine the simulation falls behind and the tight defaults abort good moves), and
#: joint_states may be as old as the client's stale_timeout (3 s) before a move aborts (CI, load
#: 4-9 on 2 cores: pick_place's move aborted on joint_states 1.02 s old)
TOLERANT = ['-p', 'path_tolerance:=0.5', '-p', 'goal_time_tolerance:=2.0',
            '-p', 'state_timeout:=3.0']
#: the simulation's speed [simulated s per wall s]: the driver owns the clock (/clock) and the
#: nodes follow it (use_sim_time), so a starved driver slows everyone's time instead of
#: falling behind a wall clock; the script's client is told (PX100_REAL_TIME_FACTOR)
SPEED = float(os.environ.get('PX100_TEST_EXAMPLES_RTF', '2.0'))
SIM_TIME = ['-p', 'use_sim_time:=true', '-p', 'publish_clock:=true',
            '-p', f'real_time_factor:={SPEED}']


def _imports(tree):
    return [n for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom))]


@pytest.mark.parametrize('script', sorted(CASES))
def test_only_the_import_lines_name_this_project(script):
    """px100_control only in the imports: upstream's arm, armtag, pointcloud, robot peers."""
    with open(os.path.join(EXAMPLES, f'{script}.py'), encoding='utf-8') as f:
        source = f.read()
    tree = ast.parse(source)
    ours = {n.module for n in _imports(tree) if isinstance(n, ast.ImportFrom)
            and n.module.startswith('px100_control')}
    assert ours == {'px100_control.client.arm', 'px100_control.client.armtag',
                    'px100_control.client.pointcloud', 'px100_control.client.robot'}
    body = [n for n in tree.body if n not in _imports(tree)]
    assert 'px100_control' not in ''.join(ast.unparse(n) for n in body[1:])
    assert 'find_ref_to_arm_base_transform()' in source and 'get_cluster_positions(' in source


class Markers:
    """
    The latest world/markers of the px100 (a subscription on the test's node).

    Kept serialized and read when asked: they come at 30 Hz of simulated time, and decoding
    each one cost the test's process about 3 CPU-s per example.
    """

    def __init__(self, node):
        from px100_control.ros.common import LATCHED_QOS
        from visualization_msgs.msg import MarkerArray
        self.raw = None
        node.create_subscription(MarkerArray, '/px100/world/markers', self._on, LATCHED_QOS,
                                 raw=True)

    def _on(self, raw):
        self.raw = raw

    def now(self):
        """Return {object name: position [m]} of the latest markers ({} before the first)."""
        from px100_control.bag.world import markers_from_decoded
        from rclpy.serialization import deserialize_message
        from visualization_msgs.msg import MarkerArray
        raw = self.raw
        if raw is None:
            return {}
        return {m.name: np.array(m.position)
                for m in markers_from_decoded(deserialize_message(raw, MarkerArray))
                if m.ns == 'objects'}


def _run(script, tmp_path):
    """Start the nodes, run the script; return (its output, the objects' poses before, after)."""
    pytest.importorskip('rclpy')
    import rclpy
    from px100_control.tools.processes import NodeProcess
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import CameraInfo
    scene = CASES[script][0]
    procs = [NodeProcess('bringup', ['--ros-args', '-p', f'scene:={scene}', '-p',
                                     'publish_pose:=false'] + TOLERANT + SIM_TIME),
             NodeProcess('pc_filter', ['--ros-args', '--params-file', FILTER, '-p',
                                       'use_sim_time:=true'])]
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node('examples_probe', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    try:
        markers, frames = Markers(node), []
        # a frame's colour camera_info, not its 0.9 MB image (the camera builds an image only
        # for a subscriber); a few frames: the camera's first ones may precede the bodies
        node.create_subscription(CameraInfo, '/px100/camera/color/camera_info',
                                 lambda m: frames.append(1), 1)
        # up, or a node process gone (a bad parameter): fail with its output, not after the wait
        assert wait_for(lambda: (len(frames) >= 10 and markers.now())
                        or not all(p.alive() for p in procs), STARTUP_TIMEOUT) \
            and all(p.alive() for p in procs), \
            'no camera frame or world/markers\n' + '\n'.join(
                f'-- {p.name} ({"running" if p.alive() else "exited"}):\n{p.output()[-3000:]}'
                for p in procs)
        before = markers.now()
        proc = subprocess.run([sys.executable, os.path.join(EXAMPLES, f'{script}.py')],
                              capture_output=True, text=True, timeout=600,
                              env=dict(os.environ, PX100_CONNECT_TIMEOUT='60',
                                       PX100_REAL_TIME_FACTOR=str(SPEED)))
        after = markers.now()
        return proc, before, after
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
        for p in procs:
            p.stop()


def _evidence(proc) -> str:
    """Return the script's warnings and errors, then the ends of its stdout and stderr."""
    lines = (proc.stdout + proc.stderr).splitlines()
    flagged = [line for line in lines if any(word in line for word in
                                             ('ERROR', 'WARN', 'Could not', 'Traceback'))]
    parts = ['-- warnings and errors:', *flagged[-40:], '-- stdout:', proc.stdout[-2000:],
             '-- stderr:', proc.stderr[-3000:]]
    return '\n'.join(parts)


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.parametrize('script', sorted(CASES))
def test_example_moves_every_object_where_it_meant(script, tmp_path):
    """The script runs to its end and every object rests on a spot it meant for it."""
    proc, before, after = _run(script, tmp_path)
    log = _evidence(proc)
    assert proc.returncode == 0, log
    assert sorted(after) == sorted(before), log
    spots = CASES[script][1]
    if spots is None:           # pick_place: every object in the tray
        (cx, cy), half = TRAY
        for name, p in after.items():
            assert abs(p[0] - cx) < half and abs(p[1] - cy) < half, \
                f'{name} at {p.tolist()}, not in the tray\n{log}'
        return
    taken = []
    for name, p in sorted(after.items()):
        near = [s for s in spots[name] if np.hypot(p[0] - s[0], p[1] - s[1]) < TOLERANCE]
        assert near and near[0] not in taken, \
            f'{name} at {p.tolist()}, not on a free spot of {spots[name]}\n{log}'
        taken.append(near[0])
