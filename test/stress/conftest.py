"""
Fixtures of the stress suite: the nodes as processes (one graph for the package) and the probe.

Every test here carries the ``stress`` marker. Sizes: the reduced form by default (CI),
``PX100_STRESS=full`` for the campaign of the issue (10,000 inputs per topic and service).
"""
import os

import pytest

from .harness import SHARED_PROCESS_ENV

NODES = ('sim_driver', 'ik_service', 'trajectory_server')


def pytest_collection_modifyitems(config, items):
    """Mark every test of this directory ``stress`` (and ``ros``)."""
    for item in items:
        if '/stress/' in str(item.fspath).replace('\\', '/'):
            item.add_marker(pytest.mark.stress)
            item.add_marker(pytest.mark.ros)


@pytest.fixture(scope='module')
def model():
    """Return the px100 RobotModel."""
    from px100_control.models.registry import load_robot
    return load_robot('px100')


@pytest.fixture(scope='module')
def limits(model):
    """Return the monitor's joint facts."""
    from .harness import Limits
    return Limits.from_model(model)


@pytest.fixture(scope='package')
def stress_processes():
    """
    Return a factory like ``node_process`` whose processes live for the stress package.

    At teardown every process still running is stopped with SIGINT; one that had to be killed
    fails the package.
    """
    from px100_control.tools.processes import NodeProcess
    procs = []

    def _start(name, *args, env=None):
        p = NodeProcess(name, args, env=dict(env or os.environ, **SHARED_PROCESS_ENV))
        procs.append(p)
        return p

    yield _start
    killed = []
    for p in reversed(procs):
        p.stop()
        if p.killed:
            killed.append(p.name)
    assert not killed, f'processes ignored SIGINT and were killed: {killed}'


@pytest.fixture(scope='package')
def stress_probe():
    """Yield one Probe (the test's own node, own context) for the stress package."""
    from px100_control.models.registry import load_robot

    from .harness import Limits, Probe
    p = Probe(Limits.from_model(load_robot('px100')))
    yield p
    p.close()


@pytest.fixture(scope='package')
def stress_graph(stress_processes, stress_probe):
    """
    Start sim_driver, ik_service and trajectory_server once for the stress modules.

    Package scope: the graph (namespace px100, default scene) is stopped after the last stress
    module; a later module in the same domain would otherwise have a second driver.
    """
    from .harness import Graph
    g = Graph(stress_processes)
    for n in NODES:
        g.start(n)
    stress_probe.wait_ready(NODES, timeout=60.0)
    return g


@pytest.fixture(scope='module')
def module_probe(stress_probe):
    """Return the package's probe."""
    return stress_probe


@pytest.fixture(scope='module')
def graph(stress_graph, stress_probe):
    """Return the package's graph with every node running (dead ones restarted, recorded)."""
    stress_graph.revive(stress_probe, cause='dead at the start of a stress module')
    return stress_graph
