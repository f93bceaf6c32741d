"""
The perception examples' scenes leave room for the px100's open fingers at every grasp.

The px100 has no wrist rotation: a top-down grasp closes its fingers across the object's
bearing from the base, and open they stand ~45 mm out on each side. An object on that line
within reach of an open finger stops the descent (the move aborts: 'shoulder did not settle'),
as the earlier layouts did. For each object of each example scene: the arm at its top-down
grasp (the gripper at the object's centre, fingers fully open, every other object in place),
the nearest collision geometry of another body is at least CLEARANCE away (MuJoCo's
mj_geomDistance on the simulator's own model), and the approach above it is reachable.
"""
import math

import mujoco
import numpy as np
from px100_control.kinematics.solve import solve_ik
from px100_control.models.registry import load_robot
from px100_control.sim import mjcf
from px100_control.sim.scene import load_scene
import pytest

ROBOT = load_robot('px100')
SCENES = ('perception_pick_place', 'color_sorter', 'block_organizer', 'size_organizer',
          'chessboard_cleanup')
#: least room [m] between an open finger and another body: above the clusters' error (~5 mm)
CLEARANCE = 0.01
#: the examples approach this far [m] above an object's top
APPROACH = 0.04


def _top_down(x: float, y: float, z: float) -> np.ndarray:
    """Return the gripper pose at (x, y, z) [m] pointing down, facing its bearing."""
    yaw = math.atan2(y, x)
    T = np.eye(4)
    T[:3, :3] = np.array([[0.0, -math.sin(yaw), math.cos(yaw)],
                          [0.0, math.cos(yaw), math.sin(yaw)],
                          [-1.0, 0.0, 0.0]])
    T[:3, 3] = (x, y, z)
    return T


def _collides(model, g: int) -> bool:
    return bool(model.geom_contype[g] or model.geom_conaffinity[g])


@pytest.mark.parametrize('name', SCENES)
def test_open_fingers_clear_every_other_object_at_each_grasp(name):
    scene = load_scene(name, ROBOT)
    spec, _ = mjcf.build_spec(ROBOT, scene)
    model = spec.compile()
    data = mujoco.MjData(model)

    def body(g):
        return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[g]) or ''
    fingers = [g for g in range(model.ngeom) if body(g).endswith('finger_link')
               and _collides(model, g)]
    others = {b.name: [g for g in range(model.ngeom) if body(g) == f'scene/{b.name}'
                       and _collides(model, g)] for b in scene.bodies if b.name != 'table'}
    assert fingers and all(others.values()), (fingers, others)
    for obj in scene.objects:
        x, y, z = obj.position
        above = solve_ik(ROBOT, _top_down(x, y, 2 * z + APPROACH), mode='pitch')
        grasp = solve_ik(ROBOT, _top_down(x, y, z), mode='pitch')
        assert above.success and grasp.success, (obj.name, above.reason, grasp.reason)
        mujoco.mj_resetData(model, data)
        for joint, q in zip(ROBOT.joint_names, grasp.q):
            data.qpos[model.jnt_qposadr[model.joint(joint).id]] = q
        for finger in ROBOT.gripper.fingers:
            j = model.joint(finger).id
            lo, hi = model.jnt_range[j]
            data.qpos[model.jnt_qposadr[j]] = hi if abs(hi) > abs(lo) else lo    # open
        mujoco.mj_forward(model, data)
        room = min((mujoco.mj_geomDistance(model, data, f, g, 0.1, None), other)
                   for other, geoms in others.items() if other != obj.name
                   for g in geoms for f in fingers)
        assert room[0] >= CLEARANCE, (obj.name, f'{1000 * room[0]:.1f} mm from {room[1]}')
