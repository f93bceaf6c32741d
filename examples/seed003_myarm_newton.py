#!/usr/bin/env python3
"""
Seed 003: Elephant myArm 300 Pi (7-DOF, PoE), Newton-Raphson IK for the grasp and place poses.

The document's solver (pinv of the space Jacobian on the twist log(T_target T^-1), steps scaled
to norm <= 0.5, projection onto the joint limits, ||twist|| < 1e-4) is
``px100_control.kinematics.iterative.newton_raphson_twist`` on the registered 'myarm300pi'.
Grasp: Rx(180 deg) at (17.5, 2.5, 5) cm from theta_init = [0, 30, 0, -45, 0, -45, 0] deg;
place: R_y(90) R_x(45) at (0.105, 0.075, 0.1) m. Figures: error vs iteration for both solves
(document Figs. 2-3) and the arm at its grasp pose over the blue cube (Fig. 4).

Run: python examples/seed003_myarm_newton.py [--out DIR]
"""
import math

from example_support import set_axes_equal, start
import matplotlib.pyplot as plt
import numpy as np
from px100_control.kinematics.iterative import newton_raphson_twist
from px100_control.kinematics.se3 import exp_se3, rot_x, rot_y, transform
from px100_control.models.registry import load_robot

NAME = 'seed003_myarm_newton'
CM = 0.01
THETA_INIT_DEG = [0, 30, 0, -45, 0, -45, 0]
GRASP_TABLE_DEG = [-12.73, 68.82, -60.13, -81.36, -44.14, -41.83, -55.14]
PLACE_TABLE_DEG = [46.83, 64.76, -70.94, -103.01, -83.66, -108.91, -100.89]
T_GRASP = transform(rot_x(math.pi), np.array([17.5, 2.5, 5.0]) * CM)
T_PLACE = transform(rot_y(math.pi / 2) @ rot_x(math.pi / 4), [0.105, 0.075, 0.10])
T_PLACE_PRINTED = np.array([[0.0, 0.7071, 0.7071, 0.1050], [0.0, 0.7071, -0.7071, 0.0750],
                            [-1.0, 0.0, 0.0, 0.1000], [0.0, 0.0, 0.0, 1.0]])
D1, D3, D5, D7 = 0.1695, 0.1155, 0.1278, 0.0660
#: the document's points q_i on the joint axes at zero configuration [m]
AXIS_POINTS = [(0, 0, 0), (0, 0, D1), (0, 0, D1 + D3), (0, 0, D1 + D3), (0, 0, D1 + D3 + D5),
               (0, 0, D1 + D3 + D5), (0, 0, D1 + D3 + D5 + D7)]


def why_table(ours_deg, table_deg) -> str:
    """Return the explanation of a joint-table difference, with its size."""
    d = float(np.abs(np.asarray(ours_deg) - table_deg).max())
    return (f'largest difference {d:.3f} deg, more than the 2-decimal rounding; cause not '
            'identified: the arm is redundant, so any small implementation difference (pinv '
            'cut-off, the twist log near 180 deg, the order of operations) shifts where '
            'Newton-Raphson ends in the self-motion; FK of the printed table reaches the '
            'target within its rounding (test/robots/test_seeds.py), so both are solutions')


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
    rep.compare('grasp joint angles [deg] (Table 2)', np.degrees(q_grasp), GRASP_TABLE_DEG,
                0.005, why=why_table(np.degrees(q_grasp), GRASP_TABLE_DEG))
    perr = float(np.linalg.norm(m.fk(q_grasp)[:3, 3] - T_GRASP[:3, 3]))
    rep.compare('position error [m]', perr, 5.91e-9, 0.005e-9,
                why='the error after the last step depends on the exact iterates (both are '
                    'below 1e-8 m, far inside tol = 1e-4 on the twist)')
    rep.values['grasp'] = (q_grasp, info_g)

    rep.section('Place: from the grasp solution (document: 6 iterations, Table 3, 0.00000 m)')
    q_place, info_p = newton_raphson_twist(m, T_PLACE, q_grasp)
    rep.compare('converged, iterations', (info_p['converged'], info_p['iter']), (1, 6), 0)
    rep.compare('place joint angles [deg] (Table 3)', np.degrees(q_place), PLACE_TABLE_DEG,
                0.005, why=why_table(np.degrees(q_place), PLACE_TABLE_DEG))
    perr = float(np.linalg.norm(m.fk(q_place)[:3, 3] - T_PLACE[:3, 3]))
    rep.compare('position error [m] (printed with 5 decimals)', perr, 0.0, 0.5e-5)
    _, info_0 = newton_raphson_twist(m, T_PLACE, np.radians(THETA_INIT_DEG))
    rep.compare('place solve from theta_init instead: converged', info_0['converged'], 1, 0,
                why=f'from theta_init the iteration does not converge in 50 steps (last '
                    f'||twist|| = {info_0["err"][-1]:.3g}: stuck against the joint limits); the '
                    'document does not say which start it used, only the grasp solution '
                    'reproduces its 6 iterations')
    rep.values['place'] = (q_place, info_p)

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
