"""
Kinematics benchmark: px100_control FK/IK against the IK solvers people use for this arm.

One run, the same targets for everyone: N random in-limit configurations -> FK -> full (4, 4)
targets (all reachable). Success = position error < 1e-4 m, orientation error < 1e-3 rad, and
the answer within the joint limits. Rows:

- px100_control: FK (numpy PoE and the plain-float kernel); the closed-form scalar solve
  (``analytic.<robot>.ik_xyz_pitch`` when the robot has one); ``solve_ik`` end to end
  ('auto' = analytic, and forced 'dls' and 'newton' iterative methods, seeded at home);
  the vectorised ``solve_ik_batch`` over 10^6 targets (solutions/s).
- modern_robotics ``IKinSpace`` called the way Interbotix's ``set_ee_pose_matrix`` calls it
  (eomg = ev = 1e-3, 20 iterations, seeds 0 and waist -+120 deg, wrap, limit check), "as
  intended" and "as shipped" (the shipped ``[[0.0] * n] * 3`` aliases the three seeds, so all
  three are +120 deg).
- when installed (``scripts/bench_setup.sh`` builds a separate venv): ikpy, roboticstoolbox
  ``ik_LM`` (tuned), pinocchio CLIK.

``run(quick) -> dict`` returns the figures (and a ``markdown`` table); ``main()`` prints the
table with time ratios and writes ``benchmarks/results/kinematics_<robot>.json``. Peers missing
from this interpreter are measured by re-running this script in the bench venv
(``$PX100_BENCH_VENV``, default /tmp/pxvenv/bench) when it exists.
Usage: ``python benchmarks/bench_kinematics.py [--quick] [--robot px100] [--targets N]``.
"""
import argparse
import importlib
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time

import bound
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: the run's bound [s] with --quick and without: past it the run fails naming its stage
BOUND_S = (300.0, 900.0)
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from px100_control.kinematics.iterative import chain, fk_batch  # noqa: E402
from px100_control.kinematics.kernels import fk_jacobian_py  # noqa: E402
from px100_control.kinematics.solve import solve_ik, solve_ik_batch  # noqa: E402
from px100_control.models.registry import load_robot  # noqa: E402

BENCH_VENV = os.environ.get('PX100_BENCH_VENV', '/tmp/pxvenv/bench')
POS_TOL, ORI_TOL = 1e-4, 1e-3
PEERS = ('modern_robotics', 'ikpy', 'roboticstoolbox', 'pinocchio')


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------

def _errors(model, q, T):
    if q is None or not np.all(np.isfinite(q)):
        return math.inf, math.inf
    Tq = model.fk(q)
    dp = float(np.linalg.norm(Tq[:3, 3] - T[:3, 3]))
    E = Tq[:3, :3].T @ T[:3, :3]
    return dp, float(math.acos(max(-1.0, min(1.0, (np.trace(E) - 1.0) / 2.0))))


def _ok(model, q, T) -> bool:
    dp, dr = _errors(model, q, T)
    return dp < POS_TOL and dr < ORI_TOL and model.within_limits(q, tol=1e-6)


def _ok_axis(model, q, T) -> bool:
    """Position + tool x axis (the 'pitch' task of a 4-DOF arm) within tolerance and limits."""
    if q is None or not np.all(np.isfinite(q)):
        return False
    Tq = model.fk(q)
    dp = float(np.linalg.norm(Tq[:3, 3] - T[:3, 3]))
    da = math.acos(max(-1.0, min(1.0, float(Tq[:3, 0] @ T[:3, 0]))))
    return dp < POS_TOL and da < ORI_TOL and model.within_limits(q, tol=1e-6)


def _measure(name, model, targets, solve, note='', check=_ok):
    """
    Time solve(T) -> q (or None) on every target; return a row dict.

    The solves run back to back and are checked afterwards (the same for every solver: a check
    between two solves would leave the next one starting cold).
    """
    times, answers = [], []
    for T in targets:
        t0 = time.perf_counter()
        q = solve(T)
        times.append(time.perf_counter() - t0)
        answers.append(q)
    ok = sum(bool(q is not None and check(model, np.asarray(q, float), T))
             for q, T in zip(answers, targets))
    times_us = np.array(times) * 1e6
    return {'name': name, 'median_us': float(np.median(times_us)),
            'min_us': float(np.min(times_us)),
            'p90_us': float(np.percentile(times_us, 90)), 'success': ok / len(targets),
            'n': len(targets), 'note': note}


