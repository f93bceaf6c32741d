"""
Iterative IK for any serial chain (PoE model): damped least squares and Newton-Raphson.

A ``Task`` ('full' pose, 'axis' = position + tool x axis direction, or 'position'; see
``solve.make_task``) gives an error e(q) and Jacobian J(q) in the base frame, rows
[orientation (rad); position (m)]. Damped least squares with a null-space task::

    q+ = q + alpha J# e + beta (I - J# J) g(q),   J# = J^T (J J^T + lambda^2 I)^-1

with the secondary task g toward q_nominal ('nominal') or away from the joint limits ('limits').
Newton-Raphson: dq = pinv(J) e, step norm limited to 0.5 rad, then projected onto the
joint limits. Both return an ``IkResult``.

The single-configuration loops run on plain Python floats (small chains: a numpy call costs
more than the arithmetic) over the FK and Jacobian kernels ``kernels.fk_py`` /
``fk_jacobian_py`` and this module's ``chain`` data; ``fk_batch`` is the vectorised numpy FK
for many configurations.
Units: m, rad.
"""
from dataclasses import dataclass
import functools
import math
from operator import mul
from typing import List, Optional, Tuple

import numpy as np

from px100_control.kinematics.ik_types import IkResult
from px100_control.kinematics.kernels import cholesky, cholesky_solve, fk_jacobian_py
from px100_control.kinematics.se3 import log_se3

Vec = List[float]
_TWO_PI = 2.0 * math.pi
_LM_FACTOR = 0.01        # Levenberg-Marquardt damping lambda^2 += factor * |e|^2 (see solve_dls)


@dataclass(frozen=True)
class Chain:
    """Precomputed screw data of a model (numpy arrays and plain-float tuples)."""

    n: int
    w: np.ndarray         # (n, 3) unit axes (zero rows for prismatic joints)
    v: np.ndarray         # (n, 3)
    M: np.ndarray         # (4, 4)
    lower: np.ndarray
    upper: np.ndarray
    K: np.ndarray         # (n, 3, 3) skew(w)
    K2: np.ndarray        # (n, 3, 3) skew(w)^2
    Kv: np.ndarray        # (n, 3) w x v
    K2v: np.ndarray       # (n, 3) w x (w x v)
    py: tuple             # per joint (w, v, w x v, w x (w x v), revolute) as float tuples
    MR: tuple             # M rotation rows
    Mp: tuple             # M translation
    lo: tuple             # limits as floats
    hi: tuple
    wraps: tuple          # revolute joints whose range is (almost) a full turn
    axes: tuple = ()      # per joint (axis code, sign, point on the axis) for kernels.fk_py


