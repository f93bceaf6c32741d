"""
A user script driving the arm through the Interbotix-compatible client (run as a process).

It connects, makes ``--moves`` joint moves (a 2 s move near home, then short moves around it; a
different pattern per ``--index``), then disconnects. Prints one JSON line: moves tried and
succeeded, and the ids (``sec.nanosec`` stamps) of the goals it sent, so a test can look for
each one in a bag.
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
    parser.add_argument('--moving-time', type=float, default=0.6)
    parser.add_argument('--turn-file', default='',
                        help='connect at once, move only when this file holds --index, then '
                             'write index + 1 to it (scripts started together take turns)')
    parser.add_argument('--wait-subscribers', type=int, default=0,
                        help='diagnosis only: wait until this many nodes subscribe to the goal '
                             'events of the trajectory action')
    opts = parser.parse_args(argv)

    import numpy as np
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup

    t0 = time.monotonic()
    bot = InterbotixManipulatorXS(robot_model='px100', group_name='arm', gripper_name='gripper',
                                  connect_timeout=30.0)
    robot_startup()
    connect_s = time.monotonic() - t0
    deadline = time.monotonic() + 20.0
    goal_events = bot.core.call_event_topics()[2]   # the action's send_goal events
    while bot.core.get_node().count_subscribers(goal_events) < opts.wait_subscribers and \
            time.monotonic() < deadline:
        time.sleep(0.02)
    waited_s = time.monotonic() - t0 - connect_s
    turn_wait = time.monotonic()
    while opts.turn_file and _read(opts.turn_file) != str(opts.index):
        time.sleep(0.02)
    turn_wait = time.monotonic() - turn_wait
    rng = np.random.default_rng(opts.index)
    ok, goals, failures = 0, [], []
    # from wherever the last script left the arm: home first (sleep -> home takes a while)
    home = list(np.round(rng.uniform(-0.2, 0.2, 4), 3))
    lower = np.array(bot.core.model.lower) + 0.05
    upper = np.array(bot.core.model.upper) - 0.05
    for i in range(opts.moves):
        if i == 0:
            target, mt = home, 2.0
        else:  # small moves around where the arm really is
            here = bot.arm.get_joint_positions()
            target = np.clip(np.add(here, rng.uniform(-0.25, 0.25, 4)), lower, upper)
            target, mt = list(target), opts.moving_time
        before = bot.arm._last_goal
        good = bot.arm.set_joint_positions(list(target), moving_time=mt, accel_time=mt / 4,
                                           blocking=True)
        last = bot.arm._last_goal
        if last is not None and last is not before:
            goals.append(last.uuid.hex())   # the action goal id
        if good:
            ok += 1
        else:
            reason = getattr(last, 'reason', '') if last is not None else ''
            failures.append(f'move {i} to {np.round(target, 3).tolist()}: '
                            f'{bot.arm.last_goal_status()} {reason}')
    if opts.turn_file:
        with open(opts.turn_file, 'w', encoding='utf-8') as f:
            f.write(str(opts.index + 1))
    robot_shutdown()
    print(json.dumps({'index': opts.index, 'moves': opts.moves, 'succeeded': ok,
                      'tracking_aborts': sum('tracking error' in f or 'did not settle' in f
                                             for f in failures),
                      'goals': goals, 'failures': failures, 'connect_s': connect_s,
                      'waited_for_subscribers_s': waited_s, 'waited_for_turn_s': turn_wait,
                      'seconds': time.monotonic() - t0}), flush=True)
    return 0 if ok == opts.moves else 1


def _read(path: str) -> str:
    try:
        with open(path, encoding='utf-8') as f:
            return f.read().strip()
    except OSError:
        return ''


if __name__ == '__main__':
    sys.exit(main())
