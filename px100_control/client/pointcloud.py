"""
InterbotixPointCloudInterface: Interbotix's perception API over the ``pc_filter`` node.

Same constructor, methods and properties as ``interbotix_perception_modules.pointcloud``
(humble/jazzy): the 14 filter parameters as ``get_<name>`` / ``set_<name>`` and properties,
``params`` (a dict), ``get_filepath``, ``enable_pipeline``, ``get_cluster_positions``,
``load_params`` and ``save_params``. It calls ``/<filter_ns>/set_filter_params``,
``get_cluster_positions`` and ``enable_pipeline`` (:mod:`px100_control.ros.pc_filter_node`).

``get_cluster_positions`` averages ``num_samples`` answers (a cluster matched to the first
answer's within ``cluster_tol`` on each axis), transforms them from the cloud's frame to
``ref_frame`` with the latest transforms of ``/tf`` and ``/tf_static`` (a pure buffer,
:mod:`px100_control.perception.tf_buffer`; no tf2_ros here), sorts them along ``sort_axis`` and
publishes them as ``cluster_<n>`` frames on ``/tf`` (as upstream). With ``is_parallel`` the z
of a position is the top of the cluster (its point nearest the camera), as upstream.

Differences from Interbotix (documented, on purpose):

- ``node_inf`` None: the client's global node is used (created if needed) and spun in its
  background thread, as the robot classes do; a Node or a core (``get_node()``) is accepted.
- A setter refuses a value that makes the set invalid (out of range, a min not below its
  max, NaN: :func:`px100_control.perception.cloud_filter.params_error`), logs why and keeps the
  previous value; nothing is sent. Move a crop box with ``params = {...}`` (all at once).
- The ``params`` setter and ``load_params`` also send the set to the node (upstream only
  stores it until the next single setter).
- Every call is bounded: services wait ``PX100_CONNECT_TIMEOUT`` (default 10 s) at construction
  (then :class:`InterbotixException` names the missing ones), a service answer 10 s.
- The filter parameters start at Interbotix's defaults (upstream reads ROS parameters of its
  own node); ``get_filepath()`` is the ``filter_params`` parameter of the node if declared,
  else the package's ``config/filter_params.yaml``.
"""
import threading
import time
from typing import List, Optional, Tuple

from geometry_msgs.msg import TransformStamped
from interbotix_perception_msgs.srv import ClusterInfoArray, FilterParams
import numpy as np
from px100_control.client.core import env_float
import px100_control.client.robot as _robot
from px100_control.client.robot import InterbotixException
from px100_control.errors import InvalidInputError
from px100_control.paths import data_path
from px100_control.perception.cloud_filter import FilterParams as Params
from px100_control.perception.tf_buffer import TfBuffer
from px100_control.ros.pc_filter_messages import INT_PARAMS, PARAM_NAMES
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_srvs.srv import SetBool
from tf2_msgs.msg import TFMessage
import yaml

#: /tf_static: latched, as tf2's static listener subscribes
TF_STATIC_QOS = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                           reliability=ReliabilityPolicy.RELIABLE)
#: longest wait for one service answer [s]
CALL_TIMEOUT = 10.0
#: how long get_cluster_positions waits for the transform to ref_frame [s] (upstream: 4 s)
TF_TIMEOUT = 4.0


def _node_of(node_inf) -> Node:
    """Return the rclpy Node of ``node_inf``: a Node, a core (get_node()) or None (global)."""
    if node_inf is None:
        return _robot.get_interbotix_global_node() or _robot.create_interbotix_global_node()
    if isinstance(node_inf, Node):
        return node_inf
    if hasattr(node_inf, 'get_node'):
        return node_inf.get_node()
    raise InterbotixException(f'node_inf must be an rclpy Node or a core, got {node_inf!r}')


