#!/usr/bin/env python3
"""
Seed 000: PincherX-100 DH model, inverse model with all branches, null-space iterative IK.

Runs the document's own functions (examples/seed000_model.py: its mm model, its names) and
prints every number the document prints beside ours:

1. q_nom and the DH <-> actuator offsets (V.1, V.2);
2. the inverse geometric model (eq. 2) with all branches (q1, q1 +- pi; epsilon = +-1) for the
   six targets of eq. (4), and the cost function's pick;
3. the iterative algorithm (eq. 3) on its two tests (V.8), with the convergence plots (Figs. 8-9);
4. the workspace at fixed psi: the torus bounds against the inverse model on a grid;
4b. the same model with the real px100 lengths against px100_control: FK, Jacobian, the closed
   form (every front-branch solution) and solve_dls with the null-space task toward q_nom;
5. both pick-and-place main() scripts (V.6, V.8) through the Interbotix-compatible client on the
   simulated px100 started in this process, with one end-effector plot per object in mm (Figs.
   5-7, 10-12). ``--no-robot`` leaves this part out.

It names the document's errors where the project follows its code, not its text: eq. (2)'s
arctan2 argument order, the q_nom formula of V.1, object 2's psi sign, the workspace's b, and the
stop tolerance of the listing.

Run: python examples/seed000_px100.py [--out DIR] [--no-robot]
"""
import math
import os
import threading
import time

from example_support import set_axes_equal, start
import matplotlib.pyplot as plt
import numpy as np
import seed000_model as seed
from seed000_model import SeedPx100

NAME = 'seed000_px100'
#: eq. (4) as the code has it (object 2 starts at psi = -pi/10; the text says +pi/10)
OBJECTS = [[[100, 200, 3, np.pi / 4], [100, -200, 3, np.pi / 4]],
           [[0, 0, 250, -np.pi / 10], [20, 100, 20, np.pi / 2]],
           [[180, 200, 80, np.pi / 10], [180, -200, 80, np.pi / 10]]]
#: V.8 main(): targets [mm] of the iterative pick-and-place
OBJECTS_ITERATIVE = [[[100, 250, 100], [90, -100, 10]], [[20, 0, 250], [150, 50, 10]],
                     [[150, 0, 80], [40, -100, -30]]]
#: the sim_driver scene for the scripts: none (the default pick_place table would block the
#: targets at z = 3 mm and -30 mm, which the document reached in an empty RViz world)
EMPTY_SCENE = ''
URDF_WHY = ("the document's lengths are not the px100's: L1 = 89.54 vs 93.1 mm (URDF), L4 = "
            '109 vs 113.575 mm (to ee_gripper_link); its joint angles, sent to the simulated '
            'px100, put the gripper where the real geometry puts them')


def section_model(rep, m: SeedPx100):
    rep.section('V.1-V.3: q_nom, offsets, homogeneous matrix')
    rep.compare('q_nom = [0, -atan2(L2, Lm), atan2(L2, Lm), 0] [rad] (printed: 2 decimals)',
                m.q_nom, [0.0, -1.23, 1.23, 0.0], 0.005)
    text = math.atan(m.Lm / m.L2)
    rep.compare('V.1 as written: tan^-1(Lm / L2) [rad]', text, 1.23, 0.005,
                why=f'the text inverts the ratio: tan^-1(Lm/L2) = {text:.4f}; its printed 1.23 '
                    f'and its code are tan^-1(L2/Lm) = {math.atan(m.L2 / m.Lm):.4f} (the '
                    'project follows the code)')
    rep.compare('matrice_t_h(q_nom) position [mm] = (Lm + L3 + L4, 0, L1 + L2) (V.8 test 2)',
                m.position(m.q_nom), [244.0, 0.0, 189.54], 1e-9)


