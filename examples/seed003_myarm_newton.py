#!/usr/bin/env python3
"""
Seed 003: Elephant myArm 300 Pi (7-DOF, PoE), Newton-Raphson IK for the grasp and place poses.

The document's solver (pinv of the space Jacobian on the twist log(T_target T^-1), steps scaled
to norm <= 0.5, projection onto the joint limits, ||twist|| < 1e-4) is
``px100_control.kinematics.iterative.newton_raphson_twist`` on the registered 'myarm300pi'.
Grasp: Rx(180 deg) at (17.5, 2.5, 5) cm from theta_init = [0, 30, 0, -45, 0, -45, 0] deg;
place: R_y(90) R_x(45) at (0.105, 0.075, 0.1) m. Figures: error vs iteration for both solves
(document Figs. 2-3) and the arm at its grasp pose over the blue cube (Fig. 4).

Tables 2 and 3 differ from ours by 0.008 and 0.016 deg, more than their 0.005 deg rounding;
:func:`why_tables` finds why by experiment: the variants of the run that do not explain it, a
test of whether the printed place table can come from the printed inputs at all, the effect of
the inputs' own printed precision, and a fit of d1, d3, d5, d7 within that precision (with a
control on made-up tables).

Run: python examples/seed003_myarm_newton.py [--out DIR]
"""
import dataclasses
import math
from typing import Tuple

from example_support import set_axes_equal, start
import matplotlib.pyplot as plt
import numpy as np
from px100_control.kinematics.iterative import newton_raphson_twist
from px100_control.kinematics.se3 import (exp_se3, log_se3, rot_x, rot_y, screw_axis,
                                          transform)
from px100_control.models.registry import load_robot

NAME = 'seed003_myarm_newton'
CM = 0.01
THETA_INIT_DEG = [0, 30, 0, -45, 0, -45, 0]
GRASP_TABLE_DEG = [-12.73, 68.82, -60.13, -81.36, -44.14, -41.83, -55.14]
PLACE_TABLE_DEG = [46.83, 64.76, -70.94, -103.01, -83.66, -108.91, -100.89]
TABLES_DEG = np.array(GRASP_TABLE_DEG + PLACE_TABLE_DEG)
T_GRASP = transform(rot_x(math.pi), np.array([17.5, 2.5, 5.0]) * CM)
T_PLACE = transform(rot_y(math.pi / 2) @ rot_x(math.pi / 4), [0.105, 0.075, 0.10])
T_PLACE_PRINTED = np.array([[0.0, 0.7071, 0.7071, 0.1050], [0.0, 0.7071, -0.7071, 0.0750],
                            [-1.0, 0.0, 0.0, 0.1000], [0.0, 0.0, 0.0, 1.0]])
D1, D3, D5, D7 = 0.1695, 0.1155, 0.1278, 0.0660
#: the document's points q_i on the joint axes at zero configuration [m]
AXIS_POINTS = [(0, 0, 0), (0, 0, D1), (0, 0, D1 + D3), (0, 0, D1 + D3), (0, 0, D1 + D3 + D5),
               (0, 0, D1 + D3 + D5), (0, 0, D1 + D3 + D5 + D7)]


def variant(model, lengths):
    """Return the myArm model with other d1, d3, d5, d7 [m] (axes as the document's)."""
    d1, d3, d5, d7 = lengths
    z = [0.0, d1, d1 + d3, d1 + d3, d1 + d3 + d5, d1 + d3 + d5, d1 + d3 + d5 + d7]
    S = np.column_stack([screw_axis(w, (0.0, 0.0, zi)) for w, zi in zip(model.S_list[:3].T, z)])
    return dataclasses.replace(model, S_list=S, M=transform(np.eye(3), [0.0, 0.0, z[-1]]))


def solve_both(model, t_grasp=T_GRASP, t_place=T_PLACE, place_start=None, **options):
    """Return (q_grasp, q_place, info_grasp, info_place): the document's two solves."""
    q_g, info_g = newton_raphson_twist(model, t_grasp, np.radians(THETA_INIT_DEG), **options)
    q_p, info_p = newton_raphson_twist(model, t_place, q_g if place_start is None
                                       else place_start, **options)
    return q_g, q_p, info_g, info_p


def table_residual(q_grasp, q_place, tables=TABLES_DEG) -> np.ndarray:
    """Return (14,) ours - the document's Tables 2 and 3 [deg]."""
    return np.degrees(np.concatenate([q_grasp, q_place])) - tables


