"""path_timing: times for an IK path that keep every joint within its speed bound."""
import numpy as np
from px100_control.control.path_timing import joint_speed_bounds, path_times
from px100_control.models.registry import load_robot
import pytest


def test_speed_bounds_take_the_smaller_of_the_cap_and_the_urdf_limit():
    """min(cap, limit) per joint; missing (0, inf, nan) limits leave the cap."""
    b = joint_speed_bounds([0.5, 3.0, 0.0, np.inf, np.nan], 1.0)
    assert b.tolist() == [0.5, 1.0, 1.0, 1.0, 1.0]
    for bad in (0.0, -1.0, np.inf, np.nan, '1'):
        with pytest.raises(ValueError):
            joint_speed_bounds([1.0], bad)


def test_times_from_the_start_state():
    """The first point is timed from the start; each segment by its slowest joint."""
    pts = [[0.5, 0.0], [0.5, 0.2], [0.5, 0.2], [1.5, 0.2]]
    t = path_times(pts, [0.0, 0.0], [1.0, 0.5], min_dt=0.01)
    assert t.tolist() == pytest.approx([0.5, 0.9, 0.91, 1.91])


def test_first_point_at_the_start_is_at_zero_without_a_start():
    """Without a start the first point is at t = 0; a point equal to the start too."""
    assert path_times([[0.1], [0.3]], None, [1.0]).tolist() == pytest.approx([0.0, 0.2])
    assert path_times([[0.1], [0.3]], [0.1], [1.0], 0.05).tolist() == pytest.approx([0.0, 0.2])
    assert path_times([], None, [1.0]).size == 0
    with pytest.raises(ValueError):
        path_times([[0.1, 0.2]], None, [1.0])


def test_px100_path_respects_the_urdf_velocity_limits():
    """Random px100 paths: strictly increasing times, no joint above its bound."""
    model = load_robot('px100')
    rng = np.random.default_rng(3)
    lo, hi = model.lower, model.upper
    bounds = joint_speed_bounds(model.velocity_limits, 2.0)
    for _ in range(20):
        q = rng.uniform(lo, hi, size=(15, model.dof))
        start = rng.uniform(lo, hi)
        t = path_times(q, start, bounds, min_dt=0.01)
        dt = np.diff(np.concatenate([[0.0], t]))
        assert np.all(dt >= 0.01 - 1e-12)
        steps = np.abs(np.diff(np.vstack([start, q]), axis=0))
        assert np.all(steps / dt[:, None] <= bounds + 1e-9)
