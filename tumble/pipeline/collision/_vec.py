"""Tuple 3-vector helpers for the collision kernels.

Every helper takes sequences (tuples or arrays) and returns float tuples, so the
kernels never allocate. Private to the collision package.
"""
import math

from numba import njit

from ..._jit import noalloc

from ...math.quat import quat_rotate


@noalloc
def v3(a):
    """A 3-sequence as a float tuple."""
    return (float(a[0]), float(a[1]), float(a[2]))


@noalloc
def q4(a):
    """A 4-sequence (quaternion) as a float tuple."""
    return (float(a[0]), float(a[1]), float(a[2]), float(a[3]))


@noalloc
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@noalloc
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@noalloc
def scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@noalloc
def madd(a, b, s):
    """``a + s b``."""
    return (a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2])


@noalloc
def neg(a):
    return (-a[0], -a[1], -a[2])


@noalloc
def vdot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@noalloc
def vcross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@noalloc
def norm2(a):
    return a[0] * a[0] + a[1] * a[1] + a[2] * a[2]


@noalloc
def norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@noalloc
def mid(a, b):
    return (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2]))


@noalloc
def clamp(x, lo, hi):
    if x < lo:
        return lo
    if x > hi:
        return hi
    return x


@noalloc
def any_perp(u):
    """A unit vector perpendicular to the unit vector ``u`` (deterministic)."""
    ax, ay, az = abs(u[0]), abs(u[1]), abs(u[2])
    if ax <= ay and ax <= az:
        p = (0.0, u[2], -u[1])
    elif ay <= az:
        p = (-u[2], 0.0, u[0])
    else:
        p = (u[1], -u[0], 0.0)
    n = norm(p)
    return (p[0] / n, p[1] / n, p[2] / n)


@noalloc
def normalize_or(a, fallback):
    """``a / |a|``, or ``fallback`` when ``a`` is zero. Scaled first so that tiny
    (even subnormal-squared) vectors still give an exact unit vector."""
    m = max(abs(a[0]), max(abs(a[1]), abs(a[2])))
    if not m > 0.0 or m == math.inf:
        return (fallback[0], fallback[1], fallback[2])
    x, y, z = a[0] / m, a[1] / m, a[2] / m
    n = math.sqrt(x * x + y * y + z * z)
    return (x / n, y / n, z / n)


@noalloc
def frame_axes(q):
    """World directions of the local x, y, z axes of orientation ``q``."""
    return (quat_rotate(q, (1.0, 0.0, 0.0)), quat_rotate(q, (0.0, 1.0, 0.0)),
            quat_rotate(q, (0.0, 0.0, 1.0)))


@noalloc
def local_to_world(pos, q, p):
    r = quat_rotate(q, p)
    return (pos[0] + r[0], pos[1] + r[1], pos[2] + r[2])


@noalloc
def write_contact(out_point, out_normal, out_depth, out_feature, row, p, n, depth, feature):
    """Store one contact in row ``row`` of the output arrays."""
    out_point[row, 0] = p[0]
    out_point[row, 1] = p[1]
    out_point[row, 2] = p[2]
    out_normal[row, 0] = n[0]
    out_normal[row, 1] = n[1]
    out_normal[row, 2] = n[2]
    out_depth[row] = depth
    out_feature[row] = feature
