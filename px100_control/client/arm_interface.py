"""
InterbotixArmXSInterface: the arm part of the Interbotix-compatible client (``bot.arm``).

Same names, arguments, defaults and return shapes as ``interbotix_xs_modules.xs_robot.arm``
(humble = jazzy), SI units (rad, m, s). :mod:`px100_control.client.arm` exports it with
InterbotixManipulatorXS, as ``interbotix_xs_modules.xs_robot.arm`` does.

Kept from Interbotix: sticky moving_time / accel_time, yaw = atan2(y, x) on arms with fewer than
6 joints, home (zeros) and sleep poses without a limit check, commanded state (joint_commands,
T_sb) kept apart from measured state, the (theta_list, success) / bool / None return shapes,
IK tolerances eomg = ev = 1e-3, straight-line ``set_ee_cartesian_trajectory`` with its checks.

Where Interbotix is broken, this does better (documented deviations):

- IK goes to ``ik_service`` (closed form + fallbacks, every branch, solution closest to the
  measured state): it succeeds on every reachable target instead of failing away from its three
  seeds (manipulators#245). ``custom_guess`` is accepted but cannot steer the service; the
  returned solution is then the one closest to the measured joints.
- The velocity check uses the moving_time / accel_time of the command being checked, not the
  previous one (toolboxes#89), and the trapezoid's peak speed ``d / (moving_time -
  accel_time)``, which is what the joints really reach; limits are checked on the exact values
  (Interbotix truncates to 3 decimals). A refused command logs why (Interbotix is silent).
- ``blocking=True`` waits for trajectory_server's SUCCEEDED (not a blind sleep) with a deadline
  (moving_time + margin); a setter whose move fails (aborted, driver gone, timeout) logs the
  reason and returns False (``go_to_*_pose`` log it and return None).
- ``get_joint_velocities`` / ``get_joint_efforts`` return real values (rad/s, N*m).
- Refused calls: bad arguments are named in the message (``x is NaN``, ``T_sd[0][3] is inf``,
  ``moving_time is -1.0``), a target far beyond reach hints at the units (``given in mm? the
  API takes metres``); every refused setter returns False (``(theta, False)`` for the ee-pose
  setters, None for home/sleep) without moving; ``last_error`` holds the reason of the last
  refused or failed call and is cleared by every call that succeeds. ``moving_time=0`` is the
  servos' "no profile": the move runs as fast as the joint velocity limits allow.
- ``set_ee_cartesian_trajectory`` plans through ``compute_cartesian_path`` and executes the
  planned waypoints as one trajectory; ``wp_moving_time`` / ``wp_accel_time`` (servo profile
  per waypoint in Interbotix) are accepted and unused; ``moving_time`` < ``wp_period`` returns
  False instead of raising NameError.

px100_control extensions (no Interbotix equivalent): ``wait_for_last_goal``,
``last_goal_status``, ``last_error``, and ``set_ee_waypoints`` (straight end-effector lines
through waypoints with a maximum joint step between points).
"""
import math
from typing import Any, List, Optional, Sequence, Tuple

import numpy as np

from px100_control.client.core import feasible_duration, InterbotixRobotXSCore, MIN_MOVE_TIME
from px100_control.client.robot import InterbotixException
from px100_control.control.trajectory import shortest_move_time
from px100_control.errors import InvalidInputError
from px100_control.kinematics.cartesian import CartesianPathError, plan_ee_waypoints
from px100_control.kinematics.kernels import wrap
from px100_control.kinematics.rotations import euler_sxyz_to_matrix, matrix_to_euler_sxyz
from px100_control.kinematics.se3 import inv_transform, pose_error

#: simulated seconds trajectory_server may take after a move to settle (its goal_time_tolerance:
#: 1 s by default, 2 s on the nodes the client starts itself)
SETTLE_ALLOWANCE = 2.0
#: IK acceptance tolerances of Interbotix (modern_robotics eomg, ev): [rad], [m]
EOMG = 1e-3
EV = 1e-3


class MrDescription:
    """Modern Robotics description of an arm: ``Slist`` (6, n) and ``M`` (4, 4) [m]."""

    def __init__(self, Slist: np.ndarray, M: np.ndarray):
        self.Slist = np.array(Slist, dtype=float)
        self.M = np.array(M, dtype=float)


