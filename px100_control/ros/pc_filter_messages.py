"""
The pc_filter node's messages: PointCloud2 <-> arrays, ClusterInfo, markers, FilterParams.

Thin conversions around :mod:`px100_control.perception.pointcloud2` (the byte codec) and
:mod:`px100_control.perception.cloud_filter` (the pipeline), shaped as Interbotix's
``pointcloud_pipeline`` fills them: ClusterInfo colours 0..255, object markers 1 cm spheres
with a 0.1 s lifetime, the crop box a translucent green cube. Frames: the cloud's; metres.
"""
from typing import List, Sequence

from builtin_interfaces.msg import Duration
from interbotix_perception_msgs.msg import ClusterInfo
from interbotix_perception_msgs.srv import FilterParams as FilterParamsSrv
import numpy as np
from px100_control.perception import pointcloud2
from px100_control.perception.cloud_filter import Cluster, FilterParams
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker

#: the filter parameters, in FilterParams.srv's order
PARAM_NAMES = tuple(FilterParamsSrv.Request.get_fields_and_field_types())
INT_PARAMS = ('plane_max_iter', 'ror_min_neighbors', 'cluster_min_size', 'cluster_max_size')


def cloud_arrays(msg: PointCloud2):
    """Return (points (N, 3) [m], colours (N, 3) 0..255) of a PointCloud2 (codec's refusals)."""
    fields = [(f.name, f.offset, f.datatype, f.count) for f in msg.fields]
    return pointcloud2.decode(fields, msg.point_step, bytes(msg.data), msg.width, msg.height,
                              msg.row_step, msg.is_bigendian)


def cloud_message(header: Header, points: np.ndarray, colors: np.ndarray) -> PointCloud2:
    """Return an unorganised XYZRGB PointCloud2 (PCL's layout) of ``points`` and ``colors``."""
    fields, step, data = pointcloud2.encode(points, colors)
    n = len(points)
    return PointCloud2(header=header, height=1, width=n, is_bigendian=False, point_step=step,
                       row_step=step * n, is_dense=True, data=data,
                       fields=[PointField(name=name, offset=off, datatype=dt, count=cnt)
                               for name, off, dt, cnt in fields])


def cluster_infos(clusters: Sequence[Cluster], frame: str,
                  top_face: bool = False) -> List[ClusterInfo]:
    """
    Return one ClusterInfo per cluster (yaw 0: not estimated, as upstream).

    :param top_face: the position is the cluster's top-face centre, not its centroid
    """
    out = []
    for c in clusters:
        info = ClusterInfo(frame_id=frame, num_points=int(c.num_points))
        info.position.x, info.position.y, info.position.z = (
            float(v) for v in (c.top_centre if top_face else c.position))
        info.min_z_point.x, info.min_z_point.y, info.min_z_point.z = (
            float(v) for v in c.min_z_point)
        info.color = ColorRGBA(r=float(c.color[0]), g=float(c.color[1]), b=float(c.color[2]),
                               a=0.0)
        out.append(info)
    return out


def object_markers(clusters: Sequence[Cluster], header: Header,
                   top_face: bool = False) -> List[Marker]:
    """Return the position spheres (1 cm, the cluster's colour, lifetime 0.1 s)."""
    out = []
    for k, c in enumerate(clusters):
        m = Marker(header=header, id=k, type=Marker.SPHERE, action=Marker.ADD,
                   lifetime=Duration(sec=0, nanosec=100_000_000))
        m.pose.position.x, m.pose.position.y, m.pose.position.z = (
            float(v) for v in (c.top_centre if top_face else c.position))
        m.pose.orientation.w = 1.0
        m.scale.x = m.scale.y = m.scale.z = 0.01
        m.color = ColorRGBA(r=c.color[0] / 255.0, g=c.color[1] / 255.0, b=c.color[2] / 255.0,
                            a=1.0)
        out.append(m)
    return out


def crop_box_marker(p: FilterParams, header: Header) -> Marker:
    """Return the translucent green cube of the crop box."""
    m = Marker(header=header, type=Marker.CUBE, action=Marker.ADD)
    m.pose.position.x = (p.x_filter_min + p.x_filter_max) / 2.0
    m.pose.position.y = (p.y_filter_min + p.y_filter_max) / 2.0
    m.pose.position.z = (p.z_filter_min + p.z_filter_max) / 2.0
    m.pose.orientation.w = 1.0
    m.scale.x = p.x_filter_max - p.x_filter_min
    m.scale.y = p.y_filter_max - p.y_filter_min
    m.scale.z = p.z_filter_max - p.z_filter_min
    m.color = ColorRGBA(r=0.0, g=1.0, b=0.0, a=0.3)
    return m


def params_of_request(request) -> FilterParams:
    """Return the FilterParams of a set_filter_params request (not checked)."""
    return FilterParams(**{name: (int(getattr(request, name)) if name in INT_PARAMS
                                  else float(getattr(request, name))) for name in PARAM_NAMES})


def request_of_params(p: FilterParams) -> FilterParamsSrv.Request:
    """Return a set_filter_params request holding ``p``."""
    return FilterParamsSrv.Request(**{name: getattr(p, name) for name in PARAM_NAMES})
