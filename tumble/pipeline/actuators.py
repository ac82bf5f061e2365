"""Stage 1b of a step: joint actuators. PD servos, direct joint torques, MJCF actuators.

Every joint carries a PD servo (gains ``kp``, ``kd``, torque bound ``max_torque``; off while
both gains are zero) pulling it toward a target pose and rate, and an applied torque per
degree of freedom. The error is taken in the parent's joint frame from quaternions:

    ball       e = log(q_target * conj(q_rel))       rotation vector, parent joint frame
    hinge      e = wrap(theta_target - theta)        universal: per axis; slider: metres
    torque     tau = kp e - kd (qd - qd_target)      +tau on the child, -tau on the parent

How the servo enters the step is the world's PD mode:

- explicit: ``tau`` from the state at the start of the step, added as a torque here. The
  lecture's PD, unstable once ``kd h / I`` or ``kp h^2 / I`` get large.
- stable: stable PD in the explicit path (Tan, Liu and Turk 2011): the torque sees the
  end-of-step state, ``tau = kp (e - h qd') - kd (qd' - qd_target)`` with ``qd' = qd + h
  qdd``. In maximal coordinates the DoF's acceleration is linearised about the previous
  step, ``qdd = qdd_prev + A (tau - tau_prev)``, ``A = J M^-1 J^T`` of the DoF, so
  ``tau = (kp (e - h qd) - kd (qd - qd_t) - c (qdd_prev - A tau_prev)) / (1 + c A)`` with
  ``c = h kd + h^2 kp``, and ``A`` the DoF's inverse inertia with the joint's own core
  constraints holding its two bodies together (the rest of the body graph is neglected).
  Static equilibria are exact (``tau = kp e`` at rest); it stays stable far beyond explicit
  PD, but unlike the implicit mode it is not unconditional.
- implicit: no torque here; ``joints.rows`` writes the servo as a soft constraint row with
  ERP/CFM from (kp, kd) so the solver applies the implicit-Euler spring-damper, coupled
  through the whole body graph: stable for any gains and step.

MJCF actuators (``motor``: ``gear * ctrl`` along an axis; ``position``: ``kp (ctrl - q) -
kv qd`` along the axis) are explicit torques here too; position actuators on hinges and
slides are folded into the joint's servo by the World instead so they run implicitly.
"""
import numpy as np
from numba import njit

from ..math.quat import quat_conj, quat_log, quat_mul, quat_rotate
from .joints.common import INF
from .joints.rows import _dof_row, _dof_velocity, core_rows, joint_dofs
from .solvers.common import minv_jt
from .joints.servo import pd_error, servo_active

PD_IMPLICIT, PD_EXPLICIT, PD_STABLE = 0, 1, 2
PD_MODES = {"implicit": PD_IMPLICIT, "explicit": PD_EXPLICIT, "stable": PD_STABLE}
ACT_MOTOR, ACT_POSITION = 0, 1
ACTUATOR_KINDS = {"motor": ACT_MOTOR, "position": ACT_POSITION}


@njit(cache=True, inline="always")
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True)
def dof_inverse_mass(m, inv_inertia, j, e, linear, anchor_a, anchor_b, r_a, r_b, frame_a,
                     frame_b, scratch):
    """Inverse effective inertia (or mass) of joint j's DoF along world axis ``e`` while its
    core rows hold its two bodies together: the Schur complement of ``J M^-1 J^T``."""
    a, b = m.joint_parent[j], m.joint_child[j]
    nc = m.joint_core_rows[j]
    core_rows(m, scratch, 0, j, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, 0.0, 0.0)
    _dof_row(scratch, nc, a, b, e, linear, r_a, r_b, 0.0, 0.0, INF)
    n = nc + 1
    dv = np.zeros((n, 12))
    for r in range(n):
        minv_jt(scratch, r, m.body_inv_mass, inv_inertia, dv[r])
    W = np.zeros((n, n))
    for r in range(n):
        for c in range(n):
            s = 0.0
            for k in range(12):
                s += scratch.J[r, k] * dv[c, k]
            W[r, c] = s
    if nc == 0:
        return W[0, 0]
    Acc = W[:nc, :nc].copy()
    for r in range(nc):
        Acc[r, r] += 1e-12 * (1.0 + Acc[r, r])
    x = np.linalg.solve(Acc, W[:nc, nc].copy())
    out = W[nc, nc]
    for r in range(nc):
        out -= W[nc, r] * x[r]
    return max(out, 0.0)


