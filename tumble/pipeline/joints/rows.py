"""Stage 3 of a step: the constraint rows of every joint, and the joints' coordinates.

Joint j owns rows ``joint_row_start[j] ...``: first its core rows (type module), then
for each degree of freedom a limit, a motor, a damping and a friction row, written
as inactive rows (``lo == hi == 0``) when not in use. A ball joint with a swing cone or
twist range (``joint_cone``, ``joint_twist``) uses its three limit slots for those
instead of the box limit: DoF 0's for the twist row, DoF 1's for the swing-cone row,
DoF 2's stays inactive (see ``ball.py``).

ERP/CFM: a row with error C asks for the velocity ``-ERP C / h`` and is softened by
``CFM`` (ODE's units: m/N or rad/(N m) per second). A spring k and damper c acting on
the error at step h are reproduced by ``ERP = h k / (h k + c)``, ``CFM = 1 / (h k + c)``.
"""
import numpy as np
from numba import njit

from ..._jit import noalloc

from ...math.quat import quat_conj, quat_mul
from ...model.types import BALL, FIXED, HINGE, ROWS_PER_DOF, SLIDER, UNIVERSAL
from . import ball, fixed, hinge, slider, universal
from .servo import pd_error, servo_active, servo_row_terms
from .common import INF, angular_row, clear_row, joint_frames, linear_row


@noalloc
def soft_erp_cfm(k, c, h):
    """(ERP, CFM) of a spring ``k`` (N/m or N m/rad) and damper ``c`` at step ``h``."""
    return h * k / (h * k + c), 1.0 / (h * k + c)


@noalloc
def joint_dofs(m, pos, quat, j):
    """(ndof, axes (3 world vectors), coordinates (3,), linear?, frames and anchors)."""
    anchor_a, anchor_b, r_a, r_b, frame_a, frame_b = joint_frames(m, pos, quat, j)
    t = m.joint_type[j]
    if t == BALL:
        axes, q = ball.dofs(frame_a, frame_b, anchor_a, anchor_b)
        n = 3
    elif t == HINGE:
        axes, q = hinge.dofs(frame_a, frame_b, anchor_a, anchor_b)
        n = 1
    elif t == UNIVERSAL:
        axes, q = universal.dofs(frame_a, frame_b, anchor_a, anchor_b)
        n = 2
    elif t == SLIDER:
        axes, q = slider.dofs(frame_a, frame_b, anchor_a, anchor_b)
        n = 1
    else:
        axes, q = fixed.dofs(frame_a, frame_b, anchor_a, anchor_b)
        n = 0
    return n, axes, q, t == SLIDER, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b


@noalloc
def core_rows(t, rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm):
    """Write the core rows (those that hold it together) of a joint of type ``t`` between
    bodies ``a`` and ``b`` from row ``r`` on. (No model argument: handing the model's
    fifty arrays to this call for every joint cost more than writing the rows.)"""
    if t == BALL:
        ball.core_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm)
    elif t == HINGE:
        hinge.core_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm)
    elif t == UNIVERSAL:
        universal.core_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h,
                            cfm)
    elif t == FIXED:
        fixed.core_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm)
    elif t == SLIDER:
        slider.core_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm)


