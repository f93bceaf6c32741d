"""
pc_filter: Interbotix's point-cloud filter node (``pointcloud_pipeline``) on numpy.

Node ``pointcloud_pipeline`` in namespace ``/pc_filter`` (Interbotix's ``pc_filter.launch.py``
with its default ``filter_ns``; ``-r __ns:=/other`` moves it), so Interbotix's
``InterbotixPointCloudInterface`` finds its services at ``/pc_filter/...``:

- subscribes ``cloud_topic`` (sensor_msgs/PointCloud2, keep last 1, reliable or
  ``cloud_reliability:=best_effort``; default ``/<robot_name>/camera/depth/color/points``);
- ``set_filter_params`` (interbotix_perception_msgs/FilterParams): all 14 parameters at once.
  A set with a wrong value (out of the schema's range, a min not below its max, NaN,
  cluster_min_size above cluster_max_size) is refused as a whole, every wrong one named in the
  log and on ``/diagnostics`` (ERROR); the previous parameters stay. The response is empty, as
  upstream. An accepted set updates the node's ROS parameters (``ros2 param get`` shows it)
  and reports OK on ``/diagnostics``;
- ``get_cluster_positions`` (ClusterInfoArray): the clusters of the latest cloud (centroid,
  mean colour 0..255, the point of least z, point count; ``frame_id`` the cloud's frame),
  largest first. With the parameter ``cluster_position:=top_face`` (not upstream; default
  ``centroid``) the position is the centre of the cluster's top face instead
  (:func:`px100_control.perception.cloud_filter.top_face_centre`). Computed on demand when
  the pipeline is disabled or the parameters changed since the last run; an empty list when
  no cloud came yet, the cloud is empty or unreadable, or nothing is left in a stage (the
  reason logged, throttled);
- ``enable_pipeline`` (std_srvs/SetBool): filter every cloud on arrival, or only on demand;
- publishes ``pointcloud/filtered`` (after crop box + voxel grid), ``pointcloud/objects``
  (after plane and outlier removal), ``markers/objects`` (a sphere per cluster) and
  ``markers/crop_box``, as upstream.

Parameters: :data:`px100_control.parameters.PC_FILTER` (Interbotix's names and defaults, with
ranges; ``ros2 param set`` is checked the same way). The pipeline:
:func:`px100_control.perception.cloud_filter.run_pipeline`. Services publish introspection
events (``<service>/_service_event``).
"""
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from interbotix_perception_msgs.srv import ClusterInfoArray
from interbotix_perception_msgs.srv import FilterParams as FilterParamsSrv
import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.parameters import PC_FILTER
from px100_control.perception.cloud_filter import FilterParams, params_error, run_pipeline
from px100_control.ros.action_events import EVENT_QOS
from px100_control.ros.common import spin_node
from px100_control.ros.parameter_schema import declare_schema
from px100_control.ros.pc_filter_messages import (cloud_arrays, cloud_message, cluster_infos,
                                                  crop_box_marker, object_markers, PARAM_NAMES,
                                                  params_of_request)
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.service_introspection import ServiceIntrospectionState
from sensor_msgs.msg import PointCloud2
from std_srvs.srv import SetBool
from visualization_msgs.msg import Marker

NODE_NAME = 'pointcloud_pipeline'
NAMESPACE = '/pc_filter'
#: the camera's cloud, newest only, by the ``cloud_reliability`` parameter. Reliable by
#: default: a best-effort reader of a reliable 4.9 MB cloud lost every cloud under load
CLOUD_RELIABILITY = {'reliable': ReliabilityPolicy.RELIABLE,
                     'best_effort': ReliabilityPolicy.BEST_EFFORT}


