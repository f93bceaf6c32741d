#!/usr/bin/env python3
"""
Pick and place with a simulated PincherX-100 through the Interbotix-compatible client.

Seed 000's three objects (pick and place targets given as (x, y, z) [mm] and the gripper pitch
psi [rad], converted to m here) are moved with seed 001's waypoint sequence:

    Home -> [Approach Pick -> Pick -> Approach Pick -> Approach Drop -> Drop -> Approach Drop]
         x objects -> Sleep

Approach poses are ``APPROACH_HEIGHT`` above the target with the same pitch; Approach -> Pick /
Drop and back are straight vertical lines (``set_ee_cartesian_trajectory``). The gripper
closes on a simulated object (sim_driver's ``object_width`` parameter) so the grasp is visible
in the finger positions. Targets the arm cannot reach are skipped, with the reason printed.

By default the nodes (sim_driver, ik_service, trajectory_server) run inside this process
(``bringup=True``); ``--connect`` uses nodes that are already running instead. The run is
recorded to an MCAP bag (when px100_control's recorder is available) and plotted to PNG files;
the paths are printed at the end.
"""
import argparse
import math
import os
import sys
import threading
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

#: seed 000 section V.6: per object, [pick, place] as (x [mm], y [mm], z [mm], psi [rad])
SEED000_OBJECTS = {
    'object1': [(100, 200, 3, math.pi / 4), (100, -200, 3, math.pi / 4)],
    'object2': [(0, 0, 250, -math.pi / 10), (20, 100, 20, math.pi / 2)],
    'object3': [(180, 200, 80, math.pi / 10), (180, -200, 80, math.pi / 10)],
}
#: approach poses are this far [m] above pick / place
APPROACH_HEIGHT = 0.04
#: width [m] of the simulated object between the fingers
OBJECT_WIDTH = 0.036
#: joint speed [rad/s] the demo plans long moves with (the px100 limit is pi)
CRUISE_SPEED = 1.5


def mm_to_m(target):
    """Return (x, y, z) [m], pitch [rad] of a seed 000 target (x, y, z [mm], psi [rad])."""
    x, y, z, psi = target
    return (x / 1000.0, y / 1000.0, z / 1000.0), float(psi)


class Trace:
    """Measured joints / setpoints / EE poses sampled from the client's node during the run."""

    def __init__(self, bot):
        from geometry_msgs.msg import PoseStamped
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        self.lock = threading.Lock()
        self.t0 = time.monotonic()
        self.js, self.sp, self.ee = [], [], []
        self.phases = []
        self.arm_joints = list(bot.arm.joint_names)
        self.fingers = list(bot.core.model.gripper.fingers) if bot.core.model.gripper else []
        node, core = bot.core.get_node(), bot.core
        qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT)
        self.subs = [
            node.create_subscription(JointState, core.topic(core.topic_joint_states),
                                     self._on_js, qos),
            node.create_subscription(JointState, core.topic('commands/joint_setpoints'),
                                     self._on_sp, qos),
            node.create_subscription(PoseStamped, core.topic('ee_pose'), self._on_ee, qos),
        ]

    def now(self) -> float:
        """Return seconds since the trace started."""
        return time.monotonic() - self.t0

    def phase(self, label: str) -> None:
        """Mark where a phase starts (labelled in the plots)."""
        with self.lock:
            self.phases.append((self.now(), label))

    def _on_js(self, msg):
        index = {n: i for i, n in enumerate(msg.name)}
        names = self.arm_joints + self.fingers
        if all(n in index for n in names):
            with self.lock:
                self.js.append([self.now()] + [msg.position[index[n]] for n in names])

    def _on_sp(self, msg):
        index = {n: i for i, n in enumerate(msg.name)}
        if len(msg.position) and all(n in index for n in self.arm_joints):
            with self.lock:
                self.sp.append([self.now()] + [msg.position[index[n]] for n in self.arm_joints])

    def _on_ee(self, msg):
        p = msg.pose.position
        with self.lock:
            self.ee.append([self.now(), p.x, p.y, p.z])

    def arrays(self):
        """Return (joint states, setpoints, ee) as arrays with time in column 0."""
        with self.lock:
            return (np.array(self.js).reshape(-1, 1 + len(self.arm_joints) + len(self.fingers)),
                    np.array(self.sp).reshape(-1, 1 + len(self.arm_joints)),
                    np.array(self.ee).reshape(-1, 4))