@functools.lru_cache(maxsize=64)
def chain(model) -> Chain:
    """Return the cached screw data of a model."""
    S = np.asarray(model.S_list, dtype=float)
    w, v = S[:3].T.copy(), S[3:].T.copy()
    n = w.shape[0]
    K = np.zeros((n, 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 0] = -w[:, 2], w[:, 1], w[:, 2]
    K[:, 1, 2], K[:, 2, 0], K[:, 2, 1] = -w[:, 0], -w[:, 1], w[:, 0]
    K2 = K @ K
    Kv = np.einsum('nij,nj->ni', K, v)
    K2v = np.einsum('nij,nj->ni', K2, v)
    revolute = [t != 'prismatic' for t in model.joint_types]
    py = tuple((tuple(w[i].tolist()), tuple(v[i].tolist()), tuple(Kv[i].tolist()),
                tuple(K2v[i].tolist()), revolute[i]) for i in range(n))
    M = np.asarray(model.M, float)
    return Chain(n=n, w=w, v=v, M=M, lower=np.asarray(model.lower, float),
                 upper=np.asarray(model.upper, float), K=K, K2=K2, Kv=Kv, K2v=K2v, py=py,
                 MR=tuple(tuple(r) for r in M[:3, :3].tolist()), Mp=tuple(M[:3, 3].tolist()),
                 lo=tuple(float(x) for x in model.lower), hi=tuple(float(x) for x in model.upper),
                 wraps=tuple(revolute[i] and float(model.upper[i] - model.lower[i])
                             >= _TWO_PI - 1e-3 for i in range(n)),
                 axes=tuple(_axis_code(w[i], Kv[i], revolute[i]) for i in range(n)))


def _axis_code(w: np.ndarray, r: np.ndarray, revolute: bool) -> tuple:
    """
    Return (code, sign, (rx, ry, rz)) of a joint for ``kernels.fk_py``.

    code 1, 2, 3: a revolute axis along +-x, +-y, +-z (sign) through the point r = w x v;
    0: any other revolute axis; -1: prismatic.
    """
    point = tuple(float(x) for x in r)
    if not revolute:
        return -1, 1.0, point
    k = int(np.argmax(np.abs(w)))
    if abs(abs(w[k]) - 1.0) < 1e-15 and all(abs(w[i]) < 1e-15 for i in range(3) if i != k):
        return k + 1, float(np.sign(w[k])), point
    return 0, 1.0, point


# ---------------------------------------------------------------------------------------------
# forward kinematics and Jacobian
# ---------------------------------------------------------------------------------------------

def fk_and_jacobian(c: Chain, q) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return (T (4, 4), J (6, n)) at q: pose and geometric Jacobian as numpy arrays.

    J rows are [omega (rad/s); velocity of the end-effector origin (m/s)] in the base frame.
    """
    R, p, Jw, Jv = fk_jacobian_py(c, [float(x) for x in q])
    T = np.array([R[0] + [p[0]], R[1] + [p[1]], R[2] + [p[2]], [0.0, 0.0, 0.0, 1.0]])
    J = np.empty((6, c.n))
    J[:3] = np.array(Jw).T
    J[3:] = np.array(Jv).T
    return T, J


def fk_batch(c: Chain, Q: np.ndarray) -> np.ndarray:
    """Return (k, 4, 4) end-effector poses of k configurations Q (k, n), vectorised."""
    Q = np.asarray(Q, dtype=float)
    k, n = Q.shape
    s = np.sin(Q)[:, :, None, None]
    cc = (1.0 - np.cos(Q))[:, :, None, None]
    rev = np.array([j[4] for j in c.py], dtype=float)[None, :, None, None]
    E = np.zeros((k, n, 4, 4))
    E[:, :, :3, :3] = np.eye(3) + rev * (s * c.K + cc * c.K2)
    E[:, :, :3, 3] = (Q[:, :, None] * c.v + cc[:, :, :, 0] * c.Kv
                      + (Q[:, :, None] - s[:, :, :, 0]) * c.K2v) * rev[:, :, :, 0] + (
        Q[:, :, None] * c.v) * (1.0 - rev[:, :, :, 0])
    E[:, :, 3, 3] = 1.0
    T = E[:, 0]
    for i in range(1, n):
        T = T @ E[:, i]
    return T @ c.M


# ---------------------------------------------------------------------------------------------
# tasks
# ---------------------------------------------------------------------------------------------

def _rotation_vector(E) -> Vec:
    """Return the rotation vector (axis * angle) of a 3x3 rotation given as nested lists."""
    a0, a1, a2 = E[2][1] - E[1][2], E[0][2] - E[2][0], E[1][0] - E[0][1]
    s2 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)       # 2 sin(theta)
    cos_t = 0.5 * (E[0][0] + E[1][1] + E[2][2] - 1.0)
    theta = math.atan2(0.5 * s2, cos_t)
    if theta < 1e-6:
        return [0.5 * a0, 0.5 * a1, 0.5 * a2]
    if math.pi - theta < 1e-4:
        # near pi: axis from the symmetric part, sign from the antisymmetric one
        B = [[0.5 * (E[r][k] + E[k][r]) + (1.0 if r == k else 0.0) for k in range(3)]
             for r in range(3)]
        i = max(range(3), key=lambda k: B[k][k])
        col = [B[0][i], B[1][i], B[2][i]]
        norm = math.sqrt(sum(x * x for x in col))
        axis = [x / norm for x in col]
        if axis[0] * a0 + axis[1] * a1 + axis[2] * a2 < 0:
            axis = [-x for x in axis]
        return [x * theta for x in axis]
    k = theta / s2
    return [a0 * k, a1 * k, a2 * k]


@dataclass
class Task:
    """
    An IK task: target position ``p`` (3,) [m] and rotation ``R`` (3, 3); ``kind`` says what.

    is constrained: 'full' the whole rotation, 'axis' only the tool x axis direction R[:, 0]
    (the pitch of a <= 4-DOF arm), 'position' none.
    """

    p: np.ndarray
    R: np.ndarray
    kind: str

    def __post_init__(self):
        """Cache plain-float copies."""
        self._p = np.asarray(self.p, dtype=float).reshape(3).tolist()
        self._R = np.asarray(self.R, dtype=float).reshape(3, 3).tolist()
        self._d = [self._R[0][0], self._R[1][0], self._R[2][0]]

    @property
    def dim(self) -> int:
        """Return the number of task rows."""
        return 3 if self.kind == 'position' else 6

    def pose(self) -> np.ndarray:
        """Return the target as a (4, 4) pose."""
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = self.R, self.p
        return T

    def errors_py(self, R, p) -> Tuple[float, float]:
        """Return (position error [m], orientation error [rad]) of a pose (nested lists)."""
        tp = self._p
        dp = math.sqrt((tp[0] - p[0]) ** 2 + (tp[1] - p[1]) ** 2 + (tp[2] - p[2]) ** 2)
        if self.kind == 'position':
            return dp, 0.0
        if self.kind == 'axis':
            d = self._d
            x0, x1, x2 = R[0][0], R[1][0], R[2][0]
            c0, c1, c2 = x1 * d[2] - x2 * d[1], x2 * d[0] - x0 * d[2], x0 * d[1] - x1 * d[0]
            return dp, math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2),
                                  x0 * d[0] + x1 * d[1] + x2 * d[2])
        tR = self._R
        # E = R^T R_t
        E = [[R[0][i] * tR[0][j] + R[1][i] * tR[1][j] + R[2][i] * tR[2][j] for j in range(3)]
             for i in range(3)]
        s = 0.5 * math.sqrt((E[2][1] - E[1][2]) ** 2 + (E[0][2] - E[2][0]) ** 2
                            + (E[1][0] - E[0][1]) ** 2)
        return dp, math.atan2(s, 0.5 * (E[0][0] + E[1][1] + E[2][2] - 1.0))

    def errors(self, T: np.ndarray) -> Tuple[float, float]:
        """Return (position error [m], orientation error [rad]) of a (4, 4) pose."""
        L = T[:3].tolist()
        return self.errors_py([r[:3] for r in L], [L[0][3], L[1][3], L[2][3]])

    def residual_cols(self, R, p, Jw, Jv):
        """
        Return (e (m,), cols (n sequences of m)): task error and Jacobian columns at a pose.

        e = [orientation error (rad); position error (m)] ('position': position only), in the
        base frame; cols[j] is the task's column of joint j (the Jacobian transposed).
        """
        tp = self._p
        ep = [tp[0] - p[0], tp[1] - p[1], tp[2] - p[2]]
        kind = self.kind
        if kind == 'position':
            return ep, Jv
        if kind == 'axis':
            d = self._d
            x0, x1, x2 = R[0][0], R[1][0], R[2][0]
            c0, c1, c2 = x1 * d[2] - x2 * d[1], x2 * d[0] - x0 * d[2], x0 * d[1] - x1 * d[0]
            sn = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
            dot = x0 * d[0] + x1 * d[1] + x2 * d[2]
            if sn > 1e-12:
                k = math.atan2(sn, dot) / sn
                ew = [c0 * k, c1 * k, c2 * k]
            elif dot < 0:          # opposite: turn about any axis perpendicular to x
                perp = [0.0, x2, -x1] if abs(x0) < 0.9 else [-x2, 0.0, x0]
                norm = math.sqrt(sum(t * t for t in perp))
                ew = [t / norm * math.pi for t in perp]
            else:
                ew = [0.0, 0.0, 0.0]
            # rotation about x does not move x: project the angular part of every column
            cols = []
            for (w0, w1, w2), v in zip(Jw, Jv):
                xw = x0 * w0 + x1 * w1 + x2 * w2
                cols.append((w0 - x0 * xw, w1 - x1 * xw, w2 - x2 * xw) + tuple(v))
            return ew + ep, cols
        tR = self._R
        # rotation error in the base frame: log(R_t R^T)
        E = [[tR[i][0] * R[j][0] + tR[i][1] * R[j][1] + tR[i][2] * R[j][2] for j in range(3)]
             for i in range(3)]
        return _rotation_vector(E) + ep, [tuple(w) + tuple(v) for w, v in zip(Jw, Jv)]

    def residual_py(self, R, p, Jw, Jv):
        """Return (e (m,), rows (m lists of n)) of the task at a pose and Jacobian."""
        e, cols = self.residual_cols(R, p, Jw, Jv)
        return e, [list(r) for r in zip(*cols)]

    def errors_of_residual(self, e) -> Tuple[float, float]:
        """Return (position error [m], orientation error [rad]) from ``residual_cols``'s e."""
        if self.kind == 'position':
            return math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), 0.0
        return (math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5]),
                math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]))


