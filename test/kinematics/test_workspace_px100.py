"""Workspace: reachability margins and the PNG rendering."""
import dataclasses

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.kinematics.analytic import px100 as ana
from px100_control.kinematics.workspace import is_reachable, render_workspace_png
from px100_control.models.registry import load_robot
import pytest


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


def test_reachable_agrees_with_ik(px100):
    """Positions of random configurations are reachable (margin >= 0); far ones are not."""
    for q in px100.random_configurations(200, np.random.default_rng(31)):
        ok, margin = is_reachable(px100, px100.fk(q)[:3, 3])
        assert ok and margin >= -1e-12
    ok, margin = is_reachable(px100, [0.5, 0.0, 0.1])
    assert not ok and margin < -0.1


def test_margin_with_pitch_is_distance_to_the_torus(px100):
    """With a pitch, the margin is the wrist-centre distance to the seed 000 annulus."""
    g = ana.geometry(px100)
    x_max = g.Lr + g.L3 + g.L4
    ok, margin = is_reachable(px100, [x_max - 0.02, 0.0, -g.v2], pitch=0.0)
    assert ok and margin == pytest.approx(0.02, abs=1e-12)
    ok, margin = is_reachable(px100, [x_max + 0.02, 0.0, -g.v2], pitch=0.0)
    assert not ok and margin == pytest.approx(-0.02, abs=1e-12)


def test_model_without_analytic_uses_ik(px100):
    """Without reach_margin the answer comes from solve_ik and the margin is NaN."""
    plain = dataclasses.replace(px100, name='plain', analytic_ik=None)
    ok, margin = is_reachable(plain, px100.fk([0.3, -0.2, 0.4, 0.1])[:3, 3])
    assert ok and np.isnan(margin)


def test_invalid_queries(px100):
    """Positions with NaN or of wrong length and a NaN pitch raise InvalidInputError."""
    with pytest.raises(InvalidInputError):
        is_reachable(px100, [np.nan, 0.0, 0.0])
    with pytest.raises(InvalidInputError):
        is_reachable(px100, [0.1, 0.0])
    with pytest.raises(InvalidInputError):
        is_reachable(px100, [0.1, 0.0, 0.1], pitch=float('nan'))


def test_render_png(px100, tmp_path):
    """The workspace renders to a non-trivial PNG file."""
    path = render_workspace_png(px100, str(tmp_path / 'sub' / 'ws.png'), samples=3000)
    data = open(path, 'rb').read()
    assert data[:8] == b'\x89PNG\r\n\x1a\n' and len(data) > 20_000
