"""
Seed 000's own PincherX-100 model (DH, millimetres), with the seed's function names.

The seed works in mm with L1 = 89.54, Lm = 35, L2 = L3 = 100, L4 = 109 and DH joint values
q_dh = q_actuator + q_nom, q_nom = [0, -atan2(L2, Lm), atan2(L2, Lm), 0]. Its equations::

    px = C1 (Lr C2 + L3 C23 + L4 C234),  py = S1 (...),  pz = L1 - (Lr S2 + L3 S23 + L4 S234)
    psi = q2 + q3 + q4,  Lr = hypot(Lm, L2)

The module-level functions use the seed's parameters, so the seed's two ``main()`` scripts run
unchanged against them (``convert_param_op_to_qdh``, ``q_dh_to_q_actuator``,
``q_actuator_to_q_dh``, ``matrice_t_h``, ``jacobienne``/``jacobian``, ``coast_function``,
``iterative_algorithm``, ``q_nom``); ``SeedPx100`` holds the same model for other parameters
(e.g. ``SeedPx100.real()`` is the px100 in metres, to cross-check the URDF model).

Note: the seed's listing has ``tolerance=1e-11`` but its printed results (35 and 47 iterations)
are reproduced exactly with ``tolerance=1e-7``; the default here follows the listing.
"""
import math
from typing import Optional

import numpy as np