# ---------------------------------------------------------------------------------------------
# small dense linear algebra on lists
# ---------------------------------------------------------------------------------------------

def _dot(a, b) -> float:
    return sum(map(mul, a, b))


def _cholesky(A) -> list:
    """Return the Cholesky factor of a damped (SPD up to rounding) Gram matrix."""
    return cholesky(A, floor=1e-150)


def _gram(vectors, lam2: float) -> list:
    """Return the Gram matrix [v_i . v_j] + lam2 I of a list of equal-length vectors."""
    n = len(vectors)
    G = [[0.0] * n for _ in range(n)]
    for i in range(n):
        vi = vectors[i]
        Gi = G[i]
        for j in range(i + 1):
            Gi[j] = G[j][i] = sum(map(mul, vi, vectors[j]))
        Gi[i] += lam2
    return G


def _dls_apply(rows, lam2: float):
    """
    Return a function b -> J# b with J# = J^T (J J^T + lam2 I)^-1 (rows: m lists of n).

    Uses the smaller of the m x m and n x n normal matrices (push-through identity), factored
    once (Cholesky) for every right-hand side.
    """
    m, n = len(rows), len(rows[0])
    cols = list(zip(*rows))
    if m <= n:
        L = _cholesky(_gram(rows, lam2))

        def apply(b):
            y = cholesky_solve(L, b)
            return [sum(map(mul, col, y)) for col in cols]
        return apply
    L = _cholesky(_gram(cols, lam2))

    def apply_n(b):
        return cholesky_solve(L, [sum(map(mul, col, b)) for col in cols])
    return apply_n


