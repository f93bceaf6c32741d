"""
A client script whose every goal, cancel, result, IK call and setpoint must end up in the bag.

Usage: ``python recording_script.py NAMESPACE [BAG_DIR [unchanged]]``: with BAG_DIR it records
itself ``with Recorder(BAG_DIR)`` and passes the Recorder to the robot (``recorder=rec``), or
with ``unchanged`` does not (the client finds the in-process Recorder itself). Without BAG_DIR
a ``record`` process started just before it records (the client finds it in the graph, or
waits for it with env PX100_RECORDER=wait). Its first command goes out right after
construction. Prints one JSON line of what it sent: the ids of its trajectory action goals
(``goals``, hex), of the goals it canceled (``cancels``), the target stamps (``sec.nanosec``) of
its ``compute_ik`` and ``compute_cartesian_path`` calls (``ik``, ``path``) and the stamps of its
setpoints.
"""
import json
import sys

from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
from px100_control.ros.conversions import stamp_id
from px100_control.ros.recorder import Recorder


def _spy(sent: dict, core) -> None:
    """Note each goal, cancel, IK call and setpoint the client sends (then send it)."""
    link, pub = core.arm_action, core.pub_setpoints

    def send(goal, call, _orig=link.send):
        sent['goals'].append(call.uuid.hex())
        _orig(goal, call)

    def cancel(call, timeout, _orig=link.cancel):
        ok = _orig(call, timeout)
        if ok:
            sent['cancels'].append(call.uuid.hex())
        return ok

    def publish(msg, _orig=pub.publish):
        sent['commands/joint_setpoints'].append(stamp_id(msg.header.stamp))
        _orig(msg)
    link.send, link.cancel, pub.publish = send, cancel, publish
    for key, client, field in (('ik', core.srv_ik, 'target'),
                               ('path', core.srv_ik_path, 'waypoints')):
        def call_async(request, _orig=client.call_async, _key=key, _field=field):
            sent[_key].append(stamp_id(getattr(request, _field).header.stamp))
            return _orig(request)
        client.call_async = call_async


def run(ns: str, recorder=None) -> dict:
    """Drive the arm and gripper, cancel a move; return what was sent (see the module doc)."""
    bot = InterbotixManipulatorXS('px100', 'arm', 'gripper', robot_name=ns, moving_time=1.0,
                                  accel_time=0.3, connect_timeout=30.0, recorder=recorder)
    sent = {'goals': [], 'cancels': [], 'ik': [], 'path': [], 'commands/joint_setpoints': []}
    _spy(sent, bot.core)
    robot_startup()
    bot.arm.set_ee_pose_components(x=0.2, z=0.15)
    bot.arm.set_ee_cartesian_trajectory(z=-0.03)
    bot.gripper.grasp(0.3)
    bot.arm.set_joint_positions([0.3, -0.3, 0.3, 0.0])
    bot.arm.set_single_joint_position('waist', -0.5, moving_time=2.0, blocking=False)
    bot.core.sleep(0.5)
    bot.core.cancel_goal(bot.arm._last_goal)
    bot.arm.wait_for_last_goal(5.0)
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
