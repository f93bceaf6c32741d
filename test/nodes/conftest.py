"""
Fixtures of the node tests: module-wide rclpy context, executors and node processes.

The nodes under test run as the installed executables (``scripts/setup.sh`` builds them), each
in its own process; the test-side nodes (clients, a fake driver) spin in this process, each in
its own single-threaded executor thread.
"""
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)


class Spinner:
    """Spin test-side nodes, one SingleThreadedExecutor per node in the client's SpinThread."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.items = []

    def add(self, node):
        """Spin node in a thread of its own; return it (a test may destroy its entities)."""
        from px100_control.client.robot import SpinThread
        from rclpy.executors import SingleThreadedExecutor
        ex = SingleThreadedExecutor(context=self.ctx)
        ex.add_node(node)
        self.items.append((node, SpinThread(ex, f'spin_{node.get_name()}').start()))
        return node

    def close(self):
        """Stop every executor and destroy the nodes."""
        for node, spin in self.items:
            spin.stop(timeout=5.0)
            node.destroy_node()
        self.items.clear()


@pytest.fixture(scope='module')
def ros_ctx():
    """Yield an rclpy Context for the whole module."""
    rclpy = pytest.importorskip('rclpy')
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    ctx.try_shutdown()


@pytest.fixture(scope='module')
def spinner(ros_ctx):
    """Yield a Spinner; its nodes are destroyed at the end of the module."""
    sp = Spinner(ros_ctx)
    yield sp
    sp.close()


@pytest.fixture(scope='module')
def processes():
    """Yield a list to append NodeProcess objects to; all are stopped (SIGINT) at the end."""
    procs = []
    yield procs
    killed = []
    for p in procs:
        p.stop()
        if p.killed:
            killed.append(p.name)
    assert not killed, f'processes ignored SIGINT and were killed: {killed}'
