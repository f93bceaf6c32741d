#!/usr/bin/env python3
"""
Print FK/IK for a few PincherX-100 targets and render its workspace to a PNG.

Usage: ``python scripts/kinematics_demo.py [--robot px100] [--png out/workspace_px100.png]``.
No ROS needed (pure kinematics).
"""
import argparse
import math
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from px100_control.tools.venv_check import require  # noqa: E402

require('numpy', 'matplotlib', 'yaml')

import numpy as np  # noqa: E402, I100

from px100_control.kinematics.rotations import (euler_sxyz_to_matrix,  # noqa: E402
                                                matrix_to_euler_sxyz)
from px100_control.kinematics.se3 import transform  # noqa: E402
from px100_control.kinematics.solve import solve_ik, solve_path  # noqa: E402
from px100_control.kinematics.workspace import is_reachable, render_workspace_png  # noqa: E402
from px100_control.models.registry import load_robot  # noqa: E402


def _fmt(q) -> str:
    return '[' + ', '.join(f'{v:+.4f}' for v in q) + ']'


def main(argv=None) -> int:
    """Run the demo."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--robot', default='px100')
    parser.add_argument('--png', default=os.path.join(ROOT, 'out', 'workspace_px100.png'))
    options = parser.parse_args(argv)
    model = load_robot(options.robot)
    np.set_printoptions(precision=4, suppress=True)
    print(f'# {model.name}: joints {list(model.joint_names)}')
    for name, q in (('home', model.home), ('sleep', model.sleep)):
        T = model.fk(q)
        r, p, y = matrix_to_euler_sxyz(T[:3, :3])
        print(f'FK {name:5s} q = {_fmt(q)} -> xyz = {_fmt(T[:3, 3])} m, '
              f'rpy = {_fmt((r, p, y))} rad')
    print('\n## IK, Interbotix style: (x, y, z, pitch), yaw = atan2(y, x)')
    targets = [(0.20, 0.00, 0.15, 0.0), (0.15, 0.10, 0.05, math.pi / 4),
               (0.10, -0.20, 0.003, math.pi / 4), (0.0, 0.0, 0.40, 0.0),
               (-0.12, 0.05, 0.15, 0.9), (0.35, 0.0, 0.10, 0.0)]
    for x, y, z, pitch in targets:
        T = transform(euler_sxyz_to_matrix(0.0, pitch, math.atan2(y, x)), [x, y, z])
        res = solve_ik(model, T, mode='pitch')
        ok, margin = is_reachable(model, (x, y, z), pitch)
        head = f'({x:+.3f}, {y:+.3f}, {z:+.3f}, pitch {pitch:+.3f}) margin {margin:+.4f} m: '
        if res.success:
            print(head + f'{len(res.solutions)} solution(s), best {_fmt(res.q)} '
                  f'(err {res.position_error:.1e} m, {res.orientation_error:.1e} rad, '
                  f'{res.method})')
            for s in res.solutions[1:]:
                print(' ' * len(head) + f'also {_fmt(s)}')
        else:
            print(head + f'no solution: {res.reason}')
    print('\n## IK, position only (pitch chosen by the secondary task toward home)')
    for x, y, z in ((0.2, 0.1, 0.1), (0.1, 0.0, 0.3)):
        res = solve_ik(model, transform(np.eye(3), [x, y, z]), mode='position')
        pitch = matrix_to_euler_sxyz(model.fk(res.q)[:3, :3])[1] if res.success else float(
            'nan')
        print(f'({x:+.3f}, {y:+.3f}, {z:+.3f}): {_fmt(res.q)} pitch {pitch:+.4f} rad '
              f'({res.method})' if res.success else f'({x}, {y}, {z}): {res.reason}')
    print('\n## A straight line, each pose seeded by the previous solution')
    line = [transform(euler_sxyz_to_matrix(0.0, 0.5, 0.0), [x, 0.0, 0.12])
            for x in np.linspace(0.12, 0.40, 8)]
    for res in solve_path(model, line, model.home):
        # a failed result's reason names its pose already ('pose 5: target is ... beyond reach')
        print(f"  pose {res.details['index']}: {_fmt(res.q)}" if res.success else
              f'  {res.reason}')
    path = render_workspace_png(model, options.png)
    print(f'\nworkspace PNG: {path}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
