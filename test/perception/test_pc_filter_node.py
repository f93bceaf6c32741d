"""
The pc_filter node (``pointcloud_pipeline`` in ``/pc_filter``) over DDS, fed synthetic clouds.

The installed node runs as a process; the test publishes the synthetic scenes of
test_cloud_filter (a table 0.6 m from the camera, boxes on it) as PointCloud2 on the px100's
camera topic and calls Interbotix's three services.
"""
import math
import threading

import numpy as np
from pc_support import (CAMERA_FRAME, close, float32_scene, PcClient, scene_cloud,
                        STARTUP_TIMEOUT, wait_for)
from px100_control.perception.cloud_filter import FilterParams, run_pipeline
from px100_control.ros.pc_filter_messages import (cloud_arrays, params_of_request,
                                                  request_of_params)
import pytest
from rclpy.executors import SingleThreadedExecutor
from std_srvs.srv import SetBool

pytestmark = pytest.mark.ros

TWO_BOXES = [(0.05, 0.03, 0.03, 0.03), (-0.06, -0.04, 0.025, 0.025)]
#: the defaults as the node holds them after a set_filter_params (float32 on the wire)
DEFAULTS = params_of_request(request_of_params(FilterParams()))


@pytest.fixture(scope='module')
def env():
    """Start pc_filter and a test client (spun in a thread) once for the module."""
    rclpy = pytest.importorskip('rclpy')
    from px100_control.tools.processes import NodeProcess
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    client = PcClient(context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(client)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    node = NodeProcess('pc_filter')
    try:
        assert wait_for(client.ready, STARTUP_TIMEOUT), node.output()
        yield client, node
    finally:
        node.stop()
        executor.shutdown(timeout_sec=2.0)
        thread.join(timeout=5.0)
        client.destroy_node()
        ctx.try_shutdown()
        assert not node.killed, node.output()


@pytest.fixture
def fresh(env):
    """Start each test with the defaults and the pipeline enabled; check the node survived."""
    client, node = env
    client.send_params(FilterParams())
    client.call(client.enable, SetBool.Request(data=True))
    yield client, node
    assert node.alive(), node.output()


def test_clusters_of_a_published_cloud_within_2_mm(fresh):
    client, node = fresh
    found = client.clusters_after(scene_cloud(TWO_BOXES), 2)
    points, colors = float32_scene(TWO_BOXES)
    expected = run_pipeline(points, colors, DEFAULTS, np.random.default_rng(0)).clusters
    for info, box, ref in zip(found, TWO_BOXES, expected):
        assert info.frame_id == CAMERA_FRAME
        p = (info.position.x, info.position.y, info.position.z)
        assert close(p, box, 0.002), (p, box)
        np.testing.assert_allclose(p, ref.position, atol=1e-6)
        assert info.num_points == ref.num_points
        np.testing.assert_allclose((info.color.r, info.color.g, info.color.b), ref.color,
                                   atol=1e-3)
        assert info.min_z_point.z == pytest.approx(0.6 - box[3], abs=0.003)
        assert info.yaw == 0.0
    assert wait_for(lambda: client.last_objects is not None, 10.0)
    objects, rgb = cloud_arrays(client.last_objects)        # the boxes' points, their colours
    assert len(objects) == sum(c.num_points for c in found)
    assert {tuple(c) for c in rgb} == {(220, 30, 30), (30, 200, 60)}


def test_cluster_position_top_face_reports_each_top_face_centre(fresh):
    """cluster_position:=top_face (not upstream): the position is the top face's centre."""
    client, node = fresh
    points, colors = float32_scene(TWO_BOXES)
    expected = run_pipeline(points, colors, DEFAULTS, np.random.default_rng(0)).clusters
    assert client.set_parameter('cluster_position', 'top_face').successful
    try:
        found = client.clusters_after(scene_cloud(TWO_BOXES), 2)
        for info, ref in zip(found, expected):
            np.testing.assert_allclose((info.position.x, info.position.y, info.position.z),
                                       ref.top_centre, atol=1e-6)
        refused = client.set_parameter('cluster_position', 'middle')
        assert not refused.successful and 'cluster_position' in refused.reason, refused
    finally:
        assert client.set_parameter('cluster_position', 'centroid').successful
    p = client.clusters()[0].position
    np.testing.assert_allclose((p.x, p.y, p.z), expected[0].position, atol=1e-6)


def test_set_filter_params_changes_the_result(fresh):
    client, node = fresh
    found = client.clusters_after(scene_cloud(TWO_BOXES), 2)
    smaller = min(c.num_points for c in found)
    client.send_params(FilterParams(cluster_min_size=smaller + 1))
    after = client.clusters()          # same cloud, new parameters: recomputed on the call
    assert [c.num_points for c in after] == [max(c.num_points for c in found)]
    client.send_params(FilterParams(z_filter_min=0.61, z_filter_max=0.75))
    assert client.clusters() == []     # the crop box now holds nothing
    assert wait_for(lambda: 'no point inside the crop box' in node.output(), 10.0), \
        node.output()


def test_bad_parameter_set_is_refused_every_one_named_and_the_old_kept(fresh):
    client, node = fresh
    client.send_params(FilterParams(cluster_tol=0.015))
    before = client.clusters_after(scene_cloud(TWO_BOXES), 2)
    with client.lock:
        client.diagnostics.clear()
    client.send_raw_params(voxel_leaf_size=0.0, x_filter_min=0.3, x_filter_max=0.1,
                           plane_dist_thresh=math.nan, cluster_min_size=2000)
    assert wait_for(lambda: client.diagnostics, 10.0), 'no /diagnostics report'
    status = client.diagnostics[-1]
    assert status.level == b'\x02' and 'set_filter_params refused' in status.message
    for name in ('voxel_leaf_size', 'x_filter_min', 'plane_dist_thresh', 'cluster_min_size'):
        assert name in status.message, status.message
        assert name in node.output().split('set_filter_params refused')[-1]
    after = client.clusters()
    assert [(c.position.x, c.num_points) for c in after] == \
        [(c.position.x, c.num_points) for c in before]
    assert client.parameter('cluster_tol') == pytest.approx(0.015)   # the accepted set
    assert client.parameter('voxel_leaf_size') == pytest.approx(0.004)
    # ros2 param set is checked the same way: x_filter_min above x_filter_max is refused
    result = client.set_parameter('x_filter_min', 0.5)
    assert not result.successful and 'x_filter_min (0.5) must be below x_filter_max' in \
        result.reason, result.reason
    assert client.parameter('x_filter_min') == pytest.approx(-0.25)
    assert client.set_parameter('plane_max_iter', 0).successful is False


def test_pipeline_disabled_computes_on_demand_only(fresh):
    client, node = fresh
    client.clusters_after(scene_cloud(TWO_BOXES), 2)
    client.call(client.enable, SetBool.Request(data=False))
    one_box = scene_cloud([(0.0, 0.0, 0.03, 0.03)])
    with client.lock:
        start = client.objects
    calls = [0]

    def one_cluster():
        client.pub.publish(one_box)
        calls[0] += 1
        return len(client.clusters()) == 1
    assert wait_for(one_cluster, 30.0, period=0.2)
    # one pipeline run (one pointcloud/objects message) per get_cluster_positions, none per cloud
    assert wait_for(lambda: client.objects - start >= calls[0], 10.0)
    for _ in range(5):
        client.pub.publish(one_box)
    client.clusters()
    calls[0] += 1
    assert wait_for(lambda: client.objects - start >= calls[0], 10.0)
    # one output of the enabled pipeline may still be in flight when the disable's reply
    # comes (another topic); a pipeline run per cloud would add 5 more
    with client.lock:
        assert calls[0] <= client.objects - start <= calls[0] + 1, (client.objects - start,
                                                                    calls[0])


def test_empty_and_big_endian_clouds_give_no_clusters_with_the_reason(fresh):
    client, node = fresh
    client.clusters_after(scene_cloud(TWO_BOXES), 2)
    empty = scene_cloud([])
    empty.width, empty.row_step, empty.data = 0, 0, []
    client.clusters_after(empty, 0)
    assert wait_for(lambda: 'no clusters: no point inside the crop box' in node.output(), 10.0)
    client.clusters_after(scene_cloud(TWO_BOXES), 2)
    big = scene_cloud(TWO_BOXES)
    big.is_bigendian = True
    client.clusters_after(big, 0)
    assert wait_for(lambda: 'big-endian' in node.output(), 10.0), node.output()


def test_touching_objects_merge_into_one_cluster_as_the_real_filter_does(fresh):
    """Euclidean clustering joins points within cluster_tol: two touching boxes are one."""
    client, node = fresh
    merged = client.clusters_after(scene_cloud([(0.0, 0.0, 0.03, 0.03),
                                                (0.03, 0.0, 0.03, 0.02)]), 1)
    assert merged[0].position.x == pytest.approx(0.015, abs=0.006)
    client.send_params(FilterParams(cluster_tol=0.01))
    apart = client.clusters_after(scene_cloud([(0.0, 0.0, 0.03, 0.03),
                                               (0.06, 0.0, 0.03, 0.02)]), 2)
    assert sorted(round(c.position.x, 2) for c in apart) == [0.0, 0.06]


def test_cloud_subscription_is_reliable_by_default_and_best_effort_on_request(env):
    """
    The cloud reader is reliable by default, best effort with ``cloud_reliability``.

    A best-effort reader lost every 4.9 MB cloud under load; with
    ``cloud_reliability:=best_effort`` a pc_filter matches a best-effort camera and filters it.
    """
    from px100_control.ros.pc_filter_node import PcFilterNode
    from rclpy.executors import SingleThreadedExecutor as Executor
    from rclpy.parameter import Parameter
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import PointCloud2
    from interbotix_perception_msgs.srv import ClusterInfoArray
    client, _ = env
    readers = client.get_subscriptions_info_by_topic('/px100/camera/depth/color/points')
    assert [r.qos_profile.reliability for r in readers if r.node_name == 'pointcloud_pipeline'] \
        == [ReliabilityPolicy.RELIABLE]
    topic = '/test_best_effort/points'
    node = PcFilterNode(namespace='/pc_best_effort', context=client.context,
                        parameter_overrides=[Parameter('cloud_topic', value=topic),
                                             Parameter('cloud_reliability', value='best_effort'),
                                             Parameter('enable_pipeline', value=True)])
    executor = Executor(context=client.context)
    executor.add_node(node)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    pub = client.create_publisher(PointCloud2, topic, QoSProfile(
        depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
    get = client.create_client(ClusterInfoArray, '/pc_best_effort/get_cluster_positions')
    try:
        assert wait_for(lambda: pub.get_subscription_count() > 0 and get.service_is_ready(),
                        STARTUP_TIMEOUT), 'the best-effort pc_filter never matched'
        cloud, found = scene_cloud(TWO_BOXES), []

        def two_clusters():
            pub.publish(cloud)
            found[:] = client.call(get, ClusterInfoArray.Request()).clusters
            return len(found) == 2
        assert wait_for(two_clusters, 30.0, period=0.2), f'{len(found)} clusters, not 2'
    finally:
        executor.shutdown(timeout_sec=2.0)
        thread.join(timeout=5.0)
        client.destroy_publisher(pub)
        client.destroy_client(get)
        node.destroy_node()
