"""
The camera and pc_filter refuse a bad start in one line naming what is wrong (exit 1).

A camera pose that sees nothing, from a parameter or from the scene file's camera block, and
filter parameters out of range or wrong together: each executable exits at once with
``<prog>: error: ...``, no traceback. (Set at run time the same values are refused and the
nodes keep running: test_camera_node.py, test/perception/test_pc_filter_node.py.)
"""
import os
import subprocess

from px100_control.tools.processes import executable_path
import pytest

pytestmark = pytest.mark.ros

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _run_all(commands, timeout=120.0):
    procs = [subprocess.Popen(c, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              cwd=ROOT) for c in commands]
    return [(p.wait(timeout), p.stdout.read()) for p in procs]


def _one_line_error(status, out, prog, *words):
    lines = out.strip().splitlines()
    assert status == 1 and 'Traceback' not in out and len(lines) == 1, (status, out)
    assert lines[0].startswith(f'{prog}: error: '), out
    for w in words:
        assert w in lines[0], (w, out)


def test_bad_camera_and_filter_parameters_at_start(tmp_path):
    scene = tmp_path / 'looking_away.yaml'
    with open(os.path.join(ROOT, 'config', 'scenes', 'pick_place.yaml')) as f:
        text = f.read()
    scene.write_text(text.replace('look_at: [0.15, 0.0, 0.0]', 'look_at: [0.9, 0.0, 0.65]'))
    results = _run_all([
        [executable_path('camera'), '--ros-args', '-p', 'look_at:=[0.18, 0.0, 1.5]'],
        [executable_path('camera'), '--ros-args', '-p', f'scene:={scene}'],
        [executable_path('pc_filter'), '--ros-args', '-p', 'voxel_leaf_size:=-1.0'],
        [executable_path('pc_filter'), '--ros-args', '-p', 'x_filter_min:=0.3'],
    ])
    _one_line_error(*results[0], 'camera', 'camera refused', 'look_at [0.18, 0.0, 1.5]',
                    'sees nothing')
    _one_line_error(*results[1], 'camera', 'look_at [0.9, 0.0, 0.65]', 'sees nothing')
    _one_line_error(*results[2], 'pc_filter', 'voxel_leaf_size', 'out of range')
    _one_line_error(*results[3], 'pc_filter', 'x_filter_min (0.3) must be below x_filter_max')
