"""
The simulated arm and its MuJoCo world.

Scenes as files, the MuJoCo model built from the URDF and the simulator that steps it under the
control laws of :mod:`px100_control.control`.

Layering: ``sim`` builds on ``control`` (the PID, servo and gripper-linkage models it runs),
never the other way round; the ROS nodes (:mod:`px100_control.ros`) sit above both.

- :mod:`.simulator`: :class:`~.simulator.ArmSimulator`, the arm, its gripper and the scene
  under per-joint PIDs and the XL430 servo model, stepped by the caller (moved here from
  ``px100_control.control.simulator``: import it from ``px100_control.sim.simulator``);
- :mod:`.scene`: ``load_scene(name_or_path, robot=None) -> Scene`` (config/scenes/<name>.yaml,
  default ``pick_place``; bad files raise InvalidInputError naming the field);
- :mod:`.mjcf`: ``build_model(robot, scene)``: the MjModel (URDF + generated collision
  geometry, finger pads, contact settings, scene bodies);
- :mod:`.stepper`: the sim_driver's time keeping (fixed physics steps advanced to a clock's
  now, or on an own clock at a real-time factor; times as arguments);
- :mod:`.driver_parameters`: the sim_driver's parameter checks and gain conversions.

Usage (robot base frame, SI units, quaternions x, y, z, w)::

    from px100_control.sim.simulator import ArmSimulator
    from px100_control.models.registry import load_robot
    from px100_control.sim.scene import load_scene

    robot = load_robot('px100')
    sim = ArmSimulator(robot, scene=load_scene('pick_place', robot))   # scene=None: no objects
    sim.objects()        # [ObjectInfo(name, kind 'object'|'fixture'|'table', shape, size, rgba,
                         #  mass)], file order
    sim.object_poses()   # {name: ((x, y, z) [m], (qx, qy, qz, qw))}, statics included
    sim.step()           # one control period (1 / control_rate s); or sim.advance(steps)
    sim.held_object()    # the object both finger pads touch and no static body does, or None
    sim.gripped_objects()  # {object both pads touch: off its support}
    sim.reset_scene()    # objects back to their initial poses (arm untouched)
    sim.reset()          # arm to sleep, torque on, and the objects back
    sim.set_mode('waist', 'velocity')   # 'position' | 'velocity' | 'torque' | 'duty'
"""
import os

# MuJoCo picks its OpenGL backend when first imported: EGL renders the camera offscreen on the
# CPU without a display (sim/ is imported before any module that imports mujoco)
os.environ.setdefault('MUJOCO_GL', 'egl')
