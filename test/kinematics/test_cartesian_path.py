"""End-effector waypoint paths: straight segments, joint steps under the bound, clear errors."""
import math

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.kinematics.cartesian import (CartesianPathError, ee_waypoint_path,
                                                interpolate_pose, plan_ee_waypoints,
                                                step_count)
from px100_control.kinematics.rotations import matrix_to_euler_sxyz
from px100_control.kinematics.se3 import log_so3, rot_x, rot_y, rot_z, transform
from px100_control.models.registry import load_robot
import pytest


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


def _down(x, y, z, pitch=0.6):
    """Return a px100 pose: yaw toward the target azimuth, the given pitch [rad]."""
    return transform(rot_z(math.atan2(y, x)) @ rot_y(pitch), [x, y, z])


WAYPOINTS = [_down(0.20, 0.10, 0.10), _down(0.15, -0.15, 0.05, 1.0), _down(0.25, 0.0, 0.20, 0.0)]


def _on_segment(p, a, b, tol=1e-9):
    ab = b - a
    s = float(np.dot(p - a, ab) / np.dot(ab, ab))
    return -tol <= s <= 1 + tol and np.linalg.norm(a + s * ab - p) < tol


def test_interpolate_pose_geodesic():
    """Geodesic: position linear in s; rotation angle from T0 linear in s, same axis."""
    T0 = transform(rot_x(0.2), [0.1, 0.0, 0.2])
    T1 = transform(rot_z(1.0) @ rot_y(-0.7), [0.3, -0.2, 0.1])
    np.testing.assert_allclose(interpolate_pose(T0, T1, 0.0, 'geodesic'), T0, atol=1e-12)
    np.testing.assert_allclose(interpolate_pose(T0, T1, 1.0, 'geodesic'), T1, atol=1e-12)
    w = log_so3(T0[:3, :3].T @ T1[:3, :3])
    for s in (0.25, 0.5, 0.8):
        T = interpolate_pose(T0, T1, s, 'geodesic')
        np.testing.assert_allclose(T[:3, 3], (1 - s) * T0[:3, 3] + s * T1[:3, 3], atol=1e-12)
        np.testing.assert_allclose(log_so3(T0[:3, :3].T @ T[:3, :3]), s * w, atol=1e-9)


def test_interpolate_pose_rpy_keeps_zero_roll():
    """'rpy': linear roll, pitch, yaw (shortest way round in yaw); zero roll stays zero."""
    T0 = transform(rot_z(3.0) @ rot_y(0.2), [0.1, 0.0, 0.2])
    T1 = transform(rot_z(-3.0) @ rot_y(0.9), [0.3, -0.2, 0.1])
    np.testing.assert_allclose(interpolate_pose(T0, T1, 0.0), T0, atol=1e-12)
    np.testing.assert_allclose(interpolate_pose(T0, T1, 1.0), T1, atol=1e-12)
    for s in (0.25, 0.5, 0.8):
        roll, pitch, yaw = matrix_to_euler_sxyz(interpolate_pose(T0, T1, s)[:3, :3])
        assert abs(roll) < 1e-12
        assert pitch == pytest.approx(0.2 + 0.7 * s)
        assert math.cos(yaw - (3.0 + s * (2 * math.pi - 6.0))) == pytest.approx(1.0)
    with pytest.raises(InvalidInputError, match='orientation'):
        interpolate_pose(T0, T1, 0.5, 'slerp')


def test_interpolate_pose_azimuth_heads_toward_the_position():
    """'azimuth': the yaw of every point is its position's azimuth when both ends' are."""
    T0, T1 = _down(0.2, 0.15, 0.1, 0.4), _down(0.1, -0.2, 0.2, 1.0)
    for s in (0.2, 0.5, 0.9):
        T = interpolate_pose(T0, T1, s, 'azimuth')
        roll, pitch, yaw = matrix_to_euler_sxyz(T[:3, :3])
        assert abs(roll) < 1e-12 and pitch == pytest.approx(0.4 + 0.6 * s)
        assert yaw == pytest.approx(math.atan2(T[1, 3], T[0, 3]))


def test_step_count_is_the_max_joint_distance_over_the_bound():
    """N = ceil(max |dq| / step), at least 1; an exact multiple is not rounded up."""
    assert step_count([0, 0], [0.25, -0.1], 0.1) == 3
    assert step_count([0, 0], [0.2, 0.0], 0.1) == 2
    assert step_count([0, 0], [0, 0], 0.1) == 1


