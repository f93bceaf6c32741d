"""Seed 001's PID experiment (scripts/pid_experiment.py): the table has the seed's pattern."""
import importlib.util
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.fixture(scope='module')
def experiment():
    path = os.path.join(ROOT, 'scripts', 'pid_experiment.py')
    spec = importlib.util.spec_from_file_location('pid_experiment', path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope='module')
def results(experiment):
    return experiment.run_experiment(duration=3.0, integral_duration=15.0)


def test_table_has_the_seed_pattern(experiment, results):
    """P leaves an error, I removes it, more P overshoots, D removes overshoot, settles faster."""
    checks = experiment.pattern_checks(results)
    assert len(checks) == 6
    failed = [claim for claim, holds in checks if not holds]
    assert not failed, experiment.format_table(results)


def test_metrics_of_a_known_response(experiment):
    """step_metrics on synthetic responses: error, overshoot and settling time."""
    import numpy as np
    t = np.linspace(0.0, 4.0, 4001)
    target, step = -0.8, -0.5
    start = target - step
    # first order, time constant 0.2 s, stops 0.01 rad short: no overshoot, settles ~0.78 s
    y = start + (step + 0.01) * (1.0 - np.exp(-t / 0.2))
    sse, over, settle = experiment.step_metrics(t, y, target, step)
    assert sse == pytest.approx(0.01, abs=1e-6)
    assert over == 0.0
    assert settle == pytest.approx(-0.2 * np.log(0.01 / 0.49), abs=2e-3)
    # damped oscillation about the target: overshoot, no steady-state error
    y2 = target - step * np.exp(-3 * t) * np.cos(6 * t)
    sse2, over2, settle2 = experiment.step_metrics(t, y2, target, step)
    assert abs(sse2) < 1e-6
    t_peak = (np.pi - np.arctan(0.5)) / 6                  # first extremum of the decay
    assert over2 == pytest.approx(0.5 * np.exp(-3 * t_peak) * abs(np.cos(6 * t_peak)),
                                  rel=1e-3)
    assert 0.5 < settle2 < 2.0


def test_script_writes_the_png(experiment, results, tmp_path):
    """The plot of the six responses is written."""
    out = tmp_path / 'pid.png'
    experiment.plot(results, str(out))
    assert out.stat().st_size > 10000
    table = experiment.format_table(results)
    assert table.count('\n') == 7 and '| 640 | 0 | 4000 |' in table