def plot(trace: Trace, objects: dict, out_dir: str) -> list:
    """Write the joint and end-effector PNG plots; return their paths."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    js, sp, ee = trace.arrays()
    n = len(trace.arm_joints)
    paths = []
    fig, axes = plt.subplots(n + 1, 1, figsize=(11, 2.1 * (n + 1)), sharex=True)
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
        ax.axhline(1000 * OBJECT_WIDTH, color='gray', ls=':', lw=1, label='object width')
        ax.legend(loc='upper right', fontsize=8)
    ax.set_ylabel('gripper\n[mm]')
    ax.set_xlabel('time [s]')
    ax.grid(alpha=0.3)
    for t, label in trace.phases:
        for a in axes:
            a.axvline(t, color='gray', lw=0.5, alpha=0.5)
        axes[0].text(t, axes[0].get_ylim()[1], ' ' + label, rotation=90, va='top', ha='left',
                     fontsize=6, color='dimgray')
    fig.suptitle('PincherX-100 pick and place: joint positions vs trajectory setpoints')
    fig.tight_layout()
    path = os.path.join(out_dir, 'pick_and_place_joints.png')
    fig.savefig(path, dpi=110)
    plt.close(fig)
    paths.append(path)

    fig = plt.figure(figsize=(8, 7))
    ax = fig.add_subplot(projection='3d')
    if len(ee):
        ax.plot(ee[:, 1], ee[:, 2], ee[:, 3], color='tab:blue', lw=1.2,
                label='end effector (ee_pose)')
        ax.scatter(*ee[0, 1:], color='black', marker='o', s=30, label='start')
    for name, info in objects.items():
        (pick, _), (place, _) = info['pick'], info['place']
        style = {'s': 60, 'depthshade': False}
        if info['status'] != 'done':
            ax.scatter(*pick, color='gray', marker='x', **style)
            ax.scatter(*place, color='gray', marker='x', **style)
            ax.text(*pick, f" {name} ({info['status']})", fontsize=7, color='gray')
            continue
        ax.scatter(*pick, color='tab:green', marker='^', **style)
        ax.scatter(*place, color='tab:red', marker='v', **style)
        ax.text(*pick, f' {name} pick', fontsize=7)
        ax.text(*place, f' {name} place', fontsize=7)
    ax.set_xlabel('x [m]')
    ax.set_ylabel('y [m]')
    ax.set_zlabel('z [m]')
    if len(ee):
        span = np.ptp(ee[:, 1:], axis=0)
        ax.set_box_aspect(np.maximum(span, 0.05 * span.max()))
    ax.set_title('End-effector path in px100/base_link')
    ax.legend(loc='upper left', fontsize=8)
    fig.tight_layout()
    path = os.path.join(out_dir, 'pick_and_place_ee_path.png')
    fig.savefig(path, dpi=110)
    plt.close(fig)
    paths.append(path)
    return paths


def start_bag(bot, out_dir: str):
    """Start recording the robot's topics to an MCAP bag; return a stop() callable or None."""
    try:
        from px100_control.ros import recorder_node
    except ImportError:
        return None, 'no recorder module'
    api = getattr(recorder_node, 'record_in_process', None)
    if api is None:
        return None, 'px100_control recorder API not available yet'
    stamp = time.strftime('%Y%m%d_%H%M%S')
    bag_dir = os.path.join(out_dir, f'pick_and_place_{stamp}')
    return api(bot.get_node().context, bag_dir, robot_name=bot.core.robot_name), bag_dir


class Demo:
    """The pick-and-place run (seed 000 objects, seed 001 waypoints)."""

    def __init__(self, bot, trace: Trace, moving_time: float):
        self.bot = bot
        self.trace = trace
        self.mt = moving_time
        self.sim = bot.core.find_node('sim_driver')
        self.failures = []

    def set_object(self, width: float) -> None:
        """Put an object of ``width`` [m] between the fingers (0: none)."""
        if self.sim is None:
            return
        problem = self.bot.core.set_remote_parameters(self.sim, {'object_width': float(width)})
        if problem:
            print(f'  (cannot set sim_driver object_width: {problem})')

    def step(self, label: str, ok) -> bool:
        """Record a step's outcome."""
        ok = bool(ok[1] if isinstance(ok, tuple) else ok)
        print(f'  {label:<15} {"ok" if ok else "FAILED"}')
        if not ok:
            self.failures.append(label)
        return ok

    def reachable(self, xyz, pitch) -> str:
        """Return '' if the pose and its approach are reachable, else why not."""
        for label, dz in (('target', 0.0), ('approach', APPROACH_HEIGHT)):
            _, ok = self.bot.arm.set_ee_pose_components(
                x=xyz[0], y=xyz[1], z=xyz[2] + dz, pitch=pitch, execute=False, moving_time=30.0)
            if not ok:
                return (f'{label} ({xyz[0]:.3f}, {xyz[1]:.3f}, {xyz[2] + dz:.3f}) m at pitch '
                        f'{pitch:.3f} rad is outside the px100 workspace or joint limits')
        return ''

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
        mt = max(self.mt, travel / CRUISE_SPEED + 0.3)
        return self.step(label, self.bot.arm.set_ee_pose_components(
            **target, moving_time=mt, accel_time=0.3))

    def line(self, label, dz) -> bool:
        """Move straight up/down by dz [m]."""
        self.trace.phase(label)
        return self.step(label, self.bot.arm.set_ee_cartesian_trajectory(
            z=dz, moving_time=max(0.5, self.mt * 0.75)))

    def move_object(self, name, pick, place) -> bool:
        """Run the seed 001 waypoint sequence for one object."""
        (p_xyz, p_pitch), (d_xyz, d_pitch) = pick, place
        print(f'{name}: pick {np.round(p_xyz, 3).tolist()} m pitch {p_pitch:.3f} -> place '
              f'{np.round(d_xyz, 3).tolist()} m pitch {d_pitch:.3f}')
        g = self.bot.gripper
        self.trace.phase('open')
        g.release(delay=0.2)
        ok = self.goto('Approach Pick', p_xyz, p_pitch, APPROACH_HEIGHT)
        ok = ok and self.line('Pick', -APPROACH_HEIGHT)
        if not ok:
            return False
        self.set_object(OBJECT_WIDTH)
        self.trace.phase('grasp')
        g.grasp(delay=1.5)
        print(f'  {"grasp":<15} finger gap {1000 * g.get_finger_width():.1f} mm '
              f'(object {1000 * OBJECT_WIDTH:.0f} mm)')
        ok = self.line('Approach Pick', APPROACH_HEIGHT) and \
            self.goto('Approach Drop', d_xyz, d_pitch, APPROACH_HEIGHT) and \
            self.line('Drop', -APPROACH_HEIGHT)
        self.trace.phase('release')
        g.release(delay=0.8)
        self.set_object(0.0)
        return ok and self.line('Approach Drop', APPROACH_HEIGHT)


