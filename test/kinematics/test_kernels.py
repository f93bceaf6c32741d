"""The plain-float kernels (px100_control.kinematics.kernels) against numpy."""
import dataclasses
import math

import numpy as np
from px100_control.kinematics.iterative import chain
from px100_control.kinematics.kernels import (cholesky, cholesky_solve, euler_sxyz,
                                              fk_jacobian_py, fk_py, NotPositiveDefinite,
                                              quaternion_xyzw, rpy_rows, wrap, wrap_angle,
                                              wrap_array)
from px100_control.kinematics.poe import fk_space, jacobian_geometric
from px100_control.kinematics.rotations import quaternion_to_matrix
from px100_control.kinematics.se3 import adjoint, rot_x, rot_y, rot_z, transform
from px100_control.models.registry import available_robots, load_robot
import pytest


def test_wrap_conventions():
    for a in np.linspace(-20.0, 20.0, 4001):
        w, v = wrap(a), wrap_angle(a)
        assert -math.pi <= w < math.pi and -math.pi < v <= math.pi
        assert abs(math.remainder(w - a, 2 * math.pi)) < 1e-12
        assert abs(math.remainder(v - a, 2 * math.pi)) < 1e-12
    assert wrap(math.pi) == -math.pi and wrap_angle(-math.pi) == math.pi


def test_wrap_array_is_wrap_on_arrays():
    """Same interval [-pi, pi) as wrap, to rounding; angles already inside come back unchanged."""
    a = np.concatenate([np.linspace(-50.0, 50.0, 100001),
                        [math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 0.0, -0.0, 1e-300]])
    w = wrap_array(a)
    assert np.all(w >= -math.pi) and np.all(w < math.pi)
    assert np.abs(w - np.array([wrap(x) for x in a])).max() < 4e-15
    inside = a[np.abs(a) < math.pi]
    assert np.array_equal(wrap_array(inside), inside)
    assert wrap_array(np.array([math.pi]))[0] == -math.pi


def test_cholesky_matches_numpy_and_refuses_non_spd():
    rng = np.random.default_rng(0)
    for n in range(1, 8):
        B = rng.normal(size=(n, n))
        A = B @ B.T + n * np.eye(n)
        L = np.array(cholesky(A.tolist()))
        np.testing.assert_allclose(L, np.linalg.cholesky(A), atol=1e-12)
        b = rng.normal(size=n)
        np.testing.assert_allclose(cholesky_solve(L.tolist(), b.tolist()),
                                   np.linalg.solve(A, b), atol=1e-10)
    with pytest.raises(NotPositiveDefinite, match='pivot 1'):
        cholesky([[1.0, 2.0], [2.0, 1.0]])
    assert cholesky([[0.0]], floor=1e-150) == [[1e-150]]


def test_rpy_rows_is_the_product_of_the_three_rotations():
    rng = np.random.default_rng(2)
    for r, p, y in rng.uniform(-4.0, 4.0, size=(300, 3)):
        np.testing.assert_allclose(rpy_rows(r, p, y), rot_z(y) @ rot_y(p) @ rot_x(r),
                                   atol=2e-16)


def test_euler_sxyz_inverts_rpy_rows_also_at_gimbal_lock():
    """In range angles come back; at pitch +-pi/2 roll is 0 and the rotation is kept."""
    rng = np.random.default_rng(3)
    for r, p, y in rng.uniform(-1.0, 1.0, size=(300, 3)) * [math.pi, math.pi / 2, math.pi]:
        np.testing.assert_allclose(euler_sxyz(rpy_rows(r, p, y)), (r, p, y), atol=1e-12)
    for p in (math.pi / 2, -math.pi / 2, math.pi / 2 - 1e-12):
        for r, y in ((0.3, -1.0), (-2.0, 2.5), (0.0, 0.0)):
            R = rpy_rows(r, p, y)
            r2, p2, y2 = euler_sxyz(R)
            assert r2 == 0.0 and abs(p2 - p) < 1e-11
            np.testing.assert_allclose(rpy_rows(r2, p2, y2), R, atol=1e-11)


def test_quaternion_round_trip():
    rng = np.random.default_rng(1)
    special = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1), (1, 1, 0, 0))
    for q in list(rng.normal(size=(500, 4))) + [np.array(v, float) for v in special]:
        q = q / np.linalg.norm(q)
        q = q if q[3] >= 0 else -q
        got = quaternion_xyzw(quaternion_to_matrix(*q).tolist())
        assert abs(math.fsum(x * x for x in got) - 1.0) < 1e-12 and got[3] >= 0.0
        np.testing.assert_allclose(quaternion_to_matrix(*got), quaternion_to_matrix(*q),
                                   atol=1e-12)


def _fk_models():
    """Every registered robot and a px100 on a tilted base (no joint axis along x, y or z)."""
    models = [load_robot(name) for name in available_robots()]
    px100 = models[available_robots().index('px100')]
    T = transform(rot_z(0.3) @ rot_x(0.7), [0.05, -0.1, 0.2])
    models.append(dataclasses.replace(px100, name='px100_tilted',
                                      S_list=adjoint(T) @ px100.S_list, M=T @ px100.M))
    return models


@pytest.mark.parametrize('model', _fk_models(), ids=lambda m: m.name)
def test_fk_kernels_match_the_product_of_exponentials(model):
    """fk_py / fk_jacobian_py equal poe.py's FK and geometric Jacobian (every joint kind)."""
    c = chain(model)
    codes = {code for code, _, _ in c.axes}
    if model.name == 'px100_tilted':
        assert codes == {0}
    if model.name == 'rrrp':
        assert -1 in codes
    for q in model.random_configurations(50, np.random.default_rng(5)):
        ql = q.tolist()
        R, p = fk_py(c, ql)
        T = fk_space(model.S_list, model.M, q)
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-14)
        np.testing.assert_allclose(p, T[:3, 3], atol=1e-14)
        R2, p2, Jw, Jv = fk_jacobian_py(c, ql)
        assert R2 == R and p2 == p
        Jg = jacobian_geometric(model.S_list, model.M, q)      # rows [v; omega]
        np.testing.assert_allclose(np.array(Jw).T, Jg[3:], atol=1e-14)
        np.testing.assert_allclose(np.array(Jv).T, Jg[:3], atol=1e-14)
