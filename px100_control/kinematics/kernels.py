"""
Plain-float kernels (math module): the small numeric helpers the hot paths share.

Small fixed-size problems run faster on Python floats than through numpy calls; these are the
one copy of each: angle wrapping (``wrap_array``: its numpy twin for arrays), the Cholesky
factor and solve of a small symmetric positive-definite matrix (nested lists), the quaternion
and the static 'sxyz' Euler angles (roll, pitch, yaw) of a rotation given as rows and back, and
the forward kinematics and geometric Jacobian of a serial chain (product of exponentials).
Units: m, rad.
"""
import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

_TWO_PI = 2.0 * math.pi


def wrap(a: float) -> float:
    """Return the angle a [rad] wrapped to [-pi, pi)."""
    return (a + math.pi) % _TWO_PI - math.pi


def wrap_array(a: np.ndarray) -> np.ndarray:
    """Return the angles a [rad] wrapped to [-pi, pi), as ``wrap`` (floor-based: faster)."""
    return a - _TWO_PI * np.floor((a + math.pi) * (1.0 / _TWO_PI))


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


def euler_sxyz(R) -> Tuple[float, float, float]:
    """
    Return (roll, pitch, yaw) [rad] of a rotation given as 3 rows, R = Rz(yaw) Ry(pitch) Rx(roll).

    The static 'sxyz' convention of ``tf_transformations`` (and URDF's fixed-axis rpy). At
    pitch = +-pi/2 (gimbal lock) roll is set to 0 and yaw absorbs the rest.
    """
    r00, r10, (r20, r21, r22) = R[0][0], R[1][0], R[2][:3]
    cy = math.hypot(r00, r10)
    if cy > 1e-9:
        return math.atan2(r21, r22), math.atan2(-r20, cy), math.atan2(r10, r00)
    return 0.0, math.atan2(-r20, cy), math.atan2(-R[0][1], R[1][1])