def lengths_fit(model, tables=TABLES_DEG, h=1e-5, iters=400):
    """
    Return (offsets (4,) [m], residual (14,) [deg]) of the d1, d3, d5, d7 fit to ``tables``.

    The offsets bring the two solves closest to the tables in the largest angle (Chebyshev).
    The residual is linear in offsets this small (checked by the final run): a finite-
    difference Jacobian, Lawson's reweighted least squares for the min-max, then a real run.
    """
    base = np.array([D1, D3, D5, D7])

    def residual(x):
        return table_residual(*solve_both(variant(model, base + x))[:2], tables)
    r0 = residual(np.zeros(4))
    A = np.column_stack([(residual(h * e) - r0) / h for e in np.eye(4)])
    w = np.full(len(r0), 1.0 / len(r0))
    for _ in range(iters):
        sw = np.sqrt(w)
        x = np.linalg.lstsq(sw[:, None] * A, -sw * r0, rcond=None)[0]
        w = w * np.abs(r0 + A @ x)
        w /= w.sum()
    return x, residual(x)


def nearest_in_rounding(model, q_table, target, half=np.radians(0.005), what='position'):
    """
    Return the smallest error [m, or twist norm] of FK(q) to the target near a printed table.

    Over the joint vectors q within +-half of q_table (the table's rounding box): projected
    gradient on the linearised error, re-linearised 4 times.
    """
    def error(q):
        if what == 'position':
            return model.fk(q)[:3, 3] - target[:3, 3]
        return log_se3(target @ np.linalg.inv(model.fk(q)))
    q = np.array(q_table, float)
    for _ in range(4):
        e = error(q)
        J = np.column_stack([(error(q + 1e-7 * u) - e) / 1e-7 for u in np.eye(len(q))])
        step = 1.0 / np.linalg.norm(J, 2) ** 2
        d = np.zeros(len(q))
        for _ in range(3000):
            d = np.clip(q + d - step * J.T @ (e + J @ d), q_table - half, q_table + half) - q
        q = q + d
    return float(np.linalg.norm(error(q)))


