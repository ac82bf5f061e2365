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
- stable: stable PD in the explicit-torque path (Tan, Liu and Turk 2011): the torque that
  the PD would exert against the end-of-step state, predicted with the full coupled
  inertia of the body graph. The prediction is exactly the implicit servo solved with the
  joints alone (no contacts): its row impulses, divided by h, are applied as explicit
  torques, then the step runs as usual with the servo rows off. Stable for stiff gains like
  the implicit mode; contacts are not part of the prediction (as in Tan et al.), and it
  costs one extra joint solve per step.
- implicit: no torque here; ``joints.rows`` writes the servo as a soft constraint row with
  ERP/CFM from (kp, kd) so the solver applies the implicit-Euler spring-damper, coupled
  through the whole body graph: stable for any gains and step.

MJCF actuators (``motor``: ``gear * ctrl`` along an axis; ``position``: ``kp (ctrl - q) -
kv qd`` along the axis) are explicit torques here too; position actuators on hinges and
slides are folded into the joint's servo by the World instead so they run implicitly.
"""
import numpy as np
from numba import njit

from .._jit import allocating, noalloc

from ..math.quat import quat_conj, quat_log, quat_mul, quat_rotate
from ..model.types import ACT_MOTOR, ROWS_PER_DOF
from .integrate import integrate_velocities
from .joints.common import INF, angular_row, clear_row, linear_row
from .joints.rows import _dof_velocity, build_joint_rows, joint_dofs
from .solvers.direct import solve_direct
from .joints.servo import pd_error, servo_active, servo_row_terms

PD_IMPLICIT, PD_EXPLICIT, PD_STABLE = 0, 1, 2
PD_MODES = {"implicit": PD_IMPLICIT, "explicit": PD_EXPLICIT, "stable": PD_STABLE}


@njit(cache=True, inline="always")
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@noalloc
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


@noalloc
def actuator_forces(m, pos, quat, vel, angvel, drive, ctrl, mode, force, torque):
    """Add explicit actuator forces and torques (N, N m, world) to ``force``/``torque``.

    drive : JointDrive of one world; ctrl : (nact,) MJCF controls; mode : PD_*.
    Servo torques are added here only in the explicit mode (``stable_servo_forces`` adds
    those of the stable mode).
    """
    nj = m.joint_type.shape[0]
    for j in range(nj):
        servo = mode == PD_EXPLICIT and servo_active(drive, j)
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
                tau = kp * err[d] - kd * (qd - drive.target_qd[j, d])
                lim = drive.max_torque[j]
                amount += min(max(tau, -lim), lim)
            if amount != 0.0:
                _apply_dof(force, torque, pos, a, b, e, linear, anchor_a, anchor_b, amount)
    for i in range(m.act_joint.shape[0]):
        if m.act_folded[i]:
            continue
        j = np.int64(m.act_joint[i])
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


@allocating
def stable_servo_forces(m, pos, quat, vel, angvel, drive, h, o_erp, o_cfm, gyroscopic,
                        tolerance, rows, imp, vel_pred, angvel_pred, inv_inertia, force,
                        torque, cache):
    """Stable PD: add the servo forces of the implicit solve as explicit forces (N, N m).

    Predicts the end-of-step velocities of the joints alone (``force``/``torque`` as they
    stand, servo rows on, no contacts), then applies ``J^T impulse / h`` of every servo row.
    rows, imp : scratch for the joint rows; vel_pred, angvel_pred : (nbody, 3) scratch;
    inv_inertia : (nbody, 3, 3) world inverse inertia at ``quat``; cache : the joint rows'
    tree plan (``solvers.tree.make_plan_cache``).
    """
    nj = m.joint_type.shape[0]
    vel_pred[:] = vel
    angvel_pred[:] = angvel
    integrate_velocities(m, quat, vel_pred, angvel_pred, force, torque, h, gyroscopic)
    build_joint_rows(m, pos, quat, vel_pred, angvel_pred, drive, h, o_erp, o_cfm, rows,
                     np.bool_(True))
    njrow = np.int64(0)
    for j in range(nj):
        njrow = max(njrow, m.joint_row_start[j] + m.joint_row_count[j])
    imp[:njrow] = 0.0
    solve_direct(rows, njrow, m.body_inv_mass, inv_inertia, vel_pred, angvel_pred, imp,
                 tolerance, cache)
    for j in range(nj):
        if not servo_active(drive, j):
            continue
        r0 = m.joint_row_start[j] + m.joint_core_rows[j]
        ndof = (m.joint_row_count[j] - m.joint_core_rows[j]) // ROWS_PER_DOF
        for d in range(ndof):
            r = r0 + d * ROWS_PER_DOF + 1
            p = imp[r] / h
            for side in range(2):
                body = rows.body_a[r] if side == 0 else rows.body_b[r]
                if body < 0:
                    continue
                o = 6 * side
                for k in range(3):
                    force[body, k] += rows.J[r, o + k] * p
                    torque[body, k] += rows.J[r, o + 3 + k] * p


@njit(cache=True)
def servoed_bodies(body_servo):
    """Indices of the bodies whose servo is on in any world: (ns,) int64."""
    on = np.zeros(body_servo.shape[1], np.bool_)
    for b in range(body_servo.shape[1]):
        on[b] = servo_on(body_servo, b)
    return np.flatnonzero(on)


@njit(cache=True, inline="always")
def servo_on(body_servo, b):
    """Whether body ``b``'s servo has a gain above zero in any world."""
    for w in range(body_servo.shape[0]):
        for k in range(4):
            if body_servo[w, b, k] > 0.0:
                return True
    return False


@noalloc
def body_servo_rows(pos, quat, servoed, gains, target_pos, target_quat, target_vel,
                    target_angvel, h, rows, r0):
    """Six implicit PD rows per servoed body from row ``r0``: its COM toward ``target_pos``
    along world x, y, z and its orientation toward ``target_quat`` about them.

    Each row is the implicit-Euler spring-damper of ``joints.servo.servo_row_terms`` between
    the body and the world, so the hand of god is stable for any gains and step.
    gains : (nbody, 4) kp, kd, kp_rot, kd_rot of one world; targets (nbody, ...), world.
    """
    zero = (0.0, 0.0, 0.0)
    r = r0
    for i in range(servoed.shape[0]):
        b = servoed[i]
        rv = quat_log(quat_mul(target_quat[b], quat_conj(quat[b])))
        for k in range(3):
            e = (1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0)
            kp, kd = gains[b, 0], gains[b, 1]
            if kp > 0.0 or kd > 0.0:
                rhs, cfm = servo_row_terms(kp, kd, h, target_pos[b, k] - pos[b, k],
                                           target_vel[b, k])
                linear_row(rows, r, -1, b, e, zero, zero, rhs, cfm, -INF, INF)
            else:
                clear_row(rows, r, -1, b)
            kp, kd = gains[b, 2], gains[b, 3]
            if kp > 0.0 or kd > 0.0:
                rhs, cfm = servo_row_terms(kp, kd, h, rv[k], target_angvel[b, k])
                angular_row(rows, r + 3, -1, b, e, rhs, cfm, -INF, INF)
            else:
                clear_row(rows, r + 3, -1, b)
            r += 1
        r += 3