@functools.lru_cache(maxsize=32)
def _unrolled_normal_solver(n: int, m: int, direct: bool = False):
    """
    Return solve(cols, e, lam2) -> (A^T A + lam2 I)^-1 A^T e, written out for n columns of m.

    With ``direct`` the right-hand side is e itself (length n): (A^T A + lam2 I)^-1 e, for the
    J J^T system of a chain with more joints than task rows (cols = the rows of J). The Gram
    matrix, its Cholesky factor and both triangular solves as straight-line code (generated
    once per size): a 4 x 4 solve costs a fifth of the looped version in CPython.
    """
    c = [[f'c{j}_{k}' for k in range(m)] for j in range(n)]
    src = ['def solve(cols, e, lam2):']
    src += [f'    {", ".join(c[j])}, = cols[{j}]' for j in range(n)]
    src.append(f'    {", ".join(f"e{k}" for k in range(n if direct else m))}, = e')
    for i in range(n):
        src.append(f'    b{i} = e{i}' if direct else
                   f'    b{i} = ' + ' + '.join(f'{c[i][k]} * e{k}' for k in range(m)))
        for j in range(i + 1):
            dot = ' + '.join(f'{c[i][k]} * {c[j][k]}' for k in range(m))
            src.append(f'    g{i}_{j} = {dot}' + (' + lam2' if i == j else ''))
    for j in range(n):
        s = f'g{j}_{j}' + ''.join(f' - l{j}_{k} * l{j}_{k}' for k in range(j))
        src.append(f'    d = {s}')
        src.append(f'    l{j}_{j} = sqrt(d) if d > 0.0 else 1e-150')
        for i in range(j + 1, n):
            s = f'g{i}_{j}' + ''.join(f' - l{i}_{k} * l{j}_{k}' for k in range(j))
            src.append(f'    l{i}_{j} = ({s}) / l{j}_{j}')
    for i in range(n):
        s = f'b{i}' + ''.join(f' - l{i}_{k} * y{k}' for k in range(i))
        src.append(f'    y{i} = ({s}) / l{i}_{i}')
    for i in reversed(range(n)):
        s = f'y{i}' + ''.join(f' - l{k}_{i} * x{k}' for k in range(i + 1, n))
        src.append(f'    x{i} = ({s}) / l{i}_{i}')
    src.append(f'    return [{", ".join(f"x{i}" for i in range(n))}]')
    namespace = {'sqrt': math.sqrt}
    exec(compile('\n'.join(src), f'<normal solver {n}x{m}>', 'exec'), namespace)  # noqa: S102
    return namespace['solve']


