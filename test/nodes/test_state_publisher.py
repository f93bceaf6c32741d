"""
robot_state_publisher (``state_publisher``) over DDS: live /tf and /tf_static of real nodes.

Against the real sim_driver (its robot_description, joint_states and world/markers): the
end-effector frame chained from ``px100/base_link`` through /tf and /tf_static equals the model's
FK of the joint state of the same stamp within 1 mm at a few poses the simulated arm is driven
to; /tf_static reaches a subscriber that joins late; the objects' frames equal world/markers.
Against inputs published here (namespace /tfx): joints absent from joint_states get no
transform, an unprefixed URDF gets the prefix, a malformed robot_description is refused with a
one-line reason and the node keeps publishing with the previous one.
"""
import threading
import time

from nodes_helpers import LATCHED, STARTUP_TIMEOUT, wait_for
import numpy as np
from px100_control.kinematics.rotations import quaternion_to_matrix
from px100_control.models.registry import load_robot
from px100_control.models.urdf_prefix import prefix_urdf
from px100_control.tools.processes import NodeProcess
import pytest
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

pytestmark = pytest.mark.ros

MODEL = load_robot('px100')
ARM = list(MODEL.joint_names)
STATIC_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                        reliability=ReliabilityPolicy.RELIABLE)
TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def _matrix(tr) -> np.ndarray:
    t, r = tr.transform.translation, tr.transform.rotation
    T = np.eye(4)
    T[:3, :3] = quaternion_to_matrix(r.x, r.y, r.z, r.w)
    T[:3, 3] = [t.x, t.y, t.z]
    return T


def chain(static, moving, root: str, frame: str) -> np.ndarray:
    """Return the pose of ``frame`` in ``root`` chained through the transforms given."""
    parent = {tr.child_frame_id: tr for tr in list(static) + list(moving)}
    T = np.eye(4)
    while frame != root:
        assert frame in parent, f'no transform to {frame} (have {sorted(parent)})'
        tr = parent[frame]
        T = _matrix(tr) @ T
        frame = tr.header.frame_id
    return T


class TfListener(Node):
    """Collect /tf, /tf_static, and the robot's joint_states and world/markers by stamp."""

    def __init__(self, name: str, ns: str, **kwargs):
        super().__init__(name, **kwargs)
        self.lock = threading.Lock()
        self.tf = []            # TFMessage, arrival order
        self.static = []
        self.states = {}        # stamp ns -> {joint: position}
        self.markers = []
        self.create_subscription(TFMessage, '/tf', lambda m: self._add(self.tf, m), TF_QOS)
        self.create_subscription(TFMessage, '/tf_static', lambda m: self._add(self.static, m),
                                 STATIC_QOS)
        self.create_subscription(JointState, f'{ns}/joint_states', self._on_js, 100)
        self.create_subscription(MarkerArray, f'{ns}/world/markers',
                                 lambda m: self._add(self.markers, m), LATCHED)

    def _add(self, seq, msg):
        with self.lock:
            seq.append(msg)

    def _on_js(self, msg):
        with self.lock:
            self.states[_ns(msg.header.stamp)] = dict(zip(msg.name, msg.position))

    def frames(self, prefix: str, since: int = 0):
        """Return the /tf messages (from index ``since``) with a frame starting ``prefix``."""
        with self.lock:
            return [m for m in self.tf[since:]
                    if any(tr.child_frame_id.startswith(prefix) for tr in m.transforms)]

    def static_of(self, prefix: str):
        """Return the transforms of the last /tf_static message of frames ``prefix...``."""
        with self.lock:
            found = [m for m in self.static
                     if m.transforms and m.transforms[0].child_frame_id.startswith(prefix)]
        return list(found[-1].transforms) if found else None


@pytest.fixture(scope='module')
def sim(ros_ctx, spinner, processes):
    """Start the real sim_driver and state_publisher (namespace /px100) and a listener."""
    listener = spinner.add(TfListener('test_tf_listener', '/px100', context=ros_ctx))
    driver = NodeProcess('sim_driver', [])
    processes.append(driver)
    state = NodeProcess('state_publisher', [])
    processes.append(state)
    ok = wait_for(lambda: listener.static_of('px100/') and listener.frames('px100/objects/'),
                  STARTUP_TIMEOUT)
    assert ok, f'no /tf_static or objects: {driver.output()}\n{state.output()}'
    pub = listener.create_publisher(JointState, '/px100/commands/joint_setpoints', 10)
    return listener, driver, state, pub


