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
CRUISE_SPEED = 2.0


def mm_to_m(target):
    """Return (x, y, z) [m], pitch [rad] of a seed 000 target (x, y, z [mm], psi [rad])."""
    x, y, z, psi = target
    return (x / 1000.0, y / 1000.0, z / 1000.0), float(psi)


class Trace:
    """
    The run's data for the plots: measured joints, setpoints and EE positions vs time.

    With a bag, the data is read back from it after the run (no extra subscriptions in this
    process); without one, the client's node subscribes to the same topics while it runs.
    Phase marks are wall-clock times, like the bag's log times.
    """

    def __init__(self, bot, subscribe: bool):
        self.lock = threading.Lock()
        self.t0_ns = time.time_ns()
        self.js, self.sp, self.ee = [], [], []
        self.phases = []
        self.arm_joints = list(bot.arm.joint_names)
        self.fingers = list(bot.core.model.gripper.fingers) if bot.core.model.gripper else []
        self.topics = {bot.core.topic(bot.core.topic_joint_states): self._on_js,
                       bot.core.topic('commands/joint_setpoints'): self._on_sp,
                       bot.core.topic('ee_pose'): self._on_ee}
        self.subs = []
        if subscribe:
            from geometry_msgs.msg import PoseStamped
            from rclpy.qos import QoSProfile, ReliabilityPolicy
            from sensor_msgs.msg import JointState
            qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT)
            node = bot.core.get_node()
            for topic, cb in self.topics.items():
                msg_type = PoseStamped if topic.endswith('ee_pose') else JointState
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
    """Start recording every topic of the robot to an MCAP bag; return (stop(), bag_dir)."""
    from px100_control.ros.recorder_node import record_in_process
    bag_dir = os.path.join(out_dir, time.strftime('pick_and_place_%Y%m%d_%H%M%S'))
    return record_in_process(bot.get_node().context, bag_dir,
                             robot_name=bot.core.robot_name), bag_dir


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
        return self.move(label, lambda: self.bot.arm.set_ee_pose_components(
            **target, moving_time=mt, accel_time=0.3))

    def line(self, label, dz) -> bool:
        """Move straight up/down by dz [m]."""
        self.trace.phase(label)
        start = self.bot.arm.get_ee_pose_command()[2, 3]

        def line():
            # after an aborted try, go the rest of the way from where the arm stopped
            return self.bot.arm.set_ee_cartesian_trajectory(
                z=start + dz - self.bot.arm.get_ee_pose_command()[2, 3],
                moving_time=max(0.5, self.mt * 0.75))
        return self.move(label, line)

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
        g.release(delay=0.5)
        self.set_object(0.0)
        return ok and self.line('Approach Drop', APPROACH_HEIGHT)


def main(argv=None) -> int:
    """Run the demo; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--connect', action='store_true',
                        help='use sim_driver/ik_service/trajectory_server already running')
    parser.add_argument('--robot-name', default='px100', help='namespace of the nodes')
    parser.add_argument('--moving-time', type=float, default=0.8,
                        help='shortest joint-space move [s] (default 0.8; longer moves get '
                             'the time they need)')
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
    parser.add_argument('--viewer', action='store_true',
                        help='watch it live in the browser: http://127.0.0.1:8080')
    args = parser.parse_args(argv)
    os.environ.setdefault('MPLBACKEND', 'Agg')
    if args.viewer:
        os.environ['PX100_VIEWER'] = '1'      # the in-process bringup adds the viewer node

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
    stop_bag, bag_dir = (None, 'disabled (--no-bag)') if args.no_bag else start_bag(bot, out_dir)
    trace = Trace(bot, subscribe=stop_bag is None)
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
    if stop_bag is not None:
        trace.read_bag(bag_dir)
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
