"""Seed 001's PID experiment (scripts/pid_experiment.py): pattern, settling, plants, reasons."""
import dataclasses

import pytest
from scripts_support import load_script

#: runs scripts/pid_experiment.py (twelve simulated step responses): not in the quick tier
pytestmark = pytest.mark.slow


@pytest.fixture(scope='module')
def experiment():
    return load_script('pid_experiment')


@pytest.fixture(scope='module')
def results(experiment):
    return experiment.run_experiment(duration=4.0, integral_duration=8.0)


@pytest.fixture(scope='module')
def tuned(experiment):
    return experiment.run_experiment(duration=4.0, integral_duration=8.0,
                                     plant=experiment.TUNED)


def test_table_has_the_seed_pattern(experiment, results, tuned):
    """
    P leaves an error, I removes it, more P overshoots, D removes overshoot (both plants).

    D shortens settling on the tuned plant only: on the physical one the D runs settle later
    than Kp 640 alone, and the check says so with the table's own numbers.
    """
    for runs in (results, tuned):
        assert all(r.settled for r in runs), experiment.format_table(runs)
        checks = experiment.pattern_checks(runs)
        assert len(checks) == 6
        failed = [claim for claim, holds in checks[:5] if not holds]
        assert not failed, experiment.format_table(runs)
    for runs in (results, tuned):
        claim, holds = experiment.pattern_checks(runs)[5]
        p640, d2000, d4000 = runs[2], runs[4], runs[5]
        assert holds == (max(d2000.settling_time, d4000.settling_time)
                         < p640.settling_time), claim
        for r in (p640, d2000, d4000):
            assert f'{r.settling_time:.2f} s' in claim, claim
        assert claim.endswith(': shorter)') == holds, claim
    assert experiment.pattern_checks(tuned)[5][1], experiment.format_table(tuned)


def test_tuned_plant_is_closer_to_the_table(experiment, results, tuned):
    """The tuned plant lands near the table; the demo's physical plant is far from it."""
    assert experiment.score(tuned) < 1.5 < 20.0 < experiment.score(results)
    cells = experiment.penalties(tuned)
    assert sum(v > 0 for v in cells.values()) <= 8
    assert max(cells.values()) < 0.5, cells
    # only the experiment's simulator changed: a default simulator is the physical plant
    from px100_control.sim.simulator import ArmSimulator
    model = experiment.load_robot('px100')
    sim = ArmSimulator(model)
    assert sim.friction == [0.1] * 4 and sim.damping == [0.1] * 4
    physical = experiment.Plant('shoulder', 0.5, 0.1, 0.1, sim.servos[0].armature)
    assert experiment.PHYSICAL.resolved(model) == physical


def test_every_gap_has_a_reason_from_the_run(experiment, results, tuned):
    """Each difference from the table is explained by the run's own numbers."""
    for runs in (results, tuned):
        for r in runs:
            for metric, (doc, tol) in zip(experiment.METRICS,
                                          experiment.SEED_NUMBERS[r.gains]):
                value = experiment.metric_value(r, metric)
                if abs(value - doc) > tol:
                    assert experiment.explain(r, metric), (r.gains, metric, value)


def test_a_reason_the_numbers_do_not_bear_out_is_refused(experiment, results):
    """A torque balance that does not close, an overshoot past its bound: no explanation."""
    p100 = results[0]
    assert 'friction' in experiment.explain(p100, 'steady-state error')
    wrong = dataclasses.replace(p100, balance=dict(p100.balance, friction=0.0))
    assert experiment.explain(wrong, 'steady-state error') == ''
    p1600 = results[3]
    assert experiment.explain(p1600, 'overshoot')
    assert experiment.explain(dataclasses.replace(p1600, overshoot=0.3), 'overshoot') == ''
    fast = dataclasses.replace(p1600, settling_time=0.05)
    assert experiment.explain(fast, 'settling time') == ''


def test_a_run_still_moving_has_not_settled(experiment):
    """A response cut while the joint still moves reports no error and no settling time."""
    import numpy as np
    t = np.linspace(0.001, 2.5, 2500)
    y = -0.5 - 0.5 * (1.0 - np.exp(-t / 1.5))            # tau 1.5 s, cut at 2.5 s
    sse, over, settle = experiment.step_metrics(t, y, -1.0, -0.5)
    assert sse is None and settle is None and over == 0.0
    t = np.linspace(0.001, 12.0, 12000)
    y = -0.5 - 0.5 * (1.0 - np.exp(-t / 1.5))
    sse, over, settle = experiment.step_metrics(t, y, -1.0, -0.5)
    assert sse == pytest.approx(0.0, abs=1e-3) and 5.0 < settle < 7.0


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
    experiment.plot([('physical', results)], str(out))
    assert out.stat().st_size > 10000
    table = experiment.format_table(results)
    assert table.count('\n') == 7 and '| 640 | 0 | 4000 |' in table
