"""
Touching and hidden objects on real nodes: sim_driver, camera and pc_filter on the occlusion scene.

The installed executables run the occlusion scene (config/scenes/occlusion.yaml); the test asks
pc_filter's ``get_cluster_positions`` (Interbotix's defaults) and maps the clusters to the base
frame with the scene's camera pose: the touching red and yellow cubes are one cluster between
them, the cube behind the wall has none, the cube half behind it is found off its centre.
"""
from interbotix_perception_msgs.srv import ClusterInfoArray
from nodes_helpers import start_node, STARTUP_TIMEOUT, wait_for
import numpy as np
from px100_control.models.registry import load_robot
from px100_control.perception.camera import transform_points
from px100_control.sim.scene import load_scene
import pytest
from rclpy.node import Node

pytestmark = pytest.mark.ros

SCENE = load_scene('occlusion', load_robot('px100'))


def _xy(name):
    return np.array(SCENE.body(name).position[:2])


def test_touching_merge_hidden_missing_half_hidden_off_centre(ros_ctx, spinner, processes):
    """The real filter's view of the occlusion scene, over DDS."""
    client = spinner.add(Node('occlusion_client', context=ros_ctx))
    get = client.create_client(ClusterInfoArray, '/pc_filter/get_cluster_positions')
    procs = [start_node(processes, 'sim_driver', 'scene:=occlusion'),
             start_node(processes, 'camera', 'scene:=occlusion'),
             start_node(processes, 'pc_filter')]
    assert get.wait_for_service(timeout_sec=STARTUP_TIMEOUT), procs[2].output()
    found = []

    def clusters():
        fut = get.call_async(ClusterInfoArray.Request())
        assert wait_for(fut.done, 30.0), procs[2].output()
        found[:] = fut.result().clusters
        return len(found) > 0
    assert wait_for(clusters, STARTUP_TIMEOUT, period=0.5), [p.output() for p in procs]
    base = transform_points(SCENE.camera.optical_pose(),
                            np.array([[c.position.x, c.position.y, c.position.z]
                                      for c in found]))[:, :2]

    def near(xy, radius):
        return [k for k, p in enumerate(base) if np.hypot(*(p - xy)) < radius]
    red, yellow = _xy('red_cube'), _xy('yellow_cube')
    pair = near((red + yellow) / 2, 0.03)
    assert len(pair) == 1, base
    assert red[1] < base[pair[0]][1] < yellow[1]
    assert near(_xy('hidden_cube'), 0.02) == [], base
    peeking = near(_xy('peeking_cube'), 0.02)
    assert len(peeking) == 1, base
    off = base[peeking[0]] - _xy('peeking_cube')
    assert off[1] > 0.0 and np.hypot(*off) > 0.005, off      # off centre, to its visible side
    assert all(p.alive() for p in procs), [p.output() for p in procs]