@noalloc
def build_joint_rows(m, pos, quat, vel, angvel, drive, h, erp, cfm, rows, servo_rows):
    """Write every joint's rows for one world. ``erp`` and ``cfm`` are the world's defaults;
    a joint's own values (>= 0) or its spring-damper override them.

    drive : JointDrive of this world. With ``servo_rows`` an active PD servo takes each
    DoF's motor row as an implicit spring-damper (see ``servo.servo_row_terms``);
    otherwise that row is the velocity motor when the joint has one."""
    for j in range(m.joint_type.shape[0]):
        t = m.joint_type[j]
        r = m.joint_row_start[j]
        a, b = m.joint_parent[j], m.joint_child[j]
        erp_h, cfm_v = _joint_erp_cfm(m, j, h, erp, cfm)
        n, axes, q, linear, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b = joint_dofs(m, pos, quat, j)
        core_rows(t, rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h,
                  cfm_v)
        r += m.joint_core_rows[j]
        servo = servo_rows and servo_active(drive, j)
        if servo:
            err = pd_error(t, q, frame_a, frame_b, drive.target_quat[j], drive.target_q[j])
        swing_twist = _has_swing_twist(m, j)
        for d in range(n):
            e_ax = axes[d]
            if not swing_twist:      # (a cone's or twist's rows: _swing_twist_rows below)
                qd = _dof_velocity(e_ax, linear, a, b, vel, angvel, r_a, r_b)
                _limit_row(rows, r, m.joint_limit[j, 0], m.joint_limit[j, 1], a, b, e_ax, linear,
                           q[d], qd, h, erp_h, cfm_v, r_a, r_b)
            if servo:
                rhs, cfm_s = servo_row_terms(drive.kp[j], drive.kd[j], h, err[d],
                                             drive.target_qd[j, d])
                _dof_row(rows, r + 1, a, b, e_ax, linear, r_a, r_b, rhs, cfm_s,
                         drive.max_torque[j] * h)
            elif m.joint_motor_max[j] > 0.0:
                _dof_row(rows, r + 1, a, b, e_ax, linear, r_a, r_b, drive.motor_target[j, d],
                         0.0, m.joint_motor_max[j] * h)
            else:
                clear_row(rows, r + 1, a, b)
            if m.joint_damping[j] > 0.0:
                # implicit damper: force -c v  <=>  J v + p / (c h) = 0, unbounded
                _dof_row(rows, r + 2, a, b, e_ax, linear, r_a, r_b, 0.0,
                         1.0 / (m.joint_damping[j] * h), INF)
            else:
                clear_row(rows, r + 2, a, b)
            if m.joint_friction[j] > 0.0:
                _dof_row(rows, r + 3, a, b, e_ax, linear, r_a, r_b, 0.0, 0.0,
                         m.joint_friction[j] * h)
            else:
                clear_row(rows, r + 3, a, b)
            r += ROWS_PER_DOF
        for k in range(r, m.joint_row_start[j] + m.joint_row_count[j]):
            clear_row(rows, k, a, b)
    # in a pass of their own: inside the loop above, the call alone (taken or not) made
    # every joint's rows six times slower to build
    _swing_twist_rows(m, pos, quat, vel, angvel, h, erp, cfm, rows)


@noalloc
def core_error(m, pos, quat, rows, j):
    """Largest position error (m or rad) of joint ``j``'s core rows, as ``build_core_rows``
    measures it (the |rhs| of its rows); a ball joint's from its anchors alone, any other
    type's by writing its core rows."""
    anchor_a, anchor_b, r_a, r_b, frame_a, frame_b = joint_frames(m, pos, quat, j)
    if m.joint_type[j] == BALL:
        return max(abs(anchor_b[0] - anchor_a[0]), abs(anchor_b[1] - anchor_a[1]),
                   abs(anchor_b[2] - anchor_a[2]))
    r0 = m.joint_row_start[j]
    core_rows(m.joint_type[j], rows, r0, m.joint_parent[j], m.joint_child[j], anchor_a,
              anchor_b, r_a, r_b, frame_a, frame_b, 1.0, 0.0)
    biggest = 0.0
    for r in range(r0, r0 + m.joint_core_rows[j]):
        biggest = max(biggest, abs(rows.rhs[r]))
    return biggest


@noalloc
def build_core_rows(m, pos, quat, rows):
    """Write only the core rows of every joint (those that hold it together) with h = 1,
    ERP = 1 and no CFM: each row's rhs is then minus its position error (m or rad), as
    projection (``stabilize.py``) wants them."""
    for j in range(m.joint_type.shape[0]):
        anchor_a, anchor_b, r_a, r_b, frame_a, frame_b = joint_frames(m, pos, quat, j)
        core_rows(m.joint_type[j], rows, m.joint_row_start[j], m.joint_parent[j],
                  m.joint_child[j], anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, 1.0, 0.0)