def _dls_solve(cols, e, lam2: float) -> Vec:
    """
    Return J# e = J^T (J J^T + lam2 I)^-1 e for J given by its columns (n sequences of m).

    The smaller normal matrix is factored: (J^T J + lam2 I)^-1 J^T e when n <= m, else
    J^T (J J^T + lam2 I)^-1 e (straight-line code for up to 6 task rows and 12 joints).
    """
    n, m = len(cols), len(e)
    if n <= m <= 6:
        return _unrolled_normal_solver(n, m)(cols, e, lam2)
    if m < n <= 12:
        y = _unrolled_normal_solver(m, n, True)(list(zip(*cols)), e, lam2)
        return [sum(map(mul, col, y)) for col in cols]
    if n <= m:
        b = [sum(map(mul, col, e)) for col in cols]
        return cholesky_solve(_cholesky(_gram(cols, lam2)), b)
    y = cholesky_solve(_cholesky(_gram(list(zip(*cols)), lam2)), e)
    return [sum(map(mul, col, y)) for col in cols]


def _matvec(rows, x) -> Vec:
    return [_dot(r, x) for r in rows]


# ---------------------------------------------------------------------------------------------
# solvers
# ---------------------------------------------------------------------------------------------

def _secondary(kind: Optional[str], q: Vec, q_nominal: Vec, lo: Vec, hi: Vec) -> Optional[Vec]:
    """Return the secondary-task joint velocity g(q) of the null-space term."""
    if kind == 'nominal':
        return [a - b for a, b in zip(q_nominal, q)]
    if kind == 'limits':
        # gradient of -sum(((q - mid) / span)^2): pushes every joint toward mid-range
        return [-4.0 * (x - 0.5 * (a + b)) / max(b - a, 1e-9) ** 2
                for x, a, b in zip(q, lo, hi)]
    if kind is None:
        return None
    raise ValueError(f"secondary task must be None, 'nominal' or 'limits', not {kind!r}")


def _project(q: Vec, c: Chain) -> Vec:
    """
    Return q inside the joint limits.

    Joints whose range spans (almost) a full turn are wrapped into [lower, lower + 2 pi) first,
    so an iterate can pass 'behind' such a joint (the px100 waist is limited to +-3.14158 rad)
    instead of sticking at a limit; then every joint is clipped.
    """
    out = []
    for x, a, b, wrap in zip(q, c.lo, c.hi, c.wraps):
        if wrap and (x < a or x > b):
            x = a + (x - a) % _TWO_PI
        out.append(a if x < a else b if x > b else x)
    return out


def _finish(method, success, q, it, pe, oe, reason='', **details) -> IkResult:
    qa = np.array(q, dtype=float)
    return IkResult(success=success, q=qa, solutions=[qa.copy()] if success else [],
                    method=method, iterations=it, position_error=pe, orientation_error=oe,
                    reason=reason, details=details)


def _not_converged(method, q, it, pe, oe) -> IkResult:
    return _finish(method, False, q, it, pe, oe, reason=(
        f'did not converge in {it} iterations (position error {pe:.3g} m, '
        f'orientation error {oe:.3g} rad)'))


def _dls_step(c: Chain, q: Vec, e: Vec, cols, lam2: float, alpha: float, gain: float,
              secondary: Optional[str], qn: Vec, check_limits: bool):
    """
    Return (step, dn): the DLS step and the null-space secondary direction (None without one).

    cols: the task Jacobian's columns (``Task.residual_cols``). Joints sitting at a limit that
    the step would push further are locked (their Jacobian column and secondary component
    removed) and the step recomputed, so a secondary task whose optimum lies on a limit settles
    there instead of fighting the projection.
    """
    n = len(q)
    lo, hi, wraps = c.lo, c.hi, c.wraps
    zero = (0.0,) * len(e)
    locked: list = []
    step: Vec = []
    dn: Optional[Vec] = None
    for _ in range(n):
        cols_l = cols if not locked else [zero if j in locked else col
                                          for j, col in enumerate(cols)]
        if secondary is None:
            step = [alpha * x for x in _dls_solve(cols_l, e, lam2)]
        else:
            rows_l = [list(r) for r in zip(*cols_l)]
            pinv = _dls_apply(rows_l, lam2)
            g = _secondary(secondary, q, qn, lo, hi)
            if locked:
                g = [0.0 if j in locked else x for j, x in enumerate(g)]
            jg = pinv(_matvec(rows_l, g))
            dn = [x - y for x, y in zip(g, jg)]
            step = [alpha * x + gain * y for x, y in zip(pinv(e), dn)]
        if not check_limits:
            return step, dn
        newly = [j for j in range(n) if not wraps[j] and j not in locked and (
            (q[j] <= lo[j] + 1e-12 and step[j] < 0.0)
            or (q[j] >= hi[j] - 1e-12 and step[j] > 0.0))]
        if not newly:
            return step, dn
        locked.extend(newly)
    return step, dn


