"""
The test oracle: hand-written rigid-body dynamics of a serial arm (M, h, forward, inverse).

Kept outside the package as an independent reference: test_sim_oracle.py compares MuJoCo's
mass matrix and bias forces with it, and oracle_simulator.py (the PID + servo + these dynamics,
semi-implicit Euler) is the exact step that benchmarks/bench_physics.py times side by side.

The equations of motion are ``(M(q) + diag(armature)) qdd + h(q, qd) = tau`` with
``h = C(q, qd) qd + g(q)``. Everything is computed in the space (base) frame from the PoE screw
axes ``S_list`` (6, n) and, per moving body k (everything rigidly carried by joint k up to the next
arm joint), its mass [kg], centre of mass [m] and rotational inertia about the COM [kg*m^2] at
q = 0 in base axes:

- mass matrix by composite rigid bodies: ``M_ij = J_i . (Ic_max(i,j) J_j)`` with ``J_i`` the
  space-Jacobian column and ``Ic_k`` the spatial inertia of bodies k..n in the space frame;
- bias forces by Newton-Euler in the space frame (Featherstone's ``f = I a + v x* I v``), gravity
  entered as a fictitious base acceleration of +9.81 m/s^2 along z.

Spatial vectors are ``[omega; v]`` (Modern Robotics order); revolute joints in rad, prismatic in m.
Gravity is -z, 9.81 m/s^2.

Where the bodies come from:

- :func:`chain_dynamics_from_urdf`: the URDF inertials (mass, origin, inertia tensor rotated by the
  inertial rpy) of every link carried by each arm joint, lumped per body. Joints that are not arm
  joints (the gripper servo, the fingers, mimic joints) are frozen at a nominal value (finger
  joints at the finger position of gripper angle 0). Placeholder inertias whose radius of gyration
  exceeds ``max_gyration_radius`` (the Interbotix dummy links carry 0.001 kg*m^2 on a 1 g link,
  i.e. a 1 m radius) are replaced by a point mass; the notes say which.
- :func:`point_mass_dynamics`: the documented fallback when there is no URDF or it has no
  inertials: one point mass ``link_mass`` [kg] per body at the middle of the segment between its
  joint axis and the next one (the end-effector for the last), plus an isotropic rotational inertia
  ``link_inertia`` [kg*m^2] so the mass matrix stays positive definite.

``armature`` is the actuator's rotor inertia reflected through the gearbox, added to the diagonal
of M (MuJoCo's ``armature``).
"""
from dataclasses import dataclass, field
import math
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from px100_control.errors import RobotModelError
from px100_control.kinematics.se3 import exp_so3
from px100_control.models.urdf_chain import load_urdf

GRAVITY = 9.81
_I3 = np.eye(3)
# (3, 9) map from a vector to its flattened skew matrix: [w] = (w @ _SKEW).reshape(3, 3).
_SKEW = np.zeros((3, 9))
_SKEW[2, 1], _SKEW[1, 2], _SKEW[2, 3] = -1.0, 1.0, 1.0
_SKEW[0, 5], _SKEW[1, 6], _SKEW[0, 7] = -1.0, -1.0, 1.0


def _skew_batch(w: np.ndarray) -> np.ndarray:
    """Return (..., 3, 3) skew matrices [w] of (..., 3) vectors (one matmul)."""
    return (w @ _SKEW).reshape(w.shape[:-1] + (3, 3))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return the row-wise cross products of (k, 3) arrays (faster than np.cross for small k)."""
    return (_skew_batch(a) @ b[:, :, None])[:, :, 0]


def _ad(V: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Return the row-wise Lie brackets ad_V X of (k, 6) twists [omega; v]."""
    A = np.zeros((V.shape[0], 6, 6))
    Ww = _skew_batch(V[:, :3])
    A[:, :3, :3] = Ww
    A[:, 3:, 3:] = Ww
    A[:, 3:, :3] = _skew_batch(V[:, 3:])
    return (A @ X[:, :, None])[:, :, 0]


