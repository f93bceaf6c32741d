"""
Workspace of an arm: reachability queries and a PNG rendering.

``is_reachable`` uses the analytic module's ``reach_margin`` when the model has one (px100: the
torus bounds of the px100 family, joint limits ignored) and otherwise asks ``solve_ik``.
``render_workspace_png`` samples random in-limit configurations (joint limits included) and
draws the side (radial r vs z) and top (x vs y) views, with the torus bounds for px100-family
arms. Units: m, rad.
"""
import math
import os
from typing import Optional, Tuple

import numpy as np

from px100_control.errors import InvalidInputError
from px100_control.kinematics.analytic import get_solver
from px100_control.kinematics.iterative import chain, fk_batch
from px100_control.kinematics.rotations import euler_sxyz_to_matrix
from px100_control.kinematics.solve import solve_ik


def _module(model):
    return get_solver(model.analytic_ik) if model.analytic_ik else None


def is_reachable(model, p, pitch: Optional[float] = None) -> Tuple[bool, float]:
    """
    Return (reachable, margin [m]) of a position p (3,) [m] in the base frame.

    With ``pitch`` [rad] the tool pitch is imposed (Interbotix sense). The margin is positive
    inside the geometric workspace and negative outside (by how much). Models without an
    analytic ``reach_margin`` are answered by ``solve_ik`` (limits included) with margin NaN.
    :raises InvalidInputError: p not 3 finite numbers, or pitch not finite
    """
    try:
        p = np.asarray(p, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f'position is not numeric: {p!r}') from exc
    if p.size != 3 or not np.all(np.isfinite(p)):
        raise InvalidInputError(f'position must be 3 finite numbers, got {p.tolist()}')
    if pitch is not None and not math.isfinite(float(pitch)):
        raise InvalidInputError(f'pitch must be finite, got {pitch!r}')
    module = _module(model)
    if module is not None and hasattr(module, 'reach_margin'):
        margin = float(module.reach_margin(model, p, None if pitch is None else float(pitch)))
        return margin >= 0.0, margin
    T = np.eye(4)
    T[:3, 3] = p
    if pitch is not None:
        T[:3, :3] = euler_sxyz_to_matrix(0.0, float(pitch), math.atan2(p[1], p[0]))
    res = solve_ik(model, T, mode='position' if pitch is None else 'pitch',
                   tol_position=1e-6, tol_orientation=1e-6)
    return bool(res.success), float('nan')


def sample_workspace(model, count: int = 20000, seed: int = 0) -> np.ndarray:
    """Return (count, 3) end-effector positions [m] of random in-limit configurations."""
    Q = model.random_configurations(count, np.random.default_rng(seed))
    return fk_batch(chain(model), Q)[:, :3, 3]


def render_workspace_png(model, path: str, samples: int = 20000, seed: int = 0) -> str:
    """
    Render the reachable workspace of ``model`` to a PNG at ``path`` and return the path.

    Side view (radial distance from the first joint axis vs height) and top view of sampled
    reachable positions; px100-family arms also get the torus bounds at pitch 0.
    """
    import matplotlib  # optional: plots only (matplotlib takes seconds to import)
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt  # optional: after use('Agg')

    P = sample_workspace(model, samples, seed)
    r = np.hypot(P[:, 0], P[:, 1])
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 5.5))
    ax1.scatter(np.where(P[:, 0] >= 0, r, -r), P[:, 2], s=0.5, alpha=0.3, color='tab:blue',
                label='reachable (joint limits included)')
    ax1.set_xlabel('signed radial distance along x [m]')
    ax1.set_ylabel('z [m]')
    ax1.set_title(f'{model.name}: side view')
    module = _module(model)
    if module is not None and hasattr(module, 'geometry'):
        try:
            g = module.geometry(model)
            lo, hi = abs(g.Lr - g.L3), g.Lr + g.L3
            t = np.linspace(0.0, 2.0 * math.pi, 400)
            for radius, style in ((hi, '-'), (lo, '--')):
                # wrist-centre annulus at pitch 0, shifted by the tool length
                ax1.plot(g.u2 + g.L4 + radius * np.cos(t), -(g.v2 + radius * np.sin(t)),
                         style, color='tab:red', lw=1.0,
                         label=f'torus bound at pitch 0 ({radius:.3f} m)')
            outer = g.Lr + g.L3 + g.L4
            ax1.plot(g.u2 + outer * np.cos(t), -g.v2 + outer * np.sin(t), ':', color='k',
                     lw=1.0, label=f'reach bound, any pitch ({outer:.3f} m from the shoulder)')
        except Exception:  # noqa: BLE001 - the bounds are decoration only
            pass
    ax1.axis('equal')
    ax1.grid(True, lw=0.3)
    ax1.legend(loc='lower left', fontsize=8, markerscale=10)
    ax2.scatter(P[:, 0], P[:, 1], s=0.5, alpha=0.3, color='tab:green')
    ax2.set_xlabel('x [m]')
    ax2.set_ylabel('y [m]')
    ax2.set_title(f'{model.name}: top view ({samples} random in-limit configurations)')
    ax2.axis('equal')
    ax2.grid(True, lw=0.3)
    fig.tight_layout()
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
