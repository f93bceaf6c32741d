"""
A user script driving the arm through the Interbotix-compatible client (run as a process).

It connects, makes ``--moves`` joint moves (short moving times, a different target pattern per
``--index``), then disconnects. Prints one JSON line: moves tried and succeeded, and the ids
(``sec.nanosec`` stamps) of the goals it sent, so a test can look for each one in a bag.
Usage: ``python client_script.py --index I --moves N [--moving-time S]``.
"""
import argparse
import json
import sys
import time


def main(argv=None) -> int:
    """Run the script; exit 0 if every move succeeded, 1 otherwise."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--index', type=int, default=0)
    parser.add_argument('--moves', type=int, default=4)
    parser.add_argument('--moving-time', type=float, default=0.4)
    opts = parser.parse_args(argv)

    import numpy as np
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
    from px100_control.ros.conversions import stamp_id
    from builtin_interfaces.msg import Time

    t0 = time.monotonic()
    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm', gripper_name='gripper',
                                  connect_timeout=30.0)
    robot_startup()
    connect_s = time.monotonic() - t0
    rng = np.random.default_rng(opts.index)
    model_lo = np.array([-1.0, -0.6, -0.6, -0.6])
    model_hi = np.array([1.0, 0.6, 0.6, 0.6])
    ok, goals, failures = 0, [], []
    for i in range(opts.moves):
        target = rng.uniform(model_lo, model_hi)
        good = bot.arm.set_joint_positions(list(target), moving_time=opts.moving_time,
                                           accel_time=opts.moving_time / 4, blocking=True)
        last = bot.arm._last_goal
        if last is not None:
            goals.append(stamp_id(Time(sec=last.key[0], nanosec=last.key[1])))
        if good:
            ok += 1
        else:
            failures.append(f'move {i} to {np.round(target, 3).tolist()}: '
                            f'{bot.arm.last_goal_status()}')
    robot_shutdown()
    print(json.dumps({'index': opts.index, 'moves': opts.moves, 'succeeded': ok,
                      'goals': goals, 'failures': failures, 'connect_s': connect_s,
                      'seconds': time.monotonic() - t0}), flush=True)
    return 0 if ok == opts.moves else 1


if __name__ == '__main__':
    sys.exit(main())