class SeedPx100:
    """
    The seed 000 model for given link lengths (any consistent unit).

    :param L1: base -> shoulder height; Lm, L2: shoulder -> elbow offsets (forward, up);
        L3: elbow -> wrist; L4: wrist -> end effector
    """

    def __init__(self, L1: float = 89.54, Lm: float = 35.0, L2: float = 100.0,
                 L3: float = 100.0, L4: float = 109.0, verbose: bool = False):
        self.L1, self.Lm, self.L2, self.L3, self.L4 = L1, Lm, L2, L3, L4
        self.Lr = math.hypot(Lm, L2)
        self.q_nom = np.array([0.0, -math.atan2(L2, Lm), math.atan2(L2, Lm), 0.0])
        self.verbose = verbose

    @classmethod
    def real(cls, verbose: bool = False) -> 'SeedPx100':
        """Return the model with the real px100 lengths in metres (URDF, to ee_gripper_link)."""
        return cls(L1=0.0931, Lm=0.035, L2=0.1, L3=0.1, L4=0.113575, verbose=verbose)

    def _print(self, *args) -> None:
        if self.verbose:
            print(*args)

    # seed V.2
    def q_dh_to_q_actuator(self, q_dh) -> np.ndarray:
        """Return the actuator command for DH joint values (q_dh - q_nom)."""
        return np.asarray(q_dh, dtype=float) - self.q_nom

    def q_actuator_to_q_dh(self, q_actuator) -> np.ndarray:
        """Return the DH joint values of an actuator command (q_actuator + q_nom)."""
        return np.asarray(q_actuator, dtype=float) + self.q_nom

    # seed V.3
    def matrice_t_h(self, q_dh) -> np.ndarray:
        """Return the (4, 4) end-effector pose of DH joint values (seed section V.3)."""
        Lr, L1, L3, L4 = self.Lr, self.L1, self.L3, self.L4
        C1, S1 = math.cos(q_dh[0]), math.sin(q_dh[0])
        C2, S2 = math.cos(q_dh[1]), math.sin(q_dh[1])
        C23, S23 = math.cos(q_dh[1] + q_dh[2]), math.sin(q_dh[1] + q_dh[2])
        a = q_dh[1] + q_dh[2] + q_dh[3]
        C234, S234 = math.cos(a), math.sin(a)
        r = Lr * C2 + L3 * C23 + L4 * C234
        return np.array([[C1 * C234, -C1 * S234, -S1, C1 * r],
                         [S1 * C234, -S1 * S234, C1, S1 * r],
                         [-S234, -C234, 0.0, -(Lr * S2 + L3 * S23 + L4 * S234) + L1],
                         [0.0, 0.0, 0.0, 1.0]])

    def position(self, q_dh) -> np.ndarray:
        """Return the end-effector position, shape (3,), of DH joint values."""
        return self.matrice_t_h(q_dh)[:3, 3]

    # seed V.4
    def all_solutions(self, param_op) -> np.ndarray:
        """Return every (k, 4) DH solution of [px, py, pz, psi] (seed eq. 2, all branches)."""
        px, py, pz, phi = (float(v) for v in param_op)
        L1, L3, L4, Lr = self.L1, self.L3, self.L4, self.Lr
        a = math.atan2(py, px)
        sols = []
        for j in (a, a + math.pi, a - math.pi):
            U = px * math.cos(j) + py * math.sin(j) - L4 * math.cos(phi)
            V = L1 - pz - L4 * math.sin(phi)
            A, B = 2 * Lr * U, 2 * Lr * V
            W = U ** 2 + V ** 2 + Lr ** 2 - L3 ** 2
            value = A ** 2 + B ** 2 - W ** 2
            if value >= 0:
                root = math.sqrt(value)
                for eps in (-1, 1):
                    q2 = math.atan2(B * W - eps * A * root, A * W + eps * B * root)
                    S2, C2 = math.sin(q2), math.cos(q2)
                    q3 = math.atan2(-U * S2 + V * C2, U * C2 + V * S2 - Lr)
                    sols.append([j, q2, q3, phi - q2 - q3])
        return np.array(sols, dtype=float).reshape(-1, 4)

    @staticmethod
    def coast_function(qnom, q) -> np.ndarray:
        """Return the row of q (k, 4) closest to qnom (Euclidean; seed section V.5)."""
        q = np.asarray(q, dtype=float)
        distances = np.linalg.norm(q - np.asarray(qnom, dtype=float), axis=1)
        return np.array(q[int(np.argmin(distances))])

    def convert_param_op_to_qdh(self, param_op) -> np.ndarray:
        """
        Return the DH solution of [px, py, pz, psi] closest to q_nom (seed section V.4).

        An empty (0, 4) array when there is none, as in the seed.
        """
        sols = self.all_solutions(param_op)
        if sols.size > 0:
            best = self.coast_function(self.q_nom, sols)
            self._print(f'The best solution for q vector is: {best}')
            return best
        self._print('There is no solution for this position')
        return np.empty((0, 4))

    # seed V.7
    def jacobienne(self, q) -> np.ndarray:
        """Return the (3, 4) position Jacobian d(px, py, pz)/dq_dh (seed section V.7)."""
        Lr, L3, L4 = self.Lr, self.L3, self.L4
        C1, S1 = math.cos(q[0]), math.sin(q[0])
        C2, S2 = math.cos(q[1]), math.sin(q[1])
        C23, S23 = math.cos(q[1] + q[2]), math.sin(q[1] + q[2])
        a = q[1] + q[2] + q[3]
        C234, S234 = math.cos(a), math.sin(a)
        r = Lr * C2 + L3 * C23 + L4 * C234
        h = Lr * S2 + L3 * S23 + L4 * S234
        return np.array([[-r * S1, -h * C1, -(L3 * S23 + L4 * S234) * C1, -L4 * S234 * C1],
                         [r * C1, -h * S1, -(L3 * S23 + L4 * S234) * S1, -L4 * S234 * S1],
                         [0.0, -r, -L3 * C23 - L4 * C234, -L4 * C234]])

    # seed V.8
    def iterative_algorithm(self, q_initial, x_but, tolerance: float = 1e-11,
                            max_iterations: int = 100, qnom=None, alpha: float = 0.3,
                            beta: float = 0.3, return_info: bool = False):
        """
        Seed eq. (3): q+ = q + alpha J# (x_but - x) + beta (I - J# J)(qnom - q).

        Stops when |q_k - q_k+1| < tolerance. Returns q (DH) if the final position and pitch
        are geometrically reachable (seed's D >= 0 test) else None; with ``return_info`` a
        tuple (q or None, {'iterations', 'position', 'psi', 'converged', 'history'}), history
        the (k + 1, 4) DH joint values from q_initial to the last iterate.
        """
        x_but = np.asarray(x_but, dtype=float)[:3]
        qk0 = np.asarray(q_initial, dtype=float)
        x_courant = self.position(qk0)
        J = self.jacobienne(qk0)
        self._print('The Jacobian has the correct shape.' if J.shape == (3, 4) else
                    f'The Jacobian does not have the correct shape, current shape: {J.shape}')
        eye = np.eye(len(qk0))
        qk1 = qk0
        history = [qk0]
        iterations, converged = max_iterations, False
        for i in range(max_iterations):
            J_inverse = np.linalg.pinv(J)
            term1 = alpha * J_inverse @ (x_but - x_courant)
            term2 = beta * (eye - J_inverse @ J) @ (
                (np.asarray(qnom, float) - qk0) if qnom is not None else np.zeros_like(qk0))
            qk1 = qk0 + term1 + term2
            history.append(qk1)
            if np.linalg.norm(qk0 - qk1) < tolerance:
                self._print(f'Stop criterion reached after {i + 1} iterations.')
                iterations, converged = i + 1, True
                break
            qk0 = qk1
            J = self.jacobienne(qk0)
            x_courant = self.position(qk0)
        phi = float(np.sum(qk1[1:]))
        px, py, pz = x_but
        L1, L3, L4, Lr = self.L1, self.L3, self.L4, self.Lr
        U = px * math.cos(qk1[0]) + py * math.sin(qk1[0]) - L4 * math.cos(phi)
        V = L1 - pz - L4 * math.sin(phi)
        A, B = 2 * Lr * U, 2 * Lr * V
        W = U ** 2 + V ** 2 + Lr ** 2 - L3 ** 2
        D = A ** 2 + B ** 2 - W ** 2
        pos = self.position(qk1)
        info = {'iterations': iterations, 'position': pos, 'psi': phi, 'converged': converged,
                'history': np.array(history)}
        if D >= 0:
            self._print(f'The best coordination is: {qk1} \t for the next position {x_but}\n'
                        f'Which corresponds in real parameters to: {np.append(pos, phi)}')
            result = qk1
        else:
            self._print('No valid solution was found.')
            result = None
        return (result, info) if return_info else result