def why_tables(rep, m, q_grasp, q_place, info_g) -> str:
    """
    Find by experiment why Tables 2 and 3 differ from ours by more than their rounding.

    Print what was tried, test whether the printed place table can come from the printed
    inputs, and fit the printed lengths within their own rounding; return the explanation,
    or '' if the experiments do not account for the difference.
    """
    rep.section('Why Tables 2 and 3 differ by 0.01-0.02 deg: experiments')
    gap = table_residual(q_grasp, q_place)
    print(f'  ours - document: grasp max {np.abs(gap[:7]).max():.4f} deg, place max '
          f'{np.abs(gap[7:]).max():.4f} deg (rounding of the tables: 0.005 deg)')
    print('  variant of the run                                  iterations  max |ours - doc| '
          'grasp / place [deg]')
    variants = [
        ('as printed (above)', {}),
        ('place target = the printed 4-decimal matrix', {'t_place': T_PLACE_PRINTED}),
        ("place solve from the document's rounded Table 2",
         {'place_start': np.radians(GRASP_TABLE_DEG)}),
        ('no 0.5 rad step limit', {'max_step': 1e9}),
    ]
    for label, options in variants:
        qg, qp, ig, ip = solve_both(m, **options)
        r = table_residual(qg, qp)
        print(f'  {label:52s} {ig["iter"]:2d}, {ip["iter"]:2d}      {np.abs(r[:7]).max():.4f} / '
              f'{np.abs(r[7:]).max():.4f}')
    clipped = np.add(_clipped_steps(m, T_GRASP, np.radians(THETA_INIT_DEG)),
                     _clipped_steps(m, T_PLACE, q_grasp))
    print(f'  joint-limit projection: {clipped[0]} of the {clipped[1]} steps touch a limit, so '
          'its exact form cannot matter')
    place_best = nearest_in_rounding(m, np.radians(PLACE_TABLE_DEG), T_PLACE)
    grasp_best = nearest_in_rounding(m, np.radians(GRASP_TABLE_DEG), T_GRASP, what='twist')
    print(f'  closest any joint vector within the rounding of Table 3 gets to the printed place '
          f'position: {place_best * 1000:.4f} mm (the document prints 0.00000 m, < 0.005 mm); '
          f'Table 2 to the grasp pose: twist {grasp_best:.1e}')
    base = np.array([D1, D3, D5, D7])
    moves = []
    for k in range(4):
        x = np.zeros(4)
        x[k] = 0.05e-3
        moves.append(np.abs(table_residual(*solve_both(variant(m, base + x))[:2]) - gap).max())
    for k in range(3):
        for T, name in ((T_GRASP, 'grasp'), (T_PLACE, 'place')):
            T2 = T.copy()
            T2[k, 3] += 0.05e-3
            kw = {'t_grasp': T2} if name == 'grasp' else {'t_place': T2}
            moves.append(np.abs(table_residual(*solve_both(m, **kw)[:2]) - gap).max())
    print(f'  0.05 mm (half the printed 0.1 mm) on one of d1, d3, d5, d7 or a target coordinate '
          f'moves the solution by {min(moves):.3f} to {max(moves):.3f} deg')
    x, r = lengths_fit(m)
    fitted = variant(m, base + x)
    qg, qp, ig, ip = solve_both(fitted)
    err = float(np.linalg.norm(fitted.fk(qg)[:3, 3] - T_GRASP[:3, 3]))
    print(f'  d1, d3, d5, d7 = {np.round((base + x) * 1000, 4).tolist()} mm (printed + '
          f'{np.round(x * 1000, 4).tolist()} mm): both tables within {np.abs(r).max():.4f} deg, '
          f'{ig["iter"]} and {ip["iter"]} iterations, grasp position error {err:.3g} m')
    rng = np.random.default_rng(0)
    control = []
    for _ in range(3):
        fake = np.degrees(np.concatenate([q_grasp, q_place])) + rng.choice([-1, 1], 14) * \
            rng.uniform(0.004, np.abs(gap).max(), 14)
        control.append(np.abs(lengths_fit(m, fake)[1]).max())
    print(f'  control: the same fit on 3 made-up tables with errors of the same size leaves '
          f'{min(control):.4f} to {max(control):.4f} deg')
    rep.values['tables_analysis'] = {'place_best_m': place_best, 'fit_offsets_m': x,
                                     'fit_residual_deg': np.abs(r).max(), 'control': control,
                                     'moves_deg': moves, 'grasp_error_fit': err}
    if not (place_best > 5e-6 and np.abs(r).max() <= 0.005 and np.abs(x).max() <= 0.05e-3
            and min(control) > 2 * np.abs(r).max() and max(moves) >= np.abs(gap).max() / 2
            and (ig['iter'], ip['iter']) == (8, 6)):
        return ''
    return ('the document ran with lengths (or targets) that differ from its printed ones by '
            'less than their printed precision (4 decimals in m): no joint vector within the '
            f'rounding of Table 3 reaches the printed place position within the printed '
            f'0.00000 m (best {place_best * 1000:.3f} mm); 0.05 mm on one printed input moves '
            f'the solution by up to {max(moves):.3f} deg; d1, d3, d5, d7 moved by '
            f'{np.round(x * 1000, 3).tolist()} mm reproduce every angle of both tables within '
            f'{np.abs(r).max():.4f} deg (made-up tables: >= {min(control):.4f} deg); the '
            'printed digits cannot tell which input it was')


def _clipped_steps(model, target, q0) -> Tuple[int, int]:
    """Return (steps that end on a joint limit, steps) of a solve."""
    q, count = np.array(q0, float), 0
    for k in range(50):
        q_next, info = newton_raphson_twist(model, target, q, max_iters=1)
        if info['converged']:
            return count, k
        count += int(np.any(np.isclose(q_next, model.lower) | np.isclose(q_next, model.upper)))
        q = q_next
    return count, 50


def joint_points(model, q) -> np.ndarray:
    """Return the (9, 3) stick-figure points [m]: base, the 7 axis points, the flange."""
    pts, T = [np.zeros(3)], np.eye(4)
    for S, qi, p in zip(model.S_list.T, q, AXIS_POINTS):
        pts.append((T @ np.append(p, 1.0))[:3])
        T = T @ exp_se3(S, qi)
    pts.append(model.fk(q)[:3, 3])
    return np.array(pts)


