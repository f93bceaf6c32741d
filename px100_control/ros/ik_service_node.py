"""
ik_service: inverse kinematics as ROS services.

Services (docs/ros_interfaces.md, relative to ``/<robot_name>``; px100_control_msgs):
``compute_ik`` and ``compute_cartesian_path`` (:mod:`px100_control.ros.ik_services`). A target
is in ``<robot_name>/base_link`` (``frame_id`` empty or ``base_link`` accepted too); an
all-zero quaternion means "orientation free": position-only IK, the free angles chosen toward
``nominal_pose``. A solution is the one closest to the seed (the last measured ``joint_states``;
``nominal_pose`` before any state arrived).

Parameters: ``orientation_mode`` 'pitch' (solve position + pitch, report the roll/yaw a
4/5-DOF arm cannot reach; a residual above ``orientation_tolerance`` [rad] is named in the
message) or 'strict' (the whole pose or nothing); ``method`` ('auto' analytic where the robot
has one, iterative otherwise or as a fallback); ``tol_position`` [m], ``tol_orientation``
[rad], ``max_iterations``; ``nominal_pose`` (default: the model's home pose);
``max_path_joint_velocity`` [rad/s] and ``min_path_point_time`` [s] time Cartesian paths.
The IK itself is :func:`px100_control.kinematics.solve.solve_ik` / ``solve_path`` (closed
forms first on plain floats, the iterative search only where needed). The node spins
single-threaded.
"""
import sys
import threading

import numpy as np
from px100_control.control.ik_requests import MODES, parameter_error
from px100_control.errors import InvalidInputError
from px100_control.parameters import IK_SERVICE
from px100_control.ros.common import (declare_robot_parameters, frame_id, init_robot_node,
                                      robot_topic, spin_node)
from px100_control.ros.conversions import pose_values_to_matrix
from px100_control.ros.ik_services import IkServices
from px100_control.ros.parameter_schema import declare_schema
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState

NODE_NAME = 'ik_service'

__all__ = ['IkServiceNode', 'main']


class IkServiceNode(Node):
    """Serve compute_ik and compute_cartesian_path with the IK of the robot model."""

    def __init__(self, **node_kwargs):
        init_robot_node(self, NODE_NAME, node_kwargs)
        self.model = declare_robot_parameters(self)
        declare_schema(self, IK_SERVICE,
                       defaults={'nominal_pose': [float(x) for x in self.model.home]})
        self.add_on_set_parameters_callback(self._check_parameters)
        bad = self._check_parameters([self.get_parameter(n) for n in IK_SERVICE.names
                                      if n not in ('robot_model', 'robot_name')]).reason
        if bad:
            raise InvalidInputError(f'ik_service parameters: {bad}')
        self._names = list(self.model.joint_names)
        self._index = {name: i for i, name in enumerate(self._names)}
        self._frames = ('', frame_id(self, self.model.base_frame), self.model.base_frame)
        self._lock = threading.Lock()
        self._meas = np.full(self.model.dof, np.nan)
        self._have_state = False
        self._js_names = None
        self._js_map = None
        self._load_parameters()
        self.add_post_set_parameters_callback(lambda params: self._load_parameters())
        self.create_subscription(JointState, robot_topic(self, 'joint_states'),
                                 self._on_joint_states, qos_profile_sensor_data)
        self._ik_services = IkServices(self)
        self.get_logger().info(
            f'ik_service ready: {self.model.name} ({self.model.dof} joints, analytic '
            f'{self.model.analytic_ik or "none"}), orientation_mode {self._mode_param}')

    # ------------------------------------------------------------------ parameters
    def _check_parameters(self, params) -> SetParametersResult:
        for p in params:
            error = parameter_error(p.name, p.value, self.model.dof)
            if error:
                return SetParametersResult(successful=False, reason=error)
        return SetParametersResult(successful=True)

    def _load_parameters(self) -> None:
        """Freeze the parameters into plain attributes (read on every request)."""
        get = self.get_parameter
        self._mode_param = str(get('orientation_mode').value)
        self._mode = MODES[self._mode_param]
        self._orientation_tol = float(get('orientation_tolerance').value)
        self._nominal = np.asarray(get('nominal_pose').value, float)
        self._kwargs = {'method': str(get('method').value),
                        'tol_position': float(get('tol_position').value),
                        'tol_orientation': float(get('tol_orientation').value),
                        'max_iterations': int(get('max_iterations').value)}

    # ------------------------------------------------------------------ inputs
    def _on_joint_states(self, msg: JointState) -> None:
        if msg.name != self._js_names:
            self._js_names = list(msg.name)
            self._js_map = [(i, self._index[x]) for i, x in enumerate(msg.name)
                            if x in self._index]
        pos = msg.position
        with self._lock:
            for i, j in self._js_map:
                if i < len(pos):
                    self._meas[j] = pos[i]
            self._have_state = not np.any(np.isnan(self._meas))

    def _seed(self) -> np.ndarray:
        """Return the current measured arm state, or the nominal pose before any arrived."""
        with self._lock:
            return self._meas.copy() if self._have_state else self._nominal

    def _target(self, frame: str, values):
        """Return (T, mode) of a request pose; raise InvalidInputError when it is malformed."""
        if frame not in self._frames:
            raise InvalidInputError(
                f"frame_id '{frame}' is not the base frame '{self._frames[1]}' "
                '(no tf lookup here: send targets in the base frame)')
        T, free = pose_values_to_matrix(values, allow_zero_quaternion=True)
        return T, ('position' if free else self._mode)


def main(args=None):
    """Run the ik_service node (``ros2 run px100_control ik_service``)."""
    return spin_node(lambda options: IkServiceNode(), args, schema=IK_SERVICE,
                     description='Inverse kinematics services of px100_control '
                                 '(compute_ik, compute_cartesian_path).')


if __name__ == '__main__':
    sys.exit(main())
