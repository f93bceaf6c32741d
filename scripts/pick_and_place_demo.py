#!/usr/bin/env python3
"""
Pick and place with a simulated PincherX-100 through the Interbotix-compatible client, verified.

The objects are real bodies of the simulated scene (sim_driver parameter ``scene``, default
``pick_place``): their poses are read from the world (``bot.world``), never hard-coded. Each is
moved to its target with seed 001's waypoint sequence::

    Home -> [Approach Pick -> Pick -> grasp -> Approach Pick -> Approach Place -> Place ->
             release -> Approach Place] x objects -> Sleep

Approach poses are ``APPROACH_HEIGHT`` above the grasp with the same pitch (top-down when the
arm reaches it); Approach -> Pick / Place and back are straight vertical lines
(``set_ee_cartesian_trajectory``); the gripper closes on the object (``gripper.grasp()``) and
holds it by friction only. Afterwards the demo reads where every object ended and prints, per
object, its final position, its error against the target and a verdict: ``placed`` (within
``--tolerance``, default 10 mm), ``dropped`` (lifted, but it ended elsewhere) or ``not picked``
(it never left the table). It exits 1 when an object is not placed.

By default the nodes (sim_driver, ik_service, trajectory_server) run inside this process
(``bringup=True``); ``--connect`` uses nodes that are already running instead. The run is
recorded to an MCAP bag and plotted (joints, end-effector path, object paths next to the arm's);
the paths are printed at the end. ``--jitter M --seed N`` moves the objects' initial positions
by up to M [m] (uniform in x and y, seeded) through a copy of the scene file.

``--perception`` finds the objects with the camera instead of ``bot.world``, as Interbotix's
perception demos do (:mod:`px100_control.client.camera_objects`): the camera, state_publisher
and pc_filter start as processes (the camera without its pose on /tf, moved by up to
``--camera-jitter`` [m] from the scene's, seeded by ``--seed``), the ArmTag places the camera
relative to the arm at sleep, and the filter's clusters, named by the objects' colours in the
scene file, give where to pick. The verdicts are judged on the simulator's truth as before.
"""
import argparse
import math
import os
import shlex
import sys
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from px100_control.tools.venv_check import require  # noqa: E402

require('numpy', 'matplotlib', 'yaml', 'mujoco', 'rclpy')

import numpy as np  # noqa: E402, I100

#: where the default scene's objects go: the resting position of each object's centre [m] in
#: the base frame (x, y; z = the object's starting height, the table). Other scenes: --targets.
TARGETS = {
    'blue_cylinder': (0.10, -0.08),     # across to the other side, where the red cube was
    'green_cube': (0.11, 0.0),          # nearer the base
    'red_cube': (0.10, 0.08),           # across, over the green cube's new place
}
#: approach poses are this far [m] above the grasp
APPROACH_HEIGHT = 0.05
#: the grasp point is this far [m] above the object's centre (pads on the upper half)
GRASP_ABOVE_CENTRE = 0.0
#: the object is released this far [m] above its resting height at the target
RELEASE_HEIGHT = 0.003
#: the gripper counts as closed when its finger gap changes less than this [m] in 0.1 s
GRIPPER_STILL = 0.0002
#: longest wait [s] for the gripper to close on an object
GRASP_TIMEOUT = 2.5
#: joint speed [rad/s] the demo plans long moves with (the px100 limit is pi)
CRUISE_SPEED = 1.5
#: pitches tried for a grasp, top-down first [rad]
PITCHES = [math.pi / 2 - k * 0.1 for k in range(8)]
#: a grasp pitch must also reach this much [m] farther out and higher: the vertical lines then
#: stay away from the stretched-arm singularity (where the elbow would have to move too fast)
REACH_MARGIN = 0.012


