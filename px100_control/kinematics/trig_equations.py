"""
Solvers for the standard equation types of closed-form inverse geometric models.

The eight types of Khalil & Dombre (*Modeling, Identification and Control of Robots*,
section 7.5), the catalogue from which hand-made inverse models such as the RRRP arm's
(``analytic/rrrp.py``) are assembled. Unknowns: ``q``/``qi``/``qj`` are angles [rad], ``r``
a prismatic length [m]; every other symbol is a known coefficient.

| type | equations |
| --- | --- |
| 1 | X r = Y |
| 2 | X sin q + Y cos q = Z |
| 3 | X1 sin q + Y1 cos q = Z1 ; X2 sin q + Y2 cos q = Z2 |
| 4 | X1 r sin q = Y1 ; X2 r cos q = Y2 |
| 5 | X1 sin q = Y1 + Z1 r ; X2 cos q = Y2 + Z2 r |
| 6 | W sin qj = X cos qi + Y sin qi + Z1 ; W cos qj = X sin qi - Y cos qi + Z2 |
| 7 | W1 cos qj + W2 sin qj = X cos qi + Y sin qi + Z1 ;
|   | W1 sin qj - W2 cos qj = X sin qi - Y cos qi + Z2 |
| 8 | X cos qi + Y cos(qi + qj) = Z1 ; X sin qi + Y sin(qi + qj) = Z2 |

Every solver returns the list of ALL real solutions (possibly empty; a double root once),
angles wrapped to (-pi, pi]. ``tol`` is the relative tolerance under which a slightly negative
discriminant (rounding at the workspace boundary) counts as zero. Degenerate coefficient sets
whose unknown drops out (e.g. X = Y = 0 in type 2) return [] rather than a continuum: the
caller must pick another equation (as the RRRP inverse model does: |cos q3| vs |sin q3|).
"""
import math
from typing import List, Tuple

from px100_control.kinematics.kernels import wrap_angle

_TINY = 1e-300


def _sqrt_disc(disc: float, scale: float, tol: float):
    """Return sqrt(disc), 0 for a tiny negative disc, None when disc is really negative."""
    if disc >= 0.0:
        return math.sqrt(disc)
    if disc >= -tol * max(scale, _TINY):
        return 0.0
    return None


def solve_type1(X: float, Y: float, eps: float = 1e-12) -> List[float]:
    """
    Solve X r = Y for the length r.

    Example Input: X=2, Y=1  Output: [0.5]
    """
    if abs(X) <= eps:
        return []
    return [Y / X]


def solve_type2(X: float, Y: float, Z: float, tol: float = 1e-10,
                eps: float = 1e-12) -> List[float]:
    """
    Solve X sin q + Y cos q = Z for the angle q.

    With D = X^2 + Y^2: sin q = (X Z + e Y sqrt(D - Z^2)) / D and
    cos q = (Y Z - e X sqrt(D - Z^2)) / D, e = +-1.

    Example Input: X=1, Y=0, Z=1  Output: [pi/2]
    """
    D = X * X + Y * Y
    if D <= eps * eps:
        return []
    root = _sqrt_disc(D - Z * Z, D, tol)
    if root is None:
        return []
    sols = []
    for e in (1.0, -1.0):
        q = wrap_angle(math.atan2(X * Z + e * Y * root, Y * Z - e * X * root))
        if not any(abs(wrap_angle(q - s)) < 1e-15 for s in sols):
            sols.append(q)
        if root == 0.0:
            break
    return sols


