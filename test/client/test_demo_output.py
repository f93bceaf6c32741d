"""
What the demo shows a user, read back from one real run: its console, its plots, inspect's GIF.

One run of scripts/pick_and_place_demo.py (its own process, in-process nodes, default scene,
recorded): every object placed within 10 mm with its bag (world topics, object /tf frames) and
plots written, the 3D plot draws each object in its scene colour (pixels of the PNG), the phase
labels of the joints plot do not overlap, ``inspect`` on the bag draws the table and the objects
in the GIF, the console keeps the per-object progress visible (no per-goal lines), the recorder
counts the same topics at start and close and the results table stays aligned. Marked slow.
"""
import json
import os
import re
import subprocess
import sys

from client_support import SLOW
import numpy as np
from PIL import Image
import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENE = {'red_cube': (0.85, 0.15, 0.15), 'green_cube': (0.15, 0.70, 0.25),
         'blue_cylinder': (0.15, 0.35, 0.85)}
TABLE = (0.76, 0.65, 0.50)
#: matplotlib's default cycle colours the 3D plot used to draw the objects in
TAB_ORANGE, TAB_GREEN = (255, 127, 14), (44, 160, 44)


def near(img: np.ndarray, rgb, tol: int = 12) -> int:
    """Count pixels within tol (per channel, 0..255) of rgb."""
    return int((np.abs(img.astype(int) - np.asarray(rgb)).max(axis=2) <= tol).sum())


def rgb255(rgb) -> tuple:
    """Return a 0..1 colour as 0..255 integers (as matplotlib writes it)."""
    return tuple(int(round(255 * c)) for c in rgb)


@pytest.fixture(scope='module')
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp('demo')
    env = os.environ.copy()
    env['MPLBACKEND'] = 'Agg'
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, 'scripts', 'pick_and_place_demo.py'), '--out',
         str(out), '--json', str(out / 'outcome.json')],
        env=env, capture_output=True, text=True, timeout=60 + 240 * SLOW)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc, json.loads((out / 'outcome.json').read_text()), out


def test_demo_places_every_object_records_a_bag_and_plots(run):
    """Default scene: 3/3 placed within 10 mm, table printed, bag with world topics, plots."""
    from px100_control.bag.reader import open_bag
    proc, outcome, out_dir = run
    out = proc.stdout
    assert sorted(o['name'] for o in outcome['objects']) == sorted(SCENE)
    for o in outcome['objects']:
        assert o['verdict'] == 'placed' and o['error'] < 0.01, o
        assert o['lift'] > 0.02, o
        assert f"{o['name']}" in out and 'placed' in out
    assert 'placed 3/3 objects within 10 mm' in out
    bag_dir = next(line for line in out.splitlines() if line.startswith('bag:')).split()[1]
    with open_bag(bag_dir) as bag:
        counts = {name: t.message_count for name, t in bag.summary().topics.items()}
        tf_children = set()
        for _, msg in bag.iter_decoded(['/tf']):
            tf_children.update(t.child_frame_id for t in msg.transforms)
    assert counts.get('/px100/world/markers', 0) > 100
    assert counts.get('/px100/world/held_object', 0) >= 7     # '' + picked/released x 3
    assert {f'px100/objects/{n}' for n in SCENE} <= tf_children
    for name in ('pick_and_place_joints.png', 'pick_and_place_ee_path.png',
                 'pick_and_place_objects.png'):
        path = out_dir / name
        assert path.is_file() and path.stat().st_size > 20_000, path
        assert str(path) in out


def test_3d_plot_draws_each_object_in_its_scene_colour(run):
    proc, _, out = run
    img = np.asarray(Image.open(out / 'pick_and_place_ee_path.png').convert('RGB'))
    counts = {name: near(img, rgb255(rgb)) for name, rgb in SCENE.items()}
    assert min(counts.values()) > 150, counts
    # the former colours (red_cube green, green_cube orange) are gone
    assert near(img, TAB_ORANGE) < 20, near(img, TAB_ORANGE)
    assert near(img, TAB_GREEN, tol=6) < 20, near(img, TAB_GREEN, tol=6)


