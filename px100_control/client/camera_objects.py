"""
Objects found by the camera: the perception demo's eyes, through Interbotix's perception API.

:class:`CameraObjects` locates a scene's objects the way an Interbotix perception script does:
the ArmTag places the camera relative to the arm
(:class:`~px100_control.client.armtag.InterbotixArmTagInterface`), the point-cloud filter
returns the clusters in the arm's base frame
(:class:`~px100_control.client.pointcloud.InterbotixPointCloudInterface`), and each object of
the task is named by colour: the cluster nearest the object's declared colour in hue and
saturation (:func:`color_distance`: the lit render keeps the hue but washes the saturation
out, 0.8 declared is ~0.55 seen), one cluster per object (an optimal assignment); a cluster
farther than :data:`MAX_COLOR_DISTANCE` from every object (the arm, the fixtures) names
nothing. The object's
centre is the cluster's x, y and half its top's height (it rests on the table, z = 0); the
filter reports the centre of each cluster's top face (``cluster_position:=top_face``), not the
centroid of its points, which the sides the camera sees pull toward it (2-5 mm measured).

With ``start_nodes`` it starts what the in-process bringup lacks, each as its own process:
``camera`` (``publish_pose:=false``: only the ArmTag says where it is; its pose may be moved
from the scene's), ``state_publisher`` (the arm's /tf, for the tag's pose) and ``pc_filter``
(:data:`FILTER_SETTINGS`); a pc_filter already running gets them set.
"""
import colorsys
import time
from types import SimpleNamespace
from typing import Dict, Mapping, Optional, Sequence

import numpy as np
from px100_control.bag.world import marker_scale
from px100_control.client.armtag import InterbotixArmTagInterface
from px100_control.client.pointcloud import InterbotixPointCloudInterface
from px100_control.client.robot import InterbotixException
from px100_control.perception.camera import CameraSpec
from px100_control.tools.processes import NodeProcess
from scipy.optimize import linear_sum_assignment

#: largest color_distance of a cluster from the colour of the object it is named after
MAX_COLOR_DISTANCE = 0.25
#: below this saturation a colour is grey (its hue means nothing)
GREY = 0.15
#: longest wait [s] for a started node (the filter's services, the camera's first frame)
CAMERA_START_TIMEOUT = 90.0
#: the service that shows pc_filter is up
FILTER_SERVICE = '/pc_filter/get_cluster_positions'
FILTER_NODE = '/pc_filter/pointcloud_pipeline'
#: the pc_filter parameters the demo tunes (as an Interbotix user tunes them for a scene): the
#: top face's centre as the position, and cluster size bounds no cluster of the view comes near
#: (measured over 32 jittered views, 6 noisy frames each: objects >= 45 points, fixture
#: fragments <= 25, the arm and the bin up to ~1030; Interbotix's 50..1000 made the count flicker
#: between samples, so every get_cluster_positions failed: nothing seen)
FILTER_SETTINGS = {'cluster_position': 'top_face', 'cluster_min_size': 35,
                   'cluster_max_size': 10000}


def color_distance(declared: Sequence[float], seen: Sequence[float]) -> float:
    """
    Return how far a seen colour (0..255) is from a declared one (0..1).

    Two colours: the hue difference (0..0.5 of the circle) plus half the saturation
    difference; two greys: the value difference; a grey and a colour: 1.
    """
    h1, s1, v1 = colorsys.rgb_to_hsv(*[float(c) for c in declared[:3]])
    h2, s2, v2 = colorsys.rgb_to_hsv(*[float(c) / 255.0 for c in seen[:3]])
    if s1 < GREY and s2 < GREY:
        return abs(v1 - v2)
    if s1 < GREY or s2 < GREY:
        return 1.0
    dh = abs(h1 - h2) % 1.0
    return min(dh, 1.0 - dh) + 0.5 * abs(s1 - s2)


def name_clusters(clusters: Sequence[dict], colors: Mapping[str, Sequence[float]]
                  ) -> Dict[str, dict]:
    """
    Return {object name: cluster} by colour (see the module docstring).

    :param clusters: Interbotix cluster dicts ('color' 0..255)
    :param colors: {name: rgba 0..1} of the objects looked for
    """
    names = list(colors)
    if not clusters or not names:
        return {}
    cost = np.array([[color_distance(colors[n], c['color']) for c in clusters]
                     for n in names])
    rows, cols = linear_sum_assignment(cost)
    return {names[r]: clusters[c] for r, c in zip(rows, cols)
            if cost[r, c] <= MAX_COLOR_DISTANCE}


