"""
What the viewer's controls ask for, as plain values (no ROS, no viser).

The live page's sliders, buttons and gizmo end in a trajectory goal, an IK request or a gripper
effort; here are the settings they are checked against and the goal a control's move makes.
Joint positions [rad] (m for prismatic joints), times [s], efforts [N*m].
"""
from typing import Dict, List, Optional, Tuple

from px100_control.parameters import VIEWER
from px100_control.viewer.robot import ArmJoints, clip_pose

#: hosts a page with controls may be served on without ``allow_remote_control``
LOOPBACK = ('127.0.0.1', 'localhost', '::1')
#: gripper effort of the Open/Close buttons [N*m]: the client's default grasp pressure
#: (PWM 250 of 885 at 1.4 N*m stall torque)
GRIPPER_EFFORT = 250.0 / 885.0 * 1.4
#: fraction of a joint's velocity limit a control's move may use
SPEED_FRACTION = 0.5
#: shortest period between two goals or IK requests from dragging [s]
DRAG_PERIOD = 0.2


def check_settings(rate: float, trail: int, port: int) -> None:
    """
    Refuse viewer settings out of the schema's ranges (:data:`px100_control.parameters.VIEWER`).

    :param rate: page updates [Hz] (1..60)
    :param trail: end-effector trail points (2..100000)
    :param port: TCP port (1..65535)
    :raises ValueError: naming the setting and its range
    """
    for name, value, unit in (('rate', rate, ' Hz'), ('trail_length', trail, ''),
                              ('port', int(port), '')):
        spec = VIEWER[name]
        if not spec.low <= value <= spec.high:
            raise ValueError(f'viewer {name} must be within {spec.low:g}..{spec.high:g}{unit}, '
                             f'not {value}')


def forced_read_only(host: str, read_only: bool, allow_remote_control: bool) -> bool:
    """Return True when a page with controls would be served beyond loopback unasked."""
    return str(host) not in LOOPBACK and not read_only and not allow_remote_control


def model_matches(arm: ArmJoints, model) -> bool:
    """Return True when a robot model has the URDF arm's joints, in the same order."""
    return model is not None and tuple(model.joint_names) == tuple(arm.joint_names)


def named_poses(arm: ArmJoints, model) -> Dict[str, Optional[Tuple[float, ...]]]:
    """
    Return the Home and Sleep poses (one value per arm joint, or None) of the URDF's arm.

    From the robot model when it matches the URDF (:func:`model_matches`); otherwise Home is
    all zeros (clipped into the limits) and there is no Sleep pose.
    """
    if model_matches(arm, model):
        return {'home': clip_pose(arm, model.home), 'sleep': clip_pose(arm, model.sleep)}
    return {'home': clip_pose(arm, [0.0] * len(arm.joint_names)), 'sleep': None}


def gripper_joint(model, actuated) -> Optional[str]:
    """Return the gripper servo joint of the model if the URDF has it actuated, else None."""
    gripper = getattr(model, 'gripper', None)
    return gripper.joint if gripper is not None and gripper.joint in actuated else None


def goal_move(model, positions: Dict[str, float], joints_now: Dict[str, float],
              moving_time: float) -> Tuple[List[str], List[float], float]:
    """
    Return (joint names, target positions, move time [s]) of a control's one-point goal.

    model: the arm's joints and limits (an :class:`~px100_control.viewer.robot.ArmJoints` or a
    RobotModel). The names are the model's arm joints found in ``positions``, in model order;
    the time is ``moving_time`` or longer, so that no joint moves faster than SPEED_FRACTION of
    its velocity limit from ``joints_now`` (joints not in it do not lengthen the move).

    :raises ValueError: a target outside its joint's limits
    """
    names = [n for n in model.joint_names if n in positions]
    target = [float(positions[n]) for n in names]
    t = moving_time
    for n, q in zip(names, target):
        k = model.joint_index(n)
        lo, hi = float(model.lower[k]), float(model.upper[k])
        if not lo <= q <= hi:
            raise ValueError(f'{n} = {q:.3f} is outside its limits [{lo:.3f}, {hi:.3f}]')
        now = joints_now.get(n)
        vmax = float(model.velocity_limits[k]) * SPEED_FRACTION
        if now is not None and vmax > 0:
            t = max(t, abs(q - now) / vmax)
    return names, target, t