def section_inverse(rep, m: SeedPx100):
    rep.section('V.4-V.5: inverse geometric model, all branches, cost function (eq. 4 targets)')
    for k, obj in enumerate(OBJECTS, 1):
        for which, target in zip(('start', 'goal'), obj):
            sols = m.all_solutions(target)
            best = m.coast_function(m.q_nom, sols) if len(sols) else None
            print(f'  object {k} {which} {np.round(target, 4).tolist()}: {len(sols)} branches')
            for s in sols:
                cost = np.linalg.norm(s - m.q_nom)
                pick = '  <- closest to q_nom' if best is not None and np.all(s == best) else ''
                err = np.linalg.norm(m.position(s) - np.asarray(target[:3], float))
                print(f'    q_dh = [{", ".join(f"{v:+.5f}" for v in s)}]  cost {cost:.4f}  '
                      f'|FK - target| = {err:.1e} mm{pick}')
            if best is not None:
                qa = m.q_dh_to_q_actuator(best)
                print(f'    actuator command q_dh - q_nom = {np.round(qa, 5).tolist()}')
    x_test = np.array([m.Lm + m.L3 + m.L4, 0.0, m.L1 + m.L2, -1.0])
    with_print = SeedPx100(verbose=False)
    q = with_print.convert_param_op_to_qdh(with_print.q_actuator_to_q_dh(x_test))
    rep.compare('V.8 test 2: "The best solution for q vector is" [rad]', q,
                [-0.00505783, -0.48857186, 0.90243115, -1.41385929], 0.5e-8)
    rep.note('V.8 feeds convert_param_op_to_qdh(q_actuator_to_q_dh(x)): it adds q_nom to an '
             'operational vector [mm, mm, mm, rad]; the printed solutions follow that code, and '
             'so does this example')

    rep.section('Document errors in eq. (2) and eq. (4) (the project follows the code)')
    px, py = 100.0, 200.0
    q1_text, q1_code = math.atan2(px, py), math.atan2(py, px)
    sols_text = []
    for j in (q1_text, q1_text + math.pi, q1_text - math.pi):
        sols_text += list(_branches(m, [px, py, 3, np.pi / 4], j))
    miss = min((np.linalg.norm(m.position(s)[:2] - [px, py]) for s in sols_text),
               default=float('nan'))
    rep.compare("eq. (2) q1 = arctan2(px, py) for object 1 start [rad] vs the code's "
                'arctan2(py, px)', q1_text, q1_code, 1e-9,
                why=f'eq. (2) swaps the arguments: with its q1 every branch misses the target by '
                    f'at least {miss:.1f} mm in the plane (or has no solution); the code uses '
                    'arctan2(py, px)')
    plus = m.all_solutions([0, 0, 250, np.pi / 10])
    minus = m.all_solutions([0, 0, 250, -np.pi / 10])
    rep.compare('object 2 start psi [rad]: code vs eq. (4)', -np.pi / 10, np.pi / 10, 0.0,
                why=f'eq. (4) writes +pi/10, main() -pi/10; with +pi/10 the target has '
                    f'{len(plus)} solutions (unreachable), with -pi/10 {len(minus)}: the '
                    'project follows main()')


def _branches(m, target, q1):
    """Return eq. (2)'s solutions for one given q1 (both epsilon)."""
    px, py, pz, phi = (float(v) for v in target)
    U = px * math.cos(q1) + py * math.sin(q1) - m.L4 * math.cos(phi)
    V = m.L1 - pz - m.L4 * math.sin(phi)
    A, B = 2 * m.Lr * U, 2 * m.Lr * V
    W = U ** 2 + V ** 2 + m.Lr ** 2 - m.L3 ** 2
    value = A ** 2 + B ** 2 - W ** 2
    if value < 0:
        return []
    out = []
    for eps in (-1, 1):
        q2 = math.atan2(B * W - eps * A * math.sqrt(value), A * W + eps * B * math.sqrt(value))
        q3 = math.atan2(-U * math.sin(q2) + V * math.cos(q2),
                        U * math.cos(q2) + V * math.sin(q2) - m.Lr)
        out.append(np.array([q1, q2, q3, phi - q2 - q3]))
    return out