def rpy_rows(roll: float, pitch: float, yaw: float) -> List[List[float]]:
    """Return the rotation Rz(yaw) Ry(pitch) Rx(roll) (angles [rad]) as 3 rows of 3 floats."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr]]


# ---------------------------------------------------------------------------------------------
# forward kinematics of a serial chain (product of exponentials)
# ---------------------------------------------------------------------------------------------

def fk_py(c, q: Sequence[float], axes: Optional[list] = None):
    """
    Return (R 3x3 nested lists, p [x, y, z] [m]) of the end effector at q (plain floats).

    c: the chain's plain-float screw data (``iterative.chain(model)``: ``axes``, ``py``, ``MR``,
    ``Mp``). Each revolute joint is T_i = (R_i, (I - R_i) r) about its axis point r; axes along
    a base coordinate axis at q = 0 take the short form of R_i (fewer products), others the
    Rodrigues form of the screw; a prismatic joint translates along v.

    :param axes: (optional) a list that receives one entry per joint, in the base frame at q:
        (omega, point) of a revolute joint (unit axis direction, a point on the axis [m]), or
        (None, v) of a prismatic one (its unit direction); ``fk_jacobian_py`` reads them
    """
    r00 = r11 = r22 = 1.0
    r01 = r02 = r10 = r12 = r20 = r21 = 0.0
    px = py_ = pz = 0.0
    cos, sin = math.cos, math.sin
    for (code, sg, (rx, ry, rz)), (w, v, kv, k2v, rev), th in zip(c.axes, c.py, q):
        if axes is not None:
            if rev:
                wx, wy, wz = w
                axes.append(((r00 * wx + r01 * wy + r02 * wz, r10 * wx + r11 * wy + r12 * wz,
                              r20 * wx + r21 * wy + r22 * wz),
                             (r00 * rx + r01 * ry + r02 * rz + px,
                              r10 * rx + r11 * ry + r12 * rz + py_,
                              r20 * rx + r21 * ry + r22 * rz + pz)))
            else:
                vx, vy, vz = v
                axes.append((None, (r00 * vx + r01 * vy + r02 * vz,
                                    r10 * vx + r11 * vy + r12 * vz,
                                    r20 * vx + r21 * vy + r22 * vz)))
        if code == 3:          # about z: columns 0, 1 turn; d = (I - Rz) r
            t = sg * th
            cs, sn = cos(t), sin(t)
            dx, dy = rx - cs * rx + sn * ry, ry - sn * rx - cs * ry
            px += r00 * dx + r01 * dy
            py_ += r10 * dx + r11 * dy
            pz += r20 * dx + r21 * dy
            r00, r01 = cs * r00 + sn * r01, cs * r01 - sn * r00
            r10, r11 = cs * r10 + sn * r11, cs * r11 - sn * r10
            r20, r21 = cs * r20 + sn * r21, cs * r21 - sn * r20
        elif code == 2:        # about y: columns 0, 2
            t = sg * th
            cs, sn = cos(t), sin(t)
            dx, dz = rx - cs * rx - sn * rz, rz + sn * rx - cs * rz
            px += r00 * dx + r02 * dz
            py_ += r10 * dx + r12 * dz
            pz += r20 * dx + r22 * dz
            r00, r02 = cs * r00 - sn * r02, sn * r00 + cs * r02
            r10, r12 = cs * r10 - sn * r12, sn * r10 + cs * r12
            r20, r22 = cs * r20 - sn * r22, sn * r20 + cs * r22
        elif code == 1:        # about x: columns 1, 2
            t = sg * th
            cs, sn = cos(t), sin(t)
            dy, dz = ry - cs * ry + sn * rz, rz - sn * ry - cs * rz
            px += r01 * dy + r02 * dz
            py_ += r11 * dy + r12 * dz
            pz += r21 * dy + r22 * dz
            r01, r02 = cs * r01 + sn * r02, cs * r02 - sn * r01
            r11, r12 = cs * r11 + sn * r12, cs * r12 - sn * r11
            r21, r22 = cs * r21 + sn * r22, cs * r22 - sn * r21
        elif rev:              # any other axis: R_i = I + s K + cc K^2, K^2 = w w^T - I
            wx, wy, wz = w
            s, cc = sin(th), 1.0 - cos(th)
            ts = th - s
            a00 = 1.0 + cc * (wx * wx - 1.0)
            a11 = 1.0 + cc * (wy * wy - 1.0)
            a22 = 1.0 + cc * (wz * wz - 1.0)
            a01 = cc * wx * wy - s * wz
            a10 = cc * wx * wy + s * wz
            a02 = cc * wx * wz + s * wy
            a20 = cc * wx * wz - s * wy
            a12 = cc * wy * wz - s * wx
            a21 = cc * wy * wz + s * wx
            tx = th * v[0] + cc * kv[0] + ts * k2v[0]
            ty = th * v[1] + cc * kv[1] + ts * k2v[1]
            tz = th * v[2] + cc * kv[2] + ts * k2v[2]
            px, py_, pz = (r00 * tx + r01 * ty + r02 * tz + px,
                           r10 * tx + r11 * ty + r12 * tz + py_,
                           r20 * tx + r21 * ty + r22 * tz + pz)
            r00, r01, r02 = (r00 * a00 + r01 * a10 + r02 * a20, r00 * a01 + r01 * a11
                             + r02 * a21, r00 * a02 + r01 * a12 + r02 * a22)
            r10, r11, r12 = (r10 * a00 + r11 * a10 + r12 * a20, r10 * a01 + r11 * a11
                             + r12 * a21, r10 * a02 + r11 * a12 + r12 * a22)
            r20, r21, r22 = (r20 * a00 + r21 * a10 + r22 * a20, r20 * a01 + r21 * a11
                             + r22 * a21, r20 * a02 + r21 * a12 + r22 * a22)
        else:                  # prismatic: translate along v
            tx, ty, tz = th * v[0], th * v[1], th * v[2]
            px += r00 * tx + r01 * ty + r02 * tz
            py_ += r10 * tx + r11 * ty + r12 * tz
            pz += r20 * tx + r21 * ty + r22 * tz
    # times the home pose M
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = c.MR
    mx, my, mz = c.Mp
    R = [[r00 * m00 + r01 * m10 + r02 * m20, r00 * m01 + r01 * m11 + r02 * m21,
          r00 * m02 + r01 * m12 + r02 * m22],
         [r10 * m00 + r11 * m10 + r12 * m20, r10 * m01 + r11 * m11 + r12 * m21,
          r10 * m02 + r11 * m12 + r12 * m22],
         [r20 * m00 + r21 * m10 + r22 * m20, r20 * m01 + r21 * m11 + r22 * m21,
          r20 * m02 + r21 * m12 + r22 * m22]]
    p = [r00 * mx + r01 * my + r02 * mz + px, r10 * mx + r11 * my + r12 * mz + py_,
         r20 * mx + r21 * my + r22 * mz + pz]
    return R, p


def fk_jacobian_py(c, q: Sequence[float]):
    """
    Return (R, p, Jw, Jv) at q on plain floats: pose (as ``fk_py``) and geometric Jacobian.

    Jw[i], Jv[i]: column i as 3-tuples, the angular velocity [rad/s] and the velocity of the
    end-effector origin [m/s] per unit joint rate, in the base frame: (omega, omega x (p - r))
    of a revolute joint about the axis point r, (0, v) of a prismatic one.
    """
    axes: list = []
    R, p = fk_py(c, q, axes)
    ex, ey, ez = p
    Jw: list = []
    Jv: list = []
    for omega, r in axes:
        if omega is None:
            Jw.append((0.0, 0.0, 0.0))
            Jv.append(r)
            continue
        ox, oy, oz = omega
        dx, dy, dz = ex - r[0], ey - r[1], ez - r[2]
        Jw.append(omega)
        Jv.append((oy * dz - oz * dy, oz * dx - ox * dz, ox * dy - oy * dx))
    return R, p, Jw, Jv
