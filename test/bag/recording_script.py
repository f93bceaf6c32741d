"""
A client script whose every goal, IK request and setpoint must end up in the bag.

Usage: ``python recording_script.py NAMESPACE [BAG_DIR [unchanged]]``: with BAG_DIR it records
itself ``with Recorder(BAG_DIR)`` and passes the Recorder to the robot (``recorder=rec``), or
with ``unchanged`` does not (the client finds the in-process Recorder itself). Without BAG_DIR
a ``record`` process started just before it records (the client finds it in the graph, or
waits for it with env PX100_RECORDER=wait). Its first command goes out right after
construction. Prints one JSON line: the stamps (``sec.nanosec``) it published per topic.
"""
import json
import sys

from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
from px100_control.ros.conversions import stamp_id
from px100_control.ros.recorder import Recorder


def run(ns: str, recorder=None) -> dict:
    """Drive the arm and gripper; return {topic: [stamp ids]} of what was published."""
    bot = InterbotixManipulatorXS('px100', 'arm', 'gripper', robot_name=ns, moving_time=1.0,
                                  accel_time=0.3, connect_timeout=30.0, recorder=recorder)
    sent = {'trajectory/goal': [], 'ik/request': [], 'commands/joint_setpoints': []}
    core = bot.core
    for topic, pub in (('trajectory/goal', core.pub_goal), ('ik/request', core.pub_ik),
                       ('commands/joint_setpoints', core.pub_setpoints)):
        def publish(msg, _orig=pub.publish, _topic=topic):
            sent[_topic].append(stamp_id(msg.header.stamp))
            _orig(msg)
        pub.publish = publish
    robot_startup()
    bot.arm.set_ee_pose_components(x=0.2, z=0.15)
    bot.gripper.grasp(0.3)
    bot.arm.set_joint_positions([0.3, -0.3, 0.3, 0.0])
    bot.gripper.release(0.3)
    bot.arm.go_to_sleep_pose()
    robot_shutdown()
    return sent


if __name__ == '__main__':
    namespace = sys.argv[1]
    if len(sys.argv) > 2:
        with Recorder(sys.argv[2], robot_name=namespace) as rec:
            result = run(namespace, None if sys.argv[3:] == ['unchanged'] else rec)
    else:
        result = run(namespace)
    print(json.dumps(result), flush=True)