def section_iterative(rep, m: SeedPx100):
    rep.section('V.8: iterative algorithm q+ = q + a J#(x* - x) + b (I - J#J)(q_nom - q)')
    tests = [('test 1: [100, 200, 3], start from the inverse model at psi = pi/4',
              np.array([100.0, 200.0, 3.0, np.pi / 4]),
              [1.10714871, -0.68382443, 1.45740347, 0.10058747],
              [99.99999953, 199.9999944, 3.00000576, 0.87416651], 35),
             ("test 2: q_nom's position [244, 0, 189.54], psi = -1 start",
              np.array([m.Lm + m.L3 + m.L4, 0.0, m.L1 + m.L2, -1.0]),
              [-2.48477522e-10, -1.23412154e+00, 1.23412164e+00, -1.86862729e-07],
              [2.43999997e+02, -6.06285147e-08, 1.89539999e+02, -7.97795007e-08], 47)]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    for col, (title, x, q_print, real_print, n_print) in enumerate(tests):
        print(f'  {title}')
        q0 = m.convert_param_op_to_qdh(m.q_actuator_to_q_dh(x))
        q, info = m.iterative_algorithm(q0, x[:3], tolerance=1e-7, qnom=m.q_nom,
                                        return_info=True)
        q11, info11 = m.iterative_algorithm(q0, x[:3], qnom=m.q_nom, return_info=True)
        rep.compare('  stop after (iterations), tolerance 1e-7', info['iterations'], n_print, 0)
        rep.compare("  stop after (iterations), the listing's tolerance 1e-11",
                    info11['iterations'], n_print, 0,
                    why="the listing's default tolerance=1e-11 runs on; the printed counts and "
                        'values are reproduced exactly with 1e-7, so the printed run used 1e-7')
        rep.compare('  "The best coordination is" q_dh [rad]', q, q_print,
                    0.5e-8 + 1e-8 * np.abs(q_print))
        rep.compare('  "corresponds in real parameters to" [mm, mm, mm, rad]',
                    np.append(info['position'], info['psi']), real_print,
                    1e-9 + 2e-9 * np.abs(real_print))
        H = info['history']
        P = np.array([m.position(h) for h in H])
        err = np.linalg.norm(P - x[:3], axis=1)
        psi = H[:, 1:].sum(axis=1)
        ax = axes[0, col]
        ax.semilogy(err, '-o', ms=3)
        ax.set_title(f'Fig. {8 + col}: {title.split(":")[0]} ({info["iterations"]} iterations)')
        ax.set_ylabel('|x* - x| [mm]')
        ax.grid(True, which='both', alpha=0.3)
        ax = axes[1, col]
        ax.plot(psi, '-o', ms=3, label='psi = q2 + q3 + q4')
        ax.plot(np.linalg.norm(H - m.q_nom, axis=1), '-', label='|q - q_nom|')
        ax.set_xlabel('iteration')
        ax.set_ylabel('[rad]')
        ax.legend(fontsize=8)
        ax.grid(True, alpha=0.3)
        rep.values[f'iterative_{col + 1}'] = (q, info, info11)
    rep.save(fig, 'iterative_convergence.png')


