"""The px100 from its URDF, a DH table, a modified DH table and a PoE table is the same arm."""
import io

import numpy as np
from px100_control.kinematics.dh import DHRow, fk_dh
from px100_control.kinematics.poe import fk_space, jacobian_body, jacobian_space
from px100_control.models.registry import _matrix, load_robot, table_to_poe
import pytest

TOL = 1e-12


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


@pytest.fixture(scope='module')
def configs(px100):
    return px100.random_configurations(200, np.random.default_rng(12))


def _rows(table):
    return [DHRow(float(j['a']), float(j['alpha']), float(j['d']), float(j['theta']))
            for j in table['joints']]


def test_alternative_models_declared(px100):
    """px100.yaml declares dh, mdh and poe tables over the same joints, in group order."""
    alt = px100.extra['alternative_models']
    assert set(alt) == {'dh', 'mdh', 'poe'}
    for table in alt.values():
        assert tuple(j['name'] for j in table['joints']) == px100.joint_names


def test_urdf_fk_equals_poe_model(px100, configs):
    """The URDF's own forward kinematics (yourdfpy) equals the PoE model built from it."""
    yourdfpy = pytest.importorskip('yourdfpy')
    urdf = yourdfpy.URDF.load(io.StringIO(px100.urdf_xml), build_scene_graph=True,
                              load_meshes=False, load_collision_meshes=False)
    for q in configs[:50]:
        cfg = dict(zip(px100.joint_names, q))
        urdf.update_cfg(cfg)
        T_urdf = urdf.get_transform(px100.ee_frame, px100.base_frame)
        np.testing.assert_allclose(px100.fk(q), T_urdf, atol=TOL, rtol=0)


@pytest.mark.parametrize('convention', ['dh', 'mdh'])
def test_dh_tables_equal_urdf(px100, configs, convention):
    """Chaining the (M)DH link transforms gives the URDF pose at every configuration."""
    table = px100.extra['alternative_models'][convention]
    rows = _rows(table)
    tool = _matrix(table.get('tool'))
    for q in configs:
        T = fk_dh(rows, q, tool=tool, modified=convention == 'mdh')
        np.testing.assert_allclose(T, px100.fk(q), atol=TOL, rtol=0)


@pytest.mark.parametrize('convention', ['dh', 'mdh', 'poe'])
def test_tables_give_same_screws_and_jacobians(px100, configs, convention):
    """Every table's PoE form has the URDF's screw axes, M, space and body Jacobians."""
    S, M, _ = table_to_poe(px100.extra['alternative_models'][convention])
    np.testing.assert_allclose(S, px100.S_list, atol=TOL, rtol=0)
    np.testing.assert_allclose(M, px100.M, atol=TOL, rtol=0)
    for q in configs[:50]:
        np.testing.assert_allclose(fk_space(S, M, q), px100.fk(q), atol=TOL, rtol=0)
        np.testing.assert_allclose(jacobian_space(S, q), px100.jacobian_space(q), atol=TOL,
                                   rtol=0)
        np.testing.assert_allclose(jacobian_body(S, M, q), px100.jacobian_body(q), atol=TOL,
                                   rtol=0)


def test_dh_offsets_are_the_seed_q_nom(px100):
    """The DH theta offsets are seed 000's q_nom = [0, -atan2(L2, Lm), +atan2(L2, Lm), 0]."""
    rows = _rows(px100.extra['alternative_models']['dh'])
    a = np.arctan2(0.1, 0.035)
    np.testing.assert_allclose([r.theta for r in rows], [0.0, -a, a, 0.0], atol=1e-15)
    np.testing.assert_allclose(rows[1].a, np.hypot(0.035, 0.1), atol=1e-15)