def _ad_transpose(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Return the row-wise ad_V^T F of (k, 6) twists V and wrenches F."""
    A = np.zeros((V.shape[0], 6, 6))
    Ww = _skew_batch(V[:, :3])
    A[:, :3, :3] = Ww
    A[:, 3:, 3:] = Ww
    A[:, 3:, :3] = _skew_batch(V[:, 3:])
    return (np.transpose(A, (0, 2, 1)) @ F[:, :, None])[:, :, 0]


def spatial_inertia(mass: float, com, inertia_com) -> np.ndarray:
    """
    Return the (6, 6) spatial inertia [omega; v] about a frame's origin.

    :param mass: [kg]; com: (3,) centre of mass in that frame [m]
    :param inertia_com: (3, 3) rotational inertia about the COM in that frame's axes [kg*m^2]
    Example Input: mass=2, com=0, inertia_com=I  Output: diag(1, 1, 1, 2, 2, 2)
    """
    C = _skew_batch(np.asarray(com, dtype=float))
    G = np.zeros((6, 6))
    G[:3, :3] = np.asarray(inertia_com, dtype=float) - mass * C @ C
    G[:3, 3:] = mass * C
    G[3:, :3] = -mass * C
    G[3:, 3:] = mass * _I3
    return G


def lump_inertias(parts: Sequence[Tuple[float, np.ndarray, np.ndarray]]):
    """
    Return (mass, com (3,), inertia about com (3, 3)) of rigidly joined parts.

    :param parts: [(mass [kg], com (3,) [m], inertia about its com (3, 3) [kg*m^2])], one frame
    """
    mass = float(sum(p[0] for p in parts))
    if mass <= 0.0:
        return 0.0, np.zeros(3), sum((p[2] for p in parts), np.zeros((3, 3)))
    com = sum(p[0] * np.asarray(p[1], float) for p in parts) / mass
    inertia = np.zeros((3, 3))
    for m, c, I in parts:
        d = np.asarray(c, float) - com
        inertia += np.asarray(I, float) + m * (d @ d * _I3 - np.outer(d, d))
    return mass, com, inertia


@dataclass(frozen=True, eq=False)
class ChainDynamics:
    """
    Rigid-body dynamics of an n-joint serial chain (see the module docstring).

    :param S_list: (6, n) space screw axes at q = 0 (unit omega for revolute, unit v prismatic)
    :param masses: (n,) mass of body k [kg]
    :param coms: (n, 3) COM of body k at q = 0, base frame [m]
    :param inertias: (n, 3, 3) rotational inertia of body k about its COM, base axes at q = 0
    :param armature: (n,) reflected rotor inertia per joint [kg*m^2 or kg]
    """

    S_list: np.ndarray
    masses: np.ndarray
    coms: np.ndarray
    inertias: np.ndarray
    armature: np.ndarray
    gravity: float = GRAVITY
    source: str = 'urdf'
    notes: Tuple[str, ...] = ()
    _cache: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        n = self.S_list.shape[1]
        w = self.S_list[:3].T.copy()
        v = self.S_list[3:].T.copy()
        W = _skew_batch(w)
        W2 = W @ W
        c = self._cache
        c['n'] = n
        c['w'] = w[:, :, None]
        c['v'] = v[:, :, None]
        c['W'], c['W2'] = W, W2
        c['Wv'] = (W @ v[:, :, None])[:, :, 0]
        c['W2v'] = (W2 @ v[:, :, None])[:, :, 0]
        c['eye'] = np.broadcast_to(_I3, (n, 3, 3)).copy()
        c['a_g'] = np.array([0.0, 0.0, 0.0, 0.0, 0.0, self.gravity])
        c['triu'] = np.triu(np.ones((n, n), dtype=bool))
        c['L'] = np.tril(np.ones((n, n)))          # inclusive prefix sums
        c['Ls'] = np.tril(np.ones((n, n)), -1)     # exclusive prefix sums
        c['U'] = np.triu(np.ones((n, n)))          # inclusive suffix sums
        # Spatial inertia of each body in the space frame at q = 0.
        c['G0'] = np.array([spatial_inertia(self.masses[k], self.coms[k], self.inertias[k])
                            for k in range(n)]).reshape(n, 6, 6)
        c['E'] = np.zeros((n, 4, 4))
        c['E'][:, 3, 3] = 1.0
        c['Tprev'] = np.zeros((n, 4, 4))
        c['Tprev'][0] = np.eye(4)
        c['Ad'] = np.zeros((n, 6, 6))
        # Plain-float constants of the scalar fast path (numpy calls cost microseconds each).
        c['joints'] = [(
            tuple(w[k].tolist()), tuple(v[k].tolist()), tuple(c['Wv'][k].tolist()),
            tuple(c['W2v'][k].tolist()),
            tuple(float(x) for x in (w[k, 0] ** 2, w[k, 1] ** 2, w[k, 2] ** 2,
                                     w[k, 0] * w[k, 1], w[k, 0] * w[k, 2], w[k, 1] * w[k, 2])),
            float(self.masses[k]), tuple(self.coms[k].tolist()),
            tuple(tuple(row) for row in self.inertias[k].tolist()), float(self.armature[k]),
            bool(np.linalg.norm(w[k]) < 1e-9))
            for k in range(n)]

    @property
    def dof(self) -> int:
        """Return the number of joints."""
        return self._cache['n']

    # --- kinematics shared by every quantity -----------------------------------------------
    def _frames(self, q: np.ndarray):
        """Return (T (n, 4, 4) body displacements T_k = e^[S1]q1..e^[Sk]qk, J (n, 6))."""
        c = self._cache
        n = c['n']
        s, co = np.sin(q), np.cos(q)
        oc = (1.0 - co)[:, None]
        E = c['E']
        E[:, :3, :3] = c['eye'] + s[:, None, None] * c['W'] + oc[:, :, None] * c['W2']
        E[:, :3, 3] = q[:, None] * c['v'][:, :, 0] + oc * c['Wv'] + (q - s)[:, None] * c['W2v']
        Tprev = c['Tprev']
        T = np.empty((n, 4, 4))
        Tk = E[0]
        T[0] = Tk
        for k in range(1, n):
            Tprev[k] = Tk
            Tk = Tk @ E[k]
            T[k] = Tk
        Rp = Tprev[:, :3, :3]
        Jw = (Rp @ c['w'])[:, :, 0]
        Jv = (Rp @ c['v'])[:, :, 0] + _cross(Tprev[:, :3, 3], Jw)
        return T, np.concatenate([Jw, Jv], axis=1)

    def _body_inertias(self, T):
        """Return (n, 6, 6) spatial inertias of each body in the space frame at the pose."""
        Ad = self._cache['Ad']
        Rt = np.transpose(T[:, :3, :3], (0, 2, 1))
        Ad[:, :3, :3] = Rt
        Ad[:, 3:, 3:] = Rt
        Ad[:, 3:, :3] = -Rt @ _skew_batch(T[:, :3, 3])
        return np.transpose(Ad, (0, 2, 1)) @ self._cache['G0'] @ Ad

    def _mass_matrix(self, J, G):
        c = self._cache
        n = c['n']
        Icomp = (c['U'] @ G.reshape(n, 36)).reshape(n, 6, 6)
        X = (Icomp @ J[:, :, None])[:, :, 0]
        P = J @ X.T
        return np.where(c['triu'], P, P.T)

    def _rnea(self, J, G, qd, qdd, gravity: bool):
        c = self._cache
        Jq = J * qd[:, None]
        V = c['L'] @ Jq
        Vp = c['Ls'] @ Jq
        acc = _ad(Vp, J) * qd[:, None]
        if qdd is not None:
            acc = acc + J * qdd[:, None]
        a = c['L'] @ acc
        if gravity:
            a = a + c['a_g']
        h = (G @ V[:, :, None])[:, :, 0]
        f = (G @ a[:, :, None])[:, :, 0] - _ad_transpose(V, h)
        F = c['U'] @ f
        return (J * F).sum(axis=1)

    def displacement_lists(self, q: Sequence[float]):
        """
        Return (R, p) of e^[S1]q1 ... e^[Sn]qn as a 3x3 row tuple and a 3-tuple (plain floats).

        The pose of anything on the last body is this times its pose at q = 0 (e.g. the
        end-effector: times M). Same Rodrigues products as :meth:`evaluate_lists`.
        """
        sin, cos = math.sin, math.cos
        R00, R01, R02, R10, R11, R12, R20, R21, R22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
        p0 = p1 = p2 = 0.0
        for k, joint in enumerate(self._cache['joints']):
            (wx, wy, wz), (vx, vy, vz), Wv, W2v, ww = joint[:5]
            qk = q[k]
            s, co = (0.0, 1.0) if joint[9] else (sin(qk), cos(qk))
            oc, qs = 1.0 - co, qk - s
            E00, E11, E22 = co + oc * ww[0], co + oc * ww[1], co + oc * ww[2]
            a, b = oc * ww[3], s * wz
            E01, E10 = a - b, a + b
            a, b = oc * ww[4], s * wy
            E02, E20 = a + b, a - b
            a, b = oc * ww[5], s * wx
            E12, E21 = a - b, a + b
            e0 = qk * vx + oc * Wv[0] + qs * W2v[0]
            e1 = qk * vy + oc * Wv[1] + qs * W2v[1]
            e2 = qk * vz + oc * Wv[2] + qs * W2v[2]
            p0, p1, p2 = (R00 * e0 + R01 * e1 + R02 * e2 + p0, R10 * e0 + R11 * e1 + R12 * e2 + p1,
                          R20 * e0 + R21 * e1 + R22 * e2 + p2)
            R00, R01, R02, R10, R11, R12, R20, R21, R22 = (
                R00 * E00 + R01 * E10 + R02 * E20, R00 * E01 + R01 * E11 + R02 * E21,
                R00 * E02 + R01 * E12 + R02 * E22, R10 * E00 + R11 * E10 + R12 * E20,
                R10 * E01 + R11 * E11 + R12 * E21, R10 * E02 + R11 * E12 + R12 * E22,
                R20 * E00 + R21 * E10 + R22 * E20, R20 * E01 + R21 * E11 + R22 * E21,
                R20 * E02 + R21 * E12 + R22 * E22)
        return ((R00, R01, R02), (R10, R11, R12), (R20, R21, R22)), (p0, p1, p2)

    def evaluate_lists(self, q: Sequence[float], qd: Sequence[float]):
        """
        Return (M, h) as plain lists: the scalar fast path of :meth:`evaluate`.

        Same equations, written with Python floats because for a handful of joints numpy's
        per-call overhead dominates; ``M`` includes the armature, ``h = C(q, qd) qd + g(q)``.
        :param q: n joint positions; qd: n joint velocities (any float sequences)
        """
        joints = self._cache['joints']
        n = len(joints)
        sin, cos = math.sin, math.cos
        # cumulative displacement T_{k-1} = (R, p) of the bodies before joint k
        R00, R01, R02, R10, R11, R12, R20, R21, R22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
        p0 = p1 = p2 = 0.0
        Js, bodies = [], []
        for k in range(n):
            (wx, wy, wz), (vx, vy, vz), Wv, W2v, ww, m, c0, I0, _, prismatic = joints[k]
            qk = q[k]
            s, co = (0.0, 1.0) if prismatic else (sin(qk), cos(qk))
            oc, qs = 1.0 - co, qk - s
            # space-Jacobian column J_k = Ad_{T_{k-1}} S_k
            jw0 = R00 * wx + R01 * wy + R02 * wz
            jw1 = R10 * wx + R11 * wy + R12 * wz
            jw2 = R20 * wx + R21 * wy + R22 * wz
            jv0 = R00 * vx + R01 * vy + R02 * vz + p1 * jw2 - p2 * jw1
            jv1 = R10 * vx + R11 * vy + R12 * vz + p2 * jw0 - p0 * jw2
            jv2 = R20 * vx + R21 * vy + R22 * vz + p0 * jw1 - p1 * jw0
            Js.append((jw0, jw1, jw2, jv0, jv1, jv2))
            # joint motion e^[S_k]q_k = (E, e) by Rodrigues (prismatic: w = 0, e = q v)
            E00, E11, E22 = co + oc * ww[0], co + oc * ww[1], co + oc * ww[2]
            a, b = oc * ww[3], s * wz
            E01, E10 = a - b, a + b
            a, b = oc * ww[4], s * wy
            E02, E20 = a + b, a - b
            a, b = oc * ww[5], s * wx
            E12, E21 = a - b, a + b
            e0 = qk * vx + oc * Wv[0] + qs * W2v[0]
            e1 = qk * vy + oc * Wv[1] + qs * W2v[1]
            e2 = qk * vz + oc * Wv[2] + qs * W2v[2]
            # T_k = T_{k-1} e^[S_k]q_k
            p0, p1, p2 = (R00 * e0 + R01 * e1 + R02 * e2 + p0, R10 * e0 + R11 * e1 + R12 * e2 + p1,
                          R20 * e0 + R21 * e1 + R22 * e2 + p2)
            R00, R01, R02, R10, R11, R12, R20, R21, R22 = (
                R00 * E00 + R01 * E10 + R02 * E20, R00 * E01 + R01 * E11 + R02 * E21,
                R00 * E02 + R01 * E12 + R02 * E22, R10 * E00 + R11 * E10 + R12 * E20,
                R10 * E01 + R11 * E11 + R12 * E21, R10 * E02 + R11 * E12 + R12 * E22,
                R20 * E00 + R21 * E10 + R22 * E20, R20 * E01 + R21 * E11 + R22 * E21,
                R20 * E02 + R21 * E12 + R22 * E22)
            # body k: COM, first moment h = m c and inertia about the base origin I_O
            cx = R00 * c0[0] + R01 * c0[1] + R02 * c0[2] + p0
            cy = R10 * c0[0] + R11 * c0[1] + R12 * c0[2] + p1
            cz = R20 * c0[0] + R21 * c0[1] + R22 * c0[2] + p2
            (i00, i01, i02), (i10, i11, i12), (i20, i21, i22) = I0
            A00 = R00 * i00 + R01 * i10 + R02 * i20
            A01 = R00 * i01 + R01 * i11 + R02 * i21
            A02 = R00 * i02 + R01 * i12 + R02 * i22
            A10 = R10 * i00 + R11 * i10 + R12 * i20
            A11 = R10 * i01 + R11 * i11 + R12 * i21
            A12 = R10 * i02 + R11 * i12 + R12 * i22
            A20 = R20 * i00 + R21 * i10 + R22 * i20
            A21 = R20 * i01 + R21 * i11 + R22 * i21
            A22 = R20 * i02 + R21 * i12 + R22 * i22
            cc = cx * cx + cy * cy + cz * cz
            bodies.append((
                m, m * cx, m * cy, m * cz,
                A00 * R00 + A01 * R01 + A02 * R02 + m * (cc - cx * cx),
                A10 * R10 + A11 * R11 + A12 * R12 + m * (cc - cy * cy),
                A20 * R20 + A21 * R21 + A22 * R22 + m * (cc - cz * cz),
                A00 * R10 + A01 * R11 + A02 * R12 - m * cx * cy,
                A00 * R20 + A01 * R21 + A02 * R22 - m * cx * cz,
                A10 * R20 + A11 * R21 + A12 * R22 - m * cy * cz))
        # composite bodies k..n-1 (suffix sums) and M_ij = J_i . (Ic_j J_j), i <= j
        M = [[0.0] * n for _ in range(n)]
        comp = [0.0] * 10
        for j in range(n - 1, -1, -1):
            comp = [x + y for x, y in zip(comp, bodies[j])]
            m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz = comp
            w0, w1, w2, u0, u1, u2 = Js[j]
            X = (Ixx * w0 + Ixy * w1 + Ixz * w2 + hy * u2 - hz * u1,
                 Ixy * w0 + Iyy * w1 + Iyz * w2 + hz * u0 - hx * u2,
                 Ixz * w0 + Iyz * w1 + Izz * w2 + hx * u1 - hy * u0,
                 m * u0 - (hy * w2 - hz * w1), m * u1 - (hz * w0 - hx * w2),
                 m * u2 - (hx * w1 - hy * w0))
            for i in range(j + 1):
                Ji = Js[i]
                Mij = (Ji[0] * X[0] + Ji[1] * X[1] + Ji[2] * X[2] + Ji[3] * X[3]
                       + Ji[4] * X[4] + Ji[5] * X[5])
                M[i][j] = Mij
                M[j][i] = Mij
            M[j][j] += joints[j][8]
        # Newton-Euler in the space frame: f_k = G_k a_k + v_k x* G_k v_k
        V0 = V1 = V2 = V3 = V4 = V5 = 0.0
        a0 = a1 = a2 = a3 = a4 = 0.0
        a5 = float(self.gravity)
        fs = []
        for k in range(n):
            w0, w1, w2, u0, u1, u2 = Js[k]
            qdk = qd[k]
            # a_k += ad_{V_{k-1}} J_k qd_k
            a0 += (V1 * w2 - V2 * w1) * qdk
            a1 += (V2 * w0 - V0 * w2) * qdk
            a2 += (V0 * w1 - V1 * w0) * qdk
            a3 += (V1 * u2 - V2 * u1 + V4 * w2 - V5 * w1) * qdk
            a4 += (V2 * u0 - V0 * u2 + V5 * w0 - V3 * w2) * qdk
            a5 += (V0 * u1 - V1 * u0 + V3 * w1 - V4 * w0) * qdk
            V0 += w0 * qdk
            V1 += w1 * qdk
            V2 += w2 * qdk
            V3 += u0 * qdk
            V4 += u1 * qdk
            V5 += u2 * qdk
            m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz = bodies[k]
            # G a and G V (G (w; v) = (I_O w + h x v; m v - h x w))
            f0 = Ixx * a0 + Ixy * a1 + Ixz * a2 + hy * a5 - hz * a4
            f1 = Ixy * a0 + Iyy * a1 + Iyz * a2 + hz * a3 - hx * a5
            f2 = Ixz * a0 + Iyz * a1 + Izz * a2 + hx * a4 - hy * a3
            f3 = m * a3 - (hy * a2 - hz * a1)
            f4 = m * a4 - (hz * a0 - hx * a2)
            f5 = m * a5 - (hx * a1 - hy * a0)
            g0 = Ixx * V0 + Ixy * V1 + Ixz * V2 + hy * V5 - hz * V4
            g1 = Ixy * V0 + Iyy * V1 + Iyz * V2 + hz * V3 - hx * V5
            g2 = Ixz * V0 + Iyz * V1 + Izz * V2 + hx * V4 - hy * V3
            g3 = m * V3 - (hy * V2 - hz * V1)
            g4 = m * V4 - (hz * V0 - hx * V2)
            g5 = m * V5 - (hx * V1 - hy * V0)
            fs.append((
                f0 + V1 * g2 - V2 * g1 + V4 * g5 - V5 * g4,
                f1 + V2 * g0 - V0 * g2 + V5 * g3 - V3 * g5,
                f2 + V0 * g1 - V1 * g0 + V3 * g4 - V4 * g3,
                f3 + V1 * g5 - V2 * g4, f4 + V2 * g3 - V0 * g5, f5 + V0 * g4 - V1 * g3))
        h = [0.0] * n
        F0 = F1 = F2 = F3 = F4 = F5 = 0.0
        for k in range(n - 1, -1, -1):
            f = fs[k]
            F0 += f[0]
            F1 += f[1]
            F2 += f[2]
            F3 += f[3]
            F4 += f[4]
            F5 += f[5]
            J = Js[k]
            h[k] = J[0] * F0 + J[1] * F1 + J[2] * F2 + J[3] * F3 + J[4] * F4 + J[5] * F5
        return M, h

    # --- public API --------------------------------------------------------------------------
    def evaluate(self, q, qd) -> Tuple[np.ndarray, np.ndarray]:
        """
        Return (M (n, n) including armature, h (n,) = C(q, qd) qd + g(q)) in one pass.

        :param q: (n,) joint positions; qd: (n,) joint velocities
        """
        M, h = self.evaluate_lists([float(x) for x in np.ravel(q)],
                                   [float(x) for x in np.ravel(qd)])
        return np.array(M), np.array(h)

    def evaluate_vectorized(self, q, qd) -> Tuple[np.ndarray, np.ndarray]:
        """
        Return (M, h) like :meth:`evaluate`, computed with batched numpy (reference path).

        :param q: (n,) joint positions; qd: (n,) joint velocities
        """
        q = np.asarray(q, dtype=float)
        qd = np.asarray(qd, dtype=float)
        T, J = self._frames(q)
        G = self._body_inertias(T)
        M = self._mass_matrix(J, G)
        M[np.diag_indices_from(M)] += self.armature
        return M, self._rnea(J, G, qd, None, True)

    def mass_matrix(self, q) -> np.ndarray:
        """Return the (n, n) joint-space inertia matrix M(q) + diag(armature)."""
        return self.evaluate(q, np.zeros(self.dof))[0]

    def gravity_torque(self, q) -> np.ndarray:
        """Return g(q) (n,): the joint torques [N*m] that hold the arm still at q."""
        return self.evaluate(q, np.zeros(self.dof))[1]

    def bias_forces(self, q, qd) -> np.ndarray:
        """Return h(q, qd) = C(q, qd) qd + g(q) (n,) [N*m]."""
        return self.evaluate(q, qd)[1]

    def inverse_dynamics(self, q, qd, qdd, gravity: bool = True) -> np.ndarray:
        """Return tau = (M + diag(armature)) qdd + C qd (+ g) (n,) [N*m or N]."""
        q, qd, qdd = (np.asarray(x, dtype=float) for x in (q, qd, qdd))
        T, J = self._frames(q)
        G = self._body_inertias(T)
        return self._rnea(J, G, qd, qdd, gravity) + self.armature * qdd

    def forward_dynamics(self, q, qd, tau) -> np.ndarray:
        """Return qdd (n,) = (M + diag(armature))^-1 (tau - h(q, qd))."""
        M, h = self.evaluate(q, qd)
        return np.linalg.solve(M, np.asarray(tau, dtype=float) - h)

    def com_positions(self, q) -> np.ndarray:
        """Return (n, 3) centres of mass of the moving bodies in the base frame [m]."""
        T, _ = self._frames(np.asarray(q, dtype=float))
        return (T[:, :3, :3] @ self.coms[:, :, None])[:, :, 0] + T[:, :3, 3]

    def potential_energy(self, q) -> float:
        """Return the gravitational potential energy of the moving bodies [J] (z = 0 datum)."""
        return float(self.gravity * self.masses @ self.com_positions(q)[:, 2])

    def kinetic_energy(self, q, qd) -> float:
        """Return 0.5 qd^T (M + diag(armature)) qd [J]."""
        qd = np.asarray(qd, dtype=float)
        return float(0.5 * qd @ self.mass_matrix(q) @ qd)


# --- construction ----------------------------------------------------------------------------
def _origin(x) -> np.ndarray:
    return np.eye(4) if x is None else np.array(x, dtype=float)


def _joint_transform(joint, value: float) -> np.ndarray:
    """Return the (4, 4) motion of a URDF joint at a value (rad or m), in the joint frame."""
    T = np.eye(4)
    if joint.type in ('revolute', 'continuous'):
        axis = np.array(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), float)
        T[:3, :3] = exp_so3(axis / np.linalg.norm(axis), value)
    elif joint.type == 'prismatic':
        axis = np.array(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), float)
        T[:3, 3] = axis / np.linalg.norm(axis) * value
    return T


def _nominal_values(urdf, arm_joints, fixed_values: Dict[str, float]) -> Dict[str, float]:
    """Return the frozen value of every non-arm movable joint (mimic joints resolved)."""
    values = {}
    for j in urdf.robot.joints:
        if j.type in ('fixed', 'floating', 'planar') or j.name in arm_joints:
            continue
        if j.name in fixed_values:
            values[j.name] = float(fixed_values[j.name])
            continue
        lo = getattr(j.limit, 'lower', None) if j.limit is not None else None
        hi = getattr(j.limit, 'upper', None) if j.limit is not None else None
        v = 0.0
        if lo is not None and hi is not None and not (lo <= 0.0 <= hi):
            v = 0.5 * (lo + hi)
        values[j.name] = v
    for j in urdf.robot.joints:
        if j.mimic is not None and j.name not in arm_joints and j.name not in fixed_values:
            base = values.get(j.mimic.joint, 0.0)
            values[j.name] = float(j.mimic.multiplier or 1.0) * base + float(j.mimic.offset or 0.0)
    return values


def chain_dynamics_from_urdf(urdf_xml: str, base_frame: str, joint_names: Sequence[str],
                             S_list: np.ndarray, armature, fixed_values: Optional[dict] = None,
                             max_gyration_radius: float = 0.5,
                             gravity: float = GRAVITY) -> ChainDynamics:
    """
    Return the ChainDynamics of the arm joints of a URDF from its link inertials.

    :param urdf_xml: URDF text; base_frame: the link the arm is mounted on (fixed to the world)
    :param joint_names: the arm joints in chain order; S_list: their (6, n) screw axes
    :param armature: scalar or (n,) reflected rotor inertia [kg*m^2]
    :param fixed_values: values of non-arm joints to freeze at (others: 0 or mid-range)
    :raises RobotModelError: no inertial data on any moving link, or broken joints
    """
    urdf = load_urdf(urdf_xml)
    arm = list(joint_names)
    values = _nominal_values(urdf, set(arm), fixed_values or {})
    children = {}
    for j in urdf.robot.joints:
        children.setdefault(j.parent, []).append(j)
    links = {link.name: link for link in urdf.robot.links}
    n = len(arm)
    parts = [[] for _ in range(n)]
    notes = []
    seen = set()
    # Walk the tree from the base at q = 0; body index = last arm joint on the path.
    stack = [(base_frame, np.eye(4), -1)]
    while stack:
        name, T, body = stack.pop()
        link = links.get(name)
        if body >= 0 and link is not None and link.inertial is not None:
            inertial = link.inertial
            mass = float(inertial.mass or 0.0)
            To = T @ _origin(inertial.origin)
            I_local = np.zeros((3, 3)) if inertial.inertia is None else np.array(
                inertial.inertia, float)
            if mass > 0.0 and np.sqrt(max(np.trace(I_local), 0.0) / (2.0 * mass)) \
                    > max_gyration_radius:
                notes.append(f"link '{name}': placeholder inertia {np.diag(I_local).tolist()} "
                             f'on {mass} kg replaced by a point mass')
                I_local = np.zeros((3, 3))
            R = To[:3, :3]
            parts[body].append((mass, To[:3, 3], R @ I_local @ R.T))
        seen.add(name)
        for j in children.get(name, ()):
            if j.child in seen:
                continue
            Tj = T @ _origin(j.origin)
            child_body = body
            if j.name in arm:
                child_body = arm.index(j.name)
                if child_body <= body:
                    raise RobotModelError(f"arm joint '{j.name}' is out of chain order")
            else:
                Tj = Tj @ _joint_transform(j, values.get(j.name, 0.0))
            stack.append((j.child, Tj, child_body))
    missing = [arm[k] for k in range(n) if not parts[k]]
    if len(missing) == n:
        raise RobotModelError('the URDF has no inertial data on the links the arm moves')
    masses, coms, inertias = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3, 3))
    for k in range(n):
        if parts[k]:
            masses[k], coms[k], inertias[k] = lump_inertias(parts[k])
        else:
            notes.append(f"joint '{arm[k]}' carries no inertial link (massless body)")
    return ChainDynamics(S_list=np.array(S_list, float), masses=masses, coms=coms,
                         inertias=inertias, armature=np.broadcast_to(
                             np.asarray(armature, float), (n,)).copy(),
                         gravity=gravity, source='urdf', notes=tuple(notes))


def _axis_point(S: np.ndarray) -> Optional[np.ndarray]:
    """Return the point of a revolute screw axis closest to the origin (None if prismatic)."""
    w, v = S[:3], S[3:]
    if np.linalg.norm(w) < 1e-9:
        return None
    return np.cross(w, v) / (w @ w)


def point_mass_dynamics(S_list: np.ndarray, M: np.ndarray, armature, link_mass: float = 0.1,
                        link_inertia: float = 1e-4, gravity: float = GRAVITY) -> ChainDynamics:
    """
    Return the fallback ChainDynamics: one point mass per body (see the module docstring).

    :param S_list: (6, n) screw axes; M: (4, 4) end-effector pose at q = 0
    :param link_mass: [kg] per body; link_inertia: isotropic [kg*m^2] per body
    """
    S_list = np.array(S_list, float)
    n = S_list.shape[1]
    points = []
    last = np.zeros(3)
    for k in range(n):
        p = _axis_point(S_list[:, k])
        last = last if p is None else p
        points.append(last)
    points.append(np.array(M[:3, 3], float))
    coms = np.array([0.5 * (points[k] + points[k + 1]) for k in range(n)])
    note = (f'no URDF inertials: point masses of {link_mass} kg mid-way between joint axes, '
            f'isotropic inertia {link_inertia} kg*m^2')
    return ChainDynamics(S_list=S_list, masses=np.full(n, float(link_mass)), coms=coms,
                         inertias=np.broadcast_to(link_inertia * _I3, (n, 3, 3)).copy(),
                         armature=np.broadcast_to(np.asarray(armature, float), (n,)).copy(),
                         gravity=gravity, source='point-mass approximation', notes=(note,))


def dynamics_for_model(model, armature, fixed_values: Optional[dict] = None,
                       link_mass: float = 0.1, link_inertia: float = 1e-4) -> ChainDynamics:
    """
    Return the ChainDynamics of a RobotModel: from its URDF inertials, else point masses.

    :param model: a px100_control RobotModel (joint_names, S_list, M, urdf_xml, base_frame)
    """
    if model.urdf_xml:
        try:
            return chain_dynamics_from_urdf(model.urdf_xml, model.base_frame, model.joint_names,
                                            model.S_list, armature, fixed_values)
        except RobotModelError as exc:
            fallback = point_mass_dynamics(model.S_list, model.M, armature, link_mass,
                                           link_inertia)
            return ChainDynamics(S_list=fallback.S_list, masses=fallback.masses,
                                 coms=fallback.coms, inertias=fallback.inertias,
                                 armature=fallback.armature, source=fallback.source,
                                 notes=(f'URDF not usable for dynamics ({exc})',)
                                 + fallback.notes)
    return point_mass_dynamics(model.S_list, model.M, armature, link_mass, link_inertia)