def section_product(rep):
    rep.section("The document's model against px100_control's kinematics (real px100 lengths)")
    from px100_control.kinematics.analytic import px100 as analytic
    from px100_control.kinematics.iterative import solve_dls, Task
    from px100_control.kinematics.poe import jacobian_geometric
    from px100_control.models.registry import load_robot
    px100, s = load_robot('px100'), SeedPx100.real()
    print(f'  SeedPx100.real(): L1 = {s.L1}, Lm = {s.Lm}, L2 = {s.L2}, L3 = {s.L3}, L4 = {s.L4} m '
          '(URDF, to ee_gripper_link); q_dh = q + q_nom')
    Q = px100.random_configurations(200, rng=7)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])      # Rx(-pi/2)
    d_pos = d_rot = d_jac = 0.0
    for q in Q:
        T_seed, T = s.matrice_t_h(s.q_actuator_to_q_dh(q)), px100.fk(q)
        d_pos = max(d_pos, np.abs(T_seed[:3, 3] - T[:3, 3]).max())
        d_rot = max(d_rot, np.abs(T_seed[:3, :3] - T[:3, :3] @ rx).max())
        J = jacobian_geometric(px100.S_list, px100.M, q)[:3]
        d_jac = max(d_jac, np.abs(s.jacobienne(s.q_actuator_to_q_dh(q)) - J).max())
    rep.compare(f'matrice_t_h position vs px100.fk, largest difference over {len(Q)} '
                'configurations [m]', d_pos, 0.0, 1e-12)
    rep.compare('matrice_t_h rotation vs px100.fk rotation x Rx(-pi/2) (its z axis is the '
                "URDF's -y)", d_rot, 0.0, 1e-12)
    rep.compare('jacobienne vs the linear rows of jacobian_geometric (PoE) [m/rad]', d_jac,
                0.0, 1e-12)
    g = analytic.geometry(px100)
    found = total = back = 0
    for obj in OBJECTS:
        for target in obj:
            x, y, z, psi = np.asarray(target, float) * [1e-3, 1e-3, 1e-3, 1.0]
            ours = analytic.solve_xyz_pitch(g, x, y, z, psi)
            for sol in s.all_solutions([x, y, z, psi]):
                if abs(math.remainder(sol[0] - math.atan2(y, x), 2 * math.pi)) > 1e-9:
                    back += 1
                    continue
                qa = np.remainder(s.q_dh_to_q_actuator(sol) + math.pi, 2 * math.pi) - math.pi
                total += 1
                found += any(np.abs(np.array(o) - qa).max() < 1e-9 for o in ours)
    rep.compare('eq. (4) targets (in m): front-branch solutions of the inverse model that the '
                'closed form analytic.px100.solve_xyz_pitch also returns', found, total, 0)
    rep.note(f'the {back} back-branch solutions (q1 + pi) keep psi = q2 + q3 + q4, which turns '
             'the tool upside down; the closed form keeps the tool direction there instead')
    worst = 0.0
    print('  V.8 main() targets in m, from q_nom: seed iterative_algorithm (alpha = beta = 0.3) '
          "vs solve_dls(secondary='nominal', q_nominal = home = q_nom)")
    for obj in OBJECTS_ITERATIVE:
        for target in obj:
            x = np.asarray(target, float) * 1e-3
            q, info = s.iterative_algorithm(s.q_nom, x, tolerance=1e-10, qnom=s.q_nom,
                                            max_iterations=2000, return_info=True)
            r = solve_dls(px100, Task(x, np.eye(3), 'position'), px100.home,
                          secondary='nominal', check_limits=False)
            diff = np.abs(np.asarray(r.q) - s.q_dh_to_q_actuator(info['history'][-1])).max()
            worst = max(worst, diff)
            print(f'    {np.round(x, 3).tolist()} m: seed {info["iterations"]} iterations, '
                  f'solve_dls {r.iterations} ({"ok" if r.success else r.reason}), '
                  f'|q_seed - q_dls| = {diff:.1e} rad')
    rep.compare('largest |q_seed - q_dls| over the 6 targets [rad]', worst, 0.0, 1e-6)


