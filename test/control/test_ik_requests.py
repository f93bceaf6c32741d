"""The ik_service's answers on plain values: parameter checks, status texts, timed paths."""
import numpy as np
from px100_control.control import ik_requests as ik
from px100_control.errors import InvalidInputError
from px100_control.kinematics.se3 import rot_x
from px100_control.kinematics.solve import solve_ik
from px100_control.models.registry import load_robot
import pytest

MODEL = load_robot('px100')
KWARGS = {'method': 'auto', 'tol_position': 1e-6, 'tol_orientation': 1e-6,
          'max_iterations': 200}


@pytest.mark.parametrize('name, value, error', [
    ('orientation_mode', 'sideways', "orientation_mode must be 'pitch' or 'strict', got "
                                     "'sideways'"),
    ('method', 'magic', "method must be one of ('auto', 'analytic', 'dls', 'newton'), got "
                        "'magic'"),
    ('tol_position', 0.0, 'tol_position must be > 0, got 0.0'),
    ('orientation_tolerance', float('inf'), 'orientation_tolerance must be > 0, got inf'),
    ('max_iterations', 2.5, 'max_iterations must be an integer >= 1'),
    ('max_iterations', 0, 'max_iterations must be an integer >= 1'),
    ('min_path_point_time', -1.0, 'min_path_point_time must be >= 0, got -1.0'),
    ('max_path_joint_velocity', 0.0, 'max_path_joint_velocity must be > 0, got 0.0'),
    ('nominal_pose', [0.0, 0.0, 0.0], 'nominal_pose needs 4 finite values, got [0.0, 0.0, 0.0]'),
    ('nominal_pose', [0.0, 0.0, float('nan'), 0.0], 'nominal_pose needs 4 finite values'),
])
def test_bad_parameters_are_named(name, value, error):
    assert ik.parameter_error(name, value, 4).startswith(error)


@pytest.mark.parametrize('name, value', [('orientation_mode', 'strict'), ('method', 'dls'),
                                         ('tol_position', 1e-4), ('max_iterations', 3),
                                         ('nominal_pose', [0.0, 0.1, 0.2, 0.3]),
                                         ('min_path_point_time', 0.0)])
def test_good_parameters_pass(name, value):
    assert ik.parameter_error(name, value, 4) is None


def test_status_values_and_the_dropped_roll_warning():
    T = MODEL.fk(np.array([0.2, -0.3, 0.4, 0.1]))
    T[:3, :3] = T[:3, :3] @ rot_x(0.2)
    res = solve_ik(MODEL, T, mode='pitch', q_seed=np.zeros(4))
    assert res.success
    values = dict(ik.result_values(res, 'pitch'))
    assert values['mode'] == 'pitch' and values['solutions'] == str(len(res.solutions))
    assert float(values['unreachable_roll']) == pytest.approx(res.details['unreachable_roll'],
                                                              abs=1e-3)
    message = ik.solved_message(res, 'pitch', 0.01, 4)
    assert message.startswith('solved (warning: the target roll 0.2 rad')
    assert '4-DOF arm cannot reach were dropped' in message
    assert ik.solved_message(res, 'pitch', 0.5, 4) == 'solved'
    assert ik.solved_message(res, 'full', 0.01, 4) == 'solved'
    assert ik.fmt(1.0) == '1.000e+00' and ik.fmt(float('inf')) == 'inf'


def test_path_targets_name_the_bad_pose_and_refuse_mixed_modes():
    def target(values):
        if not np.all(np.isfinite(values)):
            raise InvalidInputError('pose contains NaN')
        return np.eye(4), 'position' if values[3:] == (0.0, 0.0, 0.0, 0.0) else 'pitch'

    with pytest.raises(InvalidInputError, match='the path has no poses'):
        ik.path_targets([], target)
    with pytest.raises(InvalidInputError, match='pose 1: pose contains NaN'):
        ik.path_targets([(0.1,) * 7, (float('nan'),) * 7], target)
    with pytest.raises(InvalidInputError, match='mixes position-only poses'):
        ik.path_targets([(0.1, 0, 0, 0, 0, 0, 0), (0.1, 0, 0, 0, 0, 0, 1.0)], target)
    targets, mode = ik.path_targets([(0.1, 0, 0, 0, 0, 0, 1.0)] * 3, target)
    assert len(targets) == 3 and mode == 'pitch'


def test_a_path_is_solved_and_timed_within_the_speed_bound():
    seed = np.array(MODEL.sleep, float)
    T0 = MODEL.fk(np.array([0.2, -0.4, 0.6, 0.3]))
    targets = []
    for k in range(6):
        T = T0.copy()
        T[:3, 3] += np.array([0.005, 0.004, -0.003]) * k
        targets.append(T)
    reply = ik.plan_path(MODEL, targets, 'pitch', seed, None, KWARGS, 0.5, 0.01)
    assert reply.ok and reply.message == 'solved' and len(reply.points) == 6
    Q = np.array([q for q, _ in reply.points])
    t = np.array([0.0] + [t for _, t in reply.points])
    steps = np.abs(np.diff(np.vstack([seed, Q]), axis=0))
    assert np.all(np.diff(t) >= 0.01 - 1e-12)
    assert np.all(steps.max(axis=1) / np.diff(t) <= 0.5 + 1e-9)
    for q, T in zip(Q, targets):
        np.testing.assert_allclose(MODEL.fk(q)[:3, 3], T[:3, 3], atol=1e-9)
    assert dict(reply.values)['solved'] == '6'


def test_a_path_stops_at_the_unreachable_pose():
    T0 = MODEL.fk(np.array([0.0, -0.4, 0.6, 0.3]))
    far = T0.copy()
    far[:3, 3] = [0.7, 0.0, 0.1]
    reply = ik.plan_path(MODEL, [T0, T0, T0, far, T0], 'pitch', np.zeros(4), None, KWARGS,
                         1.0, 0.01)
    assert not reply.ok and 'pose 3' in reply.message
    assert dict(reply.values)['failed_index'] == '3' and len(reply.points) == 3
