"""
Kinematics benchmark of seed 003's 7-DOF myArm 300 Pi against the same peers as the px100's.

The same code as ``bench_kinematics.py`` with ``--robot myarm300pi`` (1,000 random reachable
targets made by FK from in-limit configurations; peers from the bench venv). Usage:
``python benchmarks/bench_kinematics_myarm300pi.py [--quick]``.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)

import bench_kinematics  # noqa: E402 - after the path fix

ROBOT = 'myarm300pi'
#: the run's bound [s] (--quick, full): bench_kinematics's
BOUND_S = bench_kinematics.BOUND_S


def run(quick: bool = False) -> dict:
    """Run bench_kinematics for the myarm300pi; return its figures."""
    return bench_kinematics.run(quick=quick, robot=ROBOT)


if __name__ == '__main__':
    sys.exit(bench_kinematics.main(['--robot', ROBOT] + sys.argv[1:]))