def _targets(model, n, seed=7):
    Q = model.random_configurations(n, np.random.default_rng(seed))
    return Q, fk_batch(chain(model), Q)


# ---------------------------------------------------------------------------------------------
# px100_control
# ---------------------------------------------------------------------------------------------

def _ours(model, Q, targets, quick):
    rows = []
    c = chain(model)
    qs = [q.tolist() for q in Q]
    t0 = time.perf_counter()
    for q in Q:
        model.fk(q)
    rows.append({'name': 'px100_control FK (poe.fk_space, numpy)', 'median_us': (
        time.perf_counter() - t0) / len(Q) * 1e6, 'success': None, 'n': len(Q), 'note': 'mean'})
    t0 = time.perf_counter()
    for q in qs:
        fk_jacobian_py(c, q)
    rows.append({'name': 'px100_control FK + Jacobian (plain-float kernel)', 'median_us': (
        time.perf_counter() - t0) / len(Q) * 1e6, 'success': None, 'n': len(Q), 'note': 'mean'})
    module = None
    if model.analytic_ik:
        module = importlib.import_module(f'px100_control.kinematics.analytic.{model.analytic_ik}')
    if module is not None and hasattr(module, 'ik_xyz_pitch'):
        from px100_control.kinematics.analytic.px100 import _pose_rows
        rows_xyzp = _pose_rows(model, np.asarray(targets)).tolist()
        home = [float(x) for x in model.home]
        times, answers, ok = [], [], 0
        solve = module.ik_xyz_pitch
        for x, y, z, p in rows_xyzp:         # timed back to back, checked afterwards
            t0 = time.perf_counter()
            sols = solve(model, x, y, z, p, home)
            times.append(time.perf_counter() - t0)
            answers.append(sols)
        for sols, T in zip(answers, targets):
            ok += bool(sols) and _ok(model, np.array(sols[0]), T) or any(
                _ok(model, np.array(s), T) for s in sols[1:])
        t = np.array(times) * 1e6
        rows.append({'name': 'px100_control closed form ik_xyz_pitch '
                             f'(analytic.{model.analytic_ik}'
                     ', math module)', 'median_us': float(np.median(t)), 'min_us': float(t.min()),
                     'p90_us': float(np.percentile(t, 90)), 'success': ok / len(targets),
                     'n': len(targets), 'note': 'all branches, limit-filtered, seed-ordered'})
    if module is not None and hasattr(module, 'ik_fast'):
        home = [float(x) for x in model.home]
        rows.append(_measure(f'px100_control closed form ik_fast (analytic.{model.analytic_ik}'
                             ', math module)', model, targets,
                             lambda T: module.ik_fast(model, T, home)[0],
                             note='first swivel from the seed one with an in-limit branch, '
                                  'the branch nearest the seed'))
    rows.append(_measure("px100_control solve_ik(mode='full') auto", model, targets,
                         lambda T: solve_ik(model, T, mode='full').q,
                         note=f'analytic: {model.analytic_ik}' if model.analytic_ik else 'dls'))
    if model.dof < 6:
        rows.append(_measure("px100_control solve_ik(mode='pitch') auto", model, targets,
                             lambda T: solve_ik(model, T, mode='pitch').q, check=_ok_axis,
                             note='yaw forced to atan2(y, x); success on position + tool x '
                                  'axis'))
    iters = []

    def dls(T):
        r = solve_ik(model, T, mode='full', method='dls')
        iters.append(r.iterations)
        return r.q if r.success else None
    rows.append(_measure("px100_control solve_ik(method='dls') seeded at home", model, targets,
                         dls))
    rows[-1]['note'] = f'median {int(np.median(iters))} iterations, restarts on failure'
    iters.clear()

    def newton(T):
        r = solve_ik(model, T, mode='full', method='newton')
        iters.append(r.iterations)
        return r.q if r.success else None
    rows.append(_measure("px100_control solve_ik(method='newton') (seed 003)", model, targets,
                         newton))
    rows[-1]['note'] = f'median {int(np.median(iters))} iterations, restarts on failure'
    batch = None
    if module is not None and hasattr(module, 'solve_batch'):
        n = 100_000 if quick else 1_000_000
        Qb, Tb = _targets(model, n, seed=8)
        from px100_control.kinematics.analytic.px100 import _pose_rows
        rows_b = _pose_rows(model, Tb)
        t0 = time.perf_counter()
        Q_sol, ok = solve_ik_batch(model, rows_b)
        dt = time.perf_counter() - t0
        t0 = time.perf_counter()
        Q_sol2, ok2 = solve_ik_batch(model, Tb)
        dt_pose = time.perf_counter() - t0
        # verify a sample of the answers by FK (position and tool pitch)
        idx = np.random.default_rng(0).choice(n, size=min(n, 100_000), replace=False)
        good = ok[idx]
        Tq = fk_batch(chain(model), np.where(good[:, None], Q_sol[idx], 0.0))
        perr = np.linalg.norm(Tq[:, :3, 3] - Tb[idx, :3, 3], axis=1)
        xa, xb = Tq[:, :3, 0], Tb[idx, :3, 0]
        aerr = np.arctan2(np.linalg.norm(np.cross(xa, xb), axis=1), np.sum(xa * xb, axis=1))
        verified = good & (perr < POS_TOL) & (aerr < ORI_TOL)
        batch = {'targets': n, 'seconds_rows': dt, 'solutions_per_s_rows': n / dt,
                 'seconds_poses': dt_pose, 'solutions_per_s_poses': n / dt_pose,
                 'success': float(ok.mean()), 'verified_fraction_of_sample': float(
                     verified.mean()), 'max_position_error_m': float(perr[good].max()),
                 'max_pitch_error_rad': float(aerr[good].max())}
        rows.append({'name': f'px100_control solve_ik_batch, {n} targets (x, y, z, pitch) rows',
                     'median_us': dt / n * 1e6, 'success': float(verified.mean()), 'n': n,
                     'note': f'{n / dt / 1e6:.2f} M solutions/s ((N,4,4) poses: '
                             f'{n / dt_pose / 1e6:.2f} M/s)'})
    return rows, batch


