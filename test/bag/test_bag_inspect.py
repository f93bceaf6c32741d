"""inspect: the printed summary, the PNG plots and the GIF of a recorded run."""
import os

from bag_support import ARM, arm_trajectory, write_run_bag
import numpy as np
from PIL import Image
from px100_control.bag import inspect_cli, plots
from px100_control.bag.reader import BagReader
import pytest


@pytest.fixture(scope='module')
def run_bag(tmp_path_factory):
    """Return a synthetic 2 s run with setpoints, ee_pose and robot_description."""
    bag_dir = str(tmp_path_factory.mktemp('inspect') / 'run')
    write_run_bag(bag_dir, seconds=2.0)
    return bag_dir


def test_summary_lists_topics_counts_rates(run_bag, capsys):
    """The summary shows duration, message count and each topic with count and rate."""
    assert inspect_cli.main([run_bag, '--no-plots']) == 0
    out = capsys.readouterr().out
    assert 'duration:   1.990 s' in out
    assert 'messages:   441' in out  # 200 joint_states + 200 ee_pose + 40 setpoints + 1
    lines = {line.split()[0]: line.split() for line in out.splitlines()
             if line.startswith('  /')}
    assert lines['/px100/joint_states'][2:4] == ['200', '100.00']
    assert lines['/px100/commands/joint_setpoints'][2] == '40'
    assert lines['/px100/robot_description'][-1] == 'transient_local'


def test_series_and_tracking_error(run_bag):
    """The extracted series hold the written values; the tracking error is setpoint - measured."""
    with BagReader(run_bag) as reader:
        series = plots.extract_series(reader)
    assert series.namespace == '/px100'
    assert series.names[:4] == ARM and series.q.shape == (200, 7)
    np.testing.assert_allclose(series.q[10, :4], arm_trajectory(0.1), atol=1e-12)
    errors = plots.tracking_errors(series)
    t, err = errors['waist']
    # at t = 0.1 s the held setpoint is the one sent at 0.1 s for 0.15 s
    k = int(np.argmin(np.abs(t - 0.1)))
    assert err[k] == pytest.approx(arm_trajectory(0.15)[0] - arm_trajectory(0.1)[0], abs=1e-9)
    assert series.urdf_xml and 'px100/base_link' in series.urdf_xml
    assert plots.hold_values(np.array([0, 1.5, 3]), np.array([1.0, 2.0]),
                             np.array([10.0, 20.0])).tolist()[1:] == [10.0, 20.0]


@pytest.mark.slow                  # renders the plots and a GIF
def test_plots_and_gif_are_written(run_bag, tmp_path, capsys):
    """joints.png, tracking_error.png, ee_path.png and a multi-frame arm.gif."""
    out = str(tmp_path / 'plots')
    assert inspect_cli.main([run_bag, '-o', out, '--max-frames', '12', '--fps', '5']) == 0
    printed = capsys.readouterr().out
    for name in ('joints.png', 'tracking_error.png', 'ee_path.png', 'arm.gif'):
        path = os.path.join(out, name)
        assert f'wrote {path}' in printed
        with Image.open(path) as im:
            assert im.size[0] > 300 and im.size[1] > 300
            if name == 'arm.gif':
                assert im.n_frames == 10  # 1.99 s at 5 fps
            else:
                # a real plot, not a blank canvas: many distinct colours
                assert len(im.convert('RGB').getcolors(maxcolors=1 << 16) or []) > 50


def test_ee_path_falls_back_to_forward_kinematics(tmp_path):
    """Without ee_pose the path comes from joint_states through the recorded URDF."""
    from px100_control.bag.tf import TfTree
    bag_dir = str(tmp_path / 'run')
    write_run_bag(bag_dir, seconds=0.5)
    with BagReader(bag_dir) as reader:
        series = plots.extract_series(reader)
    t, xyz, source = plots.ee_path(series)
    assert source == 'ee_pose'
    ee_xyz = xyz.copy()
    series.ee_t = np.zeros(0)
    t2, xyz2, source2 = plots.ee_path(series, TfTree(series.urdf_xml))
    assert source2.startswith('forward kinematics')
    np.testing.assert_allclose(xyz2, ee_xyz, atol=1e-12)
