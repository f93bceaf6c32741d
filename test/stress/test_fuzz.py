"""
Fuzz every subscribed topic and every service of sim_driver, ik_service and trajectory_server.

For each input a hypothesis campaign (PX100_STRESS=full: 10,000 inputs; default: a reduced
number so CI runs it) is sent to the real nodes running as processes. After every input: all
processes alive, no NaN/inf/out-of-limit/unknown joint on ``commands/joint_setpoints``,
``trajectory/feedback`` or ``joint_states``; the input got its answer (ik/status, a
trajectory/status entry, a service response). After each campaign: joint_states and ee_pose kept
their rate, and the nodes still serve valid requests.
"""
import json
import os

import pytest

from .harness import full_mode, fuzz, Graph, stress_size
from .targets import driver_works, goal_works, ik_works, make_targets, REDUCED

NODES = ('sim_driver', 'ik_service', 'trajectory_server')
#: joint_states is nominally 100 Hz, ee_pose too; a campaign must keep 80 % of it
MIN_RATE = {'joint_states': 80.0, 'ee_pose': 80.0}
MAX_GAP = 0.5
FIGURES = {}


@pytest.fixture(scope='module')
def graph(module_processes, module_probe):
    """Start the three nodes as processes and wait until the probe sees them."""
    g = Graph(module_processes)
    for n in NODES:
        g.start(n)
    module_probe.wait_ready(NODES, timeout=30.0)
    yield g
    dead = g.dead()
    assert not dead, f'nodes dead at the end of the module: {dead}; deaths: {g.deaths}'


@pytest.fixture(scope='module')
def targets(graph, module_probe, limits):
    """Return every fuzz target, with the parameter names each node declares."""
    params = {n: [p for p in module_probe.list_parameters(n) if p != 'use_sim_time']
              for n in NODES}
    return make_targets(module_probe, limits, params)


def _still_working(probe, limits, model):
    problems = [p for p in (driver_works(probe), ik_works(probe, model),
                            goal_works(probe, limits)) if p]
    return problems


@pytest.mark.parametrize('name', list(REDUCED))
def test_fuzz_target(name, graph, targets, module_probe, limits, model):
    """Fuzz one input: no node dies, nothing invalid reaches the driver, rates hold."""
    target = targets[name]
    count = stress_size(REDUCED[name])
    camp = fuzz(target.strategy, target.send, count, graph, module_probe, name,
                derandomize=not full_mode())
    FIGURES[name] = camp.summary()
    assert camp.tried >= count
    assert not graph.deaths, f'node deaths: {graph.deaths}'
    assert not camp.unanswered, \
        f'{len(camp.unanswered)} of {camp.tried} inputs got no answer, e.g. {camp.unanswered[:3]}'
    for topic, stats in camp.rates.items():
        assert stats['rate'] >= MIN_RATE[topic], f'{topic} rate fell to {stats}'
        assert stats['max_gap'] <= MAX_GAP, f'{topic} stalled: {stats}'
    problems = _still_working(module_probe, limits, model)
    assert not problems, f'after fuzzing {name}: {problems}'
    assert not module_probe.violations, module_probe.violations[:3]


def test_write_figures(graph):
    """Write the figures of this run to out/stress_fuzz.json (for the README table)."""
    out = os.path.join(os.path.dirname(__file__), '..', '..', 'out')
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, 'stress_fuzz.json'), 'w', encoding='utf-8') as f:
        json.dump({'targets': FIGURES, 'deaths': graph.deaths,
                   'restarts': graph.restarts}, f, indent=1)
    assert FIGURES