class InterbotixPointCloudInterface:
    """API to tune filter parameters and get the positions of objects seen by the camera."""

    def __init__(self, filter_ns: str = 'pc_filter', node_inf=None, args=None):
        """
        Connect to the pc_filter node in ``/<filter_ns>``.

        :param filter_ns: namespace of the pointcloud_pipeline node and its services
        :param node_inf: the node to build on (None: the client's global node)
        :param args: unused (rclpy arguments of upstream's own node)
        :raises InterbotixException: a service is missing after PX100_CONNECT_TIMEOUT seconds
        """
        self.node_inf = _node_of(node_inf)
        self.filter_ns = filter_ns.strip('/')
        self.filter_params = FilterParams.Request()
        self._set_local(Params())
        self.param_filepath = self._default_filepath()
        self.tf_buffer = TfBuffer()
        node, ns = self.node_inf, f'/{self.filter_ns}'
        self.srv_set_params = node.create_client(FilterParams, f'{ns}/set_filter_params')
        self.srv_enable_pipeline = node.create_client(SetBool, f'{ns}/enable_pipeline')
        self.srv_get_cluster_positions = node.create_client(ClusterInfoArray,
                                                            f'{ns}/get_cluster_positions')
        self._subs = [node.create_subscription(TFMessage, '/tf', self._on_tf, 100),
                      node.create_subscription(TFMessage, '/tf_static', self._on_tf,
                                               TF_STATIC_QOS)]
        self._pub_tf = node.create_publisher(TFMessage, '/tf', 100)
        _robot.ensure_spinning(node)
        self._wait_for_services(env_float('PX100_CONNECT_TIMEOUT', 10.0))
        node.get_logger().info('Initialized InterbotixPointCloudInterface.')

    # ------------------------------------------------------------------ plumbing
    def _default_filepath(self) -> str:
        node = self.node_inf
        if node.has_parameter('filter_params'):
            return str(node.get_parameter('filter_params').value)
        return data_path('config', 'filter_params.yaml')

    def _wait_for_services(self, timeout: float) -> None:
        clients = (self.srv_set_params, self.srv_enable_pipeline,
                   self.srv_get_cluster_positions)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if all(c.service_is_ready() for c in clients):
                return
            time.sleep(0.05)
        missing = [c.srv_name for c in clients if not c.service_is_ready()]
        if missing:
            raise InterbotixException(f'point-cloud filter services not found after {timeout} '
                                      f's: {missing} (start it: ros2 run px100_control '
                                      'pc_filter)')

    def _on_tf(self, msg: TFMessage) -> None:
        for reason in self.tf_buffer.add_message(msg):
            self.node_inf.get_logger().warning(f'tf ignored: {reason}',
                                               throttle_duration_sec=5.0)

    def _call(self, client, request):
        """Call a service; return its response, or None (logged) after CALL_TIMEOUT."""
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        if not done.wait(CALL_TIMEOUT):
            client.remove_pending_request(future)
            self.node_inf.get_logger().error(f'{client.srv_name}: no answer in {CALL_TIMEOUT} s')
            return None
        return future.result()

    def _local(self) -> Params:
        return Params(**{n: getattr(self.filter_params, n) for n in PARAM_NAMES})

    def _set_local(self, p: Params) -> None:
        for name in PARAM_NAMES:
            value = getattr(p, name)
            setattr(self.filter_params, name, int(value) if name in INT_PARAMS else float(value))

    def _apply(self, **changes) -> bool:
        """Send the set with ``changes``; refuse (logged, nothing sent) an invalid one."""
        try:
            p = self._local().updated(**changes)
        except (InvalidInputError, TypeError, ValueError) as exc:
            self.node_inf.get_logger().error(f'filter parameters not changed: {exc}')
            return False
        self._set_local(p)
        return self._call(self.srv_set_params, self.filter_params) is not None

    # ------------------------------------------------------------------ parameters
    def get_params(self) -> dict:
        """Return the filter parameters as a dict (Interbotix's names; m, counts)."""
        return {name: getattr(self.filter_params, name) for name in PARAM_NAMES}

    def set_params(self, param_dict: dict) -> None:
        """Set every filter parameter from ``param_dict`` and send the set to the node."""
        missing = [n for n in PARAM_NAMES if n not in param_dict]
        if missing:
            self.node_inf.get_logger().error(f'filter parameters not changed: {missing} '
                                             'missing')
            return
        self._apply(**{n: (int(param_dict[n]) if n in INT_PARAMS else float(param_dict[n]))
                       for n in PARAM_NAMES})

    params = property(fget=get_params, fset=set_params)

    def get_filepath(self) -> str:
        """Return the YAML file load_params / save_params use by default."""
        return self.param_filepath

    def enable_pipeline(self, enable: bool) -> None:
        """Filter every cloud as it arrives (True) or only on get_cluster_positions (False)."""
        self._call(self.srv_enable_pipeline, SetBool.Request(data=bool(enable)))

    def load_params(self, filepath: Optional[str] = None) -> None:
        """Load the filter parameters from a YAML file (ROS params layout or flat) and send."""
        path = filepath or self.get_filepath()
        with open(path, encoding='utf-8') as f:
            data = yaml.safe_load(f) or {}
        self.set_params(_ros_parameters(data))

    def save_params(self, filepath: Optional[str] = None) -> None:
        """Save the filter parameters to a YAML file in the ROS params layout."""
        path = filepath or self.get_filepath()
        with open(path, 'w', encoding='utf-8') as f:
            yaml.safe_dump({'/**/pointcloud_pipeline': {
                'ros__parameters': self.get_params()}}, f)

    # ------------------------------------------------------------------ clusters
    def get_cluster_positions(self, num_samples: int = 5, period: float = 0.1,
                              ref_frame: Optional[str] = None, sort_axis: str = 'y',
                              reverse: bool = False, is_parallel: bool = True
                              ) -> Tuple[bool, List[dict]]:
        """
        Return (success, clusters) averaged over ``num_samples`` answers ``period`` s apart.

        :param ref_frame: frame of the returned positions (None: the cloud's frame)
        :param sort_axis: 'x', 'y' or 'z' of ref_frame (anything else: 'y', with a warning)
        :param reverse: sort descending
        :param is_parallel: z of each position is the top of its cluster (ref_frame parallel
            to the table)
        :return: (True, [{'name': 'cluster_<n>', 'position': [x, y, z] m, 'yaw': 0,
            'color': [r, g, b] 0..255, 'num_points': n}, ...]) or (False, []) with the reason
            logged
        """
        log = self.node_inf.get_logger()
        root = self._clusters()
        if not root:
            log.warning('No clusters found...')
            return False, []
        samples = self._samples(root, max(int(num_samples), 1), period)
        if samples is None:
            return False, []
        frame = root[0].frame_id
        T = np.eye(4)
        if ref_frame and ref_frame.lstrip('/') != frame.lstrip('/'):
            T = self.tf_buffer.wait_for(ref_frame, frame, TF_TIMEOUT)
            if T is None:
                log.error(f"Failed to look up the transform from '{ref_frame}' to '{frame}' "
                          f'(known frames: {self.tf_buffer.frames()}).')
                return False, []
        out = [_in_frame(c, T, is_parallel) for c in samples]
        axis = {'x': 0, 'y': 1, 'z': 2}.get(sort_axis)
        if axis is None:
            log.warning(f"'{sort_axis}' is not a valid sorting axis. Set the 'sort_axis' "
                        "argument to 'x', 'y', or 'z'. Defaulting to 'y'.")
            axis = 1
        out.sort(key=lambda c: c['position'][axis], reverse=reverse)
        for k, c in enumerate(out, 1):
            c['name'] = f'cluster_{k}'
        self._publish_frames(out, ref_frame or frame)
        return True, out

    def _clusters(self) -> list:
        response = self._call(self.srv_get_cluster_positions, ClusterInfoArray.Request())
        return [] if response is None else list(response.clusters)

    def _samples(self, root: list, num_samples: int, period: float) -> Optional[List[dict]]:
        """Return the mean of each root cluster over the samples, or None (logged)."""
        log, tol = self.node_inf.get_logger(), self.filter_params.cluster_tol
        sums = [np.zeros(10) for _ in root]
        for k in range(num_samples):
            clusters = self._clusters()
            if len(clusters) != len(root):
                log.warning(f'Found {len(clusters)} clusters instead of {len(root)} clusters...')
                return None
            free = list(range(len(root)))
            for c in clusters:
                p = np.array([c.position.x, c.position.y, c.position.z])
                match = [i for i in free if np.all(np.abs(_xyz(root[i].position) - p) < tol)]
                if not match:
                    log.warning('Could not match the cluster. Please tune the filter parameters '
                                "such that all spherical 'object markers' are constant in "
                                'their respective clusters and do not flicker.')
                    return None
                free.remove(match[0])
                sums[match[0]] += np.concatenate([p, _xyz(c.min_z_point),
                                                  [c.color.r, c.color.g, c.color.b,
                                                   c.num_points]])
            if k + 1 < num_samples and period > 0:
                time.sleep(period)
        return [{'position': s[0:3] / num_samples, 'min_z': s[3:6] / num_samples,
                 'color': list(s[6:9] / num_samples), 'num_points': int(round(s[9] / num_samples))}
                for s in sums]

    def _publish_frames(self, clusters: List[dict], frame: str) -> None:
        stamp = self.node_inf.get_clock().now().to_msg()
        msg = TFMessage()
        for c in clusters:
            t = TransformStamped(child_frame_id=c['name'])
            t.header.frame_id, t.header.stamp = frame, stamp
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = \
                c['position']
            t.transform.rotation.w = 1.0
            msg.transforms.append(t)
        self._pub_tf.publish(msg)


