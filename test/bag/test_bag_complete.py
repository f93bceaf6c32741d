"""
Recordings lose nothing: each goal, cancel, result, IK call and setpoint of a script is in the bag.

A client script (recording_script.py) runs repeatedly against a bringup in its own namespace,
recorded (a) by ``record -a`` started just before it and (b) by ``with Recorder(dir)`` inside
it; each way with the client told about the recorder (env PX100_RECORDER=wait, recorder=rec)
and with the script unchanged (the client finds the recorder itself). The client's goals,
cancels and result requests are calls of the trajectory action's services and its IK requests
calls of ``compute_ik`` / ``compute_cartesian_path``: the servers publish each as service
introspection events (``<service>/_service_event``). Each run's bag must hold, for every call
the script made, the request (found by its goal id or target stamp) and the response (the
event of the same sequence number), the result of every goal, and every setpoint stamp. Runs
per way: env PX100_RECORD_RUNS, else 20 with PX100_STRESS=full, else 1 (each run is a bringup
and a script: about 14 s; benchmarks/campaign_record_all.py runs ``record -a`` 20 times against
one bringup).
"""
import json
import os
from pathlib import Path
import subprocess
import sys
import time

from px100_control.bag.calls import CLIENT_CALLS as CALLS, stamp_text
from px100_control.bag.reader import open_bag
import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
RUNS = int(os.environ.get('PX100_RECORD_RUNS', '0') or 0) or (
    20 if os.environ.get('PX100_STRESS', '').lower() == 'full' else 1)
SETPOINTS = 'commands/joint_setpoints'


def _env(**extra):
    env = os.environ.copy()
    env['PYTHONPATH'] = os.pathsep.join([ROOT] + [p for p in env.get('PYTHONPATH', '').split(
        os.pathsep) if p])
    env.update(extra)
    return env


def _answered_calls(bag_dir: str, ns: str) -> dict:
    """
    Return {what: keys of the calls whose request and response are both in the bag}.

    Read with rosbags from the bag's own type definitions. A request is the server's
    REQUEST_RECEIVED event; its response the RESPONSE_SENT event of the same sequence number.
    """
    from rosbags.highlevel import AnyReader
    out = {}
    with AnyReader([Path(bag_dir)]) as reader:
        for what, (service, key) in CALLS.items():
            topic = f'/{ns}/{service}/_service_event'
            conns = [c for c in reader.connections if c.topic == topic]
            requests, responses = {}, set()
            if not conns:       # (rosbags reads every connection when given none)
                out[what] = set()
                continue
            for c, _, raw in reader.messages(conns):
                event = reader.deserialize(raw, c.msgtype)
                seq = event.info.sequence_number
                if event.info.event_type == 1 and len(event.request):
                    requests[seq] = key(event.request[0])
                elif event.info.event_type == 2 and len(event.response):
                    responses.add(seq)
            out[what] = {k for seq, k in requests.items() if seq in responses}
    with open_bag(bag_dir) as bag:
        topic = f'/{ns}/{SETPOINTS}'
        out[SETPOINTS] = {stamp_text(msg.header.stamp) for _, msg in bag.iter_decoded(
            [topic] if topic in bag.topics else [])}
    return out


def _missing(sent: dict, bag_dir: str, ns: str) -> dict:
    sent = dict(sent, results=sent['goals'])   # every goal's result was asked for
    got = _answered_calls(bag_dir, ns)
    return {t: sorted(set(sent[t]) - got[t]) for t in sent if set(sent[t]) - got[t]}


def _run_script(ns, *args, env=None):
    """Run recording_script.py; return (stamps sent per topic, its log lines about recorders)."""
    proc = subprocess.run([sys.executable, os.path.join(HERE, 'recording_script.py'), ns,
                           *args], env=env or _env(), capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    notes = [x for x in proc.stderr.splitlines()
             if 'ecorder' in x or 'Initialized InterbotixRobotXSCore' in x]
    return json.loads(proc.stdout.strip().splitlines()[-1]), notes


def _recorder_notes(output: str) -> list:
    """Return the record process's start and ready lines (their stamps say when)."""
    return [x for x in output.splitlines() if 'recording to' in x or 'ready:' in x]


@pytest.mark.parametrize('way', ['record_process', 'recorder_context',
                                 'record_process_unchanged', 'recorder_context_unchanged'])
def test_every_command_of_the_script_is_in_the_bag(node_process, tmp_path, way):
    """RUNS runs: each bag holds every call (request and reply) and setpoint of the script."""
    ns = f'px100_rec_{os.getpid()}_{way.split("_")[1]}{int(way.endswith("unchanged"))}'
    node_process('bringup', '--no-camera', '--ros-args', '-p', f'robot_name:={ns}')
    complete, failures = 0, []
    t0 = time.monotonic()
    for i in range(RUNS):
        bag = str(tmp_path / f'run{i}')
        if way.startswith('record_process'):
            rec = node_process('record', '-a', '-o', bag, '--ros-args', '-p',
                               f'robot_name:={ns}')
            env = _env(PX100_RECORDER='wait')
            if way.endswith('unchanged'):
                del env['PX100_RECORDER']  # the script and its environment as a user's
            sent, notes = _run_script(ns, env=env)
            time.sleep(0.3)  # the last status / setpoint echoes reach the recorder
            assert rec.stop(timeout=30.0) == 0, rec.output()[-2000:]
            notes += _recorder_notes(rec.output())
        else:
            sent, notes = _run_script(ns, bag,
                                      *(['unchanged'] if way.endswith('unchanged') else []))
        assert all(sent.values()), sent   # goals, a cancel, IK and path calls, setpoints
        missing = _missing(sent, bag, ns)
        if missing:
            failures.append((i, missing, notes))
        else:
            complete += 1
    counts = {t: len(v) for t, v in sent.items()}
    print(f'{way}: {complete} of {RUNS} bags complete (last run sent {counts}; '
          f'{time.monotonic() - t0:.0f} s)')
    for failure in failures:
        print('incomplete run:', *failure, sep='\n  ')
    assert complete == RUNS, failures
