"""Slider (prismatic): orientation locked; the child's anchor moves only along the axis."""
from ..._jit import noalloc
from ...math.quat import quat_rotate
from .common import INF, set_row
from .fixed import angular_lock_rows


@noalloc
def core_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm):
    angular_lock_rows(rows, r, a, b, frame_a, frame_b, erp_h, cfm)
    d = (anchor_b[0] - anchor_a[0], anchor_b[1] - anchor_a[1], anchor_b[2] - anchor_a[2])
    for k in range(2):
        t = quat_rotate(frame_a, (0.0, 1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0))
        # d/dt (t . d) with t carried by the parent: t . d' + w_a . (t x d)
        txd = (t[1] * d[2] - t[2] * d[1], t[2] * d[0] - t[0] * d[2], t[0] * d[1] - t[1] * d[0])
        ca = (r_a[1] * t[2] - r_a[2] * t[1], r_a[2] * t[0] - r_a[0] * t[2], r_a[0] * t[1] - r_a[1] * t[0])
        cb = (r_b[1] * t[2] - r_b[2] * t[1], r_b[2] * t[0] - r_b[0] * t[2], r_b[0] * t[1] - r_b[1] * t[0])
        c = t[0] * d[0] + t[1] * d[1] + t[2] * d[2]
        set_row(rows, r + 3 + k, a, b, (-t[0], -t[1], -t[2]),
                (txd[0] - ca[0], txd[1] - ca[1], txd[2] - ca[2]), t, cb, -erp_h * c, cfm,
                -INF, INF)


@noalloc
def dofs(frame_a, frame_b, anchor_a, anchor_b):
    """Axis (world) and displacement (m) of the child's anchor along it."""
    axis = quat_rotate(frame_a, (1.0, 0.0, 0.0))
    s = (axis[0] * (anchor_b[0] - anchor_a[0]) + axis[1] * (anchor_b[1] - anchor_a[1])
         + axis[2] * (anchor_b[2] - anchor_a[2]))
    return (axis, axis, axis), (s, 0.0, 0.0)
