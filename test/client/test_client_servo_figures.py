"""
Current commands become torque through each joint's own DYNAMIXEL, as the robot file names it.

Every Interbotix arm's file lists the servo of each joint (config/robots/*.yaml ``servos``,
figures from the ROBOTIS e-Manual in px100_control/control/actuator.py); on real in-process
nodes of a vx300s the shoulder's current command reaches sim_driver as the torque of its two
XM540-W270 (not the px100's XL430), and a current beyond that servo's stall current is refused
naming it.
"""
import threading

from client_support import wait_until
import pytest

pytestmark = pytest.mark.ros

ARMS = ('px100', 'px150', 'rx150', 'rx200', 'wx200', 'wx250', 'wx250s', 'vx250', 'vx300',
        'vx300s', 'mobile_px100', 'mobile_wx200', 'mobile_wx250s', 'aloha_wx250s',
        'aloha_vx300s')


def test_every_interbotix_arm_names_the_servo_of_each_joint():
    from px100_control.control.actuator import DYNAMIXEL, joint_servos
    from px100_control.models.registry import load_robot
    for name in ARMS:
        model = load_robot(name)
        joints = list(model.joint_names) + [model.gripper.joint]
        servos = joint_servos(model.extra.get('servos'), joints)
        assert sorted(servos) == sorted(joints), name
        for s in servos.values():
            assert s.figures.source.startswith('ROBOTIS e-Manual'), s
    px100 = joint_servos(load_robot('px100').extra['servos'])
    assert {s.figures.model for s in px100.values()} == {'XL430-W250'}
    vx = joint_servos(load_robot('vx300s').extra['servos'])
    assert (vx['shoulder'].figures.model, vx['shoulder'].count) == ('XM540-W270', 2)
    assert vx['shoulder'].torque_per_amp == pytest.approx(2 * 10.6 / 4.4)
    assert DYNAMIXEL['XM430-W350'].torque_per_amp == pytest.approx(4.1 / 2.3)
    with pytest.raises(Exception, match=r"servos: elbow: 'XM999'.*XL430-W250"):
        joint_servos({'elbow': 'XM999'}, ['elbow'])


def test_vx300s_shoulder_current_is_the_torque_of_its_two_xm540(capfd):
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
    from sensor_msgs.msg import JointState
    bot = InterbotixManipulatorXS('vx300s', 'arm', 'gripper', bringup=True,
                                  node_kwargs={'parameters': {'scene': ''}})
    robot_startup()
    try:
        seen, lock = [], threading.Lock()

        def on_setpoints(msg):
            with lock:
                seen.extend(zip(msg.name, msg.effort))
        bot.core.get_node().create_subscription(
            JointState, bot.core.topic('commands/joint_setpoints'), on_setpoints, 10)
        assert bot.core.robot_set_operating_modes('single', 'shoulder', 'current')
        assert wait_until(lambda: bot.core.get_node().count_publishers(
            bot.core.topic('commands/joint_setpoints')) > 0, 5.0)
        bot.core.robot_write_joint_command('shoulder', 1000.0)        # mA
        assert wait_until(lambda: ('shoulder', pytest.approx(2 * 10.6 / 4.4)) in seen, 5.0), \
            seen
        count = len(seen)
        capfd.readouterr()
        bot.core.robot_write_joint_command('shoulder', 5000.0)       # beyond its stall current
        assert "XM540-W270's stall current (4400 mA): not sent" in capfd.readouterr().err
        assert not wait_until(lambda: len(seen) > count, 0.5), seen[count:]
        bot.core.robot_write_joint_command('shoulder', 0.0)
        assert bot.core.robot_set_operating_modes('single', 'shoulder', 'position')
    finally:
        robot_shutdown()
