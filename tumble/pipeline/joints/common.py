"""Helpers shared by the joint types: the frames of a joint and how a row is written.

A constraint row r acts between a parent body ``a`` (or the world, -1) and a child body
``b``. Its Jacobian ``J[r]`` (12,) holds [lin_a, ang_a, lin_b, ang_b], world frame, so
the row's velocity is ``J . (v_a, w_a, v_b, w_b)``. The solver finds an impulse ``p[r]``
(N s, or N m s for angular rows) within ``[lo[r], hi[r]]`` such that

    J v_new + cfm[r] p = rhs[r]

where ``rhs`` is the target velocity (ERP drift correction, motor speed) and ``cfm``
the softness in velocity per impulse (ODE's CFM divided by the step).
"""
import math

from numba import njit

from ..._jit import noalloc
from ...math.quat import quat_conj, quat_mul, quat_rotate

INF = 1e300


@njit(cache=True, inline="always")
def body_pose(pos, quat, b):
    """Position and orientation of body ``b``; the world (-1) is the identity at the origin."""
    if b < 0:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)
    return (pos[b, 0], pos[b, 1], pos[b, 2]), (quat[b, 0], quat[b, 1], quat[b, 2], quat[b, 3])


@noalloc
def joint_frames(m, pos, quat, j):
    """World-frame anchor points and joint-frame orientations of joint ``j``.

    Returns (anchor_a, anchor_b, r_a, r_b, frame_a, frame_b): anchors in the world as
    attached to the parent and to the child, lever arms from each COM, and the joint
    frame as carried by each body (x, y, z, w).
    """
    a, b = m.joint_parent[j], m.joint_child[j]
    xa, qa = body_pose(pos, quat, a)
    xb, qb = body_pose(pos, quat, b)
    r_a = quat_rotate(qa, m.joint_anchor_a[j])
    r_b = quat_rotate(qb, m.joint_anchor_b[j])
    anchor_a = (xa[0] + r_a[0], xa[1] + r_a[1], xa[2] + r_a[2])
    anchor_b = (xb[0] + r_b[0], xb[1] + r_b[1], xb[2] + r_b[2])
    frame_a = quat_mul(qa, m.joint_frame_a[j])
    frame_b = quat_mul(qb, m.joint_frame_b[j])
    return anchor_a, anchor_b, r_a, r_b, frame_a, frame_b


@njit(cache=True, inline="always")
def set_row(rows, r, a, b, lin_a, ang_a, lin_b, ang_b, rhs, cfm, lo, hi):
    """Write row ``r`` of the row arrays (see the module docstring)."""
    rows.body_a[r] = a
    rows.body_b[r] = b
    jr = rows.J[r]           # a view: its indices need no negative wrap-around
    for k in range(3):
        jr[k] = lin_a[k]
        jr[3 + k] = ang_a[k]
        jr[6 + k] = lin_b[k]
        jr[9 + k] = ang_b[k]
    rows.rhs[r] = rhs
    rows.cfm[r] = cfm
    rows.lo[r] = lo
    rows.hi[r] = hi
    rows.parent[r] = -1
    rows.mu[r] = 0.0
    rows.group[r] = -1


@njit(cache=True, inline="always")
def clear_row(rows, r, a, b):
    """An inactive row (an unreached limit, a motor switched off): no effect, zero impulse.

    Only what marks it inactive is written (``lo == hi == 0``, no friction parent: see
    ``solvers.common.row_active``): every solver skips such a row and zeroes its impulse,
    so its Jacobian is never read but times that zero (``joint_reactions``)."""
    rows.body_a[r] = a
    rows.body_b[r] = b
    rows.rhs[r] = 0.0
    rows.cfm[r] = 0.0
    rows.lo[r] = 0.0
    rows.hi[r] = 0.0
    rows.parent[r] = -1


@njit(cache=True, inline="always")
def linear_row(rows, r, a, b, e, r_a, r_b, rhs, cfm, lo, hi):
    """Row on the relative velocity of the anchor points along the world direction ``e``:
    ``e . (v_b + w_b x r_b - v_a - w_a x r_a)``."""
    ca = (r_a[1] * e[2] - r_a[2] * e[1], r_a[2] * e[0] - r_a[0] * e[2], r_a[0] * e[1] - r_a[1] * e[0])
    cb = (r_b[1] * e[2] - r_b[2] * e[1], r_b[2] * e[0] - r_b[0] * e[2], r_b[0] * e[1] - r_b[1] * e[0])
    set_row(rows, r, a, b, (-e[0], -e[1], -e[2]), (-ca[0], -ca[1], -ca[2]), e, cb,
            rhs, cfm, lo, hi)


@njit(cache=True, inline="always")
def angular_row(rows, r, a, b, e, rhs, cfm, lo, hi):
    """Row on the relative angular velocity about the world direction ``e``: ``e . (w_b - w_a)``."""
    z = (0.0, 0.0, 0.0)
    set_row(rows, r, a, b, z, (-e[0], -e[1], -e[2]), z, e, rhs, cfm, lo, hi)


@noalloc
def point_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, erp_h, cfm):
    """Three rows keeping the two anchor points together (ball, hinge, universal, fixed)."""
    for k in range(3):
        e = (1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0)
        c = anchor_b[k] - anchor_a[k]
        linear_row(rows, r + k, a, b, e, r_a, r_b, -erp_h * c, cfm, -INF, INF)


@noalloc
def angle_about_x(frame_a, frame_b):
    """Angle (rad, in (-pi, pi]) of joint frame b about the x axis of joint frame a, any
    rotation about the other axes left out: the hinge angle, the ball's twist."""
    rel = quat_mul(quat_conj(frame_a), frame_b)
    angle = 2.0 * math.atan2(rel[0], rel[3])
    if angle > math.pi:
        angle -= 2.0 * math.pi
    elif angle <= -math.pi:
        angle += 2.0 * math.pi
    return angle