@njit(cache=True)
def _apply_dof(force, torque, pos, a, b, e, linear, anchor_a, anchor_b, amount):
    """``amount`` (N m or N) along world axis ``e``: + on the child, - on the parent."""
    for side in range(2):
        body = b if side == 0 else a
        if body < 0:
            continue
        s = amount if side == 0 else -amount
        if linear:
            p = anchor_b if side == 0 else anchor_a
            r = (p[0] - pos[body, 0], p[1] - pos[body, 1], p[2] - pos[body, 2])
            c = _cross(r, e)
            for k in range(3):
                force[body, k] += s * e[k]
                torque[body, k] += s * c[k]
        else:
            for k in range(3):
                torque[body, k] += s * e[k]


@njit(cache=True)
def actuator_forces(m, pos, quat, vel, angvel, drive, ctrl, mode, h, inv_inertia, scratch,
                    force, torque):
    """Add explicit actuator forces and torques (N, N m, world) to ``force``/``torque``.

    drive : JointDrive of one world; ctrl : (nact,) MJCF controls; mode : PD_*;
    inv_inertia : (nbody, 3, 3) world inverse inertia at ``quat``, and scratch : Rows of at
    least 7 rows (both used by PD_STABLE only).
    Servo torques are added only in the explicit and stable modes.
    """
    nj = m.joint_type.shape[0]
    for j in range(nj):
        servo = mode != PD_IMPLICIT and servo_active(drive, j)
        applied = (drive.applied[j, 0] != 0.0 or drive.applied[j, 1] != 0.0
                   or drive.applied[j, 2] != 0.0)
        if not servo and not applied:
            continue
        a, b = m.joint_parent[j], m.joint_child[j]
        n, axes, q, linear, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b = joint_dofs(m, pos, quat, j)
        if servo:
            err = pd_error(m.joint_type[j], q, frame_a, frame_b, drive.target_quat[j],
                           drive.target_q[j])
        for d in range(n):
            e = axes[d]
            amount = drive.applied[j, d]
            if servo:
                qd = _dof_velocity(e, linear, a, b, vel, angvel, r_a, r_b)
                kp, kd = drive.kp[j], drive.kd[j]
                if mode == PD_STABLE:
                    A = dof_inverse_mass(m, inv_inertia, j, e, linear, anchor_a, anchor_b, r_a,
                                         r_b, frame_a, frame_b, scratch)
                    c = h * kd + h * h * kp
                    qdd_prev = (qd - drive.prev_qd[j, d]) / h if drive.has_prev[j] else 0.0
                    tau_prev = drive.prev_tau[j, d] if drive.has_prev[j] else 0.0
                    tau = (kp * (err[d] - h * qd) - kd * (qd - drive.target_qd[j, d])
                           - c * (qdd_prev - A * tau_prev)) / (1.0 + c * A)
                    drive.prev_qd[j, d] = qd
                else:
                    tau = kp * err[d] - kd * (qd - drive.target_qd[j, d])
                lim = drive.max_torque[j]
                tau = min(max(tau, -lim), lim)
                drive.prev_tau[j, d] = tau
                amount += tau
            if amount != 0.0:
                _apply_dof(force, torque, pos, a, b, e, linear, anchor_a, anchor_b, amount)
        if servo and mode == PD_STABLE:
            drive.has_prev[j] = True
    for i in range(m.act_joint.shape[0]):
        if m.act_folded[i]:
            continue
        j = m.act_joint[i]
        a, b = m.joint_parent[j], m.joint_child[j]
        n, axes, q, linear, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b = joint_dofs(m, pos, quat, j)
        e = quat_rotate(frame_a, (m.act_axis[i, 0], m.act_axis[i, 1], m.act_axis[i, 2]))
        c = min(max(ctrl[i], m.act_ctrlrange[i, 0]), m.act_ctrlrange[i, 1])
        if m.act_kind[i] == ACT_MOTOR:
            amount = c
        else:
            # coordinate along the axis: the joint's rotation vector (or offset) projected on it
            qa = 0.0
            if linear:
                for k in range(3):
                    qa += (anchor_b[k] - anchor_a[k]) * e[k]
            else:
                rv = quat_log(quat_mul(frame_b, quat_conj(frame_a)))
                for k in range(3):
                    qa += rv[k] * e[k]
            qd = _dof_velocity(e, linear, a, b, vel, angvel, r_a, r_b)
            amount = m.act_kp[i] * (c - m.act_gear[i] * qa) - m.act_kv[i] * m.act_gear[i] * qd
        # MJCF: the force range bounds the actuator's force; the joint feels gear times it
        amount = min(max(amount, m.act_forcerange[i, 0]), m.act_forcerange[i, 1])
        _apply_dof(force, torque, pos, a, b, e, linear, anchor_a, anchor_b, m.act_gear[i] * amount)