@noalloc
def _swing_twist_rows(m, pos, quat, vel, angvel, h, erp, cfm, rows):
    """The limit rows of every ball joint with a swing cone or twist range."""
    for j in range(m.joint_type.shape[0]):
        if not _has_swing_twist(m, j):
            continue
        erp_h, cfm_v = _joint_erp_cfm(m, j, h, erp, cfm)
        anchor_a, anchor_b, r_a, r_b, frame_a, frame_b = joint_frames(m, pos, quat, j)
        a, b = m.joint_parent[j], m.joint_child[j]
        r = m.joint_row_start[j] + m.joint_core_rows[j]
        for d in range(3):
            _swing_twist_row(m, rows, r, j, d, a, b, frame_a, frame_b, vel, angvel, h,
                             erp_h, cfm_v, r_a, r_b)
            r += ROWS_PER_DOF


@njit(cache=True, inline="always")
def _has_swing_twist(m, j):
    """Whether joint j is a ball joint limited by a swing cone or a twist range."""
    return m.joint_type[j] == BALL and (m.joint_cone[j, 0] > 0.0
                                        or m.joint_twist[j, 0] <= m.joint_twist[j, 1])


@njit(cache=True, inline="always")
def _joint_erp_cfm(m, j, h, erp, cfm):
    """Joint j's (ERP / h, CFM / h): its spring-damper, its own values or the world's."""
    if m.joint_stiffness[j] > 0.0 or m.joint_soft_damping[j] > 0.0:
        e, c = soft_erp_cfm(m.joint_stiffness[j], m.joint_soft_damping[j], h)
    else:
        e = m.joint_erp[j] if m.joint_erp[j] >= 0.0 else erp
        c = m.joint_cfm[j] if m.joint_cfm[j] >= 0.0 else cfm
    return e / h, c / h


@noalloc
def _dof_velocity(e, linear, a, b, vel, angvel, r_a, r_b):
    """Rate of a joint coordinate along world axis ``e`` (rad/s or m/s)."""
    out = 0.0
    for k in range(3):
        wb = angvel[b, k] if b >= 0 else 0.0
        wa = angvel[a, k] if a >= 0 else 0.0
        if linear:
            vb = vel[b, k] if b >= 0 else 0.0
            va = vel[a, k] if a >= 0 else 0.0
            out += e[k] * (vb - va)
        else:
            out += e[k] * (wb - wa)
    if linear:   # add w x r at both anchors
        for side in range(2):
            body = b if side == 0 else a
            if body < 0:
                continue
            rr = r_b if side == 0 else r_a
            w = (angvel[body, 0], angvel[body, 1], angvel[body, 2])
            c = (w[1] * rr[2] - w[2] * rr[1], w[2] * rr[0] - w[0] * rr[2], w[0] * rr[1] - w[1] * rr[0])
            s = 1.0 if side == 0 else -1.0
            out += s * (e[0] * c[0] + e[1] * c[1] + e[2] * c[2])
    return out


@njit(cache=True, inline="always")
def _dof_row(rows, r, a, b, e, linear, r_a, r_b, rhs, cfm, bound):
    if linear:
        linear_row(rows, r, a, b, e, r_a, r_b, rhs, cfm, -bound, bound)
    else:
        angular_row(rows, r, a, b, e, rhs, cfm, -bound, bound)


@noalloc
def _limit_row(rows, r, lo, hi, a, b, e, linear, q, qd, h, erp_h, cfm, r_a, r_b):
    """A one-sided row when the coordinate is past the limit [lo, hi] or would cross it
    this step."""
    if lo > hi:                    # no limit
        clear_row(rows, r, a, b)
        return
    _bound_row(rows, r, a, b, e, linear, q - lo, hi - q, qd, h, erp_h, cfm, r_a, r_b)


@noalloc
def _bound_row(rows, r, a, b, e, linear, c_lo, c_hi, qd, h, erp_h, cfm, r_a, r_b):
    """The one-sided row of a coordinate with margins ``c_lo`` above its lower bound and
    ``c_hi`` below its upper one, moving at ``qd = e . (relative velocity)``: written when
    the nearer bound is crossed or would be this step, else the row is cleared."""
    if c_lo <= c_hi and (c_lo < 0.0 or c_lo + h * qd < 0.0):
        # moving the coordinate up is allowed; down only until the limit
        rhs = -erp_h * c_lo if c_lo < 0.0 else -c_lo / h
        _dof_row(rows, r, a, b, e, linear, r_a, r_b, rhs, cfm, INF)
        rows.lo[r] = 0.0
    elif c_hi < c_lo and (c_hi < 0.0 or c_hi - h * qd < 0.0):
        rhs = -erp_h * c_hi if c_hi < 0.0 else -c_hi / h
        ne = (-e[0], -e[1], -e[2])
        _dof_row(rows, r, a, b, ne, linear, r_a, r_b, rhs, cfm, INF)
        rows.lo[r] = 0.0
    else:
        clear_row(rows, r, a, b)