def solve_type3(X1: float, Y1: float, Z1: float, X2: float, Y2: float, Z2: float,
                tol: float = 1e-10, eps: float = 1e-12) -> List[float]:
    """
    Solve the pair X1 sin q + Y1 cos q = Z1, X2 sin q + Y2 cos q = Z2 for q.

    A regular pair is linear in (sin q, cos q): one solution q = atan2(s, c). A singular pair
    (X1 Y2 = X2 Y1) falls back to type 2 on the stronger equation, keeping the roots that also
    satisfy the other one.

    Example Input: 1, 0, 0.5, 0, 1, 0.8660254  Output: [pi/6]
    """
    det = X1 * Y2 - X2 * Y1
    n1, n2 = math.hypot(X1, Y1), math.hypot(X2, Y2)
    if abs(det) > eps * max(n1 * n2, _TINY) and n1 > eps and n2 > eps:
        s = (Z1 * Y2 - Z2 * Y1) / det
        c = (X1 * Z2 - X2 * Z1) / det
        if s == 0.0 and c == 0.0:
            return []
        return [wrap_angle(math.atan2(s, c))]
    (Xa, Ya, Za), (Xb, Yb, Zb) = ((X1, Y1, Z1), (X2, Y2, Z2)) if n1 >= n2 else \
        ((X2, Y2, Z2), (X1, Y1, Z1))
    sols = solve_type2(Xa, Ya, Za, tol, eps)
    scale = max(math.hypot(Xb, Yb), abs(Zb), 1.0)
    return [q for q in sols
            if abs(Xb * math.sin(q) + Yb * math.cos(q) - Zb) <= math.sqrt(tol) * scale]


def solve_type4(X1: float, Y1: float, X2: float, Y2: float,
                eps: float = 1e-12) -> List[Tuple[float, float]]:
    """
    Solve X1 r sin q = Y1, X2 r cos q = Y2 for (q, r).

    r = +-sqrt((Y1/X1)^2 + (Y2/X2)^2); q = atan2(Y1 / (X1 r), Y2 / (X2 r)).
    """
    if abs(X1) <= eps or abs(X2) <= eps:
        return []
    a, b = Y1 / X1, Y2 / X2
    r = math.hypot(a, b)
    if r <= eps:
        return []
    return [(wrap_angle(math.atan2(a / rr, b / rr)), rr) for rr in (r, -r)]


def solve_type5(X1: float, Y1: float, Z1: float, X2: float, Y2: float, Z2: float,
                tol: float = 1e-10, eps: float = 1e-12) -> List[Tuple[float, float]]:
    """
    Solve X1 sin q = Y1 + Z1 r, X2 cos q = Y2 + Z2 r for (q, r).

    sin^2 + cos^2 = 1 gives a quadratic in r (multiplied by X1^2 X2^2):
    (Z1^2 X2^2 + Z2^2 X1^2) r^2 + 2 (Y1 Z1 X2^2 + Y2 Z2 X1^2) r
    + Y1^2 X2^2 + Y2^2 X1^2 - X1^2 X2^2 = 0; then q = atan2((Y1 + Z1 r)/X1, (Y2 + Z2 r)/X2).
    Z1 = Z2 = 0 (r drops out) returns [].
    """
    if abs(X1) <= eps or abs(X2) <= eps:
        return []
    a = Z1 * Z1 * X2 * X2 + Z2 * Z2 * X1 * X1
    b = 2.0 * (Y1 * Z1 * X2 * X2 + Y2 * Z2 * X1 * X1)
    c = Y1 * Y1 * X2 * X2 + Y2 * Y2 * X1 * X1 - X1 * X1 * X2 * X2
    if a <= eps * eps * max(X1 * X1 * X2 * X2, _TINY):
        return []
    root = _sqrt_disc(b * b - 4.0 * a * c, b * b + abs(4.0 * a * c), tol)
    if root is None:
        return []
    # numerically stable quadratic roots
    if root == 0.0:
        rs = [-b / (2.0 * a)]
    else:
        qq = -0.5 * (b + math.copysign(root, b))
        rs = [qq / a, c / qq] if qq != 0.0 else [root / (2.0 * a), -root / (2.0 * a)]
    sols = []
    for r in rs:
        q = math.atan2((Y1 + Z1 * r) / X1, (Y2 + Z2 * r) / X2)
        sols.append((wrap_angle(q), r))
    return sols