# ---------------------------------------------------------------------------------------------
# peers
# ---------------------------------------------------------------------------------------------

def _interbotix_wrap(theta, lower, upper):
    """Interbotix ``_wrap_theta_list``: wrap to [-pi, pi), then +-2 pi by rounded limits."""
    rev = 2 * np.pi
    theta = (np.asarray(theta, float) + np.pi) % rev - np.pi
    for i in range(len(theta)):
        if round(theta[i], 3) < round(lower[i], 3):
            theta[i] += rev
        elif round(theta[i], 3) > round(upper[i], 3):
            theta[i] -= rev
    return theta


def _interbotix_limits_ok(theta, lower, upper):
    """Interbotix ``_check_joint_limits`` position part (truncated to 3 decimals)."""
    t = [int(v * 1000) / 1000 for v in theta]
    return all(lo <= v <= hi for v, lo, hi in zip(t, lower, upper))


def _mr_rows(model, targets):
    import modern_robotics as mr
    n = model.dof
    lower, upper = model.lower.tolist(), model.upper.tolist()
    intended = [[0.0] * n for _ in range(3)]
    intended[1][0] = np.deg2rad(-120)
    intended[2][0] = np.deg2rad(120)
    shipped = [[0.0] * n] * 3                 # the aliasing bug: one list three times
    shipped[1][0] = np.deg2rad(-120)
    shipped[2][0] = np.deg2rad(120)

    def make(guesses):
        def solve(T):
            for guess in guesses:
                theta, success = mr.IKinSpace(model.S_list, model.M, T, guess, 0.001, 0.001)
                if success:
                    theta = _interbotix_wrap(theta, lower, upper)
                    if _interbotix_limits_ok(theta, lower, upper):
                        return theta
            return None
        return solve
    return [
        _measure('modern_robotics IKinSpace, Interbotix seeds as intended (0, -120, +120 deg)',
                 model, targets, make(intended), note='eomg = ev = 1e-3, 20 iterations'),
        _measure('modern_robotics IKinSpace, Interbotix seeds as shipped (all +120 deg)',
                 model, targets, make(shipped), note='[[0.0] * n] * 3 aliasing'),
    ]


