"""PID, servo model, gripper linkage and URDF prefixing: the simulator's parts."""
import math

import numpy as np
from px100_control.control.actuator import ServoSpec, XL430_W250
from px100_control.control.gripper import effort_to_pwm, GripperLinkage, pwm_to_effort
from px100_control.control.pid import Pid, PidGains, register_unit_torque
from px100_control.errors import InvalidInputError, RobotModelError
from px100_control.models.registry import load_robot
from px100_control.models.urdf_chain import load_urdf
from px100_control.models.urdf_prefix import prefix_frame, prefix_urdf
import pytest


# --- PID ----------------------------------------------------------------------------------------
def test_dynamixel_register_mapping():
    """XL430 factory 640/0/4000 -> SI, by the documented KPP = P/128, KPD = D/16 mapping."""
    k = register_unit_torque(1.4)
    assert k == pytest.approx(4096 / (2 * math.pi) * 1.4 / 885)
    g = PidGains.from_dynamixel(640, 0, 4000)
    assert g.p == pytest.approx(5.0 * k) and g.p == pytest.approx(5.156, abs=1e-3)
    assert g.d == pytest.approx(250.0 * k * 1e-3) and g.d == pytest.approx(0.2578, abs=1e-4)
    assert g.i == 0.0
    g7 = PidGains.from_dynamixel(100, 7, 0)
    assert g7.i == pytest.approx(7 / 65536 * k / 1e-3)
    np.testing.assert_allclose(PidGains.from_dynamixel(1600, 7, 2000).to_dynamixel(),
                               (1600, 7, 2000))


@pytest.mark.parametrize('kwargs', [{'p': -1.0}, {'i': float('nan')}, {'d': float('inf')},
                                    {'i_clamp': -0.1}, {'p': '5'}])
def test_nonsense_gains_are_refused(kwargs):
    """Negative, NaN, infinite or non-numeric gains raise with the gain's name."""
    with pytest.raises(InvalidInputError, match=next(iter(kwargs))):
        PidGains(**kwargs)


def test_register_values_outside_the_control_table_are_refused():
    """Register values must be 0..16383."""
    with pytest.raises(InvalidInputError, match='16383'):
        PidGains.from_dynamixel(20000, 0, 0)


def test_pid_integral_and_output_clamps_hold():
    """The integral term never exceeds i_clamp and the output never exceeds u_clamp."""
    pid = Pid(PidGains(p=1.0, i=10.0, i_clamp=0.3, u_clamp=0.5))
    outs = [pid.step(1.0, 0.01) for _ in range(200)]
    assert abs(pid.gains.i * pid.integral) <= 0.3 + 1e-12
    assert max(outs) == pytest.approx(0.5)
    # unwinds as soon as the error reverses: bounded integral => quick recovery
    out = [pid.step(-1.0, 0.01) for _ in range(10)]
    assert out[-1] < 0


def test_pid_terms():
    """The law u = p e + i integral + d ed + ff qd_ref, integral by rectangle rule."""
    pid = Pid(PidGains(p=2.0, i=3.0, d=0.5, ff_velocity=0.1))
    u = pid.step(0.1, 0.01, error_rate=0.2, velocity_ref=1.0)
    assert u == pytest.approx(2.0 * 0.1 + 3.0 * 0.001 + 0.5 * 0.2 + 0.1)
    pid.reset()
    assert pid.integral == 0.0
    pid.set_gains(PidGains(p=1.0))
    assert pid.step(0.2, 0.01) == pytest.approx(0.2)


# --- servo --------------------------------------------------------------------------------------
def test_servo_torque_speed_curve():
    """Stall torque at zero speed, zero torque at no-load speed, saturation, torque off."""
    s = XL430_W250
    assert s.torque(10.0, 0.0) == pytest.approx(1.4)
    assert s.torque(-10.0, 0.0) == pytest.approx(-1.4)
    assert s.torque(1.4, s.no_load_speed) == pytest.approx(0.0, abs=1e-12)
    assert s.torque(0.7, 0.0) == pytest.approx(0.7)
    assert s.torque(0.0, 1.0) == pytest.approx(-s.back_emf_damping)
    assert s.torque(1.0, 1.0, enabled=False) == 0.0
    assert s.back_emf_damping == pytest.approx(1.4 / 6.0)
    with pytest.raises(InvalidInputError):
        ServoSpec(stall_torque=-1.0)
    with pytest.raises(InvalidInputError):
        ServoSpec(pwm_limit=2.0)


# --- gripper ------------------------------------------------------------------------------------
def test_gripper_linkage_matches_interbotix_numbers():
    """d(0) = 0.01949 m; the finger limits map to about -0.378 and 1.268 rad."""
    g = GripperLinkage()
    assert g.finger_position(0.0) == pytest.approx(math.sqrt(0.024 ** 2 - 0.014 ** 2))
    assert g.finger_position(0.0) == pytest.approx(0.019494, abs=1e-6)
    assert g.angle_lower == pytest.approx(-0.378, abs=1e-3)
    assert g.angle_upper == pytest.approx(1.268, abs=1e-3)
    for theta in np.linspace(g.angle_lower, g.angle_upper, 17):
        assert g.angle_from_finger(g.finger_position(theta)) == pytest.approx(theta, abs=1e-12)
        fd = (g.finger_position(theta + 1e-7) - g.finger_position(theta - 1e-7)) / 2e-7
        assert g.finger_rate(theta) == pytest.approx(fd, rel=1e-6)


def test_gripper_object_width_and_pwm_mapping():
    """Object widths are checked; PWM <-> N*m mapping at the client edge."""
    g = GripperLinkage()
    assert g.check_object_width(0.04) == 0.04
    for bad in (-0.01, float('nan'), 0.08):
        with pytest.raises(InvalidInputError):
            g.check_object_width(bad)
    assert pwm_to_effort(250) == pytest.approx(250 / 885 * 1.4)
    assert effort_to_pwm(pwm_to_effort(350)) == pytest.approx(350)
    with pytest.raises(InvalidInputError):
        GripperLinkage(horn_radius=0.03, arm_length=0.02)
    with pytest.raises(InvalidInputError):
        g.angle_from_finger(0.1)


# --- URDF prefix --------------------------------------------------------------------------------
def test_prefix_urdf_renames_links_not_joints():
    """Every link and link reference gets '<robot>/'; joints keep bare names; idempotent."""
    model = load_robot('px100')
    text = prefix_urdf(model.urdf_xml, 'px100')
    urdf = load_urdf(text)
    assert all(link.name.startswith('px100/') for link in urdf.robot.links)
    assert all(j.parent.startswith('px100/') and j.child.startswith('px100/')
               for j in urdf.robot.joints)
    names = {j.name for j in urdf.robot.joints}
    assert {'waist', 'shoulder', 'elbow', 'wrist_angle', 'gripper', 'left_finger'} <= names
    assert prefix_urdf(text, 'px100') == text
    assert prefix_urdf(model.urdf_xml, '') == model.urdf_xml
    assert prefix_frame('px100', 'base_link') == 'px100/base_link'
    assert prefix_frame('/px100/', 'px100/base_link') == 'px100/base_link'
    assert prefix_frame('', 'base_link') == 'base_link'
    with pytest.raises(RobotModelError):
        prefix_urdf('<robot', 'x')
    with pytest.raises(RobotModelError):
        prefix_urdf('<sdf/>', 'x')
