"""Hinge: anchors coincide and the child turns only about the joint axis (x of the joint frame)."""
from ..._jit import noalloc
from ...math.quat import quat_rotate
from .common import INF, angle_about_x, angular_row, point_rows


@noalloc
def core_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm):
    point_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, erp_h, cfm)
    axis_a = quat_rotate(frame_a, (1.0, 0.0, 0.0))
    axis_b = quat_rotate(frame_b, (1.0, 0.0, 0.0))
    # The child's axis tilted by a small angle t about u gives axis_a x axis_b = t u.
    err = (axis_a[1] * axis_b[2] - axis_a[2] * axis_b[1],
           axis_a[2] * axis_b[0] - axis_a[0] * axis_b[2],
           axis_a[0] * axis_b[1] - axis_a[1] * axis_b[0])
    for k in range(2):
        u = quat_rotate(frame_a, (0.0, 1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0))
        c = u[0] * err[0] + u[1] * err[1] + u[2] * err[2]
        angular_row(rows, r + 3 + k, a, b, u, -erp_h * c, cfm, -INF, INF)


@noalloc
def dofs(frame_a, frame_b, anchor_a, anchor_b):
    """Axis (world) and hinge angle (rad, in (-pi, pi]) of the child about it."""
    angle = angle_about_x(frame_a, frame_b)
    axis = quat_rotate(frame_a, (1.0, 0.0, 0.0))
    return (axis, axis, axis), (angle, 0.0, 0.0)
