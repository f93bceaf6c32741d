#!/usr/bin/env python3
"""
Seed 004: the 4-DOF RRRR arm (standard DH, wrist offset d4), FK and closed-form position IK.

The document's section 3 formulas are written out here (q1 = atan2(Y, X); q3 = gamma +- acos(D /
(2 a2 Rk)); q2 = atan2(...)) and compared with ``px100_control.kinematics.analytic.rrrr`` on the
registered robot 'rrrr' (the document's a2, a3, d1, d4 are placeholders: the robot uses 0.2,
0.15, 0.1, 0.05 m). Figure: the arm in its elbow-up and elbow-down configurations for one
target (the document has no figure and no numbers besides its formulas).

Run: python examples/seed004_rrrr_elbow.py [--out DIR]
"""
import math

from example_support import dh_points, set_axes_equal, start
import matplotlib.pyplot as plt
import numpy as np
from px100_control.kinematics.analytic import rrrr
from px100_control.kinematics.dh import DHRow, fk_dh
from px100_control.models.registry import load_robot

NAME = 'seed004_rrrr_elbow'
TARGET_Q = (0.5, 0.9, -0.6, 0.0)     # a configuration whose end-effector point is the target


def document_ik(P, X, Y, Z):
    """Return [(label, (q1, q2, q3))] from the document's section 3 formulas, as printed."""
    q1 = math.atan2(Y, X)
    px, pz = math.hypot(X, Y), Z - P.d1
    D = px * px + pz * pz - P.a2 ** 2 - P.a3 ** 2 - P.d4 ** 2
    Rk, gamma = math.hypot(P.a3, P.d4), math.atan2(P.d4, P.a3)
    e = math.acos(D / (2 * P.a2 * Rk))
    out = []
    for label, q3 in (('+ acos', gamma + e), ('- acos', gamma - e)):
        A = P.a3 * math.cos(q3) + P.d4 * math.sin(q3)
        B = P.a3 * math.sin(q3) - P.d4 * math.cos(q3)
        den = (P.a2 + A) ** 2 + B ** 2
        q2 = math.atan2((-B * px + (P.a2 + A) * pz) / den, ((P.a2 + A) * px + B * pz) / den)
        out.append((label, (q1, q2, q3)))
    return out


def main(argv=None):
    """Run the example; return its Report."""
    args, rep = start(NAME, 'RRRR arm: FK equations, elbow-up and elbow-down IK', argv)
    m = load_robot('rrrr')
    P = rrrr.parameters(m)
    rep.section("Forward model: the document's X, Y, Z equations vs the robot model")
    worst = max(np.abs(rrrr.fk_position(P, q) - m.fk(q)[:3, 3]).max()
                for q in m.random_configurations(200, rng=1))
    rep.compare('max |FK(model) - document equations| over 200 configurations [m]', worst, 0.0,
                1e-12)
    h = math.pi / 2
    as_printed = [DHRow(0.0, 0.0, P.d1), DHRow(0.0, -h, 0.0), DHRow(P.a2, 0.0, 0.0),
                  DHRow(P.a3, h, P.d4)]
    q = np.array(TARGET_Q)
    gap = np.linalg.norm(fk_dh(as_printed, q, modified=True)[:3, 3] - rrrr.fk_position(P, q))
    rep.compare('the printed D-H table (twists -90, +90, read as modified DH) vs the equations '
                '[m]', gap, 0.0, 1e-9,
                why='the printed table does not produce the printed equations; the standard DH '
                    'table with twists +90 deg on joints 1 and 3 does (the robot uses it)')

    rep.section('Inverse position kinematics: elbow up and elbow down')
    X, Y, Z = rrrr.fk_position(P, q)
    print(f'  target (X, Y, Z) = ({X:.4f}, {Y:.4f}, {Z:.4f}) m from q = {TARGET_Q}')
    doc = document_ik(P, X, Y, Z)
    ours = rrrr.arm_solutions(P, X, Y, Z)
    for label, s in doc:
        reached = rrrr.fk_position(P, s)
        rep.compare(f'document formula q3 = gamma {label}: FK of (q1, q2, q3) vs target [m]',
                    reached, (X, Y, Z), 1e-9)
        match = min(np.abs(np.remainder(np.subtract(s, t) + math.pi, 2 * math.pi) - math.pi)
                    .max() for t in ours)
        rep.compare(f'document solution ({label}) found by analytic.rrrr [rad]', match, 0.0,
                    1e-9)
        print(f'    (q1, q2, q3) = ({s[0]:+.5f}, {s[1]:+.5f}, {s[2]:+.5f}) rad')
    extra = [t for t in ours if abs(math.remainder(t[0] - doc[0][1][0], 2 * math.pi)) > 1e-6]
    rep.note(f'analytic.rrrr also returns the {len(extra)} over-the-top solutions (q1 + pi, '
             'reach -Px) that the document leaves out; all reach the target: '
             + ', '.join(f'{np.linalg.norm(rrrr.fk_position(P, t) - (X, Y, Z)):.1e} m'
                         for t in extra))
    rep.values['solutions'] = ours

    fig = plt.figure(figsize=(9, 4.5))
    for i, (label, s) in enumerate(doc):
        ax = fig.add_subplot(1, 2, i + 1, projection='3d')
        pts = dh_points(m, list(s) + [0.0]) * 1000
        ax.plot(*pts.T, '-o', color='tab:blue', lw=3)
        ax.scatter([X * 1000], [Y * 1000], [Z * 1000], color='tab:red', s=60, label='target')
        ax.set_title(f'elbow {"up" if s[2] < math.atan2(P.d4, P.a3) else "down"} '
                     f'(q3 = gamma {label})')
        ax.set_xlabel('x [mm]')
        ax.set_ylabel('y [mm]')
        ax.set_zlabel('z [mm]')
        set_axes_equal(ax)
        ax.legend()
    rep.save(fig, 'elbow_up_down.png')
    return rep.finish()


if __name__ == '__main__':
    main()