@noalloc
def _swing_twist_row(m, rows, r, j, d, a, b, frame_a, frame_b, vel, angvel, h, erp_h, cfm,
                     r_a, r_b):
    """Limit slot ``d`` of a ball joint with a cone or twist range: d = 0 the twist row,
    d = 1 the swing-cone row (one row: it pushes along the cone's normal), d = 2 unused."""
    if d == 0 and m.joint_twist[j, 0] <= m.joint_twist[j, 1]:
        tau, e, ok = ball.twist_terms(frame_a, frame_b)
        if ok:
            qd = _dof_velocity(e, np.bool_(False), a, b, vel, angvel, r_a, r_b)
            _bound_row(rows, r, a, b, e, np.bool_(False), tau - m.joint_twist[j, 0],
                       m.joint_twist[j, 1] - tau, qd, h, erp_h, cfm, r_a, r_b)
            return
    elif d == 1 and m.joint_cone[j, 0] > 0.0:
        margin, e, ok = ball.swing_terms(frame_a, frame_b, m.joint_cone[j, 0], m.joint_cone[j, 1])
        if ok:
            qd = _dof_velocity(e, np.bool_(False), a, b, vel, angvel, r_a, r_b)
            _bound_row(rows, r, a, b, e, np.bool_(False), INF, margin, qd, h, erp_h, cfm, r_a, r_b)
            return
    clear_row(rows, r, a, b)


@noalloc
def joint_coordinates(m, pos, quat, vel, angvel, q_out, qd_out, qrel_out):
    """Coordinates (nj, 3), their rates (nj, 3) and relative rotations (nj, 4) of every joint.

    Hinge: angle (rad). Slider: displacement (m). Universal: angles about axes 1 and 2.
    Ball: rotation vector of the child joint frame in the parent's (rad). Rates are the
    relative angular velocity (or anchor velocity for sliders) along the same axes.
    """
    for j in range(m.joint_type.shape[0]):
        a, b = m.joint_parent[j], m.joint_child[j]
        n, axes, q, linear, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b = joint_dofs(m, pos, quat, j)
        rel = quat_mul(quat_conj(frame_a), frame_b)
        for k in range(4):
            qrel_out[j, k] = rel[k]
        for d in range(3):
            if d < n:
                q_out[j, d] = q[d]
                qd_out[j, d] = _dof_velocity(axes[d], linear, a, b, vel, angvel, r_a, r_b)
            else:
                q_out[j, d] = 0.0
                qd_out[j, d] = 0.0


@noalloc
def joint_reactions(m, pos, quat, rows, impulse, h, force_out, torque_out):
    """Force (N) and torque about the anchor (N m) each joint exerts on its child, world frame,
    averaged over the step: the impulses of all its rows divided by ``h``."""
    for j in range(m.joint_type.shape[0]):
        for k in range(3):
            force_out[j, k] = 0.0
            torque_out[j, k] = 0.0
        for r in range(m.joint_row_start[j], m.joint_row_start[j] + m.joint_row_count[j]):
            p = impulse[r] / h
            for k in range(3):
                force_out[j, k] += rows.J[r, 6 + k] * p
                torque_out[j, k] += rows.J[r, 9 + k] * p
        r_b = joint_frames(m, pos, quat, j)[3]
        f = force_out[j]
        # torque about the COM = torque about the anchor + r_b x f
        c = (r_b[1] * f[2] - r_b[2] * f[1], r_b[2] * f[0] - r_b[0] * f[2], r_b[0] * f[1] - r_b[1] * f[0])
        for k in range(3):
            torque_out[j, k] -= c[k]
