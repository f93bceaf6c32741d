"""
Seed 000's two main() scripts (examples/seed000_main_*.py) run against the client.

Only their import lines differ from the document.

They are ROS 1 style: no robot_startup(), ``gripper.open()/close()``, default moving_time 2 s,
and they work in the seed's millimetres through its own DH model (L1 = 89.54, L4 = 109 mm), then
send actuator angles ``q_dh - q_nom`` with ``set_joint_positions``. Every target of both scripts
gives actuator angles inside the px100 limits, so every command must succeed and the measured
joints must reach it. The end effector then lands where the *real* px100 geometry puts those
angles: a few mm from the seed's own target (its lengths differ from the URDF's L1 = 93.1 and
L4 = 113.575 mm), which is asserted honestly below as "within 8 mm of the seed's target and
within 1 mm of the URDF forward kinematics of the command".
"""
import contextlib
import functools
import io
import os

from client_support import wait_until
import numpy as np
from px100_control.client import arm as arm_module
from px100_control.client import InterbotixManipulatorXS, robot_shutdown
import pytest

pytestmark = pytest.mark.ros

EXAMPLES = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))), 'examples')


@pytest.fixture
def seed(monkeypatch):
    """Return the seed's own model module (examples/seed000_model.py), importable by name."""
    monkeypatch.syspath_prepend(EXAMPLES)
    import seed000_model
    return seed000_model


SCRIPT1_TARGETS = [[100, 200, 3], [100, -200, 3], [0, 0, 250], [20, 100, 20], [180, 200, 80],
                   [180, -200, 80]]
SCRIPT2_TARGETS = [[100, 250, 100], [90, -100, 10], [20, 0, 250], [150, 50, 10], [150, 0, 80],
                   [40, -100, -30]]


@pytest.fixture
def spy(monkeypatch, seed):
    """Record every set_joint_positions call: command, result, measured joints and ee_pose."""
    calls = []
    original = arm_module.InterbotixArmXSInterface.set_joint_positions

    def recording(self, joint_positions, *args, **kwargs):
        ok = original(self, joint_positions, *args, **kwargs)
        fk = self.core.model.fk(self.get_joint_commands())[:3, 3]
        # the servos close the last fraction after SUCCEEDED: wait (a bounded while) for it
        wait_until(lambda: np.linalg.norm(self.core.measured_ee_pose()[:3, 3] - fk) < 0.3e-3,
                   2.0)
        calls.append({'command': np.asarray(joint_positions, dtype=float).copy(), 'ok': ok,
                      'error': '' if ok else self.last_error,
                      'measured': np.array(self.get_joint_positions()),
                      'ee': self.core.measured_ee_pose()[:3, 3].copy(),
                      'fk': fk})
        return ok

    monkeypatch.setattr(arm_module.InterbotixArmXSInterface, 'set_joint_positions', recording)
    monkeypatch.setenv('PX100_BRINGUP', '1')
    monkeypatch.setenv('PX100_CONNECT_TIMEOUT', '30')
    yield calls
    robot_shutdown()


def _check(calls, targets_mm):
    assert len(calls) == len(targets_mm)
    for call, target in zip(calls, targets_mm):
        assert call['ok'] is True, \
            f'command {call["command"]} for {target} mm failed: {call["error"]}'
        np.testing.assert_allclose(call['measured'], call['command'], atol=0.005)
        assert np.linalg.norm(call['ee'] - call['fk']) < 1e-3
        seed_err_mm = np.linalg.norm(call['ee'] * 1000 - np.asarray(target, float))
        assert seed_err_mm < 8.0, f'{target} mm: ended {seed_err_mm:.1f} mm away'


def _empty_world(monkeypatch, module):
    """
    Give the script's robot no scene (sim_driver parameter scene = '').

    The document's targets at z = 3 and -30 mm are on or below the default scene's table,
    which its simulation (an empty RViz world) did not have.
    """
    monkeypatch.setattr(module, 'InterbotixManipulatorXS', functools.partial(
        InterbotixManipulatorXS, node_kwargs={'parameters': {'scene': ''}}))


def test_seed000_joint_space_main(spy, monkeypatch):
    """Section V.6 main(): convert_param_op_to_qdh targets, open/close, sleep at the end."""
    import seed000_main_joint_space
    _empty_world(monkeypatch, seed000_main_joint_space)
    with contextlib.redirect_stdout(io.StringIO()):
        seed000_main_joint_space.main()
    _check(spy, SCRIPT1_TARGETS)


def test_seed000_iterative_main(spy, monkeypatch):
    """Section V.8 main(): iterative_algorithm targets (null-space toward q_nom)."""
    import seed000_main_iterative
    _empty_world(monkeypatch, seed000_main_iterative)
    with contextlib.redirect_stdout(io.StringIO()):
        seed000_main_iterative.main()
    _check(spy, SCRIPT2_TARGETS)


def test_seed_targets_are_within_the_px100_limits(seed):
    """Every seed 000 target maps to in-limit actuator angles (so both scripts can succeed)."""
    from px100_control.models.registry import load_robot
    model = load_robot('px100')
    objects = [[[100, 200, 3, np.pi / 4], [100, -200, 3, np.pi / 4]],
               [[0, 0, 250, -np.pi / 10], [20, 100, 20, np.pi / 2]],
               [[180, 200, 80, np.pi / 10], [180, -200, 80, np.pi / 10]]]
    with contextlib.redirect_stdout(io.StringIO()):
        for obj in objects:
            for target in obj:
                qa = seed.q_dh_to_q_actuator(seed.convert_param_op_to_qdh(target))
                assert model.within_limits(qa), (target, qa)
                np.testing.assert_allclose(seed.matrice_t_h(seed.q_actuator_to_q_dh(qa))[:3, 3],
                                           target[:3], atol=1e-6)
