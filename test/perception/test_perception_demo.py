"""
The README demo with ``--perception``: the objects found by camera, ArmTag and pc_filter.

Two seeded runs (objects jittered by up to 5 mm, the camera by up to 20 mm) as a user runs it
(its own process; the demo starts camera, state_publisher and pc_filter): every object must end
within 10 mm of its target, judged on the simulator's truth; the camera's view is printed (the
ArmTag's transform, each object seen); the suite runs seed 100, PX100_PERCEPTION_E2E=1 also
seed 101. The 20-run figure is benchmarks/bench_pick_place_perception.py. Naming clusters by
colour is checked without ROS.
"""
import json
import os
import subprocess
import sys

from px100_control.client.camera_objects import color_distance, name_clusters
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OBJECTS = ['blue_cylinder', 'green_cube', 'red_cube']
#: the pick_place objects' declared colours and how the camera saw them (measured, 0..255)
DECLARED = {'red_cube': (0.85, 0.15, 0.15, 1.0), 'green_cube': (0.15, 0.70, 0.25, 1.0),
            'blue_cylinder': (0.15, 0.35, 0.85, 1.0)}
SEEN = [(218, 97, 97), (123, 251, 158), (81, 131, 191), (124, 123, 134), (67, 76, 94),
        (86, 86, 86)]        # + pedestal, bin wall, the arm


def test_clusters_are_named_by_hue_and_saturation_not_by_the_grey_or_bluish_fixtures():
    """Each object gets its own cluster; the pedestal, the bin and the arm name nothing."""
    clusters = [{'color': list(c), 'position': [float(k), 0.0, 0.0]}
                for k, c in enumerate(SEEN)]
    named = name_clusters(list(reversed(clusters)), DECLARED)
    assert {n: c['position'][0] for n, c in named.items()} == \
        {'red_cube': 0.0, 'green_cube': 1.0, 'blue_cylinder': 2.0}
    assert color_distance(DECLARED['blue_cylinder'], SEEN[4]) > \
        color_distance(DECLARED['blue_cylinder'], SEEN[2])
    assert name_clusters(clusters[3:], DECLARED) == {}     # only fixtures: nothing named
    assert name_clusters([], DECLARED) == {}


#: more seeded runs with PX100_PERCEPTION_E2E=1 (the suite runs one: ~60 s on a loaded machine)
MORE = pytest.mark.skipif(not os.environ.get('PX100_PERCEPTION_E2E'),
                          reason='one seeded run in the suite; PX100_PERCEPTION_E2E=1 runs more')


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.parametrize('seed', [100, pytest.param(101, marks=MORE)])
def test_perception_demo_places_every_object(tmp_path, seed):
    """--perception with jittered objects and camera: 3/3 placed within 10 mm, what it saw."""
    result = tmp_path / 'outcome.json'
    env = dict(os.environ, MPLBACKEND='Agg', PX100_CONNECT_TIMEOUT='120')   # loaded machine
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, 'scripts', 'pick_and_place_demo.py'),
         '--perception', '--jitter', '0.005', '--camera-jitter', '0.02', '--seed', str(seed),
         '--bringup', 'process', '--no-bag', '--no-plots', '--out', str(tmp_path),
         '--json', str(result)],
        env=env, capture_output=True, text=True, timeout=600)
    out = proc.stdout
    assert proc.returncode == 0, out[-4000:] + proc.stderr[-3000:]
    outcome = json.loads(result.read_text())
    assert outcome['perception'] and sorted(outcome['seen']) == OBJECTS
    assert sorted(o['name'] for o in outcome['objects']) == OBJECTS
    for o in outcome['objects']:
        assert o['verdict'] == 'placed' and o['error'] < 0.01, o
    assert 'ArmTag: px100/camera_color_optical_frame -> px100/base_link at' in out
    assert all(f'seen {n} at' in out for n in OBJECTS)
    assert 'placed 3/3 objects within 10 mm' in out
