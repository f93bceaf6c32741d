"""The sim_driver's parameter checks and conversions on a real ArmSimulator (no ROS)."""
from px100_control.control.pid import GAIN_FIELDS, PidGains
from px100_control.models.registry import load_robot
from px100_control.sim import driver_parameters as dp
from px100_control.sim.simulator import ArmSimulator
from px100_control.sim.stepper import Stepper
import pytest

CORE = {'publish_rate': 100.0, 'control_rate': 1000.0, 'real_time_factor': 1.0,
        'publish_clock': False, 'clock_rate': 250.0, 'dynamics_divider': 4,
        'object_width': 0.0, 'gains_units': 'si', 'world_rate': 30.0}


@pytest.fixture(scope='module')
def sim():
    return ArmSimulator(load_robot('px100'), scene=None)


def current_of(values):
    return lambda name: values[name]


@pytest.mark.parametrize('name, value, words', [
    ('control_rate', 5.0, 'control_rate = 5.0 is outside [10.0, 100000.0]'),
    ('publish_rate', float('nan'), 'publish_rate must be a number, not nan'),
    ('publish_rate', 2000.0, 'publish_rate = 2000.0 is outside'),
    ('clock_rate', True, 'clock_rate must be a number, not True'),
    ('world_rate', 0.0, 'world_rate = 0.0 is outside [0.1, 1000.0]'),
    ('dynamics_divider', 0, 'dynamics_divider must be an integer >= 1, not 0'),
    ('dynamics_divider', 2.0, 'dynamics_divider must be an integer >= 1, not 2.0'),
])
def test_core_values_are_checked(name, value, words):
    error = dp.core_error(dict(CORE, **{name: value}))
    assert error is not None and words in error, error


def test_core_values_depend_on_each_other_and_on_the_gripper(sim):
    assert dp.core_error(dict(CORE)) is None
    assert dp.core_error(dict(CORE, real_time_factor=float('inf'))) is None
    assert dp.core_error(dict(CORE, publish_rate=500.0, control_rate=200.0)) == \
        'publish_rate 500.0 Hz is above control_rate 200.0 Hz'
    assert 'wider than the open gripper' in dp.core_error(dict(CORE, object_width=0.2), sim)
    assert dp.core_error(dict(CORE, object_width=0.03), sim) is None


def test_gains_are_numbers_finite_and_stable(sim):
    si = {f: float(getattr(sim.gains('shoulder'), f)) for f in GAIN_FIELDS}
    assert dp.gains_error(sim, 'shoulder', si, 'si') is None
    assert dp.gains_error(sim, 'shoulder', dict(si, p='stiff'), 'si') == \
        "gains.shoulder.p must be a number, not 'stiff'"
    assert 'must be finite' in dp.gains_error(sim, 'shoulder', dict(si, u_clamp=float('inf')),
                                              'si')
    assert 'negative' in dp.gains_error(sim, 'shoulder', dict(si, p=-1.0), 'si')
    error = dp.gains_error(sim, 'waist', dict(si, d=50.0), 'si')
    assert error.startswith('gains.waist.d = 50 would make the control loop unstable at 1000 Hz')


def test_register_units_round_trip(sim):
    """The dynamixel defaults are the rounded registers of the SI gains, and map back."""
    regs = dp.gain_defaults(sim, 'shoulder', 'dynamixel')
    assert all(float(regs[f]).is_integer() for f in ('p', 'i', 'd'))
    gains = dp.to_gains(sim, 'shoulder', regs, 'dynamixel')
    assert isinstance(gains, PidGains)
    assert gains.p == pytest.approx(sim.gains('shoulder').p, rel=0.02)
    assert dp.gain_defaults(sim, 'shoulder', 'si')['p'] == sim.gains('shoulder').p


def test_modes(sim):
    assert dp.mode_error('operating_mode.waist', '') is None
    assert dp.mode_error('operating_mode.waist', 'torque') is None
    error = dp.mode_error('operating_mode.waist', 'current')
    assert "operating_mode.waist must be '' (default) or one of" in error
    assert 'current -> torque' in error


def test_a_change_is_checked_with_the_values_already_set(sim):
    """Only the joints a change touches are checked, with their other gains as set."""
    values = {k: float(getattr(sim.gains(j), f)) for j in sim.command_joints
              for f, k in zip(GAIN_FIELDS, dp.gain_keys(j))}
    current = current_of(values)
    assert dp.joint_change_error({'gains.elbow.p': 30.0}, current, sim, 'si') is None
    assert dp.changed_gains({'gains.elbow.p': 30.0}, current, sim.command_joints) == {
        'elbow': dict({f: values[f'gains.elbow.{f}'] for f in GAIN_FIELDS}, p=30.0)}
    assert 'unstable' in dp.joint_change_error({'gains.waist.d': 50.0}, current, sim, 'si')
    assert 'pwm -> duty' in dp.joint_change_error({'operating_mode.elbow': 'pwm'}, current,
                                                  sim, 'si')


def test_core_changes_know_the_clock_mode(sim):
    current = current_of(CORE)
    follow = Stepper(sim, 1000.0, 100.0, 250.0, 1.0, master=False)
    own = Stepper(sim, 1000.0, 100.0, 250.0, 0.0, master=True)
    assert dp.core_change_error({'gains.elbow.p': 1.0}, current, sim, follow) is None
    assert 'own clock' in dp.core_change_error({'real_time_factor': 5.0}, current, sim, follow)
    assert dp.core_change_error({'real_time_factor': 5.0}, current, sim, own) is None
    assert dp.core_change_error({'control_rate': 2000.0}, current, sim, follow) is None
    unstable = [dp.stability_error(sim, j, sim.gains(j), 1.0 / 20.0) for j in sim.command_joints]
    assert any(unstable), 'the default gains should not be stable at 20 Hz'
    slow = current_of(dict(CORE, publish_rate=10.0))
    assert dp.core_change_error({'control_rate': 20.0}, slow, sim, follow) == \
        f'control_rate 20.0 Hz: {next(e for e in unstable if e)}'
    assert dp.core_change_error({'control_rate': 20.0}, current, sim, follow) == \
        'publish_rate 100.0 Hz is above control_rate 20.0 Hz'
    follow.step_cost = 1e-3
    assert 'could not keep up' in dp.core_change_error({'control_rate': 2000.0}, current, sim,
                                                       follow)


def test_joint_switches():
    assert dp.joint_switches({'torque_enable.waist': False, 'operating_mode.elbow': 'duty',
                              'publish_rate': 5.0}) == ({'waist': False}, {'elbow': 'duty'})