def _ikpy_rows(model, targets):
    import ikpy.chain
    if model.urdf_xml is None:
        return [{'name': 'ikpy', 'skipped': 'model has no URDF'}]
    with tempfile.NamedTemporaryFile('w', suffix='.urdf', delete=False) as f:
        f.write(model.urdf_xml)
        path = f.name
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter('ignore')
        ch = ikpy.chain.Chain.from_urdf_file(path, base_elements=_urdf_chain_elements(model))
    names = [lk.name for lk in ch.links]
    active = [lk.name in model.joint_names for lk in ch.links]
    ch = ikpy.chain.Chain(ch.links, active_links_mask=active, name='arm')
    idx = [names.index(j) for j in model.joint_names]
    q0 = np.zeros(len(ch.links))

    def solve(T):
        sol = ch.inverse_kinematics(target_position=T[:3, 3], target_orientation=T[:3, :3],
                                    orientation_mode='all', initial_position=q0)
        return np.asarray(sol)[idx]
    os.unlink(path)
    return [_measure('ikpy inverse_kinematics (orientation_mode=all, start at home)', model,
                     targets, solve, note=f'chain {len(ch.links)} links from the URDF')]


def _urdf_chain_elements(model):
    """Return [base link, joint, link, joint, ...] down to the end effector (ikpy's path)."""
    from px100_control.models.urdf_chain import chain_joints, load_urdf
    urdf = load_urdf(model.urdf_xml)
    out = [model.base_frame]
    for j in chain_joints(urdf, model.base_frame, model.ee_frame):
        out += [j.name, j.child]
    return out


def _ets_from_poe(model):
    """
    Return a roboticstoolbox ETS of a PoE model whose joint axes at q = 0 are +-x/y/z, or None.

    Each joint: translate from the previous joint's axis point to this one's (the point of
    the axis closest to the origin), rotate about the coordinate axis (flipped for -x/y/z),
    with the joint's limits; then translate to the home pose M (identity rotation only).
    """
    import roboticstoolbox as rtb
    S, M = np.asarray(model.S_list, float), np.asarray(model.M, float)
    if np.abs(M[:3, :3] - np.eye(3)).max() > 1e-12:
        return None
    moves = (rtb.ET.tx, rtb.ET.ty, rtb.ET.tz)
    turns = (rtb.ET.Rx, rtb.ET.Ry, rtb.ET.Rz)
    ets, prev = rtb.ETS(), np.zeros(3)
    for i in range(model.dof):
        w, v = S[:3, i], S[3:, i]
        k = int(np.argmax(np.abs(w)))
        if model.joint_types[i] != 'revolute' or abs(abs(w[k]) - 1.0) > 1e-12:
            return None
        point = np.cross(w, v)
        for ax in range(3):
            if point[ax] != prev[ax]:
                ets *= moves[ax](float(point[ax] - prev[ax]))
        prev = point
        ets *= turns[k](qlim=[float(model.lower[i]), float(model.upper[i])],
                        flip=bool(w[k] < 0))
    for ax in range(3):
        if M[ax, 3] != prev[ax]:
            ets *= moves[ax](float(M[ax, 3] - prev[ax]))
    return ets


