"""The Khalil-Dombre equation-type solvers: every solution satisfies, none is missed."""
import math

import numpy as np
from px100_control.kinematics import trig_equations as te
import pytest


def _close_angle(a, b, tol=1e-9):
    return abs(te.wrap_angle(a - b)) < tol


@pytest.fixture
def rng():
    return np.random.default_rng(2002)


def test_wrap_angle_range():
    """Wrapping lands in (-pi, pi] and preserves the angle modulo 2 pi."""
    for q in np.linspace(-20, 20, 401):
        w = te.wrap_angle(q)
        assert -math.pi < w <= math.pi
        assert abs(math.sin(w) - math.sin(q)) < 1e-12 and abs(math.cos(w) - math.cos(q)) < 1e-12
    assert te.wrap_angle(-math.pi) == math.pi


def test_type1():
    """X r = Y; X = 0 has no (unique) solution."""
    assert te.solve_type1(2.0, 1.0) == [0.5]
    assert te.solve_type1(0.0, 1.0) == []


def test_type2_random(rng):
    """Both roots satisfy X s + Y c = Z and the generating angle is among them."""
    for _ in range(2000):
        X, Y = rng.normal(size=2)
        q0 = rng.uniform(-math.pi, math.pi)
        Z = X * math.sin(q0) + Y * math.cos(q0)
        sols = te.solve_type2(X, Y, Z)
        assert 1 <= len(sols) <= 2
        for q in sols:
            assert abs(X * math.sin(q) + Y * math.cos(q) - Z) < 1e-12
        assert any(_close_angle(q, q0, 1e-6) for q in sols)


def test_type2_special_cases():
    """No solution beyond reach, one double root at the boundary, none if X = Y = 0."""
    assert te.solve_type2(1.0, 0.0, 1.5) == []
    sols = te.solve_type2(1.0, 0.0, 1.0)
    assert len(sols) == 1 and _close_angle(sols[0], math.pi / 2)
    assert len(te.solve_type2(1.0, 1.0, math.sqrt(2.0) * (1 + 1e-13))) == 1
    assert te.solve_type2(0.0, 0.0, 0.0) == []
    sols = te.solve_type2(0.0, 2.0, 1.0)  # cos q = 1/2
    assert sorted(round(q, 12) for q in sols) == sorted(round(q, 12) for q in
                                                        (math.pi / 3, -math.pi / 3))


def test_type3_random_and_degenerate(rng):
    """A regular pair has the unique generating angle; a dependent pair falls back to type 2."""
    for _ in range(2000):
        X1, Y1, X2, Y2 = rng.normal(size=4)
        q0 = rng.uniform(-math.pi, math.pi)
        s, c = math.sin(q0), math.cos(q0)
        sols = te.solve_type3(X1, Y1, X1 * s + Y1 * c, X2, Y2, X2 * s + Y2 * c)
        assert len(sols) == 1 and _close_angle(sols[0], q0, 1e-8)
    # seed 002: s3 = xz, -c3 = zz
    q3 = 0.7
    assert _close_angle(te.solve_type3(1, 0, math.sin(q3), 0, -1, -math.cos(q3))[0], q3)
    # dependent equations (second = 2 x first): both type 2 roots survive
    sols = te.solve_type3(1.0, 1.0, 1.0, 2.0, 2.0, 2.0)
    assert len(sols) == 2
    for q in sols:
        assert abs(math.sin(q) + math.cos(q) - 1.0) < 1e-12
    # dependent but inconsistent: none
    assert te.solve_type3(1.0, 1.0, 1.0, 2.0, 2.0, 0.5) == []


def test_type4_random(rng):
    """Both (q, r) and (q + pi, -r) are returned and satisfy the pair."""
    for _ in range(500):
        X1, X2 = rng.uniform(0.5, 2.0, size=2) * rng.choice([-1, 1], size=2)
        q0, r0 = rng.uniform(-math.pi, math.pi), rng.uniform(0.1, 2.0)
        sols = te.solve_type4(X1, X1 * r0 * math.sin(q0), X2, X2 * r0 * math.cos(q0))
        assert len(sols) == 2
        for q, r in sols:
            assert abs(X1 * r * math.sin(q) - X1 * r0 * math.sin(q0)) < 1e-12
            assert abs(X2 * r * math.cos(q) - X2 * r0 * math.cos(q0)) < 1e-12
        assert any(_close_angle(q, q0) and abs(r - r0) < 1e-12 for q, r in sols)