#: the seed's own model (mm); the module-level functions below use it
SEED = SeedPx100()
L1, Lm, L2, L3, L4, Lr = SEED.L1, SEED.Lm, SEED.L2, SEED.L3, SEED.L4, SEED.Lr
q_nom = SEED.q_nom


def q_dh_to_q_actuator(q_dh) -> np.ndarray:
    """Return the actuator command of DH joint values (seed V.2)."""
    return SEED.q_dh_to_q_actuator(q_dh)


def q_actuator_to_q_dh(q_actuator) -> np.ndarray:
    """Return the DH joint values of an actuator command (seed V.2)."""
    return SEED.q_actuator_to_q_dh(q_actuator)


def matrice_t_h(q_dh) -> np.ndarray:
    """Return the (4, 4) end-effector pose [mm] of DH joint values (seed V.3)."""
    return SEED.matrice_t_h(q_dh)


def convert_param_op_to_qdh(param_op) -> np.ndarray:
    """Return the DH solution of [px, py, pz, psi] [mm, rad] closest to q_nom (seed V.4)."""
    return SEED.convert_param_op_to_qdh(param_op)


def coast_function(qnom, q) -> np.ndarray:
    """Return the row of q closest to qnom (seed V.5)."""
    return SeedPx100.coast_function(qnom, q)


def jacobienne(q) -> np.ndarray:
    """Return the (3, 4) position Jacobian [mm/rad] at DH joint values (seed V.7)."""
    return SEED.jacobienne(q)


jacobian = jacobienne   # the name seed V.8 calls


def iterative_algorithm(q_initial, x_but, tolerance: float = 1e-11, max_iterations: int = 100,
                        qnom: Optional[np.ndarray] = None):
    """Run the seed's iterative algorithm (V.8) on the seed model; q (DH) or None."""
    return SEED.iterative_algorithm(q_initial, x_but, tolerance=tolerance,
                                    max_iterations=max_iterations, qnom=qnom)