def _xyz(point) -> np.ndarray:
    return np.array([point.x, point.y, point.z])


def _in_frame(sample: dict, T: np.ndarray, is_parallel: bool) -> dict:
    """Return the upstream cluster dict of a mean sample, its position moved by T (4x4)."""
    p = T[:3, :3] @ sample['position'] + T[:3, 3]
    if is_parallel:
        p[2] = (T[:3, :3] @ sample['min_z'] + T[:3, 3])[2]
    return {'name': '', 'position': [float(v) for v in p], 'yaw': 0,
            'color': [float(v) for v in sample['color']], 'num_points': sample['num_points']}


def _ros_parameters(data: dict) -> dict:
    """Return the parameters of a ROS params YAML (the first ros__parameters) or a flat dict."""
    if not isinstance(data, dict):
        raise InterbotixException(f'filter parameter file holds {type(data).__name__}, not a '
                                  'mapping')
    if any(n in data for n in PARAM_NAMES):
        return data
    for value in data.values():
        if isinstance(value, dict):
            found = value.get('ros__parameters', None)
            if isinstance(found, dict):
                return found
            inner = _ros_parameters(value) if value else {}
            if inner:
                return inner
    return {}


def _make_accessors(name: str):
    def getter(self):
        return getattr(self.filter_params, name)

    def setter(self, value):
        self._apply(**{name: int(value) if name in INT_PARAMS else float(value)})
    getter.__doc__ = f'Return {name} (Interbotix filter parameter).'
    setter.__doc__ = f'Set {name} and send the set to the node (an invalid one is refused).'
    return getter, setter


for _name in PARAM_NAMES:
    _get, _set = _make_accessors(_name)
    setattr(InterbotixPointCloudInterface, f'get_{_name}', _get)
    setattr(InterbotixPointCloudInterface, f'set_{_name}', _set)
    setattr(InterbotixPointCloudInterface, _name, property(_get, _set))
del _name, _get, _set
