"""
Closed-form IK solvers, one module per geometry family, selected by a robot's ``ik.analytic``.

Each module ``px100_control.kinematics.analytic.<name>`` defines::

    def candidates(model, T_target, mode) -> numpy.ndarray  # (k, n), possibly k = 0

returning every closed-form candidate for the (4, 4) target in ``model.base_frame`` (mode:
'full', 'pitch' or 'position' as in ``solve.solve_ik``), before joint-limit filtering;
``solve.solve_ik`` verifies each by FK, filters limits and orders them by distance to the seed.
A module may also define ``unreachable_reason(model, T_target, mode) -> str`` to explain an
empty result in words (e.g. 'target is 0.031 m beyond the maximum reach').

Optional extras that ``solve`` and ``workspace`` use when present: ``complete = True`` (the
candidates are every solution, so no iterative fallback is tried);
``position_solutions(model, T_target, q_nominal, check_limits=True) -> (k, n)`` ('position'
mode with the free angles already chosen by the secondary task toward q_nominal);
``solve_batch(model, targets, q_seed=None, check_limits=True, return_all=False)`` (vectorised
``solve_ik_batch``); ``reach_margin(model, p, pitch=None) -> float`` [m] (``is_reachable``).
In 'pitch' mode ``solve_ik`` passes the target with its yaw already forced (``pitch_target``).

The default path of ``solve_ik`` (closed forms first, plain floats) uses, when present:
``candidates_rows(model, T_rows, mode='full'[, limits]) -> list of lists`` (the 'full'
candidates of a pose given as 4 rows of 4 floats; with ``prunes_by_limits = True`` it also takes
(lower, upper) and may leave out candidates outside them), or, for a redundant arm,
``ik_fast(model, T_rows, q_seed) -> (q or None, tried)`` (one in-limit solution near the seed).
"""
import importlib
from types import ModuleType

from px100_control.errors import RobotModelError


def get_solver(name: str) -> ModuleType:
    """Return the analytic solver module ``name``; raise RobotModelError if there is none."""
    try:
        module = importlib.import_module(f'{__name__}.{name}')
    except ModuleNotFoundError as exc:
        raise RobotModelError(f"no analytic IK solver named '{name}'") from exc
    if not hasattr(module, 'candidates'):
        raise RobotModelError(f"analytic IK module '{name}' defines no candidates()")
    return module
