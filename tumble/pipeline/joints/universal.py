"""Universal (Cardan) joint: anchors coincide; the child turns about the parent's axis 1
(joint-frame x, carried by the parent) and its own axis 2 (joint-frame y, carried by the
child), which stay perpendicular."""
import math


from ..._jit import noalloc
from ...math.quat import quat_conj, quat_mul, quat_rotate
from .common import INF, angular_row, point_rows


@noalloc
def core_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm):
    point_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, erp_h, cfm)
    a1 = quat_rotate(frame_a, (1.0, 0.0, 0.0))
    a2 = quat_rotate(frame_b, (0.0, 1.0, 0.0))
    # d/dt (a1 . a2) = (w_b - w_a) . (a2 x a1)
    u = (a2[1] * a1[2] - a2[2] * a1[1], a2[2] * a1[0] - a2[0] * a1[2], a2[0] * a1[1] - a2[1] * a1[0])
    n = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
    u = (u[0] / n, u[1] / n, u[2] / n)
    c = (a1[0] * a2[0] + a1[1] * a2[1] + a1[2] * a2[2]) / n
    angular_row(rows, r + 3, a, b, u, -erp_h * c, cfm, -INF, INF)


@noalloc
def dofs(frame_a, frame_b, anchor_a, anchor_b):
    """Axes 1 (parent) and 2 (child), world; angles about them (rad): the rotation of the
    child joint frame relative to the parent's as x-then-y Cardan angles."""
    rel = quat_mul(quat_conj(frame_a), frame_b)
    x, y, z, w = rel[0], rel[1], rel[2], rel[3]
    # rel = Rx(t1) Ry(t2): angles from the rotation matrix entries
    t1 = math.atan2(-2.0 * (y * z - x * w), 1.0 - 2.0 * (x * x + y * y))
    t2 = math.asin(max(-1.0, min(1.0, 2.0 * (x * z + y * w))))
    a1 = quat_rotate(frame_a, (1.0, 0.0, 0.0))
    a2 = quat_rotate(frame_b, (0.0, 1.0, 0.0))
    return (a1, a2, a2), (t1, t2, 0.0)
