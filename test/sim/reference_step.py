"""
The simulator step in its plain formulation: the bit-for-bit reference of ArmSimulator.step.

:class:`ReferenceStepSimulator` is an ArmSimulator whose step re-reads every constant, writes
the finger slides' reflected armature, damping and friction on every step and clips speeds with
numpy. ArmSimulator.step computes the same floats with less Python around them;
test_sim_step_identity.py checks both give identical trajectories. Not package code: kept under
test/ as the oracle of that speed-up.
"""
import mujoco
import numpy as np
from px100_control.sim.simulator import ArmSimulator


class ReferenceStepSimulator(ArmSimulator):
    """ArmSimulator with the plain step (same constructor)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._vlim = np.array(self.vel_limit)

    def step(self) -> None:
        """Advance the simulation by one control period dt."""
        m, d = self.mj_model, self.mj_data
        dt = m.opt.timestep
        n = self.n
        torque = self.joint_torque
        on = any(torque)
        q, qd = self.q, self.qd
        t = self.time
        drive = [0.0] * n
        if on:
            pids, q_ref, qd_ref, ff_until = self.pids, self.q_ref, self.qd_ref, self.ff_until
            for i, mode in enumerate(self._mode_list):
                if not torque[i]:
                    continue
                stall, lim, back, top = self._servo_consts[i]
                if mode == 'position':
                    v_ref = qd_ref[i] if t < ff_until[i] else 0.0
                    u = pids[i].step(q_ref[i] - q[i], dt, v_ref - qd[i], v_ref)
                elif mode == 'velocity':
                    u = self.velocity_pids[i].step(qd_ref[i] - qd[i], dt, 0.0, qd_ref[i])
                elif mode == 'torque':
                    b = back * qd[i]
                    u = self.u_cmd[i]
                    drive[i] = min(max(u, -top - b), top - b)
                    continue
                else:
                    u = self.u_cmd[i] * stall
                duty = u / stall
                duty = lim if duty > lim else (-lim if duty < -lim else duty)
                drive[i] = stall * duty
        self._qfrc[self._arm_dof] = drive
        if self.gripper_name:
            self._gripper_force(dt, self.gripper_torque)
        mujoco.mj_step(m, d)
        if on and not all(torque):
            for i, dof in enumerate(self._arm_dof):
                if torque[i]:
                    self._qvel[dof] = min(max(self._qvel[dof], -self._vlim[i]), self._vlim[i])
        elif on:
            self._qvel[self._arm_dof] = np.clip(self._qvel[self._arm_dof], -self._vlim,
                                                self._vlim)
        if on:
            vel = self.qd
            self.effort = [x - b * v if tq else 0.0
                           for x, b, v, tq in zip(drive, self._back_emf, vel, torque)]
        else:
            self.effort = [0.0] * n
        if self.gripper_name:
            self._after_gripper_step(self.gripper_torque)
        self.time = t + dt

    def _gripper_force(self, dt: float, on: bool) -> None:
        m = self.mj_model
        link, servo = self.linkage, self.gripper_servo
        fq, fd = self._fq, self._fd
        finger = float(self._qpos[fq[0]])
        theta = link.angle_from_finger(min(max(finger, 1e-6), link.horn_radius
                                           + link.arm_length - 1e-9))
        rate = link.finger_rate(theta)
        omega = float(self._qvel[fd[0]]) / rate
        drive = 0.0
        b = self.gripper_damping
        if on:
            mode = self.modes.get(self.gripper_name)
            if self.g_mode == 'effort':
                u = self.g_command * servo.stall_torque if mode == 'duty' else self.g_command
            elif self.g_mode == 'velocity':
                u = self.gripper_velocity_pid.step(self.g_ref_vel - omega, dt, 0.0,
                                                   self.g_ref_vel)
            else:
                u = self.gripper_pid.step(self.g_ref - theta, dt, self.g_ref_vel - omega,
                                          self.g_ref_vel)
            drive = servo.stall_torque * servo.duty(u)
            b += servo.back_emf_damping
        k = 0.5 / rate
        force = drive * k
        self._qfrc[fd[0]] = force
        self._qfrc[fd[1]] = -force
        for dof in fd:
            m.dof_armature[dof] = (servo.armature + self.gripper_inertia) * k / rate
            m.dof_damping[dof] = b * k / rate
            m.dof_frictionloss[dof] = self.gripper_friction * k
        self.g_effort = drive
        self._g_rate = rate

    def _after_gripper_step(self, on: bool) -> None:
        fq, fd = self._fq, self._fd
        rate = self._g_rate
        if on:
            vl = self.gripper_servo.velocity_limit * rate
            for dof in fd:
                v = float(self._qvel[dof])
                if v > vl:
                    self._qvel[dof] = vl
                elif v < -vl:
                    self._qvel[dof] = -vl
            self.g_effort -= self.gripper_servo.back_emf_damping * float(self._qvel[fd[0]]) / rate
        else:
            self.g_effort = 0.0
        if self._object_half is not None and not self._object_engaged and \
                float(self._qpos[fq[0]]) >= self._object_half - 1e-9:
            self._object_engaged = True
            self._set_finger_stop(self._object_half)