def section_workspace(rep, m: SeedPx100):
    rep.section('V.5: workspace at fixed psi (py = 0): (L3 - Lr)^2 < U^2 + V^2 < (L3 + Lr)^2')
    b_text = 2 * m.Lr ** 2 + 2 * m.L3
    b = 2 * m.Lr ** 2 + 2 * m.L3 ** 2
    c = -(m.Lr ** 2 - m.L3 ** 2) ** 2
    roots_text = np.sort(np.roots([-1.0, b_text, c]).real)
    roots = np.sort(np.roots([-1.0, b, c]).real)
    expected = np.sort([(m.L3 - m.Lr) ** 2, (m.L3 + m.Lr) ** 2])
    rep.compare('roots of -X^2 + bX + c with b = 2Lr^2 + 2L3 as printed [mm^2]', roots_text,
                expected, 1e-6,
                why='typo: A^2 + B^2 - W^2 = 4Lr^2 X - (X + Lr^2 - L3^2)^2 = -X^2 + '
                    '2(Lr^2 + L3^2) X - (Lr^2 - L3^2)^2, so b = 2Lr^2 + 2L3^2 (the printed W^2 '
                    'also flips the sign of its cross term); with it the roots are the printed '
                    '(L3 -+ Lr)^2')
    rep.compare('roots with b = 2Lr^2 + 2L3^2 [mm^2]', roots, expected, 1e-6)
    rep.note('the document fixes psi = 0 silently in U = px - L4, V = L1 - pz; at any psi '
             'U = px - L4 cos(psi), V = L1 - pz - L4 sin(psi): the torus moves with psi')
    xs, zs = np.linspace(-150, 400, 221), np.linspace(-250, 400, 261)
    psis = (0.0, np.pi / 4, -np.pi / 4)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.8), sharey=True)
    for ax, psi in zip(axes, psis):
        X, Z = np.meshgrid(xs, zs)
        S = (X - m.L4 * math.cos(psi)) ** 2 + (m.L1 - Z - m.L4 * math.sin(psi)) ** 2
        inside = ((m.L3 - m.Lr) ** 2 <= S) & (S <= (m.L3 + m.Lr) ** 2)
        # the inverse model with q1 = 0 (front branch, py = 0) on a coarser grid
        agree = total = 0
        for x in xs[::6]:
            for z in zs[::6]:
                has = len(_branches(m, [x, 0.0, z, psi], 0.0)) > 0
                Sg = (x - m.L4 * math.cos(psi)) ** 2 + (m.L1 - z - m.L4 * math.sin(psi)) ** 2
                bound = (m.L3 - m.Lr) ** 2 <= Sg <= (m.L3 + m.Lr) ** 2
                agree += has == bound
                total += 1
        rep.compare(f'psi = {psi:+.3f}: grid points where the bounds and the inverse model agree',
                    agree / total, 1.0, 0.0)
        ax.contourf(X, Z, inside, levels=[0.5, 1.5], colors=['tab:blue'], alpha=0.35)
        ax.contour(X, Z, S, levels=[(m.L3 - m.Lr) ** 2, (m.L3 + m.Lr) ** 2], colors='tab:blue')
        ax.plot([0], [m.L1], 'k^', label='shoulder height L1')
        ax.set_aspect('equal')
        ax.set_title(f'psi = {math.degrees(psi):+.0f} deg')
        ax.set_xlabel('px [mm] (py = 0)')
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel('pz [mm]')
    axes[0].legend(fontsize=8)
    fig.suptitle('Reachable (px, pz) at fixed psi: a torus section (annulus) shifted by L4')
    rep.save(fig, 'workspace_fixed_psi.png')


class _EeSampler:
    """Sample the measured end-effector position [m] of a client core in a thread."""

    def __init__(self):
        self.core, self.samples, self.move = None, [], -1
        self._stop = threading.Event()
        self._thread = None

    def attach(self, core):
        if self.core is core:
            return
        self.core = core
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, daemon=True)
            self._thread.start()

    def _run(self):
        while not self._stop.is_set():
            T = self.core.measured_ee_pose() if self.core is not None else None
            if T is not None:
                self.samples.append((self.move, *T[:3, 3]))
            time.sleep(0.02)

    def stop(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)


def run_script(module_name: str):
    """Run one seed main() on the simulated px100; return (moves, samples)."""
    os.environ.setdefault('PX100_BRINGUP', '1')
    os.environ.setdefault('PX100_CONNECT_TIMEOUT', '30')
    import functools
    import importlib
    from px100_control.client import arm as arm_module
    from px100_control.client import InterbotixManipulatorXS, robot_shutdown
    module = importlib.import_module(module_name)
    # the document simulated the arm alone (RViz): no table, no objects (scene '')
    module.InterbotixManipulatorXS = functools.partial(
        InterbotixManipulatorXS, node_kwargs={'parameters': {'scene': EMPTY_SCENE}})
    cls = arm_module.InterbotixArmXSInterface
    original = cls.set_joint_positions
    moves, sampler = [], _EeSampler()

    def recording(self, joint_positions, *args, **kwargs):
        sampler.attach(self.core)
        sampler.move = len(moves)
        ok = original(self, joint_positions, *args, **kwargs)
        fk = self.core.model.fk(self.get_joint_commands())[:3, 3].copy()
        end = time.monotonic() + 2.0       # the servos close the last fraction after SUCCEEDED
        while True:
            T = self.core.measured_ee_pose()
            if time.monotonic() > end or (T is not None and
                                          np.linalg.norm(T[:3, 3] - fk) < 0.3e-3):
                break
            time.sleep(0.02)
        moves.append({'command': np.asarray(joint_positions, float), 'ok': ok,
                      'ee': None if T is None else T[:3, 3].copy(), 'fk': fk})
        return ok

    cls.set_joint_positions = recording
    try:
        module.main()
    finally:
        cls.set_joint_positions = original
        sampler.stop()
        robot_shutdown()
    return moves, np.array(sampler.samples).reshape(-1, 4)


