"""
The client's InterbotixPointCloudInterface on a real pc_filter node, frames from /tf_static.

The test publishes the synthetic scene of test_cloud_filter in the camera's optical frame and
the camera's pose on /tf_static (base_link -> camera_link -> camera_color_optical_frame, 0.6 m
above the table looking down), as the camera node will; the client returns the boxes in the
base frame, Interbotix's way.
"""
import math
import os

import numpy as np
from pc_support import scene_cloud, STARTUP_TIMEOUT, wait_for
import pytest
from scipy.spatial.transform import Rotation

pytestmark = pytest.mark.ros

#: (cx, cy, size, height) in the optical frame; the table 0.6 m from the camera
BOXES = [(0.05, 0.03, 0.03, 0.03), (-0.06, -0.04, 0.025, 0.025)]
CAMERA_XY = (0.18, 0.0)          # the optical centre above the base frame's x axis [m]
#: optical axes in the base frame: x_opt = -y_base, y_opt = -x_base, z_opt = -z_base (down)
R_BASE_OPT = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def _in_base(cx, cy, height):
    """Return the box's top centre in the base frame (the table at z = 0)."""
    return np.array([CAMERA_XY[0] - cy, CAMERA_XY[1] - cx, height])


def _static_tf(node):
    from geometry_msgs.msg import TransformStamped
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from tf2_msgs.msg import TFMessage
    pub = node.create_publisher(TFMessage, '/tf_static', QoSProfile(
        depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
        reliability=ReliabilityPolicy.RELIABLE))
    link = TransformStamped(child_frame_id='px100/camera_link')
    link.header.frame_id = 'px100/base_link'
    link.transform.translation.x, link.transform.translation.z = CAMERA_XY[0], 0.6
    link.transform.rotation.w = 1.0
    optical = TransformStamped(child_frame_id='px100/camera_color_optical_frame')
    optical.header.frame_id = 'px100/camera_link'
    q = Rotation.from_matrix(R_BASE_OPT).as_quat()
    r = optical.transform.rotation
    r.x, r.y, r.z, r.w = (float(v) for v in q)
    pub.publish(TFMessage(transforms=[link, optical]))
    return pub


@pytest.fixture(scope='module')
def env():
    """Start pc_filter, the client (global node) and a camera stand-in; shut all down."""
    pytest.importorskip('rclpy')
    from px100_control.client import robot_shutdown
    from px100_control.client.pointcloud import InterbotixPointCloudInterface
    from px100_control.tools.processes import NodeProcess
    from rclpy.node import Node
    from sensor_msgs.msg import PointCloud2
    node = NodeProcess('pc_filter')
    os.environ['PX100_CONNECT_TIMEOUT'] = str(STARTUP_TIMEOUT)
    try:
        pcl = InterbotixPointCloudInterface()
        camera = Node('test_camera', context=pcl.node_inf.context)
        _static_tf(camera)
        cloud_pub = camera.create_publisher(PointCloud2, '/px100/camera/depth/color/points', 1)
        yield pcl, cloud_pub, node
        camera.destroy_node()
    finally:
        os.environ.pop('PX100_CONNECT_TIMEOUT', None)
        robot_shutdown()
        node.stop()
        assert not node.killed, node.output()


def _until_success(pcl, cloud_pub, cloud, **kwargs):
    result = []

    def done():
        cloud_pub.publish(cloud)
        result[:] = pcl.get_cluster_positions(**kwargs)
        return result[0]
    assert wait_for(done, 30.0, period=0.2), result
    return result[1]


def test_clusters_in_the_base_frame_through_tf_static(env):
    pcl, cloud_pub, node = env
    clusters = _until_success(pcl, cloud_pub, scene_cloud(BOXES), ref_frame='px100/base_link',
                              sort_axis='y', reverse=True, num_samples=3, period=0.05)
    truth = sorted((_in_base(cx, cy, h) for cx, cy, _, h in BOXES), key=lambda p: -p[1])
    assert [c['name'] for c in clusters] == ['cluster_1', 'cluster_2']
    for c, p in zip(clusters, truth):
        assert math.hypot(c['position'][0] - p[0], c['position'][1] - p[1]) < 0.002, (c, p)
        assert c['position'][2] == pytest.approx(p[2], abs=0.003)    # is_parallel: the top
        assert c['yaw'] == 0 and c['num_points'] > 50 and len(c['color']) == 3
    assert clusters[0]['position'][1] > clusters[1]['position'][1]
    ascending = _until_success(pcl, cloud_pub, scene_cloud(BOXES), ref_frame='px100/base_link',
                               sort_axis='x', num_samples=1)
    assert ascending[0]['position'][0] < ascending[1]['position'][0]
    centroid = _until_success(pcl, cloud_pub, scene_cloud(BOXES), ref_frame='px100/base_link',
                              num_samples=1, is_parallel=False)
    assert all(0.0 < c['position'][2] < 0.03 for c in centroid)   # below the tops


def test_unknown_frame_and_no_clusters_fail_with_the_reason(env):
    pcl, cloud_pub, node = env
    _until_success(pcl, cloud_pub, scene_cloud(BOXES), num_samples=1)
    assert pcl.get_cluster_positions(ref_frame='nowhere', num_samples=1) == (False, [])
    pcl.set_z_filter_min(0.65)           # above the table: nothing left
    try:
        assert pcl.get_cluster_positions(num_samples=1) == (False, [])
    finally:
        pcl.z_filter_min = 0.25


def test_filter_parameters_refused_kept_sent_saved_and_loaded(env, tmp_path):
    pcl, cloud_pub, node = env
    assert pcl.get_x_filter_min() == pytest.approx(-0.25)
    pcl.x_filter_min = 0.5               # above x_filter_max: refused, nothing sent
    assert pcl.x_filter_min == pytest.approx(-0.25)
    pcl.cluster_min_size = 10 ** 6       # above cluster_max_size: refused
    assert pcl.cluster_min_size == 50
    two = _until_success(pcl, cloud_pub, scene_cloud(BOXES), num_samples=1)
    pcl.cluster_min_size = min(c['num_points'] for c in two) + 1
    one = _until_success(pcl, cloud_pub, scene_cloud(BOXES), num_samples=1)
    assert len(one) == 1
    path = str(tmp_path / 'filter_params.yaml')
    pcl.save_params(path)
    pcl.cluster_min_size = 50
    assert len(_until_success(pcl, cloud_pub, scene_cloud(BOXES), num_samples=1)) == 2
    pcl.load_params(path)
    assert pcl.params['cluster_min_size'] == min(c['num_points'] for c in two) + 1
    assert len(_until_success(pcl, cloud_pub, scene_cloud(BOXES), num_samples=1)) == 1
    pcl.load_params()                    # the package's defaults
    assert pcl.params['cluster_min_size'] == 50 and pcl.get_filepath().endswith(
        'config/filter_params.yaml')
    pcl.enable_pipeline(False)           # on demand: still answers
    try:
        assert len(_until_success(pcl, cloud_pub, scene_cloud(BOXES), num_samples=2)) == 2
    finally:
        pcl.enable_pipeline(True)
    assert node.alive(), node.output()
