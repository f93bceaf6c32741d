"""
The simulated driver works for other robot models: their joints, limits and approximate dynamics.

Pure part: the ArmSimulator (MuJoCo model built from the robot's URDF; table robots' dynamics
from the generated URDF's approximate inertials, see models/urdf_writer.py) of every registered
robot holds the sleep pose and drives the arm to home and to a random in-limit pose (all 18
robots take about 25 s on a loaded 2-core machine: all of them run in the full suite, one per
kinematic family in the quick tier, test/tiers.py). ROS part:
SimDriverNode with ``robot_model:=<name>`` publishes the model's URDF on ``robot_description``
(FK computed from it equals the model's), ``joint_states`` with the model's joints, and
``ee_pose`` = FK(joint_states).
"""
import threading
import time

from geometry_msgs.msg import PoseStamped
import numpy as np
from px100_control.kinematics.poe import fk_space
from px100_control.models.registry import available_robots, load_robot
from px100_control.models.urdf_chain import chain_to_poe, load_urdf
from px100_control.ros.conversions import pose_to_matrix
from px100_control.sim.simulator import ArmSimulator, SimConfig
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tiers import robots

SIM_ROBOTS = available_robots()
ROS_ROBOTS = ['rrrr', 'myarm300pi', 'wx250s']
RATE = 500.0


def _tolerances(m):
    return np.array([0.002 if t == 'prismatic' else 0.01 for t in m.joint_types])


def _drive(sim, m, target, seconds):
    sim.command(list(m.joint_names), [float(x) for x in target])
    sim.advance(int(seconds * RATE))
    return np.abs(sim.positions() - target)


@pytest.mark.parametrize('name', robots(SIM_ROBOTS))
def test_simulator_holds_sleep_and_reaches_targets(name):
    """Sleep is held; home and a random in-limit pose are reached within 0.01 rad / 2 mm."""
    m = load_robot(name)
    sim = ArmSimulator(m, SimConfig(control_rate=RATE))
    assert sim.names == tuple(m.joint_names)
    np.testing.assert_allclose(sim.positions(), m.sleep, atol=1e-12)
    sim.advance(int(0.3 * RATE))
    assert np.all(np.abs(sim.positions() - m.sleep) < _tolerances(m)), 'sleep pose not held'
    tol = _tolerances(m)
    err = _drive(sim, m, m.home, 3.0)
    assert np.all(err < tol), f'home not reached: error {err.tolist()}'
    margin = 0.15 * (m.upper - m.lower)
    target = np.random.default_rng(55).uniform(m.lower + margin, m.upper - margin)
    err = _drive(sim, m, target, 3.0)
    assert np.all(err < tol), f'random target not reached: error {err.tolist()}'
    assert np.all(np.isfinite(sim.velocities()))


class _Listener(Node):
    def __init__(self, **kwargs):
        super().__init__('test_sim_robots_listener', **kwargs)
        self.lock = threading.Lock()
        self.desc, self.js, self.ee = {}, {}, {}
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        for name in ROS_ROBOTS:
            self.create_subscription(String, f'/{name}/robot_description',
                                     lambda msg, n=name: self._set(self.desc, n, msg.data),
                                     latched)
            self.create_subscription(JointState, f'/{name}/joint_states',
                                     lambda msg, n=name: self._set(self.js, n, msg), 10)
            self.create_subscription(PoseStamped, f'/{name}/ee_pose',
                                     lambda msg, n=name: self._set(self.ee, n, msg), 10)

    def _set(self, store, name, value):
        with self.lock:
            store[name] = value


@pytest.mark.ros
def test_sim_driver_publishes_each_model(rclpy_context, spin_node):
    """robot_description FK = model FK; joint_states names and sleep; ee_pose = FK(state)."""
    from px100_control.ros.sim_driver_node import SimDriverNode
    nodes = [SimDriverNode(context=rclpy_context, parameter_overrides=[
        Parameter('robot_model', Parameter.Type.STRING, name),
        Parameter('robot_name', Parameter.Type.STRING, name),
        Parameter('control_rate', Parameter.Type.DOUBLE, 500.0),
        Parameter('publish_rate', Parameter.Type.DOUBLE, 20.0)]) for name in ROS_ROBOTS]
    listener = _Listener(context=rclpy_context)
    spin_node(*nodes, listener)
    deadline = time.monotonic() + 30.0
    while time.monotonic() < deadline:
        with listener.lock:
            if all(n in listener.desc and n in listener.js and n in listener.ee
                   for n in ROS_ROBOTS):
                break
        time.sleep(0.05)
    for name in ROS_ROBOTS:
        m = load_robot(name)
        with listener.lock:
            urdf_xml, js, ee = listener.desc.get(name), listener.js.get(name), \
                listener.ee.get(name)
        assert urdf_xml and js and ee, f'{name}: nothing received'
        S, M, _ = chain_to_poe(load_urdf(urdf_xml), f'{name}/{m.base_frame}',
                               f'{name}/{m.ee_frame}', m.joint_names)
        for q in m.random_configurations(20, rng=66):
            np.testing.assert_allclose(fk_space(S, M, q), m.fk(q), atol=1e-12)
        positions = dict(zip(js.name, js.position))
        assert all(j in positions for j in m.joint_names)
        if m.gripper is not None:
            assert m.gripper.joint in positions
        q = np.array([positions[j] for j in m.joint_names])
        np.testing.assert_allclose(q, m.sleep, atol=0.02)
        assert ee.header.frame_id == f'{name}/{m.base_frame}'
        # ee_pose and joint_states of one publish cycle share the stamp; compare loosely
        np.testing.assert_allclose(pose_to_matrix(ee.pose)[0][:3, 3], m.fk(q)[:3, 3], atol=0.005)
