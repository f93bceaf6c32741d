"""The plain-float kernels (px100_control.kinematics.kernels) against numpy."""
import math

import numpy as np
from px100_control.kinematics.kernels import (cholesky, cholesky_solve, NotPositiveDefinite,
                                              quaternion_xyzw, wrap, wrap_angle)
from px100_control.kinematics.rotations import quaternion_to_matrix
import pytest


def test_wrap_conventions():
    for a in np.linspace(-20.0, 20.0, 4001):
        w, v = wrap(a), wrap_angle(a)
        assert -math.pi <= w < math.pi and -math.pi < v <= math.pi
        assert abs(math.remainder(w - a, 2 * math.pi)) < 1e-12
        assert abs(math.remainder(v - a, 2 * math.pi)) < 1e-12
    assert wrap(math.pi) == -math.pi and wrap_angle(-math.pi) == math.pi


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
