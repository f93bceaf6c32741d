"""
The result type every IK solver returns.

Non-convergence or an unreachable target is a result (``success=False`` with ``reason`` in
words), not an exception; malformed input raises ``InvalidInputError`` before solving.
"""
from typing import Callable, List, Optional

import numpy as np


class IkResult:
    """
    Outcome of an IK query.

    :param success: True when ``q`` reaches the target within tolerance and joint limits
    :param q: best solution (n,) [rad | m], or the last iterate / None on failure
    :param solutions: every valid solution, best (closest to the seed) first; a solver may
        pass ``more`` instead (a function returning the solutions after ``q``), evaluated the
        first time ``solutions`` is read, so a caller that only needs ``q`` does not pay for
        verifying the other branches
    :param method: e.g. 'analytic:px100', 'dls', 'newton-raphson'
    :param iterations: solver iterations (0 for closed forms)
    :param position_error: [m] at ``q``; orientation_error [rad] (of the constrained part)
    :param reason: '' on success, else why not (unreachable by how much, which joint limit, ...)
    """

    __slots__ = ('success', 'q', '_solutions', '_more', 'method', 'iterations',
                 'position_error', 'orientation_error', 'reason', 'details')

    def __init__(self, success: bool, q: Optional[np.ndarray],
                 solutions: Optional[List[np.ndarray]] = None, method: str = '',
                 iterations: int = 0, position_error: float = float('nan'),
                 orientation_error: float = float('nan'), reason: str = '',
                 details: Optional[dict] = None,
                 more: Optional[Callable[[], List[np.ndarray]]] = None):
        """Store the fields (see the class docstring)."""
        self.success = success
        self.q = q
        self._solutions = [] if solutions is None else solutions
        self._more = more
        self.method = method
        self.iterations = iterations
        self.position_error = position_error
        self.orientation_error = orientation_error
        self.reason = reason
        self.details = {} if details is None else details

    @property
    def solutions(self) -> List[np.ndarray]:
        """Return every valid solution, ``q`` first (the other ones computed on first use)."""
        if self._more is not None:
            more, self._more = self._more, None
            self._solutions = [self.q] + list(more())
        return self._solutions

    @solutions.setter
    def solutions(self, value: List[np.ndarray]) -> None:
        self._more = None
        self._solutions = value

    def __iter__(self):
        """Unpack as ``theta_list, success`` (the Interbotix / Modern Robotics shape)."""
        yield self.q
        yield self.success

    def __repr__(self) -> str:
        """Return the fields, like a dataclass."""
        return (f'IkResult(success={self.success!r}, q={self.q!r}, '
                f'solutions={self.solutions!r}, method={self.method!r}, '
                f'iterations={self.iterations!r}, position_error={self.position_error!r}, '
                f'orientation_error={self.orientation_error!r}, reason={self.reason!r}, '
                f'details={self.details!r})')
