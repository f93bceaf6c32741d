"""
Shared helpers of the seed examples: the output folder, Agg figures, side-by-side comparisons.

Every example builds a :class:`Report`: ``compare`` prints our value beside the document's with
the tolerance of the document's printed precision and, when they differ, the reason. An
unexplained difference is marked ``DIFFERS (unexplained)``; the tests fail on it.
"""
import argparse
from dataclasses import dataclass, field
import os
import sys
from typing import List, Optional

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)      # run from a source checkout without installing

from px100_control.tools.venv_check import require  # noqa: E402

require('numpy', 'matplotlib', 'yaml', 'mujoco', 'rclpy')

import matplotlib  # noqa: E402, I100

matplotlib.use('Agg')

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


@dataclass
class Comparison:
    """One number (or vector) of ours beside the document's."""

    label: str
    ours: np.ndarray
    doc: np.ndarray
    tol: np.ndarray
    why: str = ''

    @property
    def matches(self) -> bool:
        """Return True when every |ours - doc| <= tol."""
        return bool(np.all(np.abs(self.ours - self.doc) <= self.tol))

    @property
    def status(self) -> str:
        """Return 'matches', 'differs: <why>' or 'DIFFERS (unexplained)'."""
        if self.matches:
            return 'matches'
        return f'differs: {self.why}' if self.why else 'DIFFERS (unexplained)'


@dataclass
class Report:
    """The comparisons, notes and figures of one example run."""

    name: str
    out: str
    comparisons: List[Comparison] = field(default_factory=list)
    figures: List[str] = field(default_factory=list)
    notes: List[str] = field(default_factory=list)
    values: dict = field(default_factory=dict)

    def section(self, title: str) -> None:
        """Print a section title."""
        print(f'\n=== {title}')

    def note(self, text: str) -> None:
        """Print and keep a remark (a document error, a modelling difference)."""
        self.notes.append(text)
        print(f'  note: {text}')

    def compare(self, label: str, ours, doc, tol: float, why: str = '') -> Comparison:
        """Print ours beside the document's; ``why`` explains a difference beyond ``tol``."""
        c = Comparison(label, np.atleast_1d(np.asarray(ours, dtype=float)),
                       np.atleast_1d(np.asarray(doc, dtype=float)), np.asarray(tol, float), why)
        self.comparisons.append(c)
        t = f'{float(c.tol):g}' if c.tol.ndim == 0 else np.array2string(c.tol, precision=2)
        print(f'  {label}\n    ours     {_fmt(c.ours)}\n    document {_fmt(c.doc)}'
              f'   (tolerance {t}) -> {c.status}')
        return c

    def save(self, fig, filename: str) -> str:
        """Write a figure as PNG into the output folder and close it; return the path."""
        path = os.path.join(self.out, filename)
        fig.savefig(path, dpi=110, bbox_inches='tight')
        plt.close(fig)
        self.figures.append(path)
        print(f'  figure: {path}')
        return path

    def unexplained(self) -> List[Comparison]:
        """Return the comparisons that differ without a reason."""
        return [c for c in self.comparisons if not c.matches and not c.why]

    def finish(self) -> 'Report':
        """Print the summary and write it to report.txt in the output folder."""
        lines = [f'{self.name}: {len(self.comparisons)} comparisons, '
                 f'{sum(c.matches for c in self.comparisons)} within the printed precision, '
                 f'{sum(not c.matches and bool(c.why) for c in self.comparisons)} explained '
                 f'differences, {len(self.unexplained())} unexplained; '
                 f'{len(self.figures)} figures in {self.out}']
        lines += [f'- {c.label}: {c.status}' for c in self.comparisons]
        lines += [f'- note: {n}' for n in self.notes]
        with open(os.path.join(self.out, 'report.txt'), 'w') as f:
            f.write('\n'.join(lines) + '\n')
        print('\n' + lines[0])
        return self


def _fmt(a: np.ndarray) -> str:
    return np.array2string(a, precision=8, suppress_small=False, max_line_width=200)


#: what each example's 'document' is: the source notes the package was built from (not in this
#: repository: the numbers they print are typed into the examples)
SOURCE_NOTES = {
    'seed000': 'a lab report on the PincherX-100 (its DH model in mm, inverse model, '
               'null-space iterative IK, workspace, two pick-and-place scripts)',
    'seed001': 'a lab report on the PincherX-100 (compute_aik in MATLAB, a pick-and-place '
               'waypoint sequence, Cartesian interpolation, a PID gain table)',
    'seed002': 'a lecture note on an RRRP robot (modified DH, its closed-form inverse model)',
    'seed003': 'a homework on the Elephant myArm 300 Pi (PoE model, Newton-Raphson IK, its '
               'tables of joint angles)',
    'seed004': 'a report on a 4-DOF RRRR arm (standard DH, elbow-up and elbow-down IK)',
}


def start(name: str, description: str, argv=None, extra=None) -> (argparse.Namespace, Report):
    """Parse --out (default out/examples/<name>/) and extra options; return (args, Report)."""
    parser = argparse.ArgumentParser(prog=f'{name}.py', description=description)
    parser.add_argument('--out', default=os.path.join('out', 'examples', name),
                        help='folder for the figures and report.txt (default %(default)s)')
    if extra is not None:
        extra(parser)
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    print(f'{name}: {description}')
    notes = SOURCE_NOTES.get(name.split('_')[0])
    if notes:
        print(f"'document' below = this example's source notes: {notes}. They are not in "
              'this repository: the numbers they print are typed into this script and shown '
              "as 'document' beside ours (examples/README.md).")
    return args, Report(name, args.out)


def set_axes_equal(ax) -> None:
    """Give a 3D axes equal scale on x, y, z."""
    lims = np.array([ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d()])
    mid, half = lims.mean(axis=1), (lims[:, 1] - lims[:, 0]).max() / 2
    ax.set_xlim3d(mid[0] - half, mid[0] + half)
    ax.set_ylim3d(mid[1] - half, mid[1] + half)
    ax.set_zlim3d(mid[2] - half, mid[2] + half)


def dh_points(model, q) -> np.ndarray:
    """Return the (n + 2, 3) origins of the base, every DH/MDH frame and the tool [m]."""
    from px100_control.kinematics.dh import dh_transform, mdh_transform
    kin = model.extra['kinematics']
    link = mdh_transform if kin['convention'] == 'mdh' else dh_transform
    T = np.eye(4)
    pts = [T[:3, 3].copy()]
    for j, qi in zip(kin['joints'], q):
        theta, d = float(j.get('theta', 0.0)), float(j.get('d', 0.0))
        if j.get('type') == 'prismatic':
            d += qi
        else:
            theta += qi
        T = T @ link(float(j.get('a', 0.0)), float(j.get('alpha', 0.0)), d, theta)
        pts.append(T[:3, 3].copy())
    pts.append(model.fk(q)[:3, 3])
    return np.array(pts)


def fmt_opt(value: Optional[float]) -> str:
    """Return a number with 4 decimals, or '-' for None."""
    return '-' if value is None else f'{value:.4f}'