def test_phase_labels_of_the_joints_plot_do_not_overlap(run):
    """The demo's own phases (from its JSON), laid out by the demo's label_phases."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from px100_control.bag.plots import label_phases
    _, outcome, _ = run
    phases = [tuple(p) for p in outcome['phases']]
    assert len(phases) > 25 and {'red_cube: open', 'Approach Pick', 'grasp'} <= {
        label for _, label in phases}
    fig, (strip, ax) = plt.subplots(2, 1, figsize=(11, 12.7), sharex=True,
                                    gridspec_kw={'height_ratios': [2.75, 5]})
    ax.plot([p[0] for p in phases], [0.0] * len(phases))
    fig.tight_layout()
    texts = label_phases(strip, phases)
    renderer = fig.canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in texts]
    plt.close(fig)
    assert len(texts) == len(phases)
    overlaps = [(texts[i].get_text(), texts[j].get_text()) for i in range(len(boxes))
                for j in range(i + 1, len(boxes)) if boxes[i].overlaps(boxes[j])]
    assert not overlaps, overlaps
    inside = [t.get_text() for t, b in zip(texts, boxes)
              if b.y0 < strip.get_window_extent(renderer).y0 - 2]
    assert not inside, f'labels below the phase strip: {inside}'


def test_inspect_gif_draws_the_table_and_the_objects(run, tmp_path):
    from px100_control.bag import inspect_cli
    proc, _, _ = run
    bag_dir = next(line for line in proc.stdout.splitlines()
                   if line.startswith('bag:')).split()[1]
    assert inspect_cli.main([bag_dir, '-o', str(tmp_path), '--max-frames', '6']) == 0
    with Image.open(tmp_path / 'arm.gif') as gif:
        gif.seek(0)
        first = np.asarray(gif.convert('RGB'))
    # alpha 0.45 over the floor pane (matplotlib's 3D pane: 242 grey over the white page)
    table = tuple(int(round(0.45 * 255 * c + 0.55 * 242)) for c in TABLE)
    assert near(first, table, tol=10) > 5000, near(first, table, tol=10)
    for name, rgb in SCENE.items():
        assert near(first, rgb255(rgb), tol=30) > 40, name


def test_console_shows_the_objects_not_the_goals(run):
    proc, _, _ = run
    text = proc.stdout + proc.stderr
    assert not re.search(r'goal \d+\.\d+ accepted', text), text[-3000:]
    for name in SCENE:
        assert re.search(rf'^{name}: at \[', proc.stdout, re.M), proc.stdout
    ready = re.search(r'ready: recording (\d+) topics', text)
    closed = re.search(r'bag closed: \d+ messages on (\d+) of the (\d+) topics', text)
    assert ready and closed and ready.group(1) == closed.group(2), text[-3000:]
    assert 0 < int(closed.group(1)) <= int(closed.group(2)), text[-3000:]


def test_held_object_changes_only_at_grasp_and_release(run):
    """world/held_object in the bag: '' then each object once, '' after each (no flicker)."""
    from px100_control.bag.reader import open_bag
    proc, outcome, _ = run
    bag_dir = next(line for line in proc.stdout.splitlines()
                   if line.startswith('bag:')).split()[1]
    with open_bag(bag_dir) as bag:
        held = [msg.data for _, msg in bag.iter_decoded(['/px100/world/held_object'])]
    names = sorted(o['name'] for o in outcome['objects'])
    assert held[0::2] == [''] * (len(names) + 1) and sorted(held[1::2]) == names, held


def test_results_table_columns_line_up(run):
    proc, _, _ = run
    lines = proc.stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith('object '))
    table = lines[start:start + 4]
    assert {line.split()[0] for line in table[1:]} == set(SCENE)
    for column in ('ended at', 'target', 'verdict'):
        at = table[0].index(column)
        assert all(line[at - 2:at] == '  ' and line[at] != ' ' for line in table[1:]), table
