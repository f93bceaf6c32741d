"""
The result type every IK solver returns.

Non-convergence or an unreachable target is a result (``success=False`` with ``reason`` in
words), not an exception; malformed input raises ``InvalidInputError`` before solving.
"""
from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np


@dataclass
class IkResult:
    """
    Outcome of an IK query.

    :param success: True when ``q`` reaches the target within tolerance and joint limits
    :param q: best solution (n,) [rad | m], or the last iterate / None on failure
    :param solutions: every valid solution, best (closest to the seed) first
    :param method: e.g. 'analytic:px100', 'dls', 'newton-raphson'
    :param iterations: solver iterations (0 for closed forms)
    :param position_error: [m] at ``q``; orientation_error [rad] (of the constrained part)
    :param reason: '' on success, else why not (unreachable by how much, which joint limit, ...)
    """

    success: bool
    q: Optional[np.ndarray]
    solutions: List[np.ndarray] = field(default_factory=list)
    method: str = ''
    iterations: int = 0
    position_error: float = float('nan')
    orientation_error: float = float('nan')
    reason: str = ''
    details: dict = field(default_factory=dict)

    def __iter__(self):
        """Unpack as ``theta_list, success`` (the Interbotix / Modern Robotics shape)."""
        yield self.q
        yield self.success
