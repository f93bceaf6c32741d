"""
Closed-form IK solvers, one module per geometry family, selected by a robot's ``ik.analytic``.

Each module ``px100_control.kinematics.analytic.<name>`` defines::

    def candidates(model, T_target, mode) -> numpy.ndarray  # (k, n), possibly k = 0

returning every closed-form candidate for the (4, 4) target in ``model.base_frame`` (mode:
'full', 'pitch' or 'position' as in ``solve.solve_ik``), before joint-limit filtering;
``solve.solve_ik`` verifies each by FK, filters limits and orders them by distance to the seed.
A module may also define ``unreachable_reason(model, T_target, mode) -> str`` to explain an
empty result in words (e.g. 'target is 0.031 m beyond the maximum reach').
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