def _ets_from_table(model):
    """
    Return a roboticstoolbox ETS of a model given by a DH / modified DH table, or None.

    Standard DH per joint: Rz(q + theta) Tz(d) Tx(a) Rx(alpha); modified: Rx(alpha) Tx(a)
    Rz(q + theta) Tz(d) (prismatic: Tz(q + d)); then the table's tool transform.
    """
    import roboticstoolbox as rtb
    from spatialmath import SE3
    kin = (model.extra or {}).get('kinematics') or {}
    joints = kin.get('joints') or []
    if kin.get('convention') not in ('dh', 'mdh') or len(joints) != model.dof or kin.get('base'):
        return None
    ets = rtb.ETS()
    for i, (j, lo, hi, kind) in enumerate(zip(joints, model.lower, model.upper,
                                              model.joint_types)):
        a, alpha = float(j.get('a', 0.0)), float(j.get('alpha', 0.0))
        d, theta = float(j.get('d', 0.0)), float(j.get('theta', 0.0))
        lim = [float(lo), float(hi)]
        if kin['convention'] == 'mdh':
            ets *= rtb.ET.Rx(alpha) * rtb.ET.tx(a)
        if kind == 'prismatic':
            ets *= rtb.ET.Rz(theta) * rtb.ET.tz(d) * rtb.ET.tz(jindex=i, qlim=lim)
        else:
            ets *= rtb.ET.Rz(jindex=i, qlim=lim) * rtb.ET.Rz(theta) * rtb.ET.tz(d)
        if kin['convention'] == 'dh':
            ets *= rtb.ET.tx(a) * rtb.ET.Rx(alpha)
    tool = kin.get('tool')
    if tool:
        from px100_control.models.registry import _matrix
        ets *= rtb.ET.SE3(SE3(_matrix(tool), check=False))
    return ets


def rtb_solver(model):
    """
    Return (solve(T) -> q or None, source) with tuned roboticstoolbox ``ik_LM``, or (None, why).

    The peer's model is built from the robot's DH table, its kinematics table, or its
    axis-aligned PoE, and checked against our FK (1e-9) at 20 configurations.
    """
    import roboticstoolbox as rtb
    table = (model.extra.get('alternative_models') or {}).get('dh')
    if table is not None:
        from px100_control.models.registry import _matrix
        from spatialmath import SE3
        links = [rtb.RevoluteDH(a=j['a'], alpha=j['alpha'], d=j['d'], offset=j['theta'],
                                qlim=[lo, hi])
                 for j, lo, hi in zip(table['joints'], model.lower, model.upper)]
        robot = rtb.DHRobot(links, tool=SE3(_matrix(table.get('tool')), check=False),
                            name=model.name)
        # DHRobot.ik_LM drops the tool transform (every solve fails); its ETS keeps it
        ets = robot.ets()
        source = f'DH model from {model.name}.yaml'
    else:
        ets = _ets_from_poe(model)
        source = f'ETS built from the PoE model of {model.name}.yaml'
        if ets is None:
            ets = _ets_from_table(model)
            source = f'ETS built from the kinematics table of {model.name}.yaml'
        if ets is None:
            return None, 'no DH table and no axis-aligned PoE for this robot'
    rng = np.random.default_rng(1)
    for q in model.random_configurations(20, rng):        # the peer's model must be ours
        if np.abs(ets.fkine(q).A - model.fk(q)).max() > 1e-9:
            return None, 'ETS does not match the FK'
    q0 = np.zeros(model.dof)

    def solve(T):
        sol = ets.ik_LM(T, q0=q0, ilimit=30, slimit=100, tol=1e-10, joint_limits=True,
                        method='chan', k=1.0)
        return sol.q if sol.success else None
    return solve, source


def _rtb_rows(model, targets):
    solve, source = rtb_solver(model)
    if solve is None:
        return [{'name': 'roboticstoolbox ik_LM', 'skipped': source}]
    return [_measure("roboticstoolbox ETS.ik_LM (C++, method='chan', tuned)", model, targets,
                     solve, note=f'{source}; ilimit 30, slimit 100, tol 1e-10, joint limits')]


def _pin_rows(model, targets):
    import pinocchio as pin
    if model.urdf_xml is None:
        return [{'name': 'pinocchio CLIK', 'skipped': 'model has no URDF'}]
    full = pin.buildModelFromXML(model.urdf_xml)
    lock = [full.getJointId(n) for n in full.names[1:] if n not in model.joint_names]
    red = pin.buildReducedModel(full, lock, pin.neutral(full))
    data = red.createData()
    fid = red.getFrameId(model.ee_frame)
    names = list(red.names)[1:]
    idx = [names.index(j) for j in model.joint_names]

    def solve(T):
        # pinocchio's documented CLIK example (damped pseudo-inverse on the SE(3) log error in
        # the end-effector frame, Jlog6 correction), with unit step
        oMdes = pin.SE3(T[:3, :3], T[:3, 3])
        q = pin.neutral(red)
        for _ in range(200):
            pin.framesForwardKinematics(red, data, q)
            iMd = data.oMf[fid].actInv(oMdes)
            err = pin.log(iMd).vector
            if np.linalg.norm(err) < 1e-10:
                break
            J = pin.computeFrameJacobian(red, data, q, fid)
            J = -pin.Jlog6(iMd.inverse()) @ J
            v = -J.T @ np.linalg.solve(J @ J.T + 1e-12 * np.eye(6), err)
            q = pin.integrate(red, q, v)
            q = np.clip(q, red.lowerPositionLimit, red.upperPositionLimit)
        return q[idx]
    return [_measure('pinocchio CLIK (damped pinv, Python loop, start at neutral)', model,
                     targets, solve, note='pinocchio example-style, 200 iterations max')]


