"""
The camera in the viewer: its image, its frustum and pc_filter's clusters, in a real browser.

sim_driver, camera and pc_filter run as the installed executables (pick_place scene, arm at
sleep); the viewer node runs in this process (its page objects are inspected) and a headless
Chromium opens its page. The truths are independent of the viewer: the camera's pose from the
scene file's CameraSpec, the clusters from pc_filter's get_cluster_positions reply.
"""
from interbotix_perception_msgs.srv import ClusterInfoArray
import numpy as np
from px100_control.models.registry import load_robot
from px100_control.perception.camera import transform_points
from px100_control.sim.scene import load_scene
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from viewer_support import open_page, PORT_BASE, VIEWPORT, wait_for, wait_http

pytestmark = pytest.mark.ros

CAMERA = load_scene('pick_place', load_robot('px100')).camera
STARTUP = 120.0
#: the page's GUI image of the camera: its pixels read back through a canvas (every 4th)
READ_IMAGE = """() => {
  const img = [...document.querySelectorAll('img')].find(
      i => i.naturalWidth === 320 && i.naturalHeight === 240);
  if (!img) return null;
  const c = document.createElement('canvas');
  c.width = 320; c.height = 240;
  const g = c.getContext('2d');
  g.drawImage(img, 0, 0);
  const d = g.getImageData(0, 0, 320, 240).data, out = [];
  for (let k = 0; k < d.length; k += 16) out.push(d[k], d[k + 1], d[k + 2]);
  return out;
}"""


def _viewer(ctx, name: str, port: int):
    from px100_control.ros.viewer_node import ViewerNode
    return ViewerNode(context=ctx, parameter_overrides=[
        Parameter('robot_name', value=name), Parameter('port', value=port),
        Parameter('read_only', value=True)])


def test_image_frustum_and_clusters_on_the_page(rclpy_context, spin_node, node_process,
                                                browser):
    """The page shows the camera's frame (not blank), its frustum and the filter's clusters."""
    client = Node('viewer_camera_test', context=rclpy_context)
    clusters_cli = client.create_client(ClusterInfoArray, '/pc_filter/get_cluster_positions')
    procs = [node_process(name) for name in ('sim_driver', 'camera', 'pc_filter')]
    viewer = _viewer(rclpy_context, 'px100', PORT_BASE + 30)
    spin_node(client, viewer)
    view = viewer.camera.view
    assert wait_http(viewer.url, 30.0)
    page = open_page(browser, viewer.url, STARTUP)
    try:
        assert wait_for(lambda: view.images_sent >= 2, STARTUP), [p.output() for p in procs]
        image = view.image
        assert image.shape == (240, 320, 3)
        assert float(image.std()) > 10.0                  # a scene, not a blank frame
        assert wait_for(lambda: page.evaluate(READ_IMAGE) is not None, 30.0), 'no image'
        shown = np.asarray(page.evaluate(READ_IMAGE), dtype=float).reshape(-1, 3)
        assert shown.std() > 10.0                         # the browser drew the frame
        assert np.abs(shown.mean(axis=0) - image.reshape(-1, 3).mean(axis=0)).max() < 25.0
        assert 'Camera' in page.inner_text('body')
        assert wait_for(lambda: view.frustum_pose() is not None, 30.0), 'no frustum'
        position, wxyz = view.frustum_pose()
        assert np.allclose(position, CAMERA.position, atol=1e-4), position
        w, x, y, z = wxyz                                 # its optical axis is the camera's
        axis = np.array([2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)])
        assert np.allclose(axis, CAMERA.optical_rotation()[:, 2], atol=1e-4)

        assert clusters_cli.wait_for_service(timeout_sec=STARTUP)
        fut = clusters_cli.call_async(ClusterInfoArray.Request())   # runs the filter once
        assert wait_for(fut.done, 60.0), procs[2].output()
        found = fut.result().clusters
        assert len(found) >= 3, procs[2].output()       # the objects (and parts of the arm)
        truth = transform_points(CAMERA.optical_pose(),
                                 np.array([[c.position.x, c.position.y, c.position.z]
                                           for c in found]))
        assert wait_for(lambda: len(view.clusters) == len(found), 10.0), view.clusters
        for (xyz, rgb), c, t in zip(list(view.clusters), found, truth):
            assert np.linalg.norm(np.subtract(xyz, t)) < 0.005, (xyz, t)
            assert np.allclose(rgb, (c.color.r, c.color.g, c.color.b), atol=1.0)
        assert viewer.guard.faults == 0, viewer.guard.last
        assert all(p.alive() for p in procs)
    finally:
        page.close()


def test_no_camera_no_panel_no_error(rclpy_context, spin_node, browser):
    """A viewer without a camera: the page opens, no Camera panel, no frustum, no fault."""
    viewer = spin_node(_viewer(rclpy_context, 'px100_nocam', PORT_BASE + 31))
    assert wait_http(viewer.url, 30.0)
    page = browser.new_page(viewport=VIEWPORT)
    try:
        page.goto(viewer.url)
        page.wait_for_selector('text=state', timeout=60000)
        assert wait_for(lambda: viewer.camera.ticks >= 4, 30.0), 'the camera timer never ran'
        assert not viewer.camera.view.shown and viewer.camera.view.frustum_pose() is None
        assert page.evaluate(READ_IMAGE) is None and 'colour' not in page.inner_text('body')
        assert viewer.guard.faults == 0, viewer.guard.last
    finally:
        page.close()
