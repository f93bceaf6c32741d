"""
Plain-float kernels (math module only): the small numeric helpers the hot paths share.

Small fixed-size problems run faster on Python floats than through numpy calls; these are the
one copy of each: angle wrapping, the Cholesky factor and solve of a small symmetric
positive-definite matrix (nested lists), and the quaternion of a rotation given as rows. The
forward-kinematics kernels of a serial chain are ``iterative.fk_py`` / ``fk_jacobian_py``.
"""
import math
from typing import List, Optional, Sequence, Tuple

_TWO_PI = 2.0 * math.pi


def wrap(a: float) -> float:
    """Return the angle a [rad] wrapped to [-pi, pi)."""
    return (a + math.pi) % _TWO_PI - math.pi


def wrap_angle(q: float) -> float:
    """Return q [rad] wrapped to (-pi, pi] (the closed-form solvers' convention)."""
    w = math.remainder(q, _TWO_PI)
    return math.pi if w == -math.pi else w


class NotPositiveDefinite(ArithmeticError):
    """A matrix given to ``cholesky`` has a non-positive pivot."""


def cholesky(A: Sequence[Sequence[float]], floor: Optional[float] = None) -> List[List[float]]:
    """
    Return the lower Cholesky factor L (A = L L^T, nested lists) of a small SPD matrix.

    :param floor: a non-positive pivot becomes this value (damped least squares, where the
        matrix is SPD up to rounding); None raises NotPositiveDefinite instead
    """
    n = len(A)
    L = [[0.0] * n for _ in range(n)]
    for j in range(n):
        Lj = L[j]
        s = A[j][j]
        for k in range(j):
            s -= Lj[k] * Lj[k]
        if s > 0.0:
            d = math.sqrt(s)
        elif floor is not None:
            d = floor
        else:
            raise NotPositiveDefinite(f'pivot {j} is {s:.3g}: the matrix is not positive '
                                      'definite')
        Lj[j] = d
        for i in range(j + 1, n):
            Li = L[i]
            s = A[i][j]
            for k in range(j):
                s -= Li[k] * Lj[k]
            Li[j] = s / d
    return L


def cholesky_solve(L: Sequence[Sequence[float]], b: Sequence[float]) -> List[float]:
    """Return x with L L^T x = b, L from ``cholesky`` (forward and back substitution)."""
    n = len(b)
    y = [0.0] * n
    for i in range(n):
        Li = L[i]
        s = b[i]
        for k in range(i):
            s -= Li[k] * y[k]
        y[i] = s / Li[i]
    x = [0.0] * n
    for i in range(n - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, n):
            s -= L[k][i] * x[k]
        x[i] = s / L[i][i]
    return x


def quaternion_xyzw(R) -> Tuple[float, float, float, float]:
    """Return the unit quaternion (x, y, z, w), w >= 0, of a rotation given as 3 rows of 3."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R[0][:3], R[1][:3], R[2][:3]
    tr = r00 + r11 + r22
    if tr > 0.0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = ((r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s, 0.25 * s)
    elif r00 > r11 and r00 > r22:
        s = 2.0 * math.sqrt(1.0 + r00 - r11 - r22)
        q = (0.25 * s, (r01 + r10) / s, (r02 + r20) / s, (r21 - r12) / s)
    elif r11 > r22:
        s = 2.0 * math.sqrt(1.0 + r11 - r00 - r22)
        q = ((r01 + r10) / s, 0.25 * s, (r12 + r21) / s, (r02 - r20) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + r22 - r00 - r11)
        q = ((r02 + r20) / s, (r12 + r21) / s, 0.25 * s, (r10 - r01) / s)
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if q[3] < 0.0:
        norm = -norm
    return q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm
