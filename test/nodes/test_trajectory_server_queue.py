"""
A goal is judged on the joint_states queued for the trajectory server, not on the last one read.

The actions run in a thread of their own (px100_control.ros.trajectory_actions); the server's
joint_states are read by its node's executor. On a loaded machine that executor can lag by more
than ``state_timeout`` while the driver keeps publishing: the goal must read the queued states
and start, not be refused as if the driver had stopped ("the last joint_states are 1.18 s old"
in a parallel CI run). Here the server node runs in-process and its executor is paused by the
test, so the lag is exact.
"""
import threading
import time

from nodes_fake_driver import FakeDriver
from nodes_helpers import TrajectoryClient, wait_for
import pytest

pytestmark = pytest.mark.ros


class PausableSpin:
    """Spin one node in a thread of its own until closed; ``paused`` stops taking work."""

    def __init__(self, node, ctx):
        from rclpy.executors import SingleThreadedExecutor
        self.executor = SingleThreadedExecutor(context=ctx)
        self.executor.add_node(node)
        self.paused = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self):
        while not self._stop.is_set():
            if self.paused.is_set():
                self._stop.wait(0.01)
            else:
                self.executor.spin_once(timeout_sec=0.05)

    def close(self):
        self._stop.set()
        self._thread.join(5.0)
        self.executor.shutdown(timeout_sec=1.0)


def test_a_goal_reads_the_states_queued_behind_a_lagging_executor(ros_ctx, spinner):
    """Executor paused 1.5 s (state_timeout 1 s), driver publishing: the goal SUCCEEDS."""
    from px100_control.ros.trajectory_server_node import TrajectoryServerNode
    from rclpy.parameter import Parameter
    spinner.add(FakeDriver(context=ros_ctx))
    client = spinner.add(TrajectoryClient(context=ros_ctx))
    server = TrajectoryServerNode(context=ros_ctx, parameter_overrides=[
        Parameter('state_timeout', value=1.0), Parameter('goal_time_tolerance', value=1.0)])
    spin = PausableSpin(server, ros_ctx)
    try:
        assert wait_for(client.ready, 30.0), 'no action server'
        assert server.first_state.wait(30.0), 'the server read no joint_states'
        spin.paused.set()
        time.sleep(1.5)   # the lag itself: nothing to wait for
        paused_at = time.monotonic()
        assert wait_for(lambda: client.joint_state[0] > paused_at + 1.4, 5.0), 'driver silent'
        goal = client.send(['waist'], [(1.0, [0.3])])
        assert client.wait_status(goal, 'EXECUTING', 10.0), (
            client.statuses(goal), [d.message for d in client.diagnostics_for(goal)])
        spin.paused.clear()
        assert client.wait_terminal(goal, 15.0) == 'SUCCEEDED', \
            [d.message for d in client.diagnostics_for(goal)]
    finally:
        spin.close()
        server.destroy_node()