def test_type5_random(rng):
    """Every (q, r) satisfies both equations and the generating pair is found."""
    for _ in range(2000):
        X1, X2 = rng.uniform(0.1, 1.0, size=2)
        Z1, Z2 = rng.normal(size=2)
        q0, r0 = rng.uniform(-math.pi, math.pi), rng.uniform(-1.0, 1.0)
        Y1 = X1 * math.sin(q0) - Z1 * r0
        Y2 = X2 * math.cos(q0) - Z2 * r0
        sols = te.solve_type5(X1, Y1, Z1, X2, Y2, Z2)
        assert 1 <= len(sols) <= 2
        for q, r in sols:
            assert abs(X1 * math.sin(q) - Y1 - Z1 * r) < 1e-9
            assert abs(X2 * math.cos(q) - Y2 - Z2 * r) < 1e-9
        assert any(_close_angle(q, q0, 1e-6) and abs(r - r0) < 1e-6 for q, r in sols)
    assert te.solve_type5(1.0, 0.5, 0.0, 1.0, 0.5, 0.0) == []  # r drops out


def _check_pairs(sols, eqs, gen, tol=1e-9):
    assert sols, 'no solution'
    for qi, qj in sols:
        for e in eqs(qi, qj):
            assert abs(e) < tol
    assert any(_close_angle(qi, gen[0], 1e-6) and _close_angle(qj, gen[1], 1e-6)
               for qi, qj in sols)


def test_type6_random(rng):
    """W s_j = X c_i + Y s_i + Z1, W c_j = X s_i - Y c_i + Z2."""
    for _ in range(1000):
        W, X, Y = rng.normal(size=3)
        qi, qj = rng.uniform(-math.pi, math.pi, size=2)
        Z1 = W * math.sin(qj) - X * math.cos(qi) - Y * math.sin(qi)
        Z2 = W * math.cos(qj) - X * math.sin(qi) + Y * math.cos(qi)

        def eqs(a, b):
            return (W * math.sin(b) - X * math.cos(a) - Y * math.sin(a) - Z1,
                    W * math.cos(b) - X * math.sin(a) + Y * math.cos(a) - Z2)
        _check_pairs(te.solve_type6(W, X, Y, Z1, Z2), eqs, (qi, qj))


def test_type7_random(rng):
    """W1 c_j + W2 s_j = X c_i + Y s_i + Z1, W1 s_j - W2 c_j = X s_i - Y c_i + Z2."""
    for _ in range(1000):
        W1, W2, X, Y = rng.normal(size=4)
        qi, qj = rng.uniform(-math.pi, math.pi, size=2)
        Z1 = W1 * math.cos(qj) + W2 * math.sin(qj) - X * math.cos(qi) - Y * math.sin(qi)
        Z2 = W1 * math.sin(qj) - W2 * math.cos(qj) - X * math.sin(qi) + Y * math.cos(qi)

        def eqs(a, b):
            return (W1 * math.cos(b) + W2 * math.sin(b) - X * math.cos(a) - Y * math.sin(a) - Z1,
                    W1 * math.sin(b) - W2 * math.cos(b) - X * math.sin(a) + Y * math.cos(a) - Z2)
        _check_pairs(te.solve_type7(W1, W2, X, Y, Z1, Z2), eqs, (qi, qj))


def test_type8_random(rng):
    """The planar two-link pair: both elbows, each reproducing (Z1, Z2)."""
    for _ in range(2000):
        X, Y = rng.uniform(0.1, 1.0, size=2)
        qi, qj = rng.uniform(-math.pi, math.pi, size=2)
        Z1 = X * math.cos(qi) + Y * math.cos(qi + qj)
        Z2 = X * math.sin(qi) + Y * math.sin(qi + qj)

        def eqs(a, b):
            return (X * math.cos(a) + Y * math.cos(a + b) - Z1,
                    X * math.sin(a) + Y * math.sin(a + b) - Z2)
        sols = te.solve_type8(X, Y, Z1, Z2)
        assert len(sols) in (1, 2)
        _check_pairs(sols, eqs, (qi, qj), tol=1e-9)
    assert te.solve_type8(1.0, 1.0, 3.0, 0.0) == []  # out of reach