def solve_dls(model, task: Task, q0, *, q_nominal=None, secondary: Optional[str] = None,
              alpha: float = 1.0, beta: float = 1.0, damping: float = 1e-6,
              max_step: float = 0.5, tol_position: float = 1e-9, tol_orientation: float = 1e-9,
              tol_secondary: float = 1e-8, max_iterations: int = 200,
              check_limits: bool = True, stall_iterations: int = 30) -> IkResult:
    """
    Damped least squares from q0, with an optional null-space secondary task.

    :param task: what to reach (``Task``)
    :param secondary: None, 'nominal' (toward q_nominal, default model.home) or 'limits'
        (away from the joint limits)
    :param alpha, beta: primary / secondary gains
    :param damping: lambda of J^T (J J^T + lambda^2 I)^-1; an extra LM term (0.1 |e|)^2 damps
        large errors
    :param max_step: joint step norm limit per iteration [rad]
    :param check_limits: keep every iterate inside the joint limits (projection)
    :param stall_iterations: stop when the error has not dropped by 1 % for that many
        iterations (a local minimum: the caller restarts elsewhere)
    :return: IkResult; success when the task errors are within tolerance and, with a secondary
        task, its null-space step is below tol_secondary (``details['secondary_settled']``
        is False when the iterations ran out with only the primary task met: still a success)
    """
    c = chain(model)
    q = [float(x) for x in q0]
    if check_limits:
        q = _project(q, c)
    qn = [float(x) for x in (model.home if q_nominal is None else q_nominal)]
    met_q = None
    pe = oe = math.inf
    it = 0
    gain = beta
    prev = None
    best_err, best_it = math.inf, 0
    for it in range(max_iterations + 1):
        R, p, Jw, Jv = fk_jacobian_py(c, q)
        e, cols = task.residual_cols(R, p, Jw, Jv)
        pe, oe = task.errors_of_residual(e)
        met = pe <= tol_position and oe <= tol_orientation
        if met and secondary is None:
            return _finish('dls', True, q, it, pe, oe)
        if it == max_iterations:
            break
        if pe + oe < 0.99 * best_err:
            best_err, best_it = pe + oe, it
        elif met_q is None and it - best_it > stall_iterations:
            break           # stuck in a local minimum (e.g. on a joint limit): give up early
        lam2 = damping * damping + _LM_FACTOR * sum(x * x for x in e)
        dq, dn = _dls_step(c, q, e, cols, lam2, alpha, gain, secondary, qn, check_limits)
        if dn is not None:
            dn_norm = math.sqrt(sum(x * x for x in dn))
            if met:
                met_q = (list(q), pe, oe)
                if dn_norm * gain <= tol_secondary:
                    return _finish('dls', True, q, it, pe, oe, secondary_settled=True,
                                   secondary_step=dn_norm * gain)
            # next gain: Barzilai-Borwein secant estimate of the null-space curvature (the
            # self-motion manifold is curved: a fixed gain can oscillate), safeguarded
            if prev is not None:
                s_ = [x - y for x, y in zip(q, prev[0])]
                y_ = [x - y for x, y in zip(prev[1], dn)]
                sy = sum(x * y for x, y in zip(s_, y_))
                ss = sum(x * x for x in s_)
                gain = min(1.5 * beta, max(0.05 * beta, ss / sy)) if sy > 1e-300 else beta
            prev = (list(q), dn)
        norm = math.sqrt(sum(x * x for x in dq))
        if norm > max_step:
            k = max_step / norm
            dq = [x * k for x in dq]
        q = _project([a + b for a, b in zip(q, dq)], c) if check_limits else [
            a + b for a, b in zip(q, dq)]
        if not all(math.isfinite(x) for x in q):
            return IkResult(False, None, method='dls', iterations=it,
                            reason='iteration diverged (non-finite joint values)')
    if met_q is not None:
        qm, pm, om = met_q
        return _finish('dls', True, qm, it, pm, om, secondary_settled=False)
    return _not_converged('dls', q, it, pe, oe)