def test_px100_path_is_straight_bounded_and_reaches_every_waypoint(px100):
    """Every point is on its segment, FK reaches it, no joint step exceeds the bound."""
    q0 = np.array(px100.home, float)
    T0 = px100.fk(q0)
    step = 0.05
    path = ee_waypoint_path(px100, q0, WAYPOINTS, step)
    assert len(path.q) == len(path.poses) == sum(path.counts) + 1
    assert path.max_step <= step * (1 + 1e-9)
    assert all(c >= f for c, f in zip(path.counts, path.first_counts))
    starts = [T0[:3, 3]] + [W[:3, 3] for W in WAYPOINTS[:-1]]
    for q, T, k in zip(path.q[1:], path.poses[1:], path.segment[1:]):
        assert _on_segment(T[:3, 3], starts[k], WAYPOINTS[k][:3, 3])
        Tq = px100.fk(q)
        assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 1e-6
        assert px100.within_limits(q)
    ends = np.cumsum(path.counts)
    for k, W in enumerate(WAYPOINTS):
        np.testing.assert_allclose(path.poses[ends[k]], W, atol=1e-12)
        assert np.linalg.norm(px100.fk(path.q[ends[k]])[:3, 3] - W[:3, 3]) < 1e-6


def test_endpoint_count_alone_can_break_the_bound(px100):
    """
    The count from the waypoints' IK alone does not bound mid-segment steps; the plan does.

    Here the straight line swings the waist faster mid-segment than at its ends, so the
    endpoint rule (N = max |dq| / step) leaves a larger step, which refinement removes.
    """
    q0 = np.array(px100.home, float)
    step = 0.05
    calls = []

    def solver(poses, qs):
        calls.append(len(poses))
        from px100_control.kinematics.cartesian import model_path_solver
        return model_path_solver(px100)(poses, qs)

    path = plan_ee_waypoints(solver, q0, px100.fk(q0), WAYPOINTS, step)
    assert path.counts != path.first_counts
    first = plan_ee_waypoints(solver, q0, px100.fk(q0), WAYPOINTS, 10.0)   # one step each
    assert len(first.q) == len(WAYPOINTS) + 1
    assert len(calls) >= 4


def test_seven_dof_full_pose_path():
    """The myArm (7-DOF) follows a line with a turning tool in 'full' mode under the bound."""
    m = load_robot('myarm300pi')
    q0 = np.radians([-12.73, 68.82, -60.13, -81.36, -44.14, -41.83, -55.14])
    T0 = m.fk(q0)
    T1 = transform(T0[:3, :3] @ rot_x(0.3), T0[:3, 3] + [0.0, 0.05, 0.03])
    path = ee_waypoint_path(m, q0, [T1], 0.02, mode='full', orientation='geodesic')
    assert path.max_step <= 0.02 * (1 + 1e-9)
    for q, T in zip(path.q, path.poses):
        assert np.abs(m.fk(q) - T).max() < 1e-6


@pytest.mark.parametrize('kwargs, match', [
    ({'max_joint_step': 0.0}, 'max_joint_step'),
    ({'max_joint_step': float('nan')}, 'max_joint_step'),
    ({'max_joint_step': 'big'}, 'max_joint_step'),
    ({'waypoints': []}, 'no waypoints'),
    ({'waypoints': [np.eye(3)]}, 'waypoint 0'),
    ({'waypoints': [WAYPOINTS[0], np.full((4, 4), np.nan)]}, 'waypoint 1'),
])
def test_bad_input_is_named(px100, kwargs, match):
    """Malformed input raises InvalidInputError naming what was wrong."""
    args = {'waypoints': WAYPOINTS, 'max_joint_step': 0.05}
    args.update(kwargs)
    with pytest.raises(InvalidInputError, match=match):
        ee_waypoint_path(px100, px100.home, args['waypoints'], args['max_joint_step'])


def test_unreachable_waypoint_is_named(px100):
    """A waypoint out of reach: CartesianPathError naming its index."""
    far = _down(0.6, 0.0, 0.1)
    with pytest.raises(CartesianPathError, match='waypoint 1 has no IK solution'):
        ee_waypoint_path(px100, px100.home, [WAYPOINTS[0], far], 0.05)


def test_line_through_the_waist_axis_is_refused(px100):
    """A line through the waist axis needs an unbounded waist step there: refused, not run."""
    a, b = _down(0.15, 0.0, 0.15, 0.3), _down(-0.15, 0.0, 0.15, 0.3)
    with pytest.raises(CartesianPathError):
        ee_waypoint_path(px100, px100.home, [a, b], 0.05, max_points=400)