class Trace:
    """
    The run's data for the plots: measured joints, setpoints, EE positions, objects vs time.

    With a bag, the data is read back from it after the run (no extra subscriptions in this
    process); without one, the client's node subscribes to the same topics while it runs.
    Phase marks are wall-clock times, like the bag's log times.
    """

    def __init__(self, bot, subscribe: bool):
        from px100_control.bag.world import PathBuilder
        self.lock = threading.Lock()
        self.t0_ns = time.time_ns()
        self.js, self.sp, self.ee = [], [], []
        self.phases = []
        self.world = PathBuilder(self.t0_ns)
        self.arm_joints = list(bot.arm.joint_names)
        self.fingers = list(bot.core.model.gripper.fingers) if bot.core.model.gripper else []
        self.topics = {bot.core.topic(bot.core.topic_joint_states): self._on_js,
                       bot.core.topic('commands/joint_setpoints'): self._on_sp,
                       bot.core.topic('ee_pose'): self._on_ee,
                       bot.core.topic('world/markers'): self._on_markers,
                       bot.core.topic('world/held_object'): self._on_held}
        self.subs = []
        if subscribe:
            from geometry_msgs.msg import PoseStamped
            from rclpy.qos import QoSProfile, ReliabilityPolicy
            from sensor_msgs.msg import JointState
            from std_msgs.msg import String
            from visualization_msgs.msg import MarkerArray
            qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
            node = bot.core.get_node()
            types = {'ee_pose': PoseStamped, 'markers': MarkerArray, 'held_object': String}
            for topic, cb in self.topics.items():
                msg_type = types.get(topic.rsplit('/', 1)[-1], JointState)
                self.subs.append(node.create_subscription(
                    msg_type, topic, lambda m, cb=cb: cb(m, time.time_ns()), qos))

    def phase(self, label: str) -> None:
        """Mark where a phase starts (labelled in the plots)."""
        with self.lock:
            self.phases.append(((time.time_ns() - self.t0_ns) * 1e-9, label))

    def read_bag(self, bag_dir: str) -> None:
        """Fill the data from a recorded bag (log times)."""
        from px100_control.bag.reader import open_bag
        with open_bag(bag_dir) as bag:
            topics = [t for t in self.topics if t in bag.topics]
            for raw, msg in bag.iter_decoded(topics):
                self.topics[raw.topic](msg, raw.log_time_ns)

    def _t(self, ns: int) -> float:
        return (ns - self.t0_ns) * 1e-9

    def _on_js(self, msg, ns):
        index = {n: i for i, n in enumerate(msg.name)}
        names = self.arm_joints + self.fingers
        if all(n in index for n in names) and len(msg.position) == len(msg.name):
            with self.lock:
                self.js.append([self._t(ns)] + [msg.position[index[n]] for n in names])

    def _on_sp(self, msg, ns):
        index = {n: i for i, n in enumerate(msg.name)}
        if len(msg.position) == len(msg.name) and all(n in index for n in self.arm_joints):
            with self.lock:
                self.sp.append([self._t(ns)] + [msg.position[index[n]]
                                                for n in self.arm_joints])

    def _on_ee(self, msg, ns):
        p = msg.pose.position
        with self.lock:
            self.ee.append([self._t(ns), p.x, p.y, p.z])

    def _on_markers(self, msg, ns):
        from px100_control.bag.world import markers_from_decoded
        with self.lock:
            self.world.add_markers(ns, markers_from_decoded(msg))

    def _on_held(self, msg, ns):
        with self.lock:
            self.world.add_held(ns, msg.data)

    def arrays(self):
        """Return (joint states, setpoints, ee) as arrays with time in column 0."""
        with self.lock:
            return (np.array(self.js).reshape(-1, 1 + len(self.arm_joints) + len(self.fingers)),
                    np.array(self.sp).reshape(-1, 1 + len(self.arm_joints)),
                    np.array(self.ee).reshape(-1, 4))


