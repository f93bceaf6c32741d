"""
Every robot is data: the robot files load, match their sources and publish a URDF.

The Interbotix expectations below are an independent transcription of
shared/reference/interbotix_api.md section 6 (not read from the YAML files).
"""
import io
import math

import numpy as np
from px100_control.kinematics.iterative import chain, fk_batch
from px100_control.models.registry import available_robots, load_robot, model_from_spec, \
    read_robot_file
from px100_control.models.urdf_chain import chain_to_poe, load_urdf
from px100_control.models.urdf_writer import joint_origins, urdf_from_model
import pytest

# robot_model names that are part of the interface (issue 7)
REQUIRED = ['px100', 'rrrp', 'myarm300pi', 'rrrr', 'px150', 'rx150', 'rx200', 'wx200', 'wx250',
            'wx250s', 'vx250', 'vx300', 'vx300s']
VARIANTS = ['mobile_px100', 'mobile_wx200', 'mobile_wx250s', 'aloha_wx250s', 'aloha_vx300s']

# section 6: (pitch/roll entries after the waist as (axis, h, d)), Mx, Mz, sleep
_5 = ['waist', 'shoulder', 'elbow', 'wrist_angle', 'wrist_rotate']
_6 = ['waist', 'shoulder', 'elbow', 'forearm_roll', 'wrist_angle', 'wrist_rotate']
SEC6 = {
    'px150': (_5, [('y', .10457, 0), ('y', .25457, .05), ('y', .25457, .2), ('x', .25457, 0)],
              .358575, .25457, [0, -1.8, 1.55, .8, 0]),
    'rx150': (_5, [('y', .10457, 0), ('y', .25457, .05), ('y', .25457, .2), ('x', .25457, 0)],
              .358575, .25457, [0, -1.8, 1.55, .8, 0]),
    'rx200': (_5, [('y', .10457, 0), ('y', .30457, .05), ('y', .30457, .25), ('x', .30457, 0)],
              .408575, .30457, [0, -1.8, 1.55, .8, 0]),
    'wx200': (_5, [('y', .11065, 0), ('y', .31065, .05), ('y', .31065, .25), ('x', .31065, 0)],
              .408575, .31065, [0, -1.88, 1.5, .8, 0]),
    'wx250': (_5, [('y', .11065, 0), ('y', .36065, .04975), ('y', .36065, .29975),
                   ('x', .36065, 0)], .458325, .36065, [0, -1.8, 1.55, .8, 0]),
    'wx250s': (_6, [('y', .11065, 0), ('y', .36065, .04975), ('x', .36065, 0),
                    ('y', .36065, .29975), ('x', .36065, 0)], .458325, .36065,
               [0, -1.8, 1.55, 0, .8, 0]),
    'vx250': (_5, [('y', .12705, 0), ('y', .37705, .06), ('y', .37705, .31), ('x', .37705, 0)],
              .468575, .37705, [0, -1.76, 1.55, .8, 0]),
    'vx300': (_5, [('y', .12705, 0), ('y', .42705, .05955), ('y', .42705, .35955),
                   ('x', .42705, 0)], .536494, .42705, [0, -1.85, 1.55, .8, 0]),
    'vx300s': (_6, [('y', .12705, 0), ('y', .42705, .05955), ('x', .42705, 0),
                    ('y', .42705, .35955), ('x', .42705, 0)], .536494, .42705,
               [0, -1.85, 1.55, 0, .8, 0]),
    'mobile_px100': (['waist', 'shoulder', 'elbow', 'wrist_angle'],
                     [('y', .08518, 0), ('y', .18518, .035), ('y', .18518, .135)],
                     .248575, .18518, [0, -1.88, 1.5, .8]),
    'mobile_wx200': (_5, [('y', .104825, 0), ('y', .304825, .05), ('y', .304825, .25),
                          ('x', .304825, 0)], .408575, .304825, [0, -1.88, 1.5, .8, 0]),
    'mobile_wx250s': (_6, [('y', .104825, 0), ('y', .354825, .04975), ('x', .354825, 0),
                           ('y', .354825, .29975), ('x', .354825, 0)], .458325, .354825,
                      [0, -1.8, 1.55, 0, .8, 0]),
    'aloha_wx250s': (_6, [('y', .104825, 0), ('y', .354825, .04975), ('x', .354825, 0),
                          ('y', .354825, .29975), ('x', .354825, 0)], .458325, .354825,
                     [0, -1.88, 1.6, 0, -1.6, 0]),
    'aloha_vx300s': (_6, [('y', .12705, 0), ('y', .42705, .05955), ('x', .42705, 0),
                          ('y', .42705, .35955), ('x', .42705, 0)], .536494, .42705,
                     [0, -2.05, 1.7, 0, -2.0, 0]),
}
LIMITS_DEG = {  # shoulder; elbow; wrist_angle
    'px150': (-113, 111, -120, 95, -100, 123), 'rx150': (-106, 100, -102, 95, -100, 123),
    'rx200': (-108, 113, -108, 93, -100, 123), 'wx200': (-108, 113, -108, 93, -100, 123),
    'wx250': (-108, 114, -123, 92, -100, 123), 'wx250s': (-108, 114, -123, 92, -100, 123),
    'vx250': (-102, 100, -102, 92, -100, 123), 'vx300': (-106, 72, -101, 92, -107, 128),
    'vx300s': (-106, 72, -101, 92, -107, 128), 'mobile_px100': (-111, 107, -121, 92, -100, 123),
    'mobile_wx200': (-108, 113, -108, 93, -100, 123),
    'mobile_wx250s': (-108, 114, -123, 92, -100, 123),
    'aloha_wx250s': (-108, 114, -123, 92, -100, 123),
    'aloha_vx300s': (-106, 72, -101, 92, -107, 128),
}


