"""Ball-and-socket joint: the two anchor points coincide; rotation is free (3 DoF)."""
from ..._jit import noalloc
from ...math.quat import quat_conj, quat_log, quat_mul, quat_rotate
from .common import point_rows


@noalloc
def core_rows(m, rows, r, j, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm):
    point_rows(rows, r, m.joint_parent[j], m.joint_child[j], anchor_a, anchor_b, r_a, r_b,
               erp_h, cfm)


@noalloc
def dofs(frame_a, frame_b, anchor_a, anchor_b):
    """Axes: the parent joint frame's x, y, z (world); coordinates: the rotation vector of
    the child joint frame relative to the parent's (rad), in the parent joint frame."""
    rel = quat_mul(quat_conj(frame_a), frame_b)
    rv = quat_log(rel)
    return (quat_rotate(frame_a, (1.0, 0.0, 0.0)), quat_rotate(frame_a, (0.0, 1.0, 0.0)),
            quat_rotate(frame_a, (0.0, 0.0, 1.0))), rv
