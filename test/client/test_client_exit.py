"""
A script that exits with a client spin loop still running exits with its own status.

Ctrl-C during the robot's construction (``bringup=True``: right after the viewer's "viewer on
http://" line) raised SystemExit between the start of the action link's spin thread and its
registration, so robot_shutdown never stopped it; the daemon thread then woke in rclpy's wait
during interpreter finalization and the process aborted (SIGABRT, "terminate called without an
active exception") instead of exiting 130: 2 of 10 demo runs here. Real processes, real rclpy.
"""
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.ros

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

#: a client component's spin loop, left running by an owner interrupted before it stopped it
LEFT_SPINNING = """
import sys
import rclpy
from rclpy.executors import SingleThreadedExecutor
from px100_control.client.robot import SpinThread
rclpy.init()
node = rclpy.create_node('left_spinning')
executor = SingleThreadedExecutor()
executor.add_node(node)
SpinThread(executor, 'left_spinning').start()
print('spinning', flush=True)
sys.exit(130)
"""


def _exits_130_three_times(script: str, started: str) -> None:
    """Run ``script`` 3 times: it prints ``started``, exits 130 and never aborts."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [ROOT] + [p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep) if p]))
    for run in range(3):
        done = subprocess.run([sys.executable, '-c', script], env=env, text=True,
                              capture_output=True, timeout=60)
        assert started in done.stdout, done.stderr[-2000:]
        assert done.returncode == 130, \
            f'run {run}: exit {done.returncode}, stderr: {done.stderr[-2000:]}'
        assert 'terminate called' not in done.stderr, done.stderr[-2000:]


def test_a_spin_loop_left_running_does_not_abort_the_exit():
    """Exit 130 as asked, no abort, every time (before: SIGABRT in 6 of 6 runs)."""
    _exits_130_three_times(LEFT_SPINNING, 'spinning')


#: a trajectory_server built and never destroyed (its process interrupted while the in-process
#: bringup started): its action servers' own spin thread is running at exit
LEFT_SERVER = """
import sys
import rclpy
from px100_control.ros.trajectory_server_node import TrajectoryServerNode
rclpy.init()
node = TrajectoryServerNode()
print('serving', flush=True)
sys.exit(130)
"""


def test_a_trajectory_server_left_undestroyed_does_not_abort_the_exit():
    """Exit 130, no abort: the actions' spin thread stops at exit (before: SIGABRT)."""
    _exits_130_three_times(LEFT_SERVER, 'serving')
