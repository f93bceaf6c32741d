"""
Modern Robotics descriptions of the registered arms, like Interbotix's ``mr_descriptions``.

``mr_descriptions.px100.Slist`` (6, n) and ``.M`` (4, 4) [m] come from the robot model (URDF),
so every robot in config/robots/ has one: ``getattr(mr_descriptions, robot_model)``.
"""
from px100_control.client.arm_interface import MrDescription
from px100_control.errors import UnknownRobotError
from px100_control.models.registry import load_robot


def __getattr__(name: str):
    """Return the description (an object with Slist and M) of robot model ``name``."""
    if name.startswith('__'):
        raise AttributeError(name)
    try:
        model = load_robot(name)
    except UnknownRobotError as exc:
        raise AttributeError(f'no Modern Robotics description for {name!r}: {exc}') from None
    return MrDescription(model.S_list, model.M)