def solve_newton(model, task: Task, q0, *, max_step: float = 0.5, alpha: float = 1.0,
                 tol_position: float = 1e-9, tol_orientation: float = 1e-9,
                 max_iterations: int = 200, check_limits: bool = True) -> IkResult:
    """
    Newton-Raphson IK: pinv step, step-norm limit, joint-limit projection.

    For a 'full' task the error is the space twist log(T_target T^-1) with the space Jacobian
    (as ``newton_raphson_twist``); other tasks use ``Task.residual_py``. Generic over any model.
    """
    c = chain(model)
    q = np.array(q0, dtype=float)
    if check_limits:
        q = np.array(_project(q.tolist(), c))
    T_target = task.pose()
    pe = oe = math.inf
    it = 0
    for it in range(max_iterations + 1):
        R, p, Jw, Jv = fk_jacobian_py(c, q.tolist())
        pe, oe = task.errors_py(R, p)
        if pe <= tol_position and oe <= tol_orientation:
            return _finish('newton-raphson', True, q, it, pe, oe)
        if it == max_iterations:
            break
        if task.kind == 'full':
            T = np.array([R[0] + [p[0]], R[1] + [p[1]], R[2] + [p[2]], [0, 0, 0, 1.0]])
            Xi = log_se3(T_target @ _inv(T))
            Js = np.empty((6, c.n))
            Js[:3] = np.array(Jw).T
            # space Jacobian: linear rows at the base origin = v_ee - omega x p_ee
            Js[3:] = np.array([(a[0] - (o[1] * p[2] - o[2] * p[1]),
                                a[1] - (o[2] * p[0] - o[0] * p[2]),
                                a[2] - (o[0] * p[1] - o[1] * p[0]))
                               for o, a in zip(Jw, Jv)]).T
            dq = np.linalg.pinv(Js) @ Xi
        else:
            e, rows = task.residual_py(R, p, Jw, Jv)
            dq = np.linalg.pinv(np.array(rows)) @ np.array(e)
        norm = float(np.linalg.norm(dq))
        if norm > max_step:
            dq *= max_step / norm
        if check_limits:
            dq = np.array(_project((q + dq).tolist(), c)) - q
        q = q + alpha * dq
        if not np.all(np.isfinite(q)):
            return IkResult(False, None, method='newton-raphson', iterations=it,
                            reason='iteration diverged (non-finite joint values)')
    return _not_converged('newton-raphson', q, it, pe, oe)


def _inv(T: np.ndarray) -> np.ndarray:
    Ti = np.eye(4)
    Ti[:3, :3] = T[:3, :3].T
    Ti[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return Ti


def newton_raphson_twist(model, T_target, q0, max_iters: int = 50, tol: float = 1e-4,
                         alpha: float = 1.0, max_step: float = 0.5):
    """
    Newton-Raphson on the space twist, with its error history: return (q, info).

    Each iteration: Xi = log(T_target T(q)^-1) (space twist, [rad; m]), dq = pinv(J_s) Xi with
    the space Jacobian J_s, steps longer than ``max_step`` [rad] scaled down to it, q + dq
    projected onto the joint limits, q += alpha dq. Converged when ||Xi|| < tol (checked
    before each step, so 'iter' is the number of steps taken).
    info = {'converged': bool, 'iter': k, 'err': [||Xi|| per iteration]}.
    """
    c = chain(model)
    q = np.array(q0, dtype=float)
    T_target = np.asarray(T_target, dtype=float)
    history = []
    for k in range(max_iters):
        T, J = fk_and_jacobian(c, q)
        Xi = log_se3(T_target @ _inv(T))
        err = float(np.linalg.norm(Xi))
        history.append(err)
        if err < tol:
            return q, {'converged': True, 'iter': k, 'err': history}
        Js = J.copy()
        Js[3:] -= np.cross(J[:3].T, T[:3, 3]).T
        dq = np.linalg.pinv(Js) @ Xi
        norm = np.linalg.norm(dq)
        if norm > max_step:
            dq = dq * (max_step / norm)
        dq = np.clip(q + dq, c.lower, c.upper) - q
        q = q + alpha * dq
    return q, {'converged': False, 'iter': max_iters, 'err': history}
