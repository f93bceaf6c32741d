"""
Recordings lose nothing: every goal, IK request and setpoint of a script is in its bag.

A client script (recording_script.py) runs repeatedly against a bringup in its own namespace,
recorded (a) by ``record -a`` started just before it and (b) by ``with Recorder(dir)`` inside
it; each way with the client told about the recorder (env PX100_RECORDER=wait, recorder=rec)
and with the script unchanged (the client finds the recorder itself). Each run's bag must hold
every stamp the script published. Runs per way: env PX100_RECORD_RUNS, else 20 with
PX100_STRESS=full, else 3.
"""
import json
import os
import subprocess
import sys
import time

from px100_control.bag.reader import open_bag
import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
RUNS = int(os.environ.get('PX100_RECORD_RUNS', '0') or 0) or (
    20 if os.environ.get('PX100_STRESS', '').lower() == 'full' else 3)
TOPICS = ('trajectory/goal', 'ik/request', 'commands/joint_setpoints')


def _env(**extra):
    env = os.environ.copy()
    env['PYTHONPATH'] = os.pathsep.join([ROOT] + [p for p in env.get('PYTHONPATH', '').split(
        os.pathsep) if p])
    env.update(extra)
    return env


def _bag_stamps(bag_dir: str, ns: str) -> dict:
    out = {t: set() for t in TOPICS}
    with open_bag(bag_dir) as bag:
        present = [f'/{ns}/{t}' for t in TOPICS if f'/{ns}/{t}' in bag.topics]
        for raw, msg in bag.iter_decoded(present):
            stamp = msg.header.stamp
            out[raw.topic[len(ns) + 2:]].add(f'{stamp.sec}.{stamp.nanosec:09d}')
    return out


def _missing(sent: dict, bag_dir: str, ns: str) -> dict:
    got = _bag_stamps(bag_dir, ns)
    return {t: sorted(set(sent[t]) - got[t]) for t in TOPICS if set(sent[t]) - got[t]}


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
    """RUNS runs: each bag holds all goals, IK requests and setpoints the script sent."""
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
        assert all(sent[t] for t in TOPICS), sent
        missing = _missing(sent, bag, ns)
        if missing:
            failures.append((i, missing, notes))
        else:
            complete += 1
    counts = {t: len(sent[t]) for t in TOPICS}
    print(f'{way}: {complete} of {RUNS} bags complete (last run sent {counts}; '
          f'{time.monotonic() - t0:.0f} s)')
    for failure in failures:
        print('incomplete run:', *failure, sep='\n  ')
    assert complete == RUNS, failures