class InterbotixArmXSInterface:
    """
    The arm joint group of an X-Series robot.

    :param core: the robot's InterbotixRobotXSCore
    :param robot_model: model name ('px100')
    :param group_name: joint group ('arm')
    :param moving_time: default duration of a move [s] (sticky: every explicit value becomes
        the new default)
    :param accel_time: default ramp time of a move [s] (<= moving_time / 2)
    :param iterative_update_fk: recompute the commanded pose T_sb after every joint command
    """

    def __init__(self, core: InterbotixRobotXSCore, robot_model: str, group_name: str = 'arm',
                 moving_time: float = 2.0, accel_time: float = 0.3,
                 iterative_update_fk: bool = True) -> None:
        self.core = core
        self.last_error = ''
        self.robot_model = robot_model
        self.group_name = group_name
        self.iterative_update_fk = iterative_update_fk
        self.model = core.model
        #: distance [m] from the base to the end effector at the home pose (about the reach)
        self._reach = float(np.linalg.norm(np.asarray(self.model.M, dtype=float)[:3, 3]))
        core._group_name = group_name
        self.robot_des = MrDescription(self.model.S_list, self.model.M)
        self.group_info = self.core.robot_get_robot_info('group', group_name)
        if self.group_info.num_joints != self.robot_des.Slist.shape[1]:
            message = (f"Number of joints in group '{group_name}' does not match Modern Robotics "
                       f"description for arm model '{robot_model}' "
                       f'({self.group_info.num_joints} != {self.robot_des.Slist.shape[1]}).')
            self.core.get_node().logfatal(message)
            raise InterbotixException(message)
        if self.group_info.profile_type != 'time':
            self._warn(f"Group '{group_name}' profile_type not set to 'time'.")
        if self.group_info.mode != 'position':
            self._warn(
                f"Group '{group_name}' operating mode not set to 'position'.")
        n = self.group_info.num_joints
        self.joint_names: List[str] = list(self.group_info.joint_names)
        self.initial_guesses = [[0.0] * n for _ in range(3)]
        self.initial_guesses[1][0] = math.radians(-120)
        self.initial_guesses[2][0] = math.radians(120)
        self.rev = 2 * math.pi
        self.info_index_map = {name: i for i, name in enumerate(self.joint_names)}
        self.joint_commands: List[float] = self.get_joint_positions()
        self.T_sb = self.model.fk(self.joint_commands)
        self._last_goal = None
        self.moving_time = None
        self.accel_time = None
        self.set_trajectory_time(float(moving_time), float(accel_time))
        self.core.get_node().loginfo(
            f'\n\tArm Group Name: {self.group_name}\n\tMoving Time: {self.moving_time:.2f} '
            f'seconds\n\tAcceleration Time: {self.accel_time:.2f} seconds\n\tDrive Mode: '
            'Time-Based-Profile')
        self.core.get_node().loginfo('Initialized InterbotixArmXSInterface!')

    def _warn(self, message: str) -> None:
        """Log a warning and remember it as ``last_error``."""
        self.last_error = message
        self.core.get_node().logwarn(message)

    def _note(self, message: str) -> None:
        """Log a warning about a call that goes ahead (``last_error`` is not touched)."""
        self.core.get_node().logwarn(message)

    def _begin(self) -> None:
        """Start a command: ``last_error`` describes only the latest call."""
        self.last_error = ''

    def _timing_problem(self, moving_time, accel_time) -> Optional[str]:
        """Return why moving_time / accel_time [s] cannot be used (None: fine or not given)."""
        for name, value in (('moving_time', moving_time), ('accel_time', accel_time)):
            if value is None:
                continue
            problem = _number_problem(name, value)
            if problem is None and float(value) < 0.0:
                problem = f'{name} is {float(value)!r} (must be >= 0 s)'
            if problem is not None:
                return problem
        return None

    def _reach_problem(self, p) -> Optional[str]:
        """Return a units hint when the point p [m] lies far beyond the arm's reach."""
        dist = float(np.linalg.norm(np.asarray(p, dtype=float)))
        ratio = dist / self._reach
        if ratio < 5.0:
            return None
        unit = 'mm' if ratio >= 30.0 else 'cm'
        return (f'the target is {dist:.3g} m from the base, {ratio:.0f}x the reach of '
                f'{self.robot_model} (~{self._reach:.2f} m): given in {unit}? the API takes '
                'metres')

    def _error(self, message: str) -> None:
        """Log an error and remember it as ``last_error`` (px100_control extension)."""
        self.last_error = message
        self.core.get_node().logerror(message)

    # --------------------------------------------------------------- timing
    def set_trajectory_time(self, moving_time: Optional[float] = None,
                            accel_time: Optional[float] = None) -> None:
        """
        Set the default (sticky) moving and acceleration times [s].

        Written to the group's Profile_Velocity / Profile_Acceleration registers [ms], as the
        real driver's time-based profile does. moving_time 0 means no profile (as fast as the
        velocity limits allow). Invalid values (not numbers, NaN, inf, negative) are refused
        with a warning naming them, and the previous values are kept.
        """
        problem = self._timing_problem(moving_time, accel_time)
        if problem is not None:
            self._warn(f'Trajectory time refused: {problem}; keeping moving_time '
                       f'{self.moving_time} s, accel_time {self.accel_time} s.')
            return
        if moving_time is not None:
            mt = float(moving_time)
            if mt != self.moving_time:
                self.moving_time = mt
                self.core.robot_set_motor_registers('group', self.group_name, 'Profile_Velocity',
                                                    int(mt * 1000))
        if accel_time is not None:
            at = float(accel_time)
            if at != self.accel_time:
                self.accel_time = at
                self.core.robot_set_motor_registers('group', self.group_name,
                                                    'Profile_Acceleration', int(at * 1000))

    def _times(self, moving_time, accel_time) -> Tuple[float, float]:
        """Return the (moving_time, accel_time) a command will use (new value or sticky)."""
        mt = _finite(moving_time) if moving_time is not None else self.moving_time
        at = _finite(accel_time) if accel_time is not None else self.accel_time
        if mt is None or mt < 0.0:
            mt = self.moving_time
        if at is None or at < 0.0:
            at = self.accel_time
        return mt, min(at, mt / 2.0)

    # --------------------------------------------------------------- checks
    def _limit_problem(self, positions, moving_time: float, accel_time: float,
                       names: Optional[Sequence[str]] = None) -> Optional[str]:
        """Return why ``positions`` may not be commanded (limits, speed), or None."""
        names = list(self.joint_names if names is None else names)
        try:
            q = np.asarray(positions, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            return f'joint positions are not numbers: {positions!r}'
        if q.size != len(names):
            return (f'{q.size} joint positions given, group {self.group_name!r} has '
                    f'{len(names)} joints {names}')
        for name, value in zip(names, q):
            if not math.isfinite(value):
                return f"joint '{name}' is {value}"
        info = self.group_info
        cruise = moving_time - min(accel_time, moving_time / 2.0)
        for name, value in zip(names, q):
            i = self.info_index_map[name]
            lo, hi = info.joint_lower_limits[i], info.joint_upper_limits[i]
            if not (lo - 1e-9 <= value <= hi + 1e-9):
                return (f"joint '{name}' = {value:.4f} rad outside its limits "
                        f'[{lo:.4f}, {hi:.4f}]')
            if cruise <= 0.0:
                continue  # moving_time 0: as fast as the limits allow (no speed to refuse)
            speed = abs(value - self.joint_commands[i]) / cruise
            vmax = info.joint_velocity_limits[i]
            if speed > vmax + 1e-9:
                return (f"joint '{name}' would move {abs(value - self.joint_commands[i]):.3f} rad"
                        f' at a peak of {speed:.2f} rad/s > its limit {vmax:.2f} rad/s with '
                        f'moving_time {moving_time:.2f} s, accel_time {accel_time:.2f} s')
        return None

    def check_joint_limits(self, positions: Sequence[float], moving_time: Optional[float] = None,
                           accel_time: Optional[float] = None) -> bool:
        """
        Return True if ``positions`` [rad] are within the position and velocity limits.

        The speed is checked against the moving/accel time the command will use (the given
        ones, else the sticky defaults).
        """
        mt, at = self._times(moving_time, accel_time)
        return self._limit_problem(positions, mt, at) is None

    def check_single_joint_limit(self, joint_name: str, position: float,
                                 moving_time: Optional[float] = None,
                                 accel_time: Optional[float] = None) -> bool:
        """Return True if one joint's ``position`` [rad] is within its position/speed limits."""
        if joint_name not in self.info_index_map:
            return False
        mt, at = self._times(moving_time, accel_time)
        return self._limit_problem([position], mt, at, [joint_name]) is None

    _check_joint_limits = check_joint_limits
    _check_single_joint_limit = check_single_joint_limit

    # ----------------------------------------------------------- publishing
    def _deadline(self, duration: float) -> float:
        """
        Return the wall-time budget [s] of a move lasting ``duration`` simulated seconds.

        trajectory_server reports within duration + its settling allowance (goal_time_tolerance)
        of simulated time; the budget adds 25 % and 2 s of wall time for a loaded machine. A
        faster simulation (real_time_factor > 1) gets the budget of real time: on a loaded
        machine it may run slower than asked.
        """
        return 1.25 * (duration + SETTLE_ALLOWANCE) / min(self.core.real_time_factor, 1.0) + 2.0

    def publish_positions(self, positions: Sequence[float], moving_time: Optional[float] = None,
                          accel_time: Optional[float] = None, blocking: bool = True) -> bool:
        """
        Send the group to ``positions`` [rad] through trajectory_server (no limit check).

        :return: True if the goal was sent (non-blocking) or SUCCEEDED (blocking); False when
            refused (bad timing or positions: reason logged, nothing moves) or failed
        """
        problem = self._timing_problem(moving_time, accel_time)
        if problem is None:
            try:
                target = [float(p) for p in positions]
            except (TypeError, ValueError):
                problem = f'joint positions are not numbers: {positions!r}'
            else:
                problem = next((f"joint '{n}' is {v}" for n, v in zip(self.joint_names, target)
                                if not math.isfinite(v)), None)
                if problem is None and len(target) != len(self.joint_names):
                    problem = (f'{len(target)} joint positions given, group '
                               f'{self.group_name!r} has {len(self.joint_names)} joints')
        if problem is not None:
            self._warn(f'Move refused: {problem}.')
            return False
        self.set_trajectory_time(moving_time, accel_time)
        mt, at = self._times(None, None)
        duration, at = self._feasible_move(target, mt, at)
        if mt <= 0.0:
            self.core.get_node().logdebug(
                f'moving_time 0: the move takes {duration:.2f} s at the joint velocity limits.')
        elif duration > mt:
            self._note(
                f'A {mt:.2f} s move there exceeds the joint velocity limits: this one takes '
                f'{duration:.2f} s (the servos would cap the speed the same way).')
        self.joint_commands = target
        ok = self._execute(self.joint_names, [target], [duration], at, blocking, duration)
        if not ok:
            self._capture_after_failure()
        elif self.iterative_update_fk:
            self._update_Tsb()
        return ok

    _publish_commands = publish_positions

    def _feasible_move(self, target, moving_time: float, accel_time: float):
        """
        Return (duration, accel_time) [s] of a move to ``target`` that keeps the limits.

        The duration is moving_time, or the shortest whose trapezoid peak respects the limits:
        Interbotix sends home/sleep (and publish_positions) unchecked and the servos cap the
        speed; trajectory_server refuses a too-fast goal, so such a move is stretched instead.
        While the arm moves, trajectory_server blends its present velocity into the move: the
        duration is then searched on the server's own plan (:func:`shortest_move_time`) from
        the farther of the commanded and measured positions at the measured velocity, with
        10 % to spare for the motion since the joint_states the client read; a no-profile
        move (accel_time 0: a velocity step on top of the present one) gets MIN_MOVE_TIME / 2
        of ramp.
        """
        q = np.asarray(target, dtype=float)
        commanded = np.asarray(self.joint_commands, dtype=float)
        d = np.abs(q - commanded)
        vmax = np.asarray(self.group_info.joint_velocity_limits, dtype=float)
        if self.core.joint_state_age() >= self.core.stale_timeout:
            return feasible_duration(d, vmax, moving_time, accel_time), accel_time
        here = np.asarray(self.get_joint_positions(), dtype=float)
        d = np.maximum(d, np.abs(q - here))
        duration = feasible_duration(d, vmax, moving_time, accel_time)
        # (the server blends its setpoint's velocity, never above the limits)
        velocity = np.clip(self.get_joint_velocities(), -vmax, vmax)
        if not np.any(np.abs(velocity) > 1e-3):
            return duration, accel_time
        start = np.where(d == np.abs(q - commanded), commanded, here)
        at = accel_time if accel_time > 0.0 else MIN_MOVE_TIME / 2.0
        try:
            fast = shortest_move_time(start, q, vmax, at, v_start=velocity, at_least=duration)
        except InvalidInputError:       # the server will say why it refuses the goal
            return duration, accel_time
        return (duration if fast <= duration else 1.1 * fast), at

    def _execute(self, names, points, times, accel_time, blocking, duration) -> bool:
        for check in list(self.core._before_arm_move):
            warning = check()
            if warning:
                self._note(warning)
        try:
            pending = self.core.send_trajectory(names, points, times, accel_time)
        except InterbotixException as exc:
            self._error(f'Move not sent: {exc}')
            return False
        self._last_goal = pending
        if not blocking:
            return True
        ok, reason = self.core.wait_for_goal(pending, self._deadline(duration))
        if not ok:
            self._error(f'Move failed: {reason}')
        return ok

    def wait_for_last_goal(self, timeout: Optional[float] = None) -> bool:
        """
        Wait for the last (non-blocking) move to end; return True if it SUCCEEDED.

        px100_control extension (Interbotix has no way to wait for a non-blocking move).
        :param timeout: [s] wall; default moving_time + margin
        """
        if self._last_goal is None:
            return True
        ok, reason = self.core.wait_for_goal(
            self._last_goal, self._deadline(self.moving_time) if timeout is None else timeout)
        if not ok:
            self._error(f'Move failed: {reason}')
        return ok

    def last_goal_status(self) -> str:
        """Return the status name of the last move ('NONE', 'EXECUTING', 'SUCCEEDED', ...)."""
        return 'NONE' if self._last_goal is None else self.core.goal_status(self._last_goal)

    # ---------------------------------------------------------- joint space
    def set_joint_positions(self, joint_positions: Sequence[float],
                            moving_time: Optional[float] = None,
                            accel_time: Optional[float] = None, blocking: bool = True) -> bool:
        """
        Command positions [rad] to the arm joints.

        :return: True if commanded (and, when blocking, reached); False if refused (limits,
            speed: reason logged) or the move failed
        """
        self._begin()
        problem = self._timing_problem(moving_time, accel_time)
        mt, at = self._times(moving_time, accel_time)
        problem = problem or self._limit_problem(joint_positions, mt, at)
        if problem is not None:
            self._warn(f'Joint positions refused: {problem}.')
            return False
        return self.publish_positions(list(np.asarray(joint_positions, dtype=float)),
                                      moving_time, accel_time, blocking)

    def go_to_home_pose(self, moving_time: Optional[float] = None,
                        accel_time: Optional[float] = None, blocking: bool = True) -> None:
        """Command the arm to its Home pose (all zeros); no limit check, as in Interbotix."""
        self._begin()
        self.publish_positions([0.0] * self.group_info.num_joints, moving_time, accel_time,
                               blocking)

    def go_to_sleep_pose(self, moving_time: Optional[float] = None,
                         accel_time: Optional[float] = None, blocking: bool = True) -> None:
        """Command the arm to its Sleep pose; no limit check, as in Interbotix."""
        self._begin()
        self.publish_positions(list(self.group_info.joint_sleep_positions), moving_time,
                               accel_time, blocking)

    def set_single_joint_position(self, joint_name: str, position: float,
                                  moving_time: Optional[float] = None,
                                  accel_time: Optional[float] = None,
                                  blocking: bool = True) -> bool:
        """
        Command one joint to ``position`` [rad] (the other joints hold).

        A given moving_time / accel_time becomes the default of the whole group (as in
        Interbotix). :return: True if commanded (and reached when blocking), else False
        """
        self._begin()
        if joint_name not in self.info_index_map:
            self._warn(
                f"Joint '{joint_name}' is not in group '{self.group_name}' {self.joint_names}.")
            return False
        problem = self._timing_problem(moving_time, accel_time) or \
            _number_problem(f"position of '{joint_name}'", position)
        mt, at = self._times(moving_time, accel_time)
        problem = problem or self._limit_problem([position], mt, at, [joint_name])
        if problem is not None:
            self._warn(f'Joint position refused: {problem}.')
            return False
        self.set_trajectory_time(moving_time, accel_time)
        mt, at = self._times(None, None)
        if mt <= 0.0:  # no profile: as fast as the joint's velocity limit allows
            i = self.info_index_map[joint_name]
            d = abs(float(position) - self.joint_commands[i])
            mt = max(MIN_MOVE_TIME, 1.02 * d / self.group_info.joint_velocity_limits[i] + at)
        self.joint_commands[self.info_index_map[joint_name]] = float(position)
        ok = self._execute([joint_name], [[float(position)]], [mt], at, blocking, mt)
        if not ok:
            self._capture_after_failure()
        else:
            self._update_Tsb()
        return ok

    def _capture_after_failure(self) -> None:
        """After a failed move the arm is wherever it stopped: command that (when measurable)."""
        if self.core.joint_state_age() < self.core.stale_timeout:
            self.capture_joint_positions()
        else:
            self._update_Tsb()

    # ----------------------------------------------------------- task space
    def set_ee_pose_matrix(self, T_sd: np.ndarray, custom_guess: Optional[Sequence[float]] = None,
                           execute: bool = True, moving_time: Optional[float] = None,
                           accel_time: Optional[float] = None,
                           blocking: bool = True) -> Tuple[Any, bool]:
        """
        Command the end effector to pose T_sd (4, 4) [m] of ee_gripper_link in base_link.

        :param custom_guess: accepted for compatibility (ik_service chooses among all branches
            the solution closest to the measured joints)
        :param execute: move the arm (else only plan)
        :return: (theta_list (n,) [rad], True) on success; (closest attempt or the current joint
            commands, False) when no valid pose exists (reason logged)
        """
        self._begin()
        fallback = np.array(self.joint_commands, dtype=float)
        problem = self._timing_problem(moving_time, accel_time)
        T = None
        if problem is None:
            try:
                T = np.array(T_sd, dtype=float)
            except (TypeError, ValueError):
                problem = f'T_sd is not a matrix of numbers: {T_sd!r}'
        if problem is None and T.shape != (4, 4):
            problem = f'T_sd must be a 4x4 matrix, got shape {T.shape}'
        if problem is None:
            bad = np.argwhere(~np.isfinite(T))
            if bad.size:
                i, j = (int(v) for v in bad[0])
                problem = f'T_sd[{i}][{j}] is {T[i, j]}'
        if problem is None:
            problem = self._reach_problem(T[:3, 3])
        if problem is not None:
            self._warn(f'No valid pose could be found. Will not execute ({problem}).')
            return fallback, False
        try:
            reply = self.core.request_ik(T)
        except InterbotixException as exc:
            self._error(f'No valid pose could be found. Will not execute: {exc}')
            return fallback, False
        theta = reply.q
        problem = None
        if not reply.success or theta is None:
            problem = reply.reason or 'ik_service found no solution'
        else:
            theta = self._wrap_theta_list(theta)
            dp, dw = pose_error_norms(self.model.fk(theta), T)
            if dp > EV or dw > EOMG:
                problem = (f'the pose ik_service found is {dp * 1000:.1f} mm / {dw:.3f} rad '
                           f'from the target (ik_service: {reply.reason})')
            else:
                mt, at = self._times(moving_time, accel_time)
                problem = self._limit_problem(theta, mt, at)
        if problem is not None:
            self._warn(
                f'No valid pose could be found. Will not execute ({problem})')
            return (theta if theta is not None else fallback), False
        if execute:
            ok = self.publish_positions(list(theta), moving_time, accel_time, blocking)
            if not ok:
                return theta, False
            self.T_sb = T.copy()
        return theta, True

    def set_ee_pose_components(self, x: float = 0, y: float = 0, z: float = 0, roll: float = 0,
                               pitch: float = 0, yaw: Optional[float] = None,
                               custom_guess: Optional[Sequence[float]] = None,
                               execute: bool = True, moving_time: Optional[float] = None,
                               accel_time: Optional[float] = None,
                               blocking: bool = True) -> Tuple[Any, bool]:
        """
        Command the end effector to (x, y, z) [m] and roll, pitch, yaw [rad] ('sxyz').

        On arms with fewer than 6 joints (and whenever yaw is None) yaw = atan2(y, x).
        :return: (theta_list, success) as set_ee_pose_matrix
        """
        values = (('x', x), ('y', y), ('z', z), ('roll', roll), ('pitch', pitch)) + \
            ((('yaw', yaw),) if yaw is not None else ())
        problem = next((pr for pr in (_number_problem(n, v) for n, v in values) if pr), None)
        if problem is not None:
            self._begin()
            self._warn(f'No valid pose could be found. Will not execute ({problem}).')
            return np.array(self.joint_commands, dtype=float), False
        x, y, z, roll, pitch = (float(v) for _, v in values[:5])
        if self.group_info.num_joints < 6 or yaw is None:
            yaw = math.atan2(y, x)
        T_sd = np.eye(4)
        T_sd[:3, :3] = euler_sxyz_to_matrix(roll, pitch, yaw)
        T_sd[:3, 3] = [x, y, z]
        return self.set_ee_pose_matrix(T_sd, custom_guess, execute, moving_time, accel_time,
                                       blocking)

    def set_relative_ee_position_wrt_to_base_frame(
            self, *, dx: float = 0, dy: float = 0, dz: float = 0,
            custom_guess: Optional[Sequence[float]] = None, execute: bool = True,
            moving_time: Optional[float] = None, accel_time: Optional[float] = None,
            blocking: bool = True) -> Tuple[Any, bool]:
        """ROS 1 (noetic): set_ee_pose_components at the commanded xyz + (dx, dy, dz) [m]."""
        p = self.T_sb[:3, 3]
        return self.set_ee_pose_components(
            x=p[0] + dx, y=p[1] + dy, z=p[2] + dz, custom_guess=custom_guess, execute=execute,
            moving_time=moving_time, accel_time=accel_time, blocking=blocking)

    def set_ee_cartesian_trajectory(self, x: float = 0, y: float = 0, z: float = 0,
                                    roll: float = 0, pitch: float = 0, yaw: float = 0,
                                    moving_time: Optional[float] = None,
                                    wp_moving_time: float = 0.2, wp_accel_time: float = 0.1,
                                    wp_period: float = 0.05) -> bool:
        """
        Move the end effector along a straight line by (x, y, z) [m], (roll, pitch, yaw) [rad].

        Displacements are expressed in T_sy: the base frame turned by the end effector's yaw.
        Always blocks. A given moving_time becomes the new default.
        :return: True if the whole line was planned (IK, limits, speed) and executed
        """
        self._begin()
        values = (('x', x), ('y', y), ('z', z), ('roll', roll), ('pitch', pitch), ('yaw', yaw),
                  ('wp_period', wp_period))
        problem = next((pr for pr in (_number_problem(n, v) for n, v in values) if pr), None) \
            or self._timing_problem(moving_time, None)
        if problem is None:
            problem = self._reach_problem([x, y, z])
        if problem is not None:
            self._warn(f'Trajectory will not be executed ({problem}).')
            return False
        if self.group_info.num_joints < 6 and (y != 0 or yaw != 0):
            self._warn("'y' and 'yaw' fields must be '0' when working with arms with fewer "
                       'than 6dof.')
            return False
        if moving_time is None:
            moving_time = self.moving_time
        mt = _finite(moving_time)
        period = _finite(wp_period)
        if mt is None or period is None or period <= 0 or mt <= 0:
            self._warn(f'Invalid moving_time {moving_time!r} or wp_period {wp_period!r}.')
            return False
        N = int(mt / period + 1e-9)
        if N < 1:
            self._warn(f'moving_time {mt:.3f} s is shorter than wp_period {period:.3f} s: '
                       'nothing to plan.')
            return False
        roll0, pitch0, yaw0 = matrix_to_euler_sxyz(self.T_sb[:3, :3])
        T_sy = np.eye(4)
        T_sy[:3, :3] = euler_sxyz_to_matrix(0.0, 0.0, yaw0)
        T_yb = inv_transform(T_sy) @ self.T_sb
        rpy = np.array([roll0, pitch0, 0.0])
        poses = []
        for i in range(1, N + 1):
            s = i / N
            T = np.eye(4)
            T[:3, 3] = T_yb[:3, 3] + s * np.array([x, y, z], dtype=float)
            r = rpy + s * np.array([roll, pitch, yaw], dtype=float)
            T[:3, :3] = euler_sxyz_to_matrix(*r)
            poses.append(T_sy @ T)
        try:
            path = self.core.request_ik_path(poses)
        except InterbotixException as exc:
            self._error(f'Trajectory will not be executed: {exc}')
            return False
        planned = self._check_path(path, poses, period)
        if planned < N:
            why = self.core.last_path_reason if len(path.points) < N else \
                'a waypoint is off the line, out of limits or too fast'
            self._warn(f'Only {100.0 * planned / N:.2f}% of trajectory successfully planned. '
                       f'Trajectory will not be executed ({why}).')
            return False
        points = [list(self._wrap_theta_list(self._path_point(path, i))) for i in range(N)]
        times = [(i + 1) * period for i in range(N)]
        ok = self._execute(self.joint_names, points, times, None, True, N * period)
        if ok:
            self.T_sb = poses[-1]
            self.joint_commands = [float(v) for v in points[-1]]
        else:
            self._capture_after_failure()
        self.set_trajectory_time(mt, self.accel_time)
        return ok

    def set_ee_waypoints(self, poses: Sequence[np.ndarray], max_joint_step: float = 0.05,
                         wp_period: float = 0.05, blocking: bool = True) -> bool:
        """
        Move the end effector on straight lines through waypoints, no joint step above a max.

        px100_control extension (no Interbotix equivalent). ``poses`` are (4, 4) end-effector
        poses [m] in the base frame; between them the position moves on a straight line and the
        orientation by roll, pitch, yaw (yaw relative to the azimuth atan2(y, x) on arms with
        fewer than 6 joints, whose heading follows the position). ik_service solves every
        point; the count per
        segment is the smallest that keeps every joint step between points under
        ``max_joint_step`` [rad] (``kinematics.cartesian``). Points are ``wp_period`` [s] apart,
        stretched (with a warning) when a step would exceed a joint velocity limit.
        :return: True if the whole path was planned and (when blocking) executed; False with
            the reason logged (bad input, a pose without IK solution, a singular line)
        """
        period = _finite(wp_period)
        if period is None or period <= 0:
            self._warn(f'Waypoints refused: wp_period must be finite and > 0, got {wp_period!r}.')
            return False
        n = len(self.joint_names)

        def solve(targets, _q_start):
            path = self.core.request_ik_path(targets)
            Q = [self._wrap_theta_list(self._path_point(path, i))
                 for i in range(len(path.points))]
            return np.array(Q, dtype=float).reshape(-1, n), self.core.last_path_reason

        q0 = np.array(self.joint_commands, dtype=float)
        try:
            plan = plan_ee_waypoints(
                solve, q0, self.model.fk(q0), poses, max_joint_step,
                orientation='azimuth' if self.group_info.num_joints < 6 else 'rpy')
        except InvalidInputError as exc:
            self._warn(f'Waypoints refused: {exc}.')
            return False
        except (CartesianPathError, InterbotixException) as exc:
            self._error(f'Waypoint path will not be executed: {exc}')
            return False
        steps = np.abs(np.diff(plan.q, axis=0))
        need = float(np.max(steps / np.asarray(self.group_info.joint_velocity_limits)))
        if need > period:
            self._warn(f'Waypoint steps of {plan.max_step:.3f} rad every {period:.3f} s exceed '
                       f'a joint velocity limit: points are {1.02 * need:.3f} s apart instead.')
            period = 1.02 * need
        points = [[float(v) for v in q] for q in plan.q[1:]]
        times = [(i + 1) * period for i in range(len(points))]
        ok = self._execute(self.joint_names, points, times, None, blocking,
                           len(points) * period)
        if ok:
            self.T_sb = np.array(plan.poses[-1], dtype=float)
            self.joint_commands = points[-1]
        else:
            self._capture_after_failure()
        return ok

    def _path_point(self, path, i: int) -> np.ndarray:
        pt = path.points[i]
        if list(path.joint_names) and list(path.joint_names) != self.joint_names:
            by_name = dict(zip(path.joint_names, pt.positions))
            return np.array([by_name[j] for j in self.joint_names], dtype=float)
        return np.array(pt.positions, dtype=float)

    def _check_path(self, path, poses, period: float) -> int:
        """Return how many waypoints from the start are solved, reached and within limits."""
        prev = np.array(self.joint_commands, dtype=float)
        info = self.group_info
        vmax = np.array(info.joint_velocity_limits)
        lo, hi = np.array(info.joint_lower_limits), np.array(info.joint_upper_limits)
        for i, T in enumerate(poses):
            if i >= len(path.points) or len(path.points[i].positions) != len(self.joint_names):
                return i
            try:
                q = self._wrap_theta_list(self._path_point(path, i))
            except KeyError:
                return i
            if not np.all(np.isfinite(q)) or np.any(q < lo - 1e-9) or np.any(q > hi + 1e-9):
                return i
            dp, dw = pose_error_norms(self.model.fk(q), T)
            if dp > EV or dw > EOMG:
                return i
            if np.any(np.abs(q - prev) / period > vmax + 1e-9):
                return i
            prev = q
        return len(poses)

    # -------------------------------------------------------------- getters
    def get_joint_commands(self) -> List[float]:
        """Return a copy of the commanded joint positions [rad] (group order)."""
        return list(self.joint_commands)

    def get_single_joint_command(self, joint_name: str) -> float:
        """Return one joint's commanded position [rad]."""
        return float(self.joint_commands[self.info_index_map[joint_name]])

    def get_ee_pose_command(self) -> np.ndarray:
        """Return a copy of the commanded end-effector pose T_sb (4, 4) [m]."""
        return np.array(self.T_sb)

    def get_ee_pose(self) -> np.ndarray:
        """Return the measured end-effector pose (4, 4) [m]: FK of the measured joints."""
        return self.model.fk(self.get_joint_positions())

    def capture_joint_positions(self) -> None:
        """Set the commanded joints to the measured ones and recompute T_sb (after torque off)."""
        self.joint_commands = self.get_joint_positions()
        self._update_Tsb()

    def get_joint_positions(self) -> List[float]:
        """Return the measured joint positions [rad] (group order)."""
        return [float(v) for v in self.core.joint_positions(self.joint_names)]

    def get_joint_velocities(self) -> List[float]:
        """Return the measured joint velocities [rad/s] (group order)."""
        return [float(v) for v in self.core._joint_field(self.joint_names, 'velocity')]

    def get_joint_efforts(self) -> List[float]:
        """Return the measured joint efforts [N*m] (group order; Interbotix: mA or load)."""
        return [float(v) for v in self.core._joint_field(self.joint_names, 'effort')]

    def get_number_of_joints(self) -> int:
        """Return the number of joints in the group."""
        return int(self.group_info.num_joints)

    # -------------------------------------------------------------- helpers
    def _update_Tsb(self) -> None:
        """Recompute the commanded pose T_sb from the commanded joints."""
        self.T_sb = self.model.fk(self.joint_commands)

    update_Tsb = _update_Tsb

    def _wrap_theta_list(self, theta_list) -> np.ndarray:
        """Map angles to [-pi, pi), then by +-2 pi into the joint limits when that helps."""
        q = np.array(theta_list, dtype=float)
        info = self.group_info
        for i in range(q.size):
            q[i] = wrap(q[i])
            if round(q[i], 3) < round(info.joint_lower_limits[i], 3):
                q[i] += self.rev
            elif round(q[i], 3) > round(info.joint_upper_limits[i], 3):
                q[i] -= self.rev
        return q


def pose_error_norms(T_current: np.ndarray, T_target: np.ndarray) -> Tuple[float, float]:
    """Return (position error [m], orientation error [rad]) between two (4, 4) poses."""
    dp, dw = pose_error(T_current, T_target)
    return float(dp), float(dw)


def _number_problem(name: str, value) -> Optional[str]:
    """Return '<name> is NaN' (inf, not a number) for a bad scalar argument, else None."""
    if isinstance(value, bool):
        return f'{name} is a bool ({value}), not a number'
    try:
        v = float(value)
    except (TypeError, ValueError):
        return f'{name} is not a number: {value!r}'
    if math.isnan(v):
        return f'{name} is NaN'
    if math.isinf(v):
        return f'{name} is {v}'
    return None


def _finite(value) -> Optional[float]:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None
