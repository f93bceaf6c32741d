"""
The exit watchdog (px100_control/tools/exit_watchdog.py) in child processes of its own.

A child that hangs holding the GIL inside the block (as the main thread of a process whose
Fast DDS participant teardown deadlocked does) must end with the status given, soon after the
bound, naming the hang on stderr; a block that ends in time disarms it.
"""
import subprocess
import sys
import textwrap
import time

import pytest

ROOT = __file__.rsplit('/test/', 1)[0]
CHILD = textwrap.dedent("""
    import ctypes, sys, time
    sys.path.insert(0, {root!r})
    from px100_control.tools.exit_watchdog import exit_watchdog
    with exit_watchdog(0.3, {status}) as armed:
        print('armed', armed, flush=True)
        if {hang}:
            ctypes.PyDLL(None).sleep(20)     # a C call that keeps the GIL
    time.sleep(0.8)                          # past the bound: a disarmed watchdog stays quiet
    sys.exit(3)
""")


def _child(status, hang):
    t0 = time.monotonic()
    out = subprocess.run([sys.executable, '-c', CHILD.format(root=ROOT, status=status,
                                                             hang=hang)],
                         capture_output=True, text=True, timeout=30)
    return out, time.monotonic() - t0


@pytest.mark.skipif(not sys.platform.startswith('linux'), reason='POSIX timers of glibc')
@pytest.mark.parametrize('status', [0, 7])
def test_a_hang_ends_with_the_status_given_and_a_line(status):
    out, took = _child(status, True)
    assert out.stdout.strip() == 'armed True', out
    assert out.returncode == status, out
    assert 'participant teardown hung' in out.stderr, out
    assert took < 10.0, took                  # not the 20 s sleep


@pytest.mark.skipif(not sys.platform.startswith('linux'), reason='POSIX timers of glibc')
def test_a_block_that_ends_in_time_disarms_it():
    out, _ = _child(0, False)
    assert out.returncode == 3 and 'hung' not in out.stderr, out


NODE_PROCESS = textwrap.dedent("""
    import ctypes, sys
    sys.path.insert(0, {root!r})
    import rclpy
    from rclpy.node import Node
    from px100_control.ros import common
    destroy = Node.destroy_node

    def hang_in_the_keeper(node):     # the participant's destruction, deadlocked as Fast DDS can
        if node.get_name().startswith(common.TEARDOWN_KEEPER):
            ctypes.PyDLL(None).sleep(30)
        return destroy(node)

    Node.destroy_node = hang_in_the_keeper
    print('run_nodes returned', common.run_nodes(lambda: [rclpy.create_node('wd_probe')],
                                                 ['wd'], done=lambda nodes: True))
""")


@pytest.mark.ros
@pytest.mark.skipif(not sys.platform.startswith('linux'), reason='POSIX timers of glibc')
def test_a_node_process_whose_participant_teardown_hangs_still_ends_cleanly():
    """run_nodes: the nodes go first, then only the keeper's (participant's) teardown hangs."""
    t0 = time.monotonic()
    out = subprocess.run([sys.executable, '-c', NODE_PROCESS.format(root=ROOT)],
                         capture_output=True, text=True, timeout=60)
    took = time.monotonic() - t0
    assert out.returncode == 0, out
    assert 'participant teardown hung' in out.stderr, out
    assert 'run_nodes returned' not in out.stdout, out      # ended inside the teardown
    assert took < 20.0, took