def test_static_frames_reach_a_late_subscriber(sim, ros_ctx, spinner):
    """A subscriber created now still gets /tf_static: every fixed joint of the URDF."""
    late = spinner.add(TfListener('test_tf_late', '/px100', context=ros_ctx))
    assert wait_for(lambda: late.static_of('px100/'), 20.0), 'no /tf_static for a late one'
    children = {tr.child_frame_id for tr in late.static_of('px100/')}
    assert {'px100/ee_arm_link', 'px100/ee_gripper_link'} <= children, children
    assert all(tr.header.frame_id.startswith('px100/') for tr in late.static_of('px100/'))


def _ee_errors(listener, since: int):
    """Return [(stamp, |ee from /tf - FK|)] of the /tf messages from index ``since``."""
    static = listener.static_of('px100/')
    out = []
    for msg in listener.frames('px100/shoulder_link', since):
        stamp = _ns(msg.transforms[0].header.stamp)
        with listener.lock:
            state = listener.states.get(stamp)
        if state is None:
            continue
        T = chain(static, msg.transforms, 'px100/base_link', 'px100/ee_gripper_link')
        fk = MODEL.fk(np.array([state[j] for j in ARM]))
        out.append((stamp, float(np.linalg.norm(T[:3, 3] - fk[:3, 3])),
                    float(np.abs(T[:3, :3] - fk[:3, :3]).max())))
    return out


@pytest.mark.parametrize('q', [[0.0, -1.0, 0.8, 0.3], [0.6, -0.3, 0.2, -0.4],
                               [-0.8, 0.2, -0.5, 1.0]])
def test_end_effector_frame_equals_fk(sim, q):
    """Drive the simulated arm to a pose: /tf's ee_gripper_link is FK of the same stamp."""
    listener, driver, state, pub = sim
    with listener.lock:
        since = len(listener.tf)
    msg = JointState(name=ARM, position=[float(x) for x in q])

    def arrived():
        pub.publish(msg)
        with listener.lock:
            last = listener.states[max(listener.states)] if listener.states else {}
        return last and max(abs(last[j] - v) for j, v in zip(ARM, q)) < 0.02
    assert wait_for(arrived, 30.0, period=0.1), f'the arm did not reach {q}: {driver.output()}'
    assert wait_for(lambda: len(_ee_errors(listener, since)) >= 5, 10.0), state.output()
    errors = _ee_errors(listener, since)
    assert max(e for _, e, _ in errors) < 1e-3, errors
    assert max(r for _, _, r in errors) < 1e-6, errors
    stamps = [s for s, _, _ in errors]
    assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)
    assert state.alive(), state.output()


def test_object_frames_equal_world_markers(sim):
    """Each movable object of world/markers is a /tf frame px100/objects/<name> at its pose."""
    listener, _, state, _ = sim
    assert wait_for(lambda: listener.markers, 10.0)
    with listener.lock:
        markers = listener.markers[-1]
    objects = [m for m in markers.markers if m.ns == 'objects']
    assert objects, 'the default scene has objects'
    stamp = _ns(objects[0].header.stamp)

    def frames_of_stamp():
        for msg in listener.frames('px100/objects/'):
            if _ns(msg.transforms[0].header.stamp) == stamp:
                return msg
        return None
    assert wait_for(frames_of_stamp, 10.0), "no object frames with the markers' stamp"
    got = {tr.child_frame_id: tr for tr in frames_of_stamp().transforms}
    assert set(got) == {f'px100/objects/{m.text}' for m in objects}
    for m in objects:
        tr = got[f'px100/objects/{m.text}']
        assert tr.header.frame_id == m.header.frame_id == 'px100/base_link'
        t, r = tr.transform.translation, tr.transform.rotation
        p, o = m.pose.position, m.pose.orientation
        assert (t.x, t.y, t.z, r.x, r.y, r.z, r.w) == (p.x, p.y, p.z, o.x, o.y, o.z, o.w)