def jittered_camera(camera: CameraSpec, jitter: float, seed: int):
    """Return (position, look_at) [m] of ``camera`` moved by up to ``jitter`` on each axis."""
    rng = np.random.default_rng([seed, 29])
    position = np.asarray(camera.position) + rng.uniform(-jitter, jitter, 3)
    look_at = np.asarray(camera.look_at) + rng.uniform(-jitter, jitter, 3) * [1, 1, 0]
    return [float(v) for v in position], [float(v) for v in look_at]


class CameraObjects:
    """
    Locate objects by camera, ArmTag and point-cloud filter (the module docstring).

    :param bot: the InterbotixManipulatorXS (its core's node carries the interfaces)
    :param start_nodes: start camera, state_publisher and pc_filter processes
    :param camera_pose: (position, look_at) [m] of the started camera (None: the scene's)
    :param scene: the scene file the started camera takes its defaults from
    """

    def __init__(self, bot, start_nodes: bool = True, camera_pose=None,
                 scene: Optional[str] = None):
        self.bot = bot
        self.processes = []
        if start_nodes:
            params = ['publish_pose:=false'] + ([f'scene:={scene}'] if scene else [])
            if camera_pose is not None:
                params += [f'position:={list(camera_pose[0])}',
                           f'look_at:={list(camera_pose[1])}']
            args = ['--ros-args'] + [a for p in params for a in ('-p', p)]
            self.processes = [NodeProcess('camera', args), NodeProcess('state_publisher'),
                              NodeProcess('pc_filter', ['--ros-args'] + [
                                  a for k, v in FILTER_SETTINGS.items()
                                  for a in ('-p', f'{k}:={v}')])]
        try:
            if start_nodes:     # a loaded machine starts them slower than the client waits
                self._wait(lambda: FILTER_SERVICE in dict(
                    bot.core.get_node().get_service_names_and_types()), 'pc_filter services')
            self.pcl = InterbotixPointCloudInterface(node_inf=bot.core)
            if not start_nodes:
                problem = bot.core.set_remote_parameters(FILTER_NODE, FILTER_SETTINGS,
                                                         timeout=10.0)
                if problem:
                    bot.core.get_node().get_logger().warning(
                        f'{FILTER_NODE}: {FILTER_SETTINGS} not set ({problem})')
            self.armtag = InterbotixArmTagInterface(node_inf=bot.core)
        except Exception:
            self.close()
            raise
        self.base_frame = self.armtag.arm_base_frame

    def _wait(self, ready, what: str) -> None:
        """Wait until ``ready()`` (CAMERA_START_TIMEOUT); raise if a started node ended."""
        deadline = time.monotonic() + CAMERA_START_TIMEOUT
        while not ready():
            if any(not p.alive() for p in self.processes):
                raise InterbotixException('a perception node ended: ' + '\n'.join(
                    p.output()[-1500:] for p in self.processes if not p.alive()))
            if time.monotonic() > deadline:
                raise InterbotixException(f'no {what} after {CAMERA_START_TIMEOUT} s')
            time.sleep(0.1)

    def calibrate(self, attempts: int = 3) -> bool:
        """
        Wait for the camera, then find the camera -> arm base transform (the ArmTag).

        :param attempts: find_ref_to_arm_base_transform calls until one succeeds (each logs
            why it failed: no frame in time on a loaded machine, the tag not found)
        """
        self._wait(lambda: self.armtag._count > 0, 'camera frames')
        return any(self.armtag.find_ref_to_arm_base_transform()
                   for _ in range(max(attempts, 1)))

    def locate(self, colors: Mapping[str, Sequence[float]], attempts: int = 10
               ) -> Dict[str, np.ndarray]:
        """
        Return {name: centre [m] in the base frame} of the objects seen, named by colour.

        :param colors: {name: rgba 0..1} of the objects looked for; a missing one is not seen
        :param attempts: get_cluster_positions calls, 1 s apart, until one succeeds (no cloud
            yet, clusters that flicker)
        """
        for k in range(max(attempts, 1)):
            if k:
                time.sleep(1.0)
            ok, clusters = self.pcl.get_cluster_positions(ref_frame=self.base_frame,
                                                          sort_axis='x', reverse=True)
            if ok:
                named = name_clusters(clusters, colors)
                return {n: np.array([c['position'][0], c['position'][1],
                                     0.5 * c['position'][2]]) for n, c in named.items()}
        return {}

    def close(self) -> None:
        """Stop the processes started here."""
        for p in self.processes:
            p.stop()
        self.processes = []


def perceived_bodies(found: Mapping[str, np.ndarray], scene_objects) -> dict:
    """Return {name: a body with position, shape and scale} for the demo's pick order."""
    shapes = {b.name: b for b in scene_objects}
    return {n: SimpleNamespace(position=tuple(p), shape=shapes[n].shape,
                               scale=marker_scale(shapes[n].shape, shapes[n].size))
            for n, p in found.items() if n in shapes}