def test_required_robot_models_exist():
    """Every robot_model name of the issue (and the cheap variants) is registered."""
    names = available_robots()
    for name in REQUIRED + VARIANTS:
        assert name in names


@pytest.mark.parametrize('name', sorted(set(REQUIRED + VARIANTS)))
def test_robot_loads_consistently(name):
    """Joint data has one entry per joint; home and sleep lie within the limits."""
    m = load_robot(name)
    n = m.dof
    assert m.S_list.shape == (6, n) and m.M.shape == (4, 4)
    for arr in (m.lower, m.upper, m.velocity_limits, m.effort_limits, m.home, m.sleep):
        assert np.asarray(arr).shape == (n,)
    assert np.all(m.lower < m.upper)
    assert np.all(m.velocity_limits > 0) and np.all(m.effort_limits > 0)
    assert m.within_limits(m.home) and m.within_limits(m.sleep)
    assert m.analytic_ik, f'{name} has no analytic IK plug-in'
    assert m.urdf_xml and '<robot' in m.urdf_xml


@pytest.mark.parametrize('name', sorted(SEC6))
def test_interbotix_tables_match_section6(name):
    """S_list, M, sleep, limits, velocities and gripper numbers are the section 6 facts."""
    joints, entries, Mx, Mz, sleep = SEC6[name]
    m = load_robot(name)
    assert list(m.joint_names) == joints
    axes = {'x': (1.0, 0.0, 0.0), 'y': (0.0, 1.0, 0.0)}
    expected = [np.array([0, 0, 1, 0, 0, 0], float)]
    for axis, h, d in entries:
        v = (-h, 0.0, d) if axis == 'y' else (0.0, h, 0.0)
        expected.append(np.array(axes[axis] + v, float))
    np.testing.assert_allclose(m.S_list, np.column_stack(expected), atol=1e-15)
    M = np.eye(4)
    M[0, 3], M[2, 3] = Mx, Mz
    np.testing.assert_allclose(m.M, M, atol=1e-15)
    sl, su, el, eu, wl, wu = (math.radians(v) for v in LIMITS_DEG[name])
    if name == 'aloha_vx300s':
        # section 6's ALOHA sleep is outside the vx300s limits: clamped (documented in the file)
        assert sleep[1] < sl and sleep[2] > eu and sleep[4] < wl
        sleep = [0, sl, eu, 0, wl, 0]
    np.testing.assert_allclose(m.sleep, sleep, atol=1e-15)
    idx = {j: i for i, j in enumerate(joints)}
    for j, (lo, hi) in (('shoulder', (sl, su)), ('elbow', (el, eu)), ('wrist_angle', (wl, wu))):
        assert m.lower[idx[j]] == pytest.approx(lo, abs=1e-12)
        assert m.upper[idx[j]] == pytest.approx(hi, abs=1e-12)
    for j in ('waist', 'forearm_roll', 'wrist_rotate'):
        if j in idx:
            assert m.lower[idx[j]] == pytest.approx(-math.pi + 1e-5, abs=1e-12)
            assert m.upper[idx[j]] == pytest.approx(math.pi - 1e-5, abs=1e-12)
    slow_shoulder = name in ('rx200', 'wx200', 'vx250', 'mobile_wx200')
    for j, i in idx.items():
        expected_v = 1.0 if (j == 'shoulder' and slow_shoulder) else math.pi
        assert m.velocity_limits[i] == pytest.approx(expected_v, abs=1e-12), j
    big = name.startswith(('vx300', 'aloha_vx300'))
    g = m.gripper
    assert (g.horn_radius, g.arm_length) == ((0.022, 0.036) if big else (0.014, 0.024))
    assert (g.finger_lower, g.finger_upper) == ((0.021, 0.057) if big else (0.015, 0.037))


