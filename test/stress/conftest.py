"""
Fixtures of the stress suite: the nodes as processes (one graph per module) and the probe.

Every test here carries the ``stress`` marker. Sizes: the reduced form by default (CI),
``PX100_STRESS=full`` for the campaign of the issue (10,000 inputs per topic and service).
"""
import pytest


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


@pytest.fixture(scope='module')
def module_processes():
    """
    Return a factory like ``node_process`` whose processes live for the whole module.

    At teardown every process still running is stopped with SIGINT; one that had to be killed
    fails the module.
    """
    from px100_control.tools.processes import NodeProcess
    procs = []

    def _start(name, *args, env=None):
        p = NodeProcess(name, args, env=env)
        procs.append(p)
        return p

    yield _start
    killed = []
    for p in reversed(procs):
        p.stop()
        if p.killed:
            killed.append(p.name)
    assert not killed, f'processes ignored SIGINT and were killed: {killed}'


@pytest.fixture
def probe(limits):
    """Yield a fresh Probe node (own context); closed afterwards."""
    from .harness import Probe
    p = Probe(limits)
    yield p
    p.close()


@pytest.fixture(scope='module')
def module_probe(limits):
    """Yield one Probe for the whole module."""
    from .harness import Probe
    p = Probe(limits)
    yield p
    p.close()
