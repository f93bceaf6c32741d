"""
Campaign: ``record -a`` started before a client script must hold every call of that script.

One bringup (no camera) in a namespace of its own; then N runs, each: start the ``record -a``
process, run a client script as a user writes it (its own process, unchanged: the client finds
the recorder in the graph; ``--tell-client`` sets PX100_RECORDER=wait instead), stop the
recorder (SIGINT) and read the bag. The script moves the arm through the trajectory action
(goals, one cancel, every goal's result), calls ``compute_ik`` and ``compute_cartesian_path``,
and prints the goal ids and target stamps it sent. A run is complete when the bag holds, for
each of them, the request and its response (paired by :func:`px100_control.bag.calls
.read_calls`, named by goal id or target stamp). Prints one line per run and ``k/N complete``;
exit status 0 only when every run is complete.

Usage (venv + install sourced, e.g. ``source scripts/env.sh``):
``python benchmarks/campaign_record_all.py [--runs N] [--bound SECONDS]``; the bound
(default 90 s + 45 s per run) is printed first and stops the campaign, naming its stage.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import bound

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
os.environ.setdefault('ROS_DOMAIN_ID', str(10 + os.getpid() % 90))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)

from px100_control.bag.calls import CLIENT_CALLS as CALLS, stamp_text  # noqa: E402, I100
#: bound [s]: fixed part and per run
BOUND_BASE_S, BOUND_PER_RUN_S = 90.0, 45.0
#: after the script exits, before the recorder is stopped: its last events are in flight [s]
SETTLE_S = 0.3


# -- the client script (run as ``campaign_record_all.py --client NS``) -----------------------
def client_main(ns: str) -> int:
    """Drive the arm as a script does; print JSON of the goal ids and target stamps sent."""
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
    bot = InterbotixManipulatorXS('px100', 'arm', 'gripper', robot_name=ns, moving_time=1.0,
                                  accel_time=0.3, connect_timeout=30.0)
    sent = {'goals': [], 'cancels': [], 'ik': [], 'path': []}
    core = bot.core
    link = core.arm_action

    def send(goal, call, _orig=link.send):
        sent['goals'].append(call.uuid.hex())
        _orig(goal, call)

    def cancel(call, timeout, _orig=link.cancel):
        ok = _orig(call, timeout)
        if ok:
            sent['cancels'].append(call.uuid.hex())
        return ok
    link.send, link.cancel = send, cancel
    for key, client, field in (('ik', core.srv_ik, 'target'),
                               ('path', core.srv_ik_path, 'waypoints')):
        def call_async(request, _orig=client.call_async, _key=key, _field=field):
            sent[_key].append(stamp_text(getattr(request, _field).header.stamp))
            return _orig(request)
        client.call_async = call_async
    robot_startup()
    bot.arm.set_ee_pose_components(x=0.2, z=0.15)
    bot.arm.set_ee_cartesian_trajectory(z=-0.03)
    bot.arm.set_joint_positions([0.3, -0.3, 0.3, 0.0])
    bot.arm.set_single_joint_position('waist', -0.5, moving_time=2.0, blocking=False)
    core.sleep(0.5)
    core.cancel_goal(bot.arm._last_goal)
    bot.arm.wait_for_last_goal(5.0)
    bot.arm.go_to_sleep_pose()
    robot_shutdown()
    print(json.dumps(sent), flush=True)
    return 0


# -- the campaign -----------------------------------------------------------------------------
def missing_calls(bag_dir: str, ns: str, sent: dict) -> dict:
    """Return {what: names sent whose request or response is not in the bag} (empty: whole)."""
    from px100_control.bag.calls import read_calls
    from px100_control.bag.reader import BagReader
    sent = dict(sent, results=sent['goals'])      # the client asks for every goal's result
    out = {}
    with BagReader(bag_dir) as reader:
        for what, (service, key) in CALLS.items():
            topic = f'/{ns}/{service}/_service_event'
            calls = read_calls(reader, topic, key) if topic in reader.topics else []
            answered = {c.key for c in calls if c.answered}
            lost = sorted(set(sent[what]) - answered)
            if lost:
                out[what] = lost
    return out


def one_run(i: int, ns: str, work: str, tell_client: bool) -> tuple:
    """Record one client run; return (complete, counts sent, what is missing or why)."""
    from px100_control.tools.processes import NodeProcess
    bag = os.path.join(work, f'run{i}')
    rec = NodeProcess('record', ['-a', '-o', bag, '--ros-args', '-p', f'robot_name:={ns}'])
    env = os.environ.copy()
    env['PYTHONPATH'] = os.pathsep.join([ROOT] + [p for p in env.get('PYTHONPATH', '').split(
        os.pathsep) if p])
    if tell_client:
        env['PX100_RECORDER'] = 'wait'
    else:
        env.pop('PX100_RECORDER', None)
    try:
        proc = subprocess.run([sys.executable, os.path.abspath(__file__), '--client', ns],
                              env=env, capture_output=True, text=True, timeout=120)
        time.sleep(SETTLE_S)
    finally:
        status = rec.stop(timeout=30.0)
    if proc.returncode != 0:
        return False, {}, f'client failed ({proc.returncode}): {proc.stderr[-800:]}'
    if status != 0:
        return False, {}, f'record exited {status}: {rec.output()[-800:]}'
    sent = json.loads(proc.stdout.strip().splitlines()[-1])
    counts = {k: len(v) for k, v in sent.items()}
    if not all(sent.values()):
        return False, counts, f'the client sent nothing of some kind: {counts}'
    missing = missing_calls(bag, ns, sent)
    if missing:     # with the evidence: when the recorder got ready, what the client saw of it
        notes = [x for x in proc.stderr.splitlines() if 'ecorder' in x or 'Initialized' in x]
        notes += [x for x in rec.output().splitlines() if 'ready' in x or 'recording to' in x]
        return False, counts, f'{missing}\n    ' + '\n    '.join(notes)
    return True, counts, missing


def run(runs: int, tell_client: bool, log=print) -> int:
    """Run the campaign; return the number of complete runs."""
    from px100_control.tools.processes import NodeProcess
    ns = f'px100_campaign_{os.getpid()}'
    complete = 0
    with tempfile.TemporaryDirectory(prefix='px100_campaign_') as work:
        bringup = NodeProcess('bringup', ['--no-camera', '--ros-args', '-p',
                                          f'robot_name:={ns}'])
        try:
            for i in range(runs):
                bound.stage(f'run {i + 1} of {runs}')
                t0 = time.monotonic()
                ok, counts, detail = one_run(i, ns, work, tell_client)
                complete += ok
                log(f'run {i + 1}/{runs}: {"complete" if ok else "INCOMPLETE"} '
                    f'({time.monotonic() - t0:.1f} s, sent {counts})'
                    + ('' if ok else f': missing {detail}'))
        finally:
            bringup.stop(timeout=30.0)
    return complete


def main(argv=None) -> int:
    """Parse the options, run the campaign under its bound, print k/N."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--runs', type=int, default=20, help='runs (default 20)')
    parser.add_argument('--tell-client', action='store_true',
                        help='set PX100_RECORDER=wait for the client (default: unchanged)')
    parser.add_argument('--bound', type=float, default=None, metavar='SECONDS',
                        help=f'fail if the campaign takes longer (default {BOUND_BASE_S:.0f} s'
                             f' + {BOUND_PER_RUN_S:.0f} s per run)')
    parser.add_argument('--client', default=None, help=argparse.SUPPRESS)
    options = parser.parse_args(argv)
    if options.client:
        return client_main(options.client)
    if options.runs < 1:
        parser.error(f'--runs must be at least 1, not {options.runs}')
    bound_s = options.bound or BOUND_BASE_S + BOUND_PER_RUN_S * options.runs
    print(f'campaign_record_all: {options.runs} runs, bound {bound_s:.0f} s, '
          f'client {"told (PX100_RECORDER=wait)" if options.tell_client else "unchanged"}',
          flush=True)
    with bound.bounded('campaign_record_all', bound_s):
        complete = run(options.runs, options.tell_client, log=bound.log)
    print(f'{complete}/{options.runs} complete', flush=True)
    return 0 if complete == options.runs else 1


if __name__ == '__main__':
    sys.exit(main())