def section_scripts(rep):
    rep.section('V.6 and V.8: both main() scripts through the client on the simulated px100')
    runs = [('seed000_main_joint_space', 'V.6 (inverse model)', OBJECTS, (5, 6, 7)),
            ('seed000_main_iterative', 'V.8 (iterative algorithm)', OBJECTS_ITERATIVE,
             (10, 11, 12))]
    for module_name, title, objects, figs in runs:
        print(f'  {title}: python examples/{module_name}.py through seed000_px100.py')
        moves, samples = run_script(module_name)
        targets = [t[:3] for obj in objects for t in obj]
        rep.compare(f'{title}: moves commanded and succeeded', sum(mv['ok'] for mv in moves),
                    len(targets), 0)
        for k, (mv, tgt) in enumerate(zip(moves, targets)):
            ee = mv['ee'] * 1000 if mv['ee'] is not None else np.full(3, np.nan)
            dist = float(np.linalg.norm(ee - np.asarray(tgt, float)))
            rep.compare(f"{title} move {k}: reached [mm] vs the document's target", ee, tgt,
                        1.0, why=f'{dist:.1f} mm away: {URDF_WHY}')
            rep.compare(f'{title} move {k}: reached vs URDF FK of the command [mm]', ee,
                        mv['fk'] * 1000, 1.0)
        for i, fig_no in enumerate(figs):
            fig = plt.figure(figsize=(5.5, 5))
            ax = fig.add_subplot(projection='3d')
            sel = samples[(samples[:, 0] >= 2 * i) & (samples[:, 0] <= 2 * i + 1)]
            if len(sel):
                ax.plot(*(sel[:, 1:] * 1000).T, '.', ms=2, label='measured end effector')
            tg = np.array(targets[2 * i:2 * i + 2], float)
            ax.scatter(*tg.T, color='tab:red', s=40, label='document targets')
            reached = np.array([moves[j]['ee'] * 1000 for j in (2 * i, 2 * i + 1)
                                if j < len(moves) and moves[j]['ee'] is not None])
            if len(reached):
                ax.scatter(*reached.T, color='k', marker='x', s=40, label='reached')
            ax.set_xlabel('x [mm]')
            ax.set_ylabel('y [mm]')
            ax.set_zlabel('z [mm]')
            ax.set_title(f'Fig. {fig_no}: object {i + 1}, {title}', fontsize=9)
            set_axes_equal(ax)
            ax.legend(fontsize=7)
            rep.save(fig, f'fig{fig_no:02d}_object{i + 1}.png')
        rep.values[module_name] = moves


def main(argv=None):
    """Run the example; return its Report."""
    def extra(parser):
        parser.add_argument('--no-robot', action='store_true',
                            help='leave out the two pick-and-place scripts (no simulation)')
    args, rep = start(NAME, 'px100 DH model, inverse model, iterative IK, workspace, scripts',
                      argv, extra)
    m = SeedPx100()
    section_model(rep, m)
    section_inverse(rep, m)
    section_iterative(rep, m)
    section_workspace(rep, m)
    section_product(rep)
    if not args.no_robot:
        section_scripts(rep)
    assert seed.q_nom is not None
    return rep.finish()


if __name__ == '__main__':
    main()