def plot(trace: Trace, targets: dict, verdicts: dict, out_dir: str) -> list:
    """Write the joint, end-effector and object-path PNG plots; return their paths."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from px100_control.bag.plots import label_phases, plot_ee_and_objects_3d, plot_object_paths

    js, sp, ee = trace.arrays()
    n = len(trace.arm_joints)
    paths = []
    fig, axes = plt.subplots(n + 2, 1, figsize=(11, 2.1 * (n + 1) + 1.2), sharex=True,
                             gridspec_kw={'height_ratios': [0.55 * (n + 1)] + [1] * (n + 1)})
    strip, axes = axes[0], axes[1:]
    for i, name in enumerate(trace.arm_joints):
        ax = axes[i]
        if len(sp):
            ax.plot(sp[:, 0], sp[:, 1 + i], color='tab:orange', lw=1.0, label='setpoint')
        if len(js):
            ax.plot(js[:, 0], js[:, 1 + i], color='tab:blue', lw=1.4, ls='--',
                    label='measured')
        ax.set_ylabel(f'{name}\n[rad]')
        ax.grid(alpha=0.3)
    axes[0].legend(loc='upper right', fontsize=8)
    ax = axes[n]
    if len(js) and trace.fingers:
        ax.plot(js[:, 0], 1000 * (js[:, 1 + n] - js[:, 2 + n]), color='tab:green',
                label='finger gap')
        ax.legend(loc='upper right', fontsize=8)
    ax.set_ylabel('gripper\n[mm]')
    ax.set_xlabel('time [s]')
    ax.grid(alpha=0.3)
    for t, label in trace.phases:
        for a in axes:
            a.axvline(t, color='gray', lw=0.5, alpha=0.5)
    strip.set_ylabel('phase', fontsize=8)
    strip.tick_params(axis='x', labelbottom=False)
    for side in ('top', 'right', 'bottom'):
        strip.spines[side].set_visible(False)
    fig.suptitle('PincherX-100 pick and place: joint positions vs trajectory setpoints')
    fig.tight_layout()
    label_phases(strip, trace.phases)      # after the layout: labels measured at their size
    path = os.path.join(out_dir, 'pick_and_place_joints.png')
    fig.savefig(path, dpi=110)
    plt.close(fig)
    paths.append(path)

    world = trace.world.result()
    ee_t, ee_xyz = (ee[:, 0], ee[:, 1:]) if len(ee) else (np.zeros(0), np.zeros((0, 3)))
    paths.append(plot_ee_and_objects_3d(
        ee_xyz, world, os.path.join(out_dir, 'pick_and_place_ee_path.png'),
        title='End effector and objects in px100/base_link (x: targets)', targets=targets,
        verdicts=verdicts))
    if world.objects():
        paths.append(plot_object_paths(
            ee_t, ee_xyz, world, os.path.join(out_dir, 'pick_and_place_objects.png'),
            title='pick and place: object paths and end-effector path (px100/base_link)',
            targets=targets, verdicts=verdicts))
    return paths


def start_bag(bot, out_dir: str):
    """Start recording every topic of the robot to an MCAP bag; return (stop(), bag_dir)."""
    from px100_control.ros.recorder import record_in_process
    bag_dir = os.path.join(out_dir, time.strftime('pick_and_place_%Y%m%d_%H%M%S'))
    return record_in_process(bot.get_node().context, bag_dir,
                             robot_name=bot.core.robot_name), bag_dir


def jittered_scene(scene: str, jitter: float, seed: int, out_dir: str) -> str:
    """
    Write a copy of a scene with its objects moved by up to ``jitter`` [m] in x and y.

    :return: the path of the new scene file (uniform offsets from numpy's default_rng(seed))
    """
    import yaml
    from px100_control.sim.scene import scene_path
    with open(scene_path(scene), encoding='utf-8') as f:
        data = yaml.safe_load(f)
    rng = np.random.default_rng(seed)
    for obj in data.get('objects') or []:
        dx, dy = rng.uniform(-jitter, jitter, 2)
        x, y, z = obj['position']
        obj['position'] = [float(x + dx), float(y + dy), float(z)]
    data['name'] = f"{data.get('name', 'scene')}_jitter{seed}"
    path = os.path.join(out_dir, f"{data['name']}.yaml")
    with open(path, 'w', encoding='utf-8') as f:
        yaml.safe_dump(data, f, sort_keys=False)
    return path


class Demo:
    """The pick-and-place run over the scene's objects (seed 001 waypoints)."""

    def __init__(self, bot, trace: Trace, moving_time: float, grasp_offset: float = 0.0):
        self.bot = bot
        self.trace = trace
        self.mt = moving_time
        self.grasp_offset = grasp_offset
        self.failures = []

    def move(self, label: str, command) -> bool:
        """
        Run a move command (a callable); retry once when the machine, not the plan, failed it.

        On a heavily loaded machine the simulation can fall behind the clock and
        trajectory_server then aborts a move (tracking / settling); such a move is retried once.
        """
        result = command()
        ok = bool(result[1] if isinstance(result, tuple) else result)
        why = self.bot.arm.last_error
        machine = ('tracking error', 'did not settle', 'did not finish')
        if not ok and any(k in why for k in machine):
            print(f'  {label:<15} retrying: {why[why.find("ABORTED"):][:90] or why[:90]}')
            result = command()
        return self.step(label, result)

    def step(self, label: str, ok) -> bool:
        """Record a step's outcome."""
        ok = bool(ok[1] if isinstance(ok, tuple) else ok)
        if not ok:
            print(f'  {label:<15} FAILED: {self.bot.arm.last_error[:160]}')
            print(f'  {"":<15} then: {self.state_text()}')
            self.failures.append(label)
        return ok

    def state_text(self) -> str:
        """Return the measured joints [rad] (efforts [N m]), finger gap [mm]: why a move failed."""
        js = self.bot.core.joint_states
        if js is None:
            return 'no joint_states'
        efforts = dict(zip(js.name, js.effort)) if len(js.effort) == len(js.name) else {}
        joints = ', '.join(f'{n} {q:.3f}' + (f' ({efforts[n]:.2f})' if n in efforts else '')
                           for n, q in zip(js.name, js.position))
        width = self.bot.gripper.get_finger_width()
        gap = f'{1000 * width:.1f} mm' if width is not None else 'unknown'
        return (f'joints (effort) {joints}; finger gap {gap}; held: '
                f'{self.bot.world.held_object() or "nothing"}')

    def pitch_for(self, xyz, prefer: float = math.nan) -> float:
        """
        Return a pitch reaching xyz and its approach (with REACH_MARGIN); NaN if none does.

        ``prefer`` first (the pick's pitch for the place: an object held a little off the
        gripper's centre line then ends where it was picked relative to the gripper, not moved
        by the change of pitch: measured 3 mm at 0.3 rad), then the steepest (top-down first).
        """
        r = float(np.hypot(xyz[0], xyz[1]))
        out = (r + REACH_MARGIN) / r if r > 1e-6 else 1.0
        for pitch in ([prefer] if math.isfinite(prefer) else []) + PITCHES:
            if all(self.bot.arm.set_ee_pose_components(
                    x=xyz[0] * k, y=xyz[1] * k, z=xyz[2] + dz, pitch=pitch, execute=False,
                    moving_time=30.0)[1]
                    for k, dz in ((1.0, 0.0), (1.0, APPROACH_HEIGHT), (out, 0.0),
                                  (out, APPROACH_HEIGHT + REACH_MARGIN))):
                return pitch
        return math.nan

    def goto(self, label, xyz, pitch, dz=0.0) -> bool:
        """
        Move to (xyz + dz) [m] with the given pitch (joint-space move).

        Plans first (execute=False) to give long moves the time they need: at most
        ``CRUISE_SPEED`` on any joint, never less than the demo's moving time.
        """
        self.trace.phase(label)
        target = {'x': xyz[0], 'y': xyz[1], 'z': xyz[2] + dz, 'pitch': pitch}
        theta, ok = self.bot.arm.set_ee_pose_components(**target, execute=False,
                                                        moving_time=30.0)
        if not ok:
            return self.step(label, False)
        travel = float(np.max(np.abs(np.asarray(theta) - self.bot.arm.get_joint_commands())))
        mt = max(self.mt, travel / CRUISE_SPEED + 0.4)
        return self.move(label, lambda: self.bot.arm.set_ee_pose_components(
            **target, moving_time=mt, accel_time=min(0.4, mt / 3)))

    def line(self, label, dz) -> bool:
        """Move straight up/down by dz [m]."""
        self.trace.phase(label)
        start = self.bot.arm.get_ee_pose_command()[2, 3]

        def line():
            # after an aborted try, go the rest of the way from where the arm stopped
            return self.bot.arm.set_ee_cartesian_trajectory(
                z=start + dz - self.bot.arm.get_ee_pose_command()[2, 3],
                moving_time=max(0.8, self.mt))
        return self.move(label, line)

    def retreat(self, xyz, pitch) -> bool:
        """Go back up to the approach pose above xyz [m] (straight up, else joint space)."""
        if abs(self.bot.arm.get_ee_pose_command()[2, 3] - (xyz[2] + APPROACH_HEIGHT)) < 1e-3:
            return True
        return self.line('Approach', xyz[2] + APPROACH_HEIGHT
                         - self.bot.arm.get_ee_pose_command()[2, 3]) or \
            self.goto('Approach', xyz, pitch, APPROACH_HEIGHT)

    def wait_gripper_still(self) -> None:
        """
        Wait (simulated time) until the fingers stopped closing: on the object, or shut.

        Still = the finger gap changed less than GRIPPER_STILL in each of three fresh 0.1 s
        samples (joint_states younger than 0.1 s: a stalled simulation does not look still).
        """
        g, core = self.bot.gripper, self.bot.core
        last, still = g.get_finger_width(), 0
        for _ in range(int(GRASP_TIMEOUT / 0.1)):
            core.sleep(0.1)
            width = g.get_finger_width()
            fresh = core.joint_state_age() < 0.1
            still = still + 1 if fresh and abs(width - last) < GRIPPER_STILL else 0
            if still >= 3:
                return
            last = width

    def move_object(self, name: str, target, position=None, shift: float = 0.0) -> bool:
        """
        Pick ``name`` at ``position`` [m] (None: where the world says); place it at target.

        ``shift`` [m]: the grasp point moves that far off the centre along the closing
        direction (grasp_shift: room for an open pad beside a neighbour).
        """
        if position is None:
            position = self.bot.world.get_object_pose(name)[:3, 3]
        grasp = position + np.array([0.0, 0.0, GRASP_ABOVE_CENTRE])
        offset = self.grasp_offset + shift
        if offset:
            radial = grasp[:2] / max(1e-9, float(np.hypot(*grasp[:2])))
            tangential = np.array([-radial[1], radial[0]])     # the fingers close along it
            grasp[:2] += offset * tangential
        place = np.array(target, dtype=float) + np.array([0.0, 0.0, GRASP_ABOVE_CENTRE
                                                          + RELEASE_HEIGHT])
        p_pitch = self.pitch_for(grasp)
        d_pitch = self.pitch_for(place, prefer=p_pitch)
        print(f'{name}: at {np.round(1000 * position, 1).tolist()} mm -> target '
              f'{np.round(1000 * np.asarray(target), 1).tolist()} mm '
              f'(pitch {p_pitch:.2f} / {d_pitch:.2f} rad)'
              + (f', grasped {1000 * shift:+.1f} mm off centre: room for the open fingers'
                 if shift else ''))
        if math.isnan(p_pitch) or math.isnan(d_pitch):
            where = 'its position' if math.isnan(p_pitch) else 'its target'
            self.failures.append(f'{name}: unreachable')
            print(f'  {name}: SKIPPED, {where} is outside the workspace at every grasp pitch')
            return False
        g = self.bot.gripper
        self.trace.phase(f'{name}: open')
        g.release(delay=0.3)
        if not self.goto('Approach Pick', grasp, p_pitch, APPROACH_HEIGHT):
            return False
        if not self.line('Pick', -APPROACH_HEIGHT):
            # blocked on the way down (e.g. a finger on a neighbour): back up before going on,
            # never sweep low through the scene to the next object
            self.retreat(grasp, p_pitch)
            return False
        self.trace.phase('grasp')
        g.grasp(delay=0.3)
        self.wait_gripper_still()
        print(f'  grasp: finger gap {1000 * g.get_finger_width():.1f} mm, held: '
              f'{self.bot.world.held_object() or "nothing"}')
        ok = self.line('Approach Pick', APPROACH_HEIGHT) and \
            self.goto('Approach Place', place, d_pitch, APPROACH_HEIGHT) and \
            self.line('Place', -APPROACH_HEIGHT)
        self.trace.phase('release')
        g.release(delay=0.5)
        # back up whatever happened before (a Place that stopped short still releases)
        return self.retreat(place, d_pitch) and ok


#: distance [m] of an open finger pad's centre from the grasp point, along the closing direction
OPEN_PAD = 0.036
#: half-extents [m] of a finger pad's footprint (the px100's MuJoCo pad: 30 mm along the arm,
#: 5 mm thick along the closing direction)
PAD_HALF_ALONG, PAD_HALF_THICK = 0.015, 0.0025
#: room [m] an open pad keeps from a neighbour's footprint on the way down
PAD_MARGIN = 0.003
#: farthest [m] a grasp point moves off the object's centre along the closing direction to give
#: a pad that room (the closing fingers centre the object between them)
MAX_GRASP_SHIFT = 0.010


def footprint_radius(info) -> float:
    """Return the radius [m] of a body's horizontal footprint (box: half its diagonal)."""
    sx, sy = info.scale[0], info.scale[1]
    return 0.5 * (float(np.hypot(sx, sy)) if info.shape == 'box' else float(sx))


def clearance(name: str, bodies: dict) -> float:
    """
    Return the room [m] around ``name`` from the open pads' centres: the pick order's measure.

    That is the smallest distance from an open pad's centre to another object's footprint. The
    fingers close along the horizontal direction perpendicular to the object's bearing from
    the base (the px100 has no wrist rotation), so an object with a neighbour on that line is
    better picked once the neighbour is gone. ``bodies``: name -> WorldMarker of the objects.
    """
    p = np.array(bodies[name].position[:2])
    u = np.array([-p[1], p[0]]) / max(1e-9, float(np.hypot(*p)))
    room = math.inf
    for side in (1.0, -1.0):
        pad = p + side * OPEN_PAD * u
        for other, info in bodies.items():
            if other != name:
                room = min(room, float(np.hypot(*(pad - info.position[:2])))
                           - footprint_radius(info))
    return room


def pad_room(name: str, bodies: dict, shift: float = 0.0) -> float:
    """
    Return the room [m] the open fingers have around ``name``, the grasp ``shift`` [m] off.

    That is the smallest distance from an open pad's footprint (a PAD_HALF_ALONG x
    PAD_HALF_THICK rectangle) to another object's footprint circle, the pads OPEN_PAD either
    side of the grasp point. The fingers close along the horizontal direction perpendicular to
    the object's bearing from the base (the px100 has no wrist rotation); the grasp point is
    the object's centre moved ``shift`` along that direction. ``bodies``: name -> WorldMarker
    (or a body with position, shape, scale) of the objects.
    """
    p = np.array(bodies[name].position[:2], dtype=float)
    along = p / max(1e-9, float(np.hypot(*p)))
    closing = np.array([-along[1], along[0]])
    room = math.inf
    for side in (1.0, -1.0):
        pad = p + (shift + side * OPEN_PAD) * closing
        for other, info in bodies.items():
            if other == name:
                continue
            d = np.asarray(info.position[:2], dtype=float) - pad
            outside = np.array([max(abs(float(d @ along)) - PAD_HALF_ALONG, 0.0),
                                max(abs(float(d @ closing)) - PAD_HALF_THICK, 0.0)])
            room = min(room, float(np.hypot(*outside)) - footprint_radius(info))
    return room


def grasp_shift(name: str, bodies: dict) -> tuple:
    """
    Return (shift [m], room [m]): where along the closing direction to grasp ``name``.

    No shift when the pads have PAD_MARGIN of room over the object's centre; else the smallest
    shift (up to MAX_GRASP_SHIFT, 0.5 mm steps) that gives them that room, or the one that
    gives the most room when none does.
    """
    room = pad_room(name, bodies)
    if room >= PAD_MARGIN:
        return 0.0, room
    steps = [k * 0.0005 for k in range(1, int(round(MAX_GRASP_SHIFT / 0.0005)) + 1)]
    best = (0.0, room)
    for magnitude in steps:
        for shift in (magnitude, -magnitude):
            r = pad_room(name, bodies, shift)
            if r >= PAD_MARGIN:
                return shift, r
            if r > best[1]:
                best = (shift, r)
    return best


def plan_pick(bodies: dict, names) -> tuple:
    """
    Return (name, shift [m]) of the next object to pick and where to grasp it.

    The object whose open pads' centres have the most room (clearance) goes first; its grasp
    is shifted off centre where a pad's footprint would land on a neighbour (grasp_shift).
    ``bodies``: every object's footprint now (placed ones at their targets); the order is
    planned again before every pick (see main).
    """
    name = max(names, key=lambda n: clearance(n, bodies))
    return name, grasp_shift(name, bodies)[0]


def perceive(bot, args, scene: str):
    """
    Return (eyes, {name: centre [m]}) of the scene's objects the camera sees (--perception).

    The arm is at sleep (its start): out of the camera's view of the objects, its tag in view.
    """
    from px100_control.client.camera_objects import CameraObjects, jittered_camera
    from px100_control.models.registry import load_robot
    from px100_control.sim.scene import load_scene
    world = load_scene(scene, robot=load_robot('px100'))
    pose = jittered_camera(world.camera, args.camera_jitter, args.seed) \
        if args.camera_jitter else None
    if pose:
        print(f'camera at {np.round(pose[0], 3).tolist()} m looking at '
              f'{np.round(pose[1], 3).tolist()} m (jittered by up to '
              f'{1000 * args.camera_jitter:g} mm, seed {args.seed})')
    eyes = CameraObjects(bot, start_nodes=not args.connect, camera_pose=pose, scene=scene)
    calibrated = eyes.calibrate()
    a = eyes.armtag
    print(f'ArmTag: {a.parent_frame} -> {a.child_frame} at '
          f'{np.round(1000 * np.array([a.x, a.y, a.z]), 1).tolist()} mm' if calibrated else
          'ArmTag: not calibrated (see the log); the camera frames on tf as they are')
    found = eyes.locate({b.name: b.rgba for b in world.objects})
    for name in sorted(found):
        print(f'seen {name} at {np.round(1000 * found[name], 1).tolist()} mm')
    return eyes, found, world.objects


def look_again(bot, eyes, name, seen, scene_objects, demo, target, shift=0.0) -> None:
    """
    After a failed move (--perception): look from sleep; still where it was seen, try again.

    The camera's answer, not the world's, decides (the world mode's retry asks bot.world).
    """
    bot.arm.go_to_sleep_pose(moving_time=1.5)
    body = {b.name: b for b in scene_objects}[name]
    now = eyes.locate({name: body.rgba}).get(name)
    if now is not None and np.linalg.norm(now[:2] - seen[name][:2]) < 0.005:
        print(f'  {name}: still where it was seen, trying once more')
        demo.move_object(name, target, now, shift)


def perceived_bodies_now(seen: dict, scene_objects, remaining: list, goal: dict) -> dict:
    """Return the footprints of the seen objects, those already moved at their goal."""
    from px100_control.client.camera_objects import perceived_bodies
    where = {n: (goal[n] if n not in remaining else p) for n, p in seen.items()}
    return perceived_bodies(where, scene_objects)


def quiet_goal_lines(robot_name: str) -> None:
    """
    Hide trajectory_server's INFO line per goal (accepted / SUCCEEDED) in this process.

    The in-process nodes log through this process's rcutils loggers: warnings and errors (an
    aborted move) still show, the per-object progress is printed by the demo itself.
    """
    from rclpy.logging import LoggingSeverity, set_logger_level
    set_logger_level(f"{robot_name.strip('/')}.trajectory_server".lstrip('.'),
                     LoggingSeverity.WARN)
    print('(per-goal log lines hidden: --verbose shows them)')


def parse_targets(text: str) -> dict:
    """Return {name: (x, y[, z])} [m] of 'name:x,y[,z] name:x,y' (command line)."""
    out = {}
    for item in text.split():
        name, _, xyz = item.partition(':')
        values = [float(v) for v in xyz.split(',') if v.strip()]
        if not name or len(values) not in (2, 3):
            raise ValueError(f'bad target {item!r}: expected name:x,y or name:x,y,z [m]')
        out[name] = tuple(values)
    return out


def next_commands(bag_dir: str) -> list:
    """
    Return the closing lines that say how to look at the bag: commands that run as printed.

    In the README's shell (after ``source scripts/env.sh`` the executables are commands), with
    the ``ros2 run`` form for ROS 2 installs beside them.
    """
    env = shlex.quote(os.path.join(ROOT, 'scripts', 'env.sh'))
    bag = shlex.quote(bag_dir)
    return [f'next:  source {env} && inspect {bag}   # summary and plots of the bag',
            f'       (with ROS 2: ros2 run px100_control inspect {bag})']


def main(argv=None) -> int:
    """Run the demo; return the exit code (0 only when every object is placed)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--connect', action='store_true',
                        help='use sim_driver/ik_service/trajectory_server already running')
    parser.add_argument('--robot-name', default='px100', help='namespace of the nodes')
    parser.add_argument('--moving-time', type=float, default=1.0,
                        help='shortest joint-space move [s] (default 1.0; longer moves get '
                             'the time they need)')
    parser.add_argument('--out', default=os.path.join(ROOT, 'out'), help='output folder')
    parser.add_argument('--no-bag', action='store_true', help='do not record an MCAP bag')
    parser.add_argument('--no-plots', action='store_true', help='do not write plots')
    parser.add_argument('--scene', default='pick_place',
                        help='scene name (config/scenes) or .yaml path (default pick_place)')
    parser.add_argument('--objects', default='',
                        help='comma-separated subset of the scene objects (default: all)')
    parser.add_argument('--targets', default='',
                        help="targets 'name:x,y[,z] ...' [m] (default: the pick_place targets)")
    parser.add_argument('--tolerance', type=float, default=0.01,
                        help='largest distance [m] from the target that counts as placed')
    parser.add_argument('--jitter', type=float, default=0.0,
                        help='move the objects initial x, y by up to this [m] (uniform)')
    parser.add_argument('--seed', type=int, default=0, help='seed of --jitter')
    parser.add_argument('--grasp-offset', type=float, default=0.0,
                        help='grasp this far [m] beside the object centre, along the closing '
                             'direction (to see a bad grasp fail)')
    parser.add_argument('--gripper-pressure', type=float, default=1.0,
                        help='gripper pressure 0..1 (the grasp PWM)')
    parser.add_argument('--json', default='',
                        help='also write the outcome (per object: verdict, final, target, '
                             'error [m]; the phases [s]) to this JSON file')
    parser.add_argument('--bringup', choices=('thread', 'process'), default='thread',
                        help='run the nodes as threads of this process (default) or as child '
                             'processes (more robust on a loaded machine)')
    parser.add_argument('--real-time-factor', type=float, default=None,
                        help='simulation speed (default 1; env PX100_REAL_TIME_FACTOR); < 1 '
                             'slows the simulation down on a slow machine')
    parser.add_argument('--perception', action='store_true',
                        help='find the objects with the camera (ArmTag + pc_filter), not '
                             'bot.world')
    parser.add_argument('--camera-jitter', type=float, default=0.0, metavar='M',
                        help='with --perception: move the camera and its look-at point by up '
                             'to M [m] (seeded by --seed)')
    parser.add_argument('--verbose', action='store_true',
                        help="also print trajectory_server's INFO line per goal (about 40; "
                             'with --connect or --bringup process they always show)')
    parser.add_argument('--viewer', action='store_true',
                        help='watch it live in the browser: http://127.0.0.1:8080; at the end '
                             'the page keeps showing the final scene until Ctrl-C')
    parser.add_argument('--viewer-hold', type=float, default=None, metavar='S',
                        help='with --viewer: keep the final scene up S seconds, not until '
                             'Ctrl-C')
    args = parser.parse_args(argv)
    os.environ.setdefault('MPLBACKEND', 'Agg')
    if args.viewer:
        os.environ['PX100_VIEWER'] = '1'      # the in-process bringup adds the viewer node

    from px100_control.bag.world import format_placements, placement_verdict
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup
    from px100_control.errors import Px100Error
    from px100_control.models.registry import load_robot
    from px100_control.sim.scene import load_scene

    out_dir = os.path.abspath(args.out)
    os.makedirs(out_dir, exist_ok=True)
    try:
        targets = dict(TARGETS)
        targets.update(parse_targets(args.targets))
    except ValueError as exc:
        parser.error(str(exc))
    scene = args.scene
    try:        # a bad scene is one line here, before any node starts
        load_scene(scene, robot=load_robot('px100'))
    except (Px100Error, OSError, ValueError) as exc:
        parser.error(f'--scene {scene}: {exc}')
    if args.jitter:
        scene = jittered_scene(scene, args.jitter, args.seed, out_dir)
        print(f'scene with objects jittered by up to {1000 * args.jitter:g} mm '
              f'(seed {args.seed}): {scene}')
    started = time.monotonic()
    bot = InterbotixManipulatorXS('px100', 'arm', 'gripper', robot_name=args.robot_name,
                                  moving_time=args.moving_time, accel_time=0.3,
                                  gripper_pressure=args.gripper_pressure,
                                  bringup=False if args.connect else (
                                      'process' if args.bringup == 'process' else True),
                                  real_time_factor=args.real_time_factor,
                                  node_kwargs={'parameters': {'scene': scene}})
    robot_startup()
    if not args.verbose and not args.connect and args.bringup == 'thread':
        quiet_goal_lines(args.robot_name)      # (the nodes log in this process)
    if args.connect and scene != 'pick_place':
        sim = bot.core.find_node('sim_driver')
        problem = bot.core.set_remote_parameters(sim, {'scene': scene}) if sim else \
            'no sim_driver found'
        if problem:
            print(f'cannot load scene {scene!r}: {problem}')
            robot_shutdown()
            return 2
    stop_bag, bag_dir = (None, 'disabled (--no-bag)') if args.no_bag else start_bag(bot, out_dir)
    trace = Trace(bot, subscribe=stop_bag is None)
    demo = Demo(bot, trace, args.moving_time, grasp_offset=args.grasp_offset)
    placements = []
    eyes, seen = None, {}
    try:
        if args.perception:
            eyes, seen, scene_objects = perceive(bot, args, scene)
        bot.world.wait_for_update(2.0)
        names = bot.world.list_objects()
        if args.objects:
            wanted = [s.strip() for s in args.objects.split(',') if s.strip()]
            unknown = [n for n in wanted if n not in names]
            if unknown:
                raise SystemExit(f'unknown object(s) {unknown}; the scene has {names}')
            names = wanted
        missing = [n for n in names if n not in targets]
        if missing:
            raise SystemExit(f'no target for {missing}: give --targets name:x,y')
        start = {n: bot.world.get_object_pose(n)[:3, 3] for n in names}
        goal = {n: np.array([targets[n][0], targets[n][1],
                             targets[n][2] if len(targets[n]) > 2 else start[n][2]])
                for n in names}
        trace.phase('Home')
        bot.arm.go_to_home_pose(moving_time=max(1.5, args.moving_time))
        remaining = list(names)
        while remaining:     # the object with the most room for the open fingers first
            bot.world.wait_for_update(0.5)
            if eyes is not None:
                unseen = [n for n in remaining if n not in seen]
                if unseen:
                    name = unseen[0]
                    remaining.remove(name)
                    print(f'{name}: not seen by the camera, not picked')
                    demo.failures.append(f'{name}: not seen')
                    continue
                name, shift = plan_pick(
                    perceived_bodies_now(seen, scene_objects, remaining, goal), remaining)
                remaining.remove(name)
                if not demo.move_object(name, goal[name], seen[name], shift):
                    look_again(bot, eyes, name, seen, scene_objects, demo, goal[name], shift)
                continue
            name, shift = plan_pick({n: bot.world.get_object_info(n)
                                     for n in bot.world.list_objects()}, remaining)
            remaining.remove(name)
            if not demo.move_object(name, goal[name], shift=shift):
                # a move failed (on a loaded machine: the simulation stalled and a move was
                # aborted): if the object is still where it was, try it once more
                at = bot.world.get_object_pose(name)[:3, 3]
                if np.linalg.norm(at - start[name]) < 0.005:
                    print(f'  {name}: still at its start, trying once more')
                    demo.move_object(name, goal[name], shift=shift)
        trace.phase('Sleep')
        bot.gripper.release(delay=0.2)
        bot.arm.go_to_sleep_pose(moving_time=max(1.5, args.moving_time), accel_time=0.3)
        bot.core.sleep(0.5)                # objects settle
        bot.world.wait_for_update(1.0)
        final = {n: T[:3, 3] for n, T in bot.world.get_object_poses().items()}
    finally:
        if stop_bag is not None:
            stop_bag()
        if eyes is not None:
            eyes.close()
        if not args.viewer or sys.exc_info()[0] is not None:
            robot_shutdown()
    if stop_bag is not None:
        trace.read_bag(bag_dir)
    world = trace.world.result()
    for name in names:
        heights = world.paths[name][1][:, 2] if name in world.paths else None
        placements.append(placement_verdict(name, start[name], final[name], goal[name],
                                            heights=heights, tolerance=args.tolerance))
    verdicts = {p.name: p.verdict for p in placements}
    paths = [] if args.no_plots else plot(trace, {n: goal[n] for n in names}, verdicts, out_dir)
    placed = [p.name for p in placements if p.verdict == 'placed']
    print()
    print(format_placements(placements))
    print(f'\nplaced {len(placed)}/{len(placements)} objects within '
          f'{1000 * args.tolerance:g} mm in {time.monotonic() - started:.1f} s')
    if demo.failures:
        print(f'failed steps: {", ".join(demo.failures)}')
    print(f'bag:   {bag_dir}')
    if stop_bag is not None:
        print('\n'.join(next_commands(bag_dir)))
    for p in paths:
        print(f'plot:  {p}')
    if args.json:
        import json
        with open(args.json, 'w', encoding='utf-8') as f:
            json.dump({'scene': scene, 'seed': args.seed, 'jitter': args.jitter,
                       'perception': args.perception, 'camera_jitter': args.camera_jitter,
                       'seen': {n: [float(v) for v in p] for n, p in seen.items()},
                       'seconds': time.monotonic() - started, 'failed_steps': demo.failures,
                       'phases': trace.phases,
                       'objects': [p.__dict__ for p in placements]}, f, indent=1)
    status = 0 if len(placed) == len(placements) else 1
    if args.viewer:
        hold_viewer(bot, args.viewer_hold)
        robot_shutdown()
    return status


def hold_viewer(bot, seconds) -> None:
    """
    Keep the nodes and the page up after the run: the final placement stays visible.

    Until Ctrl-C (the client's handler stops the arm and raises SystemExit, caught here), or
    ``seconds`` [s] of wall time when given. The exit status stays the demo's.
    """
    from px100_control.client.robot import get_bringup
    url = next((n.url for n in getattr(get_bringup(bot.core.robot_name), 'nodes', [])
                if hasattr(n, 'url')), 'the viewer')
    until = 'Ctrl-C ends it' if seconds is None else f'for {seconds:g} s (or Ctrl-C)'
    print(f'viewer: the final scene stays at {url}: {until}', flush=True)
    end = math.inf if seconds is None else time.monotonic() + seconds
    try:
        while time.monotonic() < end:
            time.sleep(min(0.2, max(0.0, end - time.monotonic())))
    except (KeyboardInterrupt, SystemExit):
        print('viewer: closed')


if __name__ == '__main__':
    sys.exit(main())
