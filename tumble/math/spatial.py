"""Small vector and rigid-body kernels: cross products, skew matrices, world inertia.

Like ``quat.py``, these take sequences and return tuples (matrices as row-major
nested tuples) so compiled loops do not allocate.
"""
from numba import njit

from .quat import quat_rotate, quat_rotate_inv


@njit(cache=True, inline="always")
def cross(a, b):
    """``a x b``."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, inline="always")
def dot(a, b):
    """``a . b`` for 3-vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, inline="always")
def skew(v):
    """The matrix ``[v]x`` with ``[v]x u = v x u``, as a nested tuple (3, 3)."""
    return ((0.0, -v[2], v[1]), (v[2], 0.0, -v[0]), (-v[1], v[0], 0.0))


@njit(cache=True, inline="always")
def mat_vec(m, v):
    """``m v`` for a (3, 3) matrix and a 3-vector."""
    return (m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
            m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
            m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2])


@njit(cache=True, inline="always")
def inertia_world(q, inertia_b):
    """World-frame inertia ``R diag(I) R^T`` of a body with orientation ``q``.

    ``inertia_b`` holds the principal moments (3,) in kg m^2.
    """
    x, y, z, w = q[0], q[1], q[2], q[3]
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r01 = 2.0 * (x * y - z * w)
    r02 = 2.0 * (x * z + y * w)
    r10 = 2.0 * (x * y + z * w)
    r11 = 1.0 - 2.0 * (x * x + z * z)
    r12 = 2.0 * (y * z - x * w)
    r20 = 2.0 * (x * z - y * w)
    r21 = 2.0 * (y * z + x * w)
    r22 = 1.0 - 2.0 * (x * x + y * y)
    a, b, c = inertia_b[0], inertia_b[1], inertia_b[2]
    m00 = a * r00 * r00 + b * r01 * r01 + c * r02 * r02
    m01 = a * r00 * r10 + b * r01 * r11 + c * r02 * r12
    m02 = a * r00 * r20 + b * r01 * r21 + c * r02 * r22
    m11 = a * r10 * r10 + b * r11 * r11 + c * r12 * r12
    m12 = a * r10 * r20 + b * r11 * r21 + c * r12 * r22
    m22 = a * r20 * r20 + b * r21 * r21 + c * r22 * r22
    return ((m00, m01, m02), (m01, m11, m12), (m02, m12, m22))


@njit(cache=True, inline="always")
def inertia_world_inv(q, inv_inertia_b):
    """Inverse world inertia ``R diag(1/I) R^T``; takes the inverse principal moments."""
    return inertia_world(q, inv_inertia_b)


@njit(cache=True, inline="always")
def apply_inertia(q, inertia_b, w):
    """``I_w w`` without forming the matrix: rotate to the body, scale, rotate back."""
    wb = quat_rotate_inv(q, w)
    return quat_rotate(q, (inertia_b[0] * wb[0], inertia_b[1] * wb[1], inertia_b[2] * wb[2]))


@njit(cache=True, inline="always")
def point_velocity(vel, angvel, com, point):
    """Velocity of a world point attached to a body: ``v + w x (p - com)`` (m/s)."""
    r = (point[0] - com[0], point[1] - com[1], point[2] - com[2])
    c = cross(angvel, r)
    return (vel[0] + c[0], vel[1] + c[1], vel[2] + c[2])
