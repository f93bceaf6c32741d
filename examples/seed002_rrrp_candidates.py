#!/usr/bin/env python3
"""
Seed 002: the RRRP robot (modified DH), every candidate of its closed-form inverse model.

For a pose fMe*, the document solves q3 (type 3: s3 = x_z, -c3 = z_z), q12 = q1 + q2 (type 3:
c12 = y_x, s12 = y_y), then either q4 = (r1 - t_z) / cos q3 and q1 (type 3) when |cos q3| >
|sin q3|, or (q1, q4) together (type 5) otherwise, and q2 = q12 - q1; addCandidate keeps each.
``px100_control.kinematics.analytic.rrrp.candidates`` does the same; ``solve_ik`` keeps the
candidates whose FK is the pose. Shown for one pose on each side of the rule and for cos q3 = 0,
where t_z does not depend on q4 and both type 5 roots are real solutions. Figure: the robot in
every exact candidate (the document's figure is a drawing of the robot).

Run: python examples/seed002_rrrp_candidates.py [--out DIR]
"""
import math

from example_support import dh_points, set_axes_equal, start
import matplotlib.pyplot as plt
import numpy as np
from px100_control.kinematics.analytic import rrrp
from px100_control.kinematics.solve import solve_ik
from px100_control.models.registry import load_robot

NAME = 'seed002_rrrp_candidates'
CASES = [('|cos q3| > |sin q3| (q4 from t_z, then type 3 for q1)', (0.4, -0.3, 0.3, 0.12)),
         ('|cos q3| < |sin q3| (type 5 for q1 and q4)', (0.4, -0.3, 1.2, 0.12)),
         ('cos q3 = 0 (type 5; t_z does not depend on q4)', (0.4, -0.3, math.pi / 2, 0.12))]


def main(argv=None):
    """Run the example; return its Report."""
    args, rep = start(NAME, 'RRRP robot: all candidates of the closed-form inverse model', argv)
    m = load_robot('rrrp')
    P = rrrp.parameters(m)
    rep.section('Parameters (document table: r1 = 0.27, a2 = 0.2, r3 = 0.15, r4 = 0.07 m)')
    rep.compare('(r1, a2, r3, r4) [m]', (P.r1, P.a2, P.r3, P.r4), (0.27, 0.2, 0.15, 0.07), 0.0)
    fig = plt.figure(figsize=(13, 4.5))
    for n, (title, q) in enumerate(CASES):
        rep.section(title)
        q = np.array(q)
        T = m.fk(q)
        C = rrrp.candidates(m, T, 'full')
        errs = [float(np.abs(m.fk(c) - T).max()) for c in C]
        print(f'  pose from q = {q.round(4).tolist()}; {len(C)} candidates:')
        for c, e in zip(C, errs):
            print(f'    q = [{", ".join(f"{v:+.5f}" for v in c)}]   max |FK - pose| = {e:.1e}'
                  f'  -> {"solution" if e < 1e-9 else "spurious (t_z not met), dropped"}')
        exact = [c for c, e in zip(C, errs) if e < 1e-9]
        found = min(np.abs(np.remainder(c[:3] - q[:3] + math.pi, 2 * math.pi) - math.pi).max()
                    + abs(c[3] - q[3]) for c in exact)
        rep.compare('the generating configuration is among the exact candidates [rad]', found,
                    0.0, 1e-9)
        res = solve_ik(m, T, mode='full')
        rep.compare('solve_ik keeps the exact candidates (count)', len(res.solutions),
                    len(exact), 0, why='some exact candidates are outside the joint limits'
                    if len(res.solutions) < len(exact) else '')
        rep.values[title] = {'candidates': C, 'exact': exact}
        if 'cos q3 = 0' in title:
            rep.compare('cos q3 = 0: exact candidates (two type 5 roots)', len(exact), 2, 0)
            rep.note('with cos q3 = 0 the prismatic joint moves the tool in the horizontal '
                     f'plane only: q4 = {exact[0][3]:.4f} and {exact[1][3]:.4f} m both give the '
                     'pose (t_z cannot choose)')
        ax = fig.add_subplot(1, 3, n + 1, projection='3d')
        for k, c in enumerate(exact):
            pts = dh_points(m, c)
            ax.plot(*pts.T, '-o', lw=2.5, label=f'candidate {k}: q4 = {c[3]:.3f} m')
        ax.scatter(*T[:3, 3], color='tab:red', s=50)
        ax.set_title(title.split(' (')[0], fontsize=9)
        ax.set_xlabel('x [m]')
        ax.set_ylabel('y [m]')
        ax.set_zlabel('z [m]')
        set_axes_equal(ax)
        ax.legend(fontsize=7)
    rep.save(fig, 'rrrp_candidates.png')
    return rep.finish()


if __name__ == '__main__':
    main()