def main(argv=None):
    """Run the example; return its Report."""
    args, rep = start(NAME, 'myArm 300 Pi: Newton-Raphson IK for grasp and place', argv)
    m = load_robot('myarm300pi')
    rep.section("Model: the document's screw axes (omega_i, q_i) and d1, d3, d5, d7")
    for i, p in enumerate(AXIS_POINTS):
        w, v = m.S_list[:3, i], m.S_list[3:, i]
        # a point on the axis satisfies v = -w x p
        rep.compare(f'joint {i + 1}: v = -omega x q_i', v, -np.cross(w, p), 1e-9)
    rep.compare('place target: R_y(90) R_x(45) at (0.105, 0.075, 0.1) m vs the printed matrix',
                T_PLACE, T_PLACE_PRINTED, 0.5e-4)
    rep.note('units: the document states the grasp target in cm (17.5, 2.5, 5), the frames of '
             'Task 1-4 in cm and the place matrix in m; the kinematic parameters are in m. '
             'Here every length is in m (the grasp target is converted).')

    rep.section('Grasp: from theta_init (document: 8 iterations, Table 2, error 5.91e-9 m)')
    q_grasp, info_g = newton_raphson_twist(m, T_GRASP, np.radians(THETA_INIT_DEG))
    rep.compare('converged, iterations', (info_g['converged'], info_g['iter']), (1, 8), 0)
    rep.values['grasp'] = (q_grasp, info_g)

    rep.section('Place: from the grasp solution (document: 6 iterations, Table 3, 0.00000 m)')
    q_place, info_p = newton_raphson_twist(m, T_PLACE, q_grasp)
    rep.compare('converged, iterations', (info_p['converged'], info_p['iter']), (1, 6), 0)
    perr = float(np.linalg.norm(m.fk(q_place)[:3, 3] - T_PLACE[:3, 3]))
    rep.compare('position error [m] (printed with 5 decimals)', perr, 0.0, 0.5e-5)
    _, info_0 = newton_raphson_twist(m, T_PLACE, np.radians(THETA_INIT_DEG))
    rep.compare('place solve from theta_init instead: converged', info_0['converged'], 1, 0,
                why=f'from theta_init the iteration does not converge in 50 steps (last '
                    f'||twist|| = {info_0["err"][-1]:.3g}: stuck against the joint limits); the '
                    'document does not say which start it used, only the grasp solution '
                    'reproduces its 6 iterations')
    rep.values['place'] = (q_place, info_p)

    why = why_tables(rep, m, q_grasp, q_place, info_g)
    for label, q, table in (('grasp joint angles [deg] (Table 2)', q_grasp, GRASP_TABLE_DEG),
                            ('place joint angles [deg] (Table 3)', q_place, PLACE_TABLE_DEG)):
        d = float(np.abs(np.degrees(q) - table).max())
        rep.compare(label, np.degrees(q), table, 0.005,
                    why=why and f'largest difference {d:.3f} deg: {why}')
    perr = float(np.linalg.norm(m.fk(q_grasp)[:3, 3] - T_GRASP[:3, 3]))
    fit_err = rep.values['tables_analysis']['grasp_error_fit']
    rep.compare('grasp position error [m]', perr, 5.91e-9, 0.005e-9,
                why='' if abs(fit_err - 5.91e-9) > 0.05e-9 else
                f'the error after the 8th step follows the exact iterates: with the fitted '
                f'lengths above it is {fit_err:.3g} m')

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for ax, info, title in ((axes[0], info_g, 'Grasp (Fig. 2)'),
                            (axes[1], info_p, 'Place (Fig. 3)')):
        ax.semilogy(range(len(info['err'])), info['err'], '-o')
        ax.axhline(1e-4, color='gray', ls='--', label='tol 1e-4')
        ax.set_xlabel('iteration')
        ax.set_ylabel('||log(T_target T^-1)||')
        ax.set_title(f'{title}: {info["iter"]} iterations')
        ax.grid(True, which='both', alpha=0.3)
        ax.legend()
    rep.save(fig, 'error_vs_iteration.png')

    fig = plt.figure(figsize=(6, 6))
    ax = fig.add_subplot(projection='3d')
    pts = joint_points(m, q_grasp) * 100
    ax.plot(*pts.T, '-o', color='dimgray', lw=4, label='myArm 300 Pi')
    _box(ax, (17.5, 2.5, 2.5), (5, 5, 5), 'tab:blue', 'blue cube')
    ax.scatter([10], [12.5], [10], color='tab:red', s=40, label='red box centre (size not given)')
    ax.scatter(*(T_GRASP[:3, 3] * 100), color='k', s=30, label='grasp point')
    ax.set_xlabel('x [cm]')
    ax.set_ylabel('y [cm]')
    ax.set_zlabel('z [cm]')
    ax.set_title('Grasp pose (Fig. 4)')
    set_axes_equal(ax)
    ax.legend(fontsize=8)
    rep.save(fig, 'grasp_pose.png')
    return rep.finish()


def _box(ax, center, size, color, label, alpha=0.35):
    """Draw an axis-aligned box (center, full size) [cm]."""
    c, s = np.asarray(center, float), np.asarray(size, float) / 2
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * s + c
    faces = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]]
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    ax.add_collection3d(Poly3DCollection([corners[f] for f in faces], facecolor=color,
                                         alpha=alpha, edgecolor=color))
    ax.scatter(*c, color=color, s=5, label=label)


if __name__ == '__main__':
    main()
