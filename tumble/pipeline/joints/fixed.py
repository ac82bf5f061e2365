"""Fixed joint: anchors coincide and the relative orientation is locked (0 DoF)."""
from ..._jit import noalloc
from ...math.quat import quat_conj, quat_log, quat_mul
from .common import INF, angular_row, point_rows


@noalloc
def angular_lock_rows(rows, r, a, b, frame_a, frame_b, erp_h, cfm):
    """Three rows holding the child joint frame at the parent's orientation."""
    err = quat_log(quat_mul(frame_b, quat_conj(frame_a)))   # world rotation vector, a -> b
    for k in range(3):
        e = (1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0)
        angular_row(rows, r + k, a, b, e, -erp_h * err[k], cfm, -INF, INF)


@noalloc
def core_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm):
    point_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, erp_h, cfm)
    angular_lock_rows(rows, r + 3, a, b, frame_a, frame_b, erp_h, cfm)


@noalloc
def dofs(frame_a, frame_b, anchor_a, anchor_b):
    z = (0.0, 0.0, 0.0)
    return (z, z, z), z
