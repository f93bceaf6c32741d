"""Test-side helpers of the pc_filter tests: synthetic scenes as PointCloud2, a service client."""
import math
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
from interbotix_perception_msgs.srv import ClusterInfoArray, FilterParams
import numpy as np
from px100_control.perception.cloud_filter import FilterParams as Params
from px100_control.ros.pc_filter_messages import cloud_message, request_of_params
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header
from std_srvs.srv import SetBool
from test_cloud_filter import _scene

#: the camera's optical frame of the px100 (the camera node's name for it)
CAMERA_FRAME = 'px100/camera_color_optical_frame'
CLOUD_TOPIC = '/px100/camera/depth/color/points'
#: seconds a node process may take to come up on a loaded 2-core machine
STARTUP_TIMEOUT = 90.0


def scene_cloud(boxes, frame=CAMERA_FRAME, seed=0) -> PointCloud2:
    """Return the synthetic table-and-boxes scene of test_cloud_filter as a PointCloud2."""
    points, colors = _scene(boxes, seed=seed)
    return cloud_message(Header(frame_id=frame), points, colors)


def float32_scene(boxes, seed=0):
    """Return the scene's points as the cloud carries them (float32) and its colours."""
    points, colors = _scene(boxes, seed=seed)
    return points.astype(np.float32).astype(np.float64), colors


def wait_for(predicate, timeout: float, period: float = 0.02) -> bool:
    """Poll ``predicate`` until true or ``timeout`` [s]; return its last value."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period)
    return bool(predicate())


class PcClient(Node):
    """Publish clouds; call the pc_filter services; collect /diagnostics and objects clouds."""

    def __init__(self, **kwargs):
        super().__init__('test_pc_filter_client', **kwargs)
        self.lock = threading.Lock()
        self.diagnostics = []
        self.objects = 0
        self.last_objects = None
        self._probe, self._probe_sent = None, 0.0
        self.pub = self.create_publisher(PointCloud2, CLOUD_TOPIC, QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE))
        self.set_params = self.create_client(FilterParams, '/pc_filter/set_filter_params')
        self.get_clusters = self.create_client(ClusterInfoArray,
                                               '/pc_filter/get_cluster_positions')
        self.enable = self.create_client(SetBool, '/pc_filter/enable_pipeline')
        self.params = AsyncParameterClient(self, '/pc_filter/pointcloud_pipeline')
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, 50)
        self.create_subscription(PointCloud2, '/pc_filter/pointcloud/objects', self._on_objects,
                                 10)

    def _on_diag(self, msg):
        with self.lock:
            self.diagnostics.extend(s for s in msg.status if 'pointcloud_pipeline' in s.name)

    def _on_objects(self, msg):
        with self.lock:
            self.objects += 1
            self.last_objects = msg

    def ready(self) -> bool:
        """
        Return True once pc_filter's services and cloud are matched on both sides.

        A service is ready on the client's side before the server has discovered the client's
        response reader, and a response sent then is lost (CI: set_filter_params unanswered for
        20 s). The parameter client's endpoints were created after the service clients', and one
        participant's endpoints are announced in order: once pc_filter answers a parameter
        query, it knows the service clients' readers as well.
        """
        if not (all(c.service_is_ready() for c in (self.set_params, self.get_clusters,
                                                   self.enable))
                and self.pub.get_subscription_count() > 0):
            return False
        if self._probe is None or (not self._probe.done()
                                   and time.monotonic() - self._probe_sent > 2.0):
            self._probe = self.params.get_parameters(['use_sim_time'])
            self._probe_sent = time.monotonic()
        return self._probe.done()

    def call(self, client, request, timeout: float = 20.0):
        """Call a service (this node spins elsewhere); return the response."""
        fut = client.call_async(request)
        assert wait_for(fut.done, timeout), f'{client.srv_name}: no response in {timeout} s'
        return fut.result()

    def clusters(self):
        """Return the clusters get_cluster_positions answers now."""
        return list(self.call(self.get_clusters, ClusterInfoArray.Request()).clusters)

    def parameter(self, name: str):
        """Return the node's ROS parameter ``name`` (rcl_interfaces ParameterValue's value)."""
        fut = self.params.get_parameters([name])
        assert wait_for(fut.done, 20.0), f'get_parameters {name}: no answer'
        v = fut.result().values[0]
        return v.double_value if v.type == 3 else v.integer_value

    def set_parameter(self, name: str, value):
        """Set one ROS parameter of the node; return its SetParametersResult."""
        fut = self.params.set_parameters([Parameter(name, value=value)])
        assert wait_for(fut.done, 20.0), f'set_parameters {name}: no answer'
        return fut.result().results[0]

    def send_params(self, params: Params) -> None:
        """Call set_filter_params with every value of ``params``."""
        self.call(self.set_params, request_of_params(params))

    def send_raw_params(self, **values) -> None:
        """Call set_filter_params with the defaults changed by ``values`` (unchecked)."""
        req = request_of_params(Params())
        for name, value in values.items():
            setattr(req, name, value)
        self.call(self.set_params, req)

    def clusters_after(self, cloud: PointCloud2, count: int, timeout: float = 30.0):
        """Publish ``cloud`` until get_cluster_positions answers ``count`` clusters."""
        found = []

        def seen():
            self.pub.publish(cloud)
            found[:] = self.clusters()
            return len(found) == count
        assert wait_for(seen, timeout, period=0.2), f'{len(found)} clusters, not {count}'
        return found


def close(a, b, tol):
    """Return True when the points a and b (x, y) are within tol [m]."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) <= tol
