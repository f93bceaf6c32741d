"""Shared helpers of the bag tests: CDR messages built with rosbags, synthetic bags."""
import os

import numpy as np
from px100_control.bag import metadata as md
from px100_control.bag.writer import BagWriter
from rosbags.typesys import get_typestore, Stores

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
T0_NS = 1_700_000_000_000_000_000
ARM = ['waist', 'shoulder', 'elbow', 'wrist_angle']


def cdr(msg, type_name: str) -> bytes:
    """Return the CDR bytes of a rosbags message object."""
    return bytes(TYPESTORE.serialize_cdr(msg, type_name))


def decode(data: bytes, type_name: str):
    """Decode CDR bytes strictly (rosbags rejects size mismatches)."""
    return TYPESTORE.deserialize_cdr(data, type_name)


def _stamp(t_ns: int):
    Time = TYPESTORE.types['builtin_interfaces/msg/Time']
    Header = TYPESTORE.types['std_msgs/msg/Header']
    return Header(stamp=Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9), frame_id='')


def joint_state(t_ns: int, names, position, velocity=(), effort=()) -> bytes:
    """Return a sensor_msgs/JointState as CDR bytes."""
    JS = TYPESTORE.types['sensor_msgs/msg/JointState']
    m = JS(header=_stamp(t_ns), name=list(names), position=np.array(position, float),
           velocity=np.array(velocity, float), effort=np.array(effort, float))
    return cdr(m, 'sensor_msgs/msg/JointState')


def string(text: str) -> bytes:
    """Return a std_msgs/String as CDR bytes."""
    return cdr(TYPESTORE.types['std_msgs/msg/String'](data=text), 'std_msgs/msg/String')


def pose_stamped(t_ns: int, xyz, frame='px100/base_link') -> bytes:
    """Return a geometry_msgs/PoseStamped (identity orientation) as CDR bytes."""
    T = TYPESTORE.types
    header = _stamp(t_ns)
    header.frame_id = frame
    pose = T['geometry_msgs/msg/Pose'](
        position=T['geometry_msgs/msg/Point'](x=xyz[0], y=xyz[1], z=xyz[2]),
        orientation=T['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0, w=1.0))
    return cdr(T['geometry_msgs/msg/PoseStamped'](header=header, pose=pose),
               'geometry_msgs/msg/PoseStamped')


def arm_trajectory(t: float):
    """Return smooth arm joint values [rad] at time t [s] (inside the px100 limits)."""
    return [0.6 * np.sin(t), -0.4 + 0.3 * np.sin(0.7 * t), 0.3 * np.cos(t), 0.2 * np.sin(2 * t)]


def write_run_bag(bag_dir: str, seconds: float = 2.0, rate_hz: float = 100.0,
                  setpoint_hz: float = 20.0, with_description: bool = True,
                  chunk_size: int = 1 << 20, flush_period_s: float = 1.0) -> dict:
    """
    Write a synthetic recorded run: joint_states, setpoints, ee_pose, robot_description.

    :return: {topic: [(log_time_ns, cdr bytes)]} of what was written
    """
    from px100_control.bag.tf import TfTree
    from px100_control.models.registry import load_robot
    from px100_control.models.urdf_prefix import prefix_urdf
    model = load_robot('px100')
    urdf = prefix_urdf(model.urdf_xml, 'px100')
    tree = TfTree(urdf)
    written = {}
    with BagWriter(bag_dir, chunk_size=chunk_size, flush_period_s=flush_period_s) as bag:
        bag.add_topic('/px100/joint_states', 'sensor_msgs/msg/JointState', [md.qos_profile()])
        bag.add_topic('/px100/commands/joint_setpoints', 'sensor_msgs/msg/JointState',
                      [md.qos_profile()])
        bag.add_topic('/px100/ee_pose', 'geometry_msgs/msg/PoseStamped', [md.qos_profile()])

        def put(topic, t_ns, data):
            bag.write(topic, data, t_ns)
            written.setdefault(topic, []).append((t_ns, data))

        if with_description:
            bag.add_topic('/px100/robot_description', 'std_msgs/msg/String',
                          [md.qos_profile(durability='transient_local', depth=1)])
            put('/px100/robot_description', T0_NS, string(urdf))
        n = int(seconds * rate_hz)
        sp_every = max(1, int(round(rate_hz / setpoint_hz)))
        for i in range(n):
            t = i / rate_hz
            t_ns = T0_NS + int(round(t * 1e9))
            q = arm_trajectory(t)
            if i % sp_every == 0:
                put('/px100/commands/joint_setpoints', t_ns,
                    joint_state(t_ns, ARM, arm_trajectory(t + 0.05)))
            put('/px100/joint_states', t_ns + 1000,
                joint_state(t_ns, ARM + ['gripper', 'left_finger', 'right_finger'],
                            q + [0.0, 0.03, -0.03]))
            xyz = tree.link_poses(dict(zip(ARM, q)))['px100/ee_gripper_link'][:3, 3]
            put('/px100/ee_pose', t_ns + 2000, pose_stamped(t_ns, xyz))
    return written


def mcap_path(bag_dir: str) -> str:
    """Return the single .mcap file of a bag directory."""
    files = [f for f in os.listdir(bag_dir) if f.endswith('.mcap')]
    assert len(files) == 1, files
    return os.path.join(bag_dir, files[0])