def _peer_rows(model, targets):
    rows, missing = [], []
    for name, fn in (('modern_robotics', _mr_rows), ('ikpy', _ikpy_rows),
                     ('roboticstoolbox', _rtb_rows), ('pinocchio', _pin_rows)):
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 - any import failure means 'not installed here'
            missing.append(name)
            continue
        try:
            rows.extend(fn(model, targets))
        except Exception as exc:  # noqa: BLE001 - a peer failing must not kill the benchmark
            rows.append({'name': name, 'skipped': f'{type(exc).__name__}: {exc}'})
    return rows, missing


def _peers_in_bench_venv(robot, n, quick):
    py = os.path.join(BENCH_VENV, 'bin', 'python')
    # venv interpreters are symlinks to the same base Python: compare the venvs, not the files
    if not os.path.isfile(py) or os.path.realpath(BENCH_VENV) == os.path.realpath(sys.prefix):
        return None
    with tempfile.NamedTemporaryFile(suffix='.json', delete=False) as f:
        out = f.name
    cmd = [py, os.path.abspath(__file__), '--robot', robot, '--targets', str(n), '--peers-only',
           '--json', out] + (['--quick'] if quick else [])
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=3600)
    if proc.returncode != 0:
        return [{'name': 'bench venv', 'skipped': proc.stderr.strip()[-300:]}]
    with open(out) as f:
        rows = json.load(f)['rows']
    os.unlink(out)
    for r in rows:
        r['venv'] = BENCH_VENV
    return rows


# ---------------------------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------------------------

def _markdown(rows, ref_name):
    ref = next((r for r in rows if r.get('name') == ref_name), None)
    lines = ['| solver | median [us] | min [us] | p90 [us] | success | x ours | note |',
             '| --- | ---: | ---: | ---: | ---: | ---: | --- |']
    for r in rows:
        if 'skipped' in r:
            lines.append(f"| {r['name']} | - | - | - | - | - | skipped: {r['skipped']} |")
            continue
        ratio = (f"{r['median_us'] / ref['median_us']:.2f}" if ref and r.get('median_us')
                 and r['success'] is not None else '')
        succ = '' if r['success'] is None else f"{100 * r['success']:.1f} %"
        p90 = f"{r['p90_us']:.1f}" if r.get('p90_us') is not None else ''
        low = f"{r['min_us']:.1f}" if r.get('min_us') is not None else ''
        lines.append(f"| {r['name']} | {r['median_us']:.1f} | {low} | {p90} | {succ} | {ratio} | "
                     f"{r.get('note', '')} |")
    return '\n'.join(lines)


#: issue 8's goals for the fastest single solve against tuned ik_LM: (speed-up, success)
GOALS = {'px100': (5.0, 1.0), 'myarm300pi': (2.0, 0.999)}