def cloud_qos(reliability: str) -> QoSProfile:
    """Return the cloud subscription's QoS: keep last 1, ``reliability`` ('reliable'...)."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                      reliability=CLOUD_RELIABILITY[reliability])


#: the same no-cluster reason is logged at most once per this period [s]
REASON_PERIOD = 5.0


def default_cloud_topic(robot_name: str) -> str:
    """Return the camera cloud of robot ``robot_name`` ('' -> ``/camera/...``)."""
    name = robot_name.strip('/')
    return f'/{name}/camera/depth/color/points' if name else '/camera/depth/color/points'


class PcFilterNode(Node):
    """Filter the camera's cloud into object clusters; Interbotix's services and topics."""

    def __init__(self, **node_kwargs):
        node_kwargs.setdefault('namespace', NAMESPACE)
        super().__init__(NODE_NAME, **node_kwargs)
        declare_schema(self, PC_FILTER, skip=())
        self.add_on_set_parameters_callback(self._check_together)
        self._params = self._read_params()
        error = params_error(self._params)
        if error:
            raise InvalidInputError(f'pointcloud_pipeline parameters: {error}')
        self.add_post_set_parameters_callback(lambda params: self._reload())
        self._enabled = bool(self.get_parameter('enable_pipeline').value)
        self._top_face = self.get_parameter('cluster_position').value == 'top_face'
        self._topic = (str(self.get_parameter('cloud_topic').value)
                       or default_cloud_topic(str(self.get_parameter('robot_name').value)))
        self._cloud = None
        self._stale = True
        self._infos = []
        self._last_reason = ('', 0.0)
        self._pub_filtered = self.create_publisher(PointCloud2, 'pointcloud/filtered', 1)
        self._pub_objects = self.create_publisher(PointCloud2, 'pointcloud/objects', 1)
        self._pub_markers = self.create_publisher(Marker, 'markers/objects', 50)
        self._pub_crop = self.create_publisher(Marker, 'markers/crop_box', 1)
        self._pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.create_subscription(PointCloud2, self._topic, self._on_cloud,
                                 cloud_qos(self.get_parameter('cloud_reliability').value))
        for srv, name, callback in ((FilterParamsSrv, 'set_filter_params', self._on_set_params),
                                    (ClusterInfoArray, 'get_cluster_positions',
                                     self._on_get_clusters),
                                    (SetBool, 'enable_pipeline', self._on_enable)):
            service = self.create_service(srv, name, callback)
            service.configure_introspection(self.get_clock(), EVENT_QOS,
                                            ServiceIntrospectionState.CONTENTS)
        self.get_logger().info(f'pointcloud_pipeline ready: filtering {self._topic} '
                               f'(pipeline {"enabled" if self._enabled else "on demand"})')

    # ------------------------------------------------------------------ parameters
    def _read_params(self, changes=()) -> FilterParams:
        """Return the FilterParams of the node's parameters, ``changes`` applied."""
        values = {n: self.get_parameter(n).value for n in PARAM_NAMES}
        values.update({p.name: p.value for p in changes if p.name in values})
        return FilterParams(**values)

    def _check_together(self, params) -> SetParametersResult:
        """Refuse a set whose values are wrong together (min >= max...), naming every one."""
        error = params_error(self._read_params(params))
        return SetParametersResult(successful=error is None, reason=error or '')

    def _reload(self) -> None:
        self._params = self._read_params()
        self._enabled = bool(self.get_parameter('enable_pipeline').value)
        self._top_face = self.get_parameter('cluster_position').value == 'top_face'
        self._stale = True

    # ------------------------------------------------------------------ services
    def _on_set_params(self, request, response):
        params = params_of_request(request)
        error = params_error(params)
        if error is None:
            result = self.set_parameters([Parameter(n, value=getattr(params, n))
                                          for n in PARAM_NAMES])
            error = '; '.join(r.reason for r in result if not r.successful) or None
        if error:
            self.get_logger().error(f'set_filter_params refused, previous parameters kept: '
                                    f'{error}')
            self._diagnose(DiagnosticStatus.ERROR, f'set_filter_params refused: {error}')
        else:
            self._diagnose(DiagnosticStatus.OK, 'filter parameters set')
        return response

    def _on_get_clusters(self, request, response):
        if not self._enabled or self._stale:
            self._run()
        response.clusters = list(self._infos)
        return response

    def _on_enable(self, request, response):
        self.set_parameters([Parameter('enable_pipeline', value=bool(request.data))])
        response.success = True
        response.message = f'pipeline {"enabled" if request.data else "on demand"}'
        return response

    def _diagnose(self, level: int, message: str) -> None:
        status = DiagnosticStatus(level=level, name=self.get_fully_qualified_name(),
                                  message=message)
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        self._pub_diag.publish(msg)

    # ------------------------------------------------------------------ pipeline
    def _on_cloud(self, msg: PointCloud2) -> None:
        self._cloud = msg
        self._stale = True
        if self._enabled:
            self._run()

    def _run(self) -> None:
        """Filter the latest cloud; keep its clusters (empty with a logged reason)."""
        self._stale = False
        msg = self._cloud
        if msg is None:
            return self._empty(f'no cloud received yet on {self._topic}')
        try:
            points, colors = cloud_arrays(msg)
        except InvalidInputError as exc:
            return self._empty(f'cloud refused: {exc}')
        result = run_pipeline(points, colors, self._params, np.random.default_rng(0))
        header = msg.header
        if len(result.filtered):
            self._pub_filtered.publish(cloud_message(header, result.filtered,
                                                     result.filtered_rgb))
            self._pub_crop.publish(crop_box_marker(self._params, header))
        if len(result.objects):
            self._pub_objects.publish(cloud_message(header, result.objects,
                                                    result.objects_rgb))
        for marker in object_markers(result.clusters, header, self._top_face):
            self._pub_markers.publish(marker)
        self._infos = cluster_infos(result.clusters, header.frame_id, self._top_face)
        if result.reason or not result.clusters:
            self._empty(result.reason or 'no cluster within cluster_min_size..cluster_max_size',
                        clear=False)
        else:
            self._last_reason = ('', 0.0)

    def _empty(self, reason: str, clear: bool = True) -> None:
        """Log why there are no clusters: at once when the reason changes, else every 5 s."""
        if clear:
            self._infos = []
        now = time.monotonic()
        if reason != self._last_reason[0] or now - self._last_reason[1] >= REASON_PERIOD:
            self._last_reason = (reason, now)
            self.get_logger().warning(f'no clusters: {reason}')


def main(args=None) -> int:
    """Run the pointcloud_pipeline node until SIGINT/SIGTERM."""
    return spin_node(lambda options: PcFilterNode(), args,
                     'Interbotix point-cloud filter (pointcloud_pipeline in /pc_filter).',
                     schema=PC_FILTER)


if __name__ == '__main__':
    sys.exit(main())