def _square_sum_type2(Wsq: float, X: float, Y: float, Z1: float, Z2: float, tol: float,
                      eps: float) -> List[float]:
    """Return qi of the type 2 equation from squaring and adding types 6 and 7."""
    B1 = 2.0 * (Z1 * Y + Z2 * X)
    B2 = 2.0 * (Z1 * X - Z2 * Y)
    B3 = Wsq - X * X - Y * Y - Z1 * Z1 - Z2 * Z2
    return solve_type2(B1, B2, B3, tol, eps)


def solve_type6(W: float, X: float, Y: float, Z1: float, Z2: float, tol: float = 1e-10,
                eps: float = 1e-12) -> List[Tuple[float, float]]:
    """
    Solve W sin qj = X cos qi + Y sin qi + Z1, W cos qj = X sin qi - Y cos qi + Z2 for (qi, qj).

    Squaring and adding eliminates qj: a type 2 equation in qi; then qj = atan2 of the two
    right-hand sides (divided by W).
    """
    if abs(W) <= eps:
        return []
    sols = []
    for qi in _square_sum_type2(W * W, X, Y, Z1, Z2, tol, eps):
        ci, si = math.cos(qi), math.sin(qi)
        sj = (X * ci + Y * si + Z1) / W
        cj = (X * si - Y * ci + Z2) / W
        sols.append((qi, wrap_angle(math.atan2(sj, cj))))
    return sols


def solve_type7(W1: float, W2: float, X: float, Y: float, Z1: float, Z2: float,
                tol: float = 1e-10, eps: float = 1e-12) -> List[Tuple[float, float]]:
    """
    Solve the type 7 pair for (qi, qj).

    W1 cos qj + W2 sin qj = X cos qi + Y sin qi + Z1 and
    W1 sin qj - W2 cos qj = X sin qi - Y cos qi + Z2. Squaring and adding gives a type 2
    equation in qi; qj then solves a type 3 pair.
    """
    if math.hypot(W1, W2) <= eps:
        return []
    sols = []
    for qi in _square_sum_type2(W1 * W1 + W2 * W2, X, Y, Z1, Z2, tol, eps):
        ci, si = math.cos(qi), math.sin(qi)
        V1 = X * ci + Y * si + Z1
        V2 = X * si - Y * ci + Z2
        for qj in solve_type3(W2, W1, V1, W1, -W2, V2, tol, eps):
            sols.append((qi, qj))
    return sols


def solve_type8(X: float, Y: float, Z1: float, Z2: float, tol: float = 1e-10,
                eps: float = 1e-12) -> List[Tuple[float, float]]:
    """
    Solve X cos qi + Y cos(qi + qj) = Z1, X sin qi + Y sin(qi + qj) = Z2 for (qi, qj).

    The planar two-link case: cos qj = (Z1^2 + Z2^2 - X^2 - Y^2) / (2 X Y) (two elbow
    branches), then qi from the type 3 pair with B1 = X + Y cos qj, B2 = Y sin qj.
    """
    if abs(X) <= eps or abs(Y) <= eps:
        return []
    cj = (Z1 * Z1 + Z2 * Z2 - X * X - Y * Y) / (2.0 * X * Y)
    if abs(cj) > 1.0:
        if abs(cj) - 1.0 > tol * max(1.0, (Z1 * Z1 + Z2 * Z2) / abs(2.0 * X * Y)):
            return []
        cj = math.copysign(1.0, cj)
    sj_abs = math.sqrt(max(0.0, 1.0 - cj * cj))
    sols = []
    for sj in ((sj_abs, -sj_abs) if sj_abs > 0.0 else (0.0,)):
        qj = math.atan2(sj, cj)
        B1, B2 = X + Y * cj, Y * sj
        for qi in solve_type3(-B2, B1, Z1, B1, B2, Z2, tol, eps):
            sols.append((qi, wrap_angle(qj)))
    return sols


__all__ = ['wrap_angle', 'solve_type1', 'solve_type2', 'solve_type3', 'solve_type4',
           'solve_type5', 'solve_type6', 'solve_type7', 'solve_type8']