def _verdicts(robot, rows):
    """Return sentences comparing our fastest single solve with tuned ik_LM (and the goal)."""
    ours = [r for r in rows if 'closed form' in r.get('name', '') and r.get('success')]
    peer = next((r for r in rows if r.get('name', '').startswith('roboticstoolbox')
                 and 'skipped' not in r), None)
    if not ours or peer is None:
        return []
    best = min(ours, key=lambda r: r['median_us'])
    speedup = peer['median_us'] / best['median_us']
    text = (f"{best['name']}: {speedup:.1f}x the speed of tuned ik_LM (median "
            f"{best['median_us']:.1f} vs {peer['median_us']:.1f} us; success "
            f"{100 * best['success']:.1f} % vs {100 * peer['success']:.1f} %)")
    if robot in GOALS:
        want, succ = GOALS[robot]
        met = speedup >= want and best['success'] >= succ
        text += (f'; goal >= {want:g}x at >= {100 * succ:g} % success: '
                 + ('met' if met else 'NOT met: behind the goal'))
    faster = [r['name'] for r in rows if 'skipped' not in r and r.get('success') is not None
              and not r['name'].startswith('px100_control')
              and r['median_us'] < best['median_us']]
    out = [text]
    if faster:
        out.append('Faster than our fastest single solve: ' + ', '.join(faster))
    return out


def run(quick: bool = False, robot: str = 'px100', targets: int = 0) -> dict:
    """Run the benchmark; return the figures (rows, batch, machine) and a Markdown table."""
    model = load_robot(robot)
    n = targets or (200 if quick else 1000)
    Q, T = _targets(model, n)
    T = list(T)
    rows, batch = _ours(model, Q, T, quick)
    peer_rows, missing = _peer_rows(model, T)
    if missing:
        extra = _peers_in_bench_venv(robot, n, quick)
        if extra:
            peer_rows.extend(extra)
        else:
            peer_rows.extend({'name': m, 'skipped': 'not installed (bash scripts/bench_setup.sh)'}
                             for m in missing)
    rows += peer_rows
    ref = "px100_control solve_ik(mode='full') auto"
    verdicts = _verdicts(robot, rows)
    return {'robot': robot, 'targets': n, 'quick': quick, 'verdicts': verdicts,
            'success_criterion': f'position < {POS_TOL} m, orientation < {ORI_TOL} rad, '
                                 'within joint limits',
            'machine': f'{platform.processor() or platform.machine()}, {os.cpu_count()} cores, '
                       f'Python {platform.python_version()}',
            'load_average_1min_at_end': os.getloadavg()[0],
            'rows': rows, 'batch': batch,
            'markdown': _markdown(rows, ref) + ''.join(f'\n\n{v}' for v in verdicts),
            'ratio_reference': ref}


def main(argv=None) -> int:
    """Print the Markdown table and write benchmarks/results/kinematics_<robot>.json."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='200 targets, 10^5 batch')
    parser.add_argument('--robot', default='px100', help='registered robot model')
    parser.add_argument('--targets', type=int, default=0, help='number of targets')
    parser.add_argument('--json', default='', help='output path (default results/...)')
    parser.add_argument('--peers-only', action='store_true', help=argparse.SUPPRESS)
    bound.add_argument(parser, *BOUND_S)
    options = parser.parse_args(argv)
    if options.peers_only:
        model = load_robot(options.robot)
        _, T = _targets(model, options.targets or (200 if options.quick else 1000))
        rows, missing = _peer_rows(model, list(T))
        rows += [{'name': m, 'skipped': 'not installed in the bench venv'} for m in missing]
        with open(options.json, 'w') as f:
            json.dump({'rows': rows}, f)
        return 0
    with bound.bounded(f'bench_kinematics {options.robot}', bound.seconds(options, options.quick)):
        result = run(options.quick, options.robot, options.targets)
    print(f"## Kinematics benchmark: {result['robot']}, {result['targets']} targets "
          f"({result['machine']}; load average {result['load_average_1min_at_end']:.1f} at "
          'the end: timings scale with it)\n')
    print(result['markdown'])
    if result['batch']:
        b = result['batch']
        print(f"\nbatch: {b['targets']} targets in {b['seconds_rows']:.3f} s = "
              f"{b['solutions_per_s_rows'] / 1e6:.2f} M solutions/s (rows), "
              f"{b['solutions_per_s_poses'] / 1e6:.2f} M/s from (N, 4, 4) poses; success "
              f"{100 * b['success']:.2f} %, max position error {b['max_position_error_m']:.2e} m")
    path = options.json or os.path.join(ROOT, 'benchmarks', 'results',
                                        f'kinematics_{options.robot}.json')
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, 'w') as f:
        json.dump(result, f, indent=1, default=float)
    print(f'\nwrote {path}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