def test_seed_robots_as_written():
    """The seed robots' tables hold the seeds' dimensions and limits."""
    rrrp = read_robot_file('rrrp')['kinematics']
    assert rrrp['convention'] == 'mdh'
    assert [j['d'] for j in rrrp['joints']][0] == 0.27 and rrrp['joints'][1]['a'] == 0.2
    assert rrrp['joints'][2]['d'] == 0.15 and rrrp['tool']['xyz'][2] == 0.07
    assert load_robot('rrrp').joint_types == ('revolute',) * 3 + ('prismatic',)
    my = load_robot('myarm300pi')
    deg = [(-160, 160), (-70, 115), (-170, 170), (-113, 75), (-170, 170), (-115, 115),
           (-180, 180)]
    np.testing.assert_allclose(np.degrees(my.lower), [a for a, _ in deg], atol=1e-9)
    np.testing.assert_allclose(np.degrees(my.upper), [b for _, b in deg], atol=1e-9)
    np.testing.assert_allclose(my.M[:3, 3], [0, 0, 0.1695 + 0.1155 + 0.1278 + 0.066],
                               atol=1e-12)


def _table_robots():
    return [n for n in available_robots() if not read_robot_file(n).get('urdf')]


@pytest.mark.parametrize('name', _table_robots())
def test_generated_urdf_fk_matches_model(name):
    """The generated URDF's FK (urdf_chain and yourdfpy's own) equals the model FK (1e-12)."""
    import yourdfpy
    m = load_robot(name)
    assert m.urdf_xml == urdf_from_model(m)
    urdf = load_urdf(m.urdf_xml)
    assert urdf.validate()
    S, M, limits = chain_to_poe(urdf, m.base_frame, m.ee_frame, m.joint_names)
    Q = m.random_configurations(200, rng=7)
    c = chain(m)
    T_model = fk_batch(c, Q)
    for q, T in zip(Q, T_model):
        from px100_control.kinematics.poe import fk_space
        np.testing.assert_allclose(fk_space(S, M, q), T, atol=1e-12)
    for i, j in enumerate(m.joint_names):
        lo, hi, vel, eff = limits[j]
        assert (lo, hi, vel, eff) == pytest.approx(
            (m.lower[i], m.upper[i], m.velocity_limits[i], m.effort_limits[i]), abs=0)
    scene = yourdfpy.URDF.load(io.StringIO(m.urdf_xml), build_scene_graph=True,
                               load_meshes=False, load_collision_meshes=False)
    for q, T in zip(Q[:50], T_model[:50]):
        scene.update_cfg(dict(zip(m.joint_names, q)))
        np.testing.assert_allclose(scene.get_transform(m.ee_frame, m.base_frame), T,
                                   atol=1e-12)


@pytest.mark.parametrize('name', _table_robots())
def test_generated_urdf_inertials_and_gripper(name):
    """Every moving link has a positive mass and a positive-definite inertia; grippers exist."""
    m = load_robot(name)
    urdf = load_urdf(m.urdf_xml)
    links = {link.name: link for link in urdf.robot.links}
    for j in m.joint_names:
        inertial = links[f'{j}_link'].inertial
        assert inertial is not None and inertial.mass > 0
        assert np.all(np.linalg.eigvalsh(np.asarray(inertial.inertia)) > 0)
    joints = {j.name: j for j in urdf.robot.joints}
    if m.gripper is not None:
        assert joints[m.gripper.joint].type == 'continuous'
        left, right = m.gripper.fingers
        assert joints[left].limit.lower == m.gripper.finger_lower
        assert joints[left].limit.upper == m.gripper.finger_upper
        assert joints[right].mimic.joint == left and joints[right].mimic.multiplier == -1
    # the joint frames sit on their axes: omega x (p - point on axis) has no moment error
    P = joint_origins(m)
    for i, t in enumerate(m.joint_types):
        if t == 'revolute':
            w, v = m.S_list[:3, i], m.S_list[3:, i]
            np.testing.assert_allclose(-np.cross(w, P[i]), v, atol=1e-15)


def test_inertial_hints_change_masses():
    """The optional ``inertial`` section of a robot file tunes the approximate masses."""
    spec = read_robot_file('rrrr')
    light = dict(spec, inertial={'rod_mass_per_m': 0.1, 'motor_mass': 0.01})
    heavy = dict(spec, inertial={'rod_mass_per_m': 2.0, 'motor_mass': 0.5})
    masses = []
    for s in (light, heavy):
        urdf = load_urdf(model_from_spec(s).urdf_xml)
        masses.append(sum(lk.inertial.mass for lk in urdf.robot.links if lk.inertial))
    assert masses[1] > 5 * masses[0]
    # link 2 of rrrr: 0.2 m rod at 2 kg/m + 0.5 kg motor
    link = {lk.name: lk for lk in load_urdf(model_from_spec(heavy).urdf_xml).robot.links}
    assert link['joint2_link'].inertial.mass == pytest.approx(2.0 * 0.2 + 0.5)
