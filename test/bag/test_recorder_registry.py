"""The recorder registry: entries per DDS domain, what each records, stale entries dropped."""
import os
import subprocess
import sys

from px100_control.ros import recorder_registry as reg


def test_entries_per_domain_and_what_they_record(monkeypatch, tmp_path):
    """An entry is seen in its domain only, says which topics it records, and is removed."""
    monkeypatch.setattr(reg.tempfile, 'gettempdir', lambda: str(tmp_path))
    monkeypatch.setenv('ROS_DOMAIN_ID', '7')
    robot_only = reg.register('/px100', True, False, [], '/bags/a')
    every = reg.register('/px100', True, True, [], '/bags/b')
    named = reg.register('/arm_1', False, False, ['/arm_2/commands/joint_setpoints'], '/bags/c')
    entries = {e['output']: e for e in reg.running()}
    assert set(entries) == {'/bags/a', '/bags/b', '/bags/c'}
    assert reg.records(entries['/bags/a'], '/px100/commands/joint_setpoints')
    assert not reg.records(entries['/bags/a'], '/arm_1/commands/joint_setpoints')
    assert reg.records(entries['/bags/b'], '/arm_1/commands/joint_setpoints')
    assert reg.records(entries['/bags/c'], '/arm_2/commands/joint_setpoints')
    assert not reg.records(entries['/bags/c'], '/arm_1/compute_ik/_service_event')
    assert reg.running(exclude_pid=os.getpid()) == []
    monkeypatch.setenv('ROS_DOMAIN_ID', '8')
    assert reg.running() == []
    monkeypatch.setenv('ROS_DOMAIN_ID', '7')
    for path in (robot_only, every, named):
        reg.unregister(path)
    assert reg.running() == []
    reg.unregister(robot_only)  # twice: no error


def test_entry_of_a_dead_process_is_dropped(monkeypatch, tmp_path):
    """A recorder killed without closing (SIGKILL) leaves an entry: ignored and removed."""
    monkeypatch.setattr(reg.tempfile, 'gettempdir', lambda: str(tmp_path))
    monkeypatch.setenv('ROS_DOMAIN_ID', '7')
    code = ('import tempfile, sys; tempfile.gettempdir = lambda: sys.argv[1]; '
            'from px100_control.ros import recorder_registry as r; '
            "print(r.register('/px100', True, True, [], '/bags/dead'))")
    path = subprocess.run([sys.executable, '-c', code, str(tmp_path)], capture_output=True,
                          text=True, check=True,
                          env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
                          ).stdout.strip()
    assert os.path.isfile(path)
    assert reg.running() == []
    assert not os.path.exists(path)