class Source(Node):
    """robot_description (latched) and joint_states of a robot published by the test."""

    def __init__(self, ns: str, **kwargs):
        super().__init__('test_tf_source', namespace=ns, **kwargs)
        self.desc = self.create_publisher(String, 'robot_description', LATCHED)
        self.js = self.create_publisher(JointState, 'joint_states', 10)
        self.stamp = 1_000_000_000

    def joint_state(self, names, positions) -> int:
        """Publish one joint state with a new stamp (10 ms after the last); return it [ns]."""
        self.stamp += 10_000_000
        msg = JointState(name=list(names), position=[float(x) for x in positions])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(self.stamp, 1_000_000_000)
        self.js.publish(msg)
        return self.stamp


@pytest.fixture(scope='module')
def own(ros_ctx, spinner, processes):
    """Start a state_publisher in /tfx (publish_frequency 0: every joint state) fed here."""
    listener = spinner.add(TfListener('test_tf_listener_x', '/tfx', context=ros_ctx))
    source = spinner.add(Source('/tfx', context=ros_ctx))
    proc = NodeProcess('state_publisher', ['--ros-args', '-r', '__ns:=/tfx', '-p',
                                           'publish_frequency:=0.0'])
    processes.append(proc)
    assert wait_for(lambda: source.js.get_subscription_count() > 0
                    and source.desc.get_subscription_count() > 0, STARTUP_TIMEOUT), \
        proc.output()
    return listener, source, proc


def _tf_of(listener, stamp: int):
    for msg in listener.frames('tfx/'):
        if _ns(msg.transforms[0].header.stamp) == stamp:
            return msg
    return None


def test_own_inputs_poses_and_partial_states(own):
    """Unprefixed URDF: frames tfx/...; FK at several poses; absent joints get no transform."""
    listener, source, proc = own
    source.desc.publish(String(data=MODEL.urdf_xml))          # unprefixed links
    assert wait_for(lambda: listener.static_of('tfx/'), 20.0), proc.output()
    static = listener.static_of('tfx/')
    for q in MODEL.random_configurations(5, 8, margin=0.05):
        stamp = source.joint_state(ARM + ['gripper', 'left_finger', 'right_finger'],
                                   list(q) + [0.0, 0.03, -0.03])
        assert wait_for(lambda: _tf_of(listener, stamp), 10.0), proc.output()
        T = chain(static, _tf_of(listener, stamp).transforms, 'tfx/base_link',
                  'tfx/ee_gripper_link')
        np.testing.assert_allclose(T, MODEL.fk(q), atol=1e-9)
    stamp = source.joint_state(['waist'], [0.5])
    assert wait_for(lambda: _tf_of(listener, stamp), 10.0), proc.output()
    assert [tr.child_frame_id for tr in _tf_of(listener, stamp).transforms] == \
        ['tfx/shoulder_link']


@pytest.mark.parametrize('urdf, words', [
    ('<robot name="x"><link name="a"/>', 'not valid XML'),
    ('<robot name="x"><link name="a"/></robot>', 'no movable joint'),
    ('just text', 'not valid XML'),
    ('<urdf/>', 'not <robot>'),
])
def test_malformed_description_is_refused_and_the_node_keeps_going(own, urdf, words):
    """A bad URDF: one error line naming why; /tf goes on with the previous tree."""
    listener, source, proc = own
    source.desc.publish(String(data=prefix_urdf(MODEL.urdf_xml, 'tfx')))
    assert wait_for(lambda: listener.static_of('tfx/'), 20.0), proc.output()
    before = proc.output().count('robot_description is not a usable URDF')
    source.desc.publish(String(data=urdf))
    assert wait_for(lambda: proc.output().count('robot_description is not a usable URDF')
                    > before, 20.0), proc.output()
    lines = [x for x in proc.output().splitlines() if 'not a usable URDF' in x]
    assert words in lines[-1] and 'previous' in lines[-1], lines[-1]
    assert proc.alive(), proc.output()
    stamp = source.joint_state(ARM, [0.1, 0.2, 0.3, 0.4])
    assert wait_for(lambda: _tf_of(listener, stamp), 10.0), proc.output()
    time.sleep(0.1)
    assert proc.alive()