def main(argv=None) -> int:
    """Run the demo; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--connect', action='store_true',
                        help='use sim_driver/ik_service/trajectory_server already running')
    parser.add_argument('--robot-name', default='px100', help='namespace of the nodes')
    parser.add_argument('--moving-time', type=float, default=1.0,
                        help='duration of each joint-space move [s] (default 1.0)')
    parser.add_argument('--out', default=os.path.join(ROOT, 'out'), help='output folder')
    parser.add_argument('--no-bag', action='store_true', help='do not record an MCAP bag')
    parser.add_argument('--objects', default='object1,object2,object3',
                        help='comma-separated subset of seed 000 objects')
    parser.add_argument('--bringup', choices=('thread', 'process'), default='thread',
                        help='run the nodes as threads of this process (default) or as child '
                             'processes (more robust on a loaded machine)')
    parser.add_argument('--real-time-factor', type=float, default=None,
                        help='simulation speed (default 1; env PX100_REAL_TIME_FACTOR); < 1 '
                             'slows the simulation down on a slow machine')
    args = parser.parse_args(argv)
    os.environ.setdefault('MPLBACKEND', 'Agg')

    from px100_control.client import InterbotixManipulatorXS, robot_shutdown, robot_startup

    out_dir = os.path.abspath(args.out)
    os.makedirs(out_dir, exist_ok=True)
    started = time.monotonic()
    bot = InterbotixManipulatorXS('px100', 'arm', 'gripper', robot_name=args.robot_name,
                                  moving_time=args.moving_time, accel_time=0.3,
                                  gripper_pressure=1.0,
                                  bringup=False if args.connect else (
                                      'process' if args.bringup == 'process' else True),
                                  real_time_factor=args.real_time_factor)
    robot_startup()
    trace = Trace(bot)
    stop_bag, bag_dir = (None, 'disabled (--no-bag)') if args.no_bag else start_bag(bot, out_dir)
    demo = Demo(bot, trace, args.moving_time)
    objects = {}
    try:
        trace.phase('Home')
        bot.arm.go_to_home_pose(moving_time=max(1.5, args.moving_time))
        for name in [s.strip() for s in args.objects.split(',') if s.strip()]:
            pick, place = (mm_to_m(t) for t in SEED000_OBJECTS[name])
            objects[name] = {'pick': pick, 'place': place, 'status': 'skipped'}
            reason = demo.reachable(*pick) or demo.reachable(*place)
            if reason:
                print(f'{name}: SKIPPED, {reason}')
                objects[name]['reason'] = reason
                continue
            ok = demo.move_object(name, pick, place)
            objects[name]['status'] = 'done' if ok else 'failed'
        trace.phase('Sleep')
        bot.arm.go_to_sleep_pose(moving_time=max(1.5, args.moving_time), accel_time=0.3)
        time.sleep(0.3)
    finally:
        if stop_bag is not None:
            stop_bag()
        robot_shutdown()
    paths = plot(trace, objects, out_dir)
    done = [n for n, o in objects.items() if o['status'] == 'done']
    print(f'\nmoved {len(done)}/{len(objects)} objects ({", ".join(done) or "none"}) in '
          f'{time.monotonic() - started:.1f} s')
    for name, o in objects.items():
        if o['status'] != 'done':
            print(f'  {name}: {o["status"]}' + (f' ({o["reason"]})' if 'reason' in o else ''))
    hint = f'   (summary, plots: ros2 run px100_control inspect {bag_dir})' \
        if stop_bag is not None else ''
    print(f'bag:   {bag_dir}{hint}')
    for p in paths:
        print(f'plot:  {p}')
    return 0 if not demo.failures else 1


if __name__ == '__main__':
    sys.exit(main())
