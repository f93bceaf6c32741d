"""
An independent observer of the nodes' publish rates, run as its own process.

The probe publishes the fuzz inputs: while it serializes an 800 MB goal (or hypothesis builds
one) its own callbacks wait, so gaps it sees in ``joint_states`` may be its own. This process
only listens: for each topic it appends the receive time of every message (float64, seconds on
the system-wide monotonic clock, as ``time.monotonic()`` in the probe) to ``<dir>/<name>.f64``.
A thread also appends the time every 10 ms to ``<dir>/heartbeat.f64``: a gap there means this
process, so likely the whole machine, was not scheduled (it tells a node's own stall from one
of the machine). Prints ``ready`` once subscribed.
Usage: ``python rate_watcher.py --dir D [--robot-name px100]``.
"""
import argparse
import os
import struct
import sys
import threading
import time

#: topic (under the robot namespace) -> message type name, as (module, class)
TOPICS = {'joint_states': ('sensor_msgs.msg', 'JointState'),
          'ee_pose': ('geometry_msgs.msg', 'PoseStamped')}


def main(argv=None) -> int:
    """Listen until SIGINT, appending receive times."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--dir', required=True)
    parser.add_argument('--robot-name', default='px100')
    opts = parser.parse_args(argv)

    import importlib

    from px100_control.ros.common import make_executor
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.qos import qos_profile_sensor_data

    rclpy.init()
    node = rclpy.create_node('rate_watcher')
    files = []
    pack = struct.Struct('<d').pack

    def recorder(f):
        def on_message(_data):
            f.write(pack(time.monotonic()))
        return on_message

    for name, (module, cls) in TOPICS.items():
        f = open(os.path.join(opts.dir, f'{name}.f64'), 'wb', buffering=0)
        files.append(f)
        msg_type = getattr(importlib.import_module(module), cls)
        # raw: the bytes are not deserialized, this process stays light
        node.create_subscription(msg_type, f'/{opts.robot_name}/{name}', recorder(f),
                                 qos_profile_sensor_data, raw=True)
    beat = open(os.path.join(opts.dir, 'heartbeat.f64'), 'wb', buffering=0)
    files.append(beat)
    beating = threading.Event()

    def heartbeat():
        while not beating.wait(0.01):
            beat.write(pack(time.monotonic()))

    beater = threading.Thread(target=heartbeat, daemon=True)
    beater.start()
    print('ready', flush=True)
    executor = make_executor()
    executor.add_node(node)
    try:
        while rclpy.ok():   # not spin(): rclpy 7.1's EventsExecutor.spin() ignores SIGINT
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    beating.set()
    beater.join(1.0)
    for f in files:
        f.close()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
