"""
The ik_service's ROS services: ``compute_ik`` and ``compute_cartesian_path``.

Services (relative to ``/<robot_name>``; px100_control_msgs, ``interfaces/``):

- ``compute_ik`` (ComputeIK): one target pose, checked, solved and worded by
  :func:`px100_control.control.ik_requests.ik_answer`. ``target.header.frame_id``
  empty or the base frame; an all-zero quaternion means position-only IK; ``orientation_mode``
  'pitch', 'strict' or '' (the node's parameter); ``seed`` [rad] empty (the measured state) or
  one finite value per arm joint. The response's ``solution`` carries the arm joint names, the
  request's stamp and the solution closest to the seed (no position when ``success`` is false);
  ``message`` is 'solved' or why not.
- ``compute_cartesian_path`` (ComputeCartesianPath): one point per waypoint, each seeded by the
  previous one (no branch jumps), ``time_from_start`` from the current joint state so no joint
  exceeds ``max_path_joint_velocity`` nor its URDF velocity limit, points at least
  ``min_path_point_time`` apart (the trajectory can be sent as a FollowJointTrajectory goal as
  is); ``trajectory`` (stamp zero: start on receipt) holds the points solved before a failing
  waypoint, ``message`` says which waypoint failed and why.

Bad input returns ``success`` false with the reason; nothing raises into the executor. Both
services keep up to ``SERVICE_QOS.depth`` requests queued (the default 10 drops calls when
many clients fire at once; a client firing bursts needs as deep a QoS of its own). Both
services publish introspection events (``<service>/_service_event``, contents included) so a
recorder sees every request and reply.
"""
from px100_control.control.ik_requests import (ik_answer, path_targets, plan_path,
                                               request_mode, request_seed)
from px100_control.errors import InvalidInputError
from px100_control.ros.action_events import EVENT_QOS
from px100_control.ros.common import robot_topic
from px100_control_msgs.srv import ComputeCartesianPath, ComputeIK
from rclpy.duration import Duration
from rclpy.qos import qos_profile_services_default, QoSProfile
from rclpy.service_introspection import ServiceIntrospectionState
from trajectory_msgs.msg import JointTrajectoryPoint

#: the services' QoS: reliable and deep, so bursts from many clients lose no request
SERVICE_QOS = QoSProfile(depth=1000, reliability=qos_profile_services_default.reliability,
                         durability=qos_profile_services_default.durability)


def pose_values(pose) -> tuple:
    """Return (x, y, z, qx, qy, qz, qw) of a geometry_msgs/Pose."""
    p, o = pose.position, pose.orientation
    return p.x, p.y, p.z, o.x, o.y, o.z, o.w


class IkServices:
    """
    Serve ``compute_ik`` and ``compute_cartesian_path`` for an IkServiceNode.

    The node provides ``model``, ``_names``, ``_mode``, ``_nominal``,
    ``_kwargs``, ``_orientation_tol``, ``_seed()``, ``_target(frame, values)`` and its path
    parameters.
    """

    def __init__(self, node):
        self._node = node
        self.ik = node.create_service(ComputeIK, robot_topic(node, 'compute_ik'), self._on_ik,
                                      qos_profile=SERVICE_QOS)
        self.path = node.create_service(ComputeCartesianPath,
                                        robot_topic(node, 'compute_cartesian_path'),
                                        self._on_path, qos_profile=SERVICE_QOS)
        for service in (self.ik, self.path):
            service.configure_introspection(node.get_clock(), EVENT_QOS,
                                            ServiceIntrospectionState.CONTENTS)

    def _on_ik(self, request, response):
        n = self._node
        response.solution.name = list(n._names)
        response.solution.header.stamp = request.target.header.stamp
        try:
            mode = request_mode(request.orientation_mode, n._mode)
            T, kind = n._target(request.target.header.frame_id, pose_values(request.target.pose))
            seed = request_seed(request.seed, n.model.dof, None)
            ans = ik_answer(n.model, T, kind if kind == 'position' else mode,
                            n._seed() if seed is None else seed, n._nominal, n._kwargs,
                            n._orientation_tol)
        except InvalidInputError as exc:
            return self._refused(response, f'invalid request: {exc}')
        except Exception as exc:  # noqa: B902 - a request must never stop the node
            n.get_logger().error(f'compute_ik: internal error {exc!r}')
            return self._refused(response, f'internal error: {exc!r}')
        response.success, response.message = ans.ok, ans.message
        if ans.q is not None:
            response.solution.position = ans.q
        return _fill_result(response, ans.result)

    def _refused(self, response, message: str):
        self._node.get_logger().warning(f'compute_ik: {message}', throttle_duration_sec=1.0)
        response.success, response.message = False, message
        return response

    def _on_path(self, request, response):
        n = self._node
        response.trajectory.joint_names = list(n._names)
        try:
            plan = self._plan(request)
        except InvalidInputError as exc:
            response.message = f'invalid path request: {exc}'
        except Exception as exc:  # noqa: B902 - a request must never stop the node
            n.get_logger().error(f'compute_cartesian_path: internal error {exc!r}')
            response.message = f'internal error: {exc!r}'
        else:
            response.trajectory.points = [
                JointTrajectoryPoint(positions=q, time_from_start=Duration(seconds=t).to_msg())
                for q, t in plan.points]
            response.success, response.message = plan.ok, plan.message
        if not response.success:
            n.get_logger().warning(f'compute_cartesian_path: {response.message}')
        return response

    def _plan(self, request):
        """Return the PathReply of a path request; raise InvalidInputError on bad input."""
        n = self._node
        frame = request.waypoints.header.frame_id
        mode = request_mode(request.orientation_mode, n._mode)
        targets, kind = path_targets([pose_values(p) for p in request.waypoints.poses],
                                     lambda pose: n._target(frame, pose))
        return plan_path(n.model, targets, kind if kind == 'position' else mode, n._seed(),
                         n._nominal, n._kwargs, n.get_parameter('max_path_joint_velocity').value,
                         n.get_parameter('min_path_point_time').value)


def _fill_result(response, res):
    """Copy the solver's figures into the response (branches: closed forms only, else 0)."""
    if res is not None:
        response.method = str(res.method)
        response.iterations = int(res.iterations)
        response.position_error = float(res.position_error)
        response.orientation_error = float(res.orientation_error)
        response.num_solutions = (len(res.solutions) if res.method.startswith('analytic')
                                  else 0)
    return response
