"""Quaternion kernels, (x, y, z, w) scalar last.

Every function takes 3- or 4-element sequences (NumPy arrays or tuples) and returns
tuples, so the compiled pipeline can call them in its inner loops without allocating.
In Python, wrap a result with ``numpy.asarray``.

Rotation convention: a unit quaternion ``q`` maps body-frame vectors to the world,
``v_w = q * v_b * q^-1``; ``quat_mul(a, b)`` applies ``b`` first, then ``a``.
"""
import math

from numba import njit

# Below this angle the sin(x)/x series replaces the closed form, to avoid 0/0.
_SMALL_ANGLE = 1e-8


@njit(cache=True, inline="always")
def quat_identity():
    """The identity rotation (0, 0, 0, 1)."""
    return (0.0, 0.0, 0.0, 1.0)


@njit(cache=True, inline="always")
def quat_mul(a, b):
    """Hamilton product ``a * b`` (rotate by ``b``, then by ``a``)."""
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    bx, by, bz, bw = b[0], b[1], b[2], b[3]
    return (aw * bx + bw * ax + ay * bz - az * by,
            aw * by + bw * ay + az * bx - ax * bz,
            aw * bz + bw * az + ax * by - ay * bx,
            aw * bw - ax * bx - ay * by - az * bz)


@njit(cache=True, inline="always")
def quat_conj(q):
    """Conjugate; the inverse of a unit quaternion."""
    return (-q[0], -q[1], -q[2], q[3])


@njit(cache=True, inline="always")
def quat_normalize(q):
    """``q / |q|``. The caller guarantees ``|q| > 0`` (models and states are checked)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    inv = 1.0 / n
    return (q[0] * inv, q[1] * inv, q[2] * inv, q[3] * inv)


@njit(cache=True, inline="always")
def quat_rotate(q, v):
    """Rotate vector ``v`` by unit quaternion ``q`` (body -> world)."""
    qx, qy, qz, qw = q[0], q[1], q[2], q[3]
    # t = 2 (q_v x v);  v' = v + w t + q_v x t
    tx = 2.0 * (qy * v[2] - qz * v[1])
    ty = 2.0 * (qz * v[0] - qx * v[2])
    tz = 2.0 * (qx * v[1] - qy * v[0])
    return (v[0] + qw * tx + (qy * tz - qz * ty),
            v[1] + qw * ty + (qz * tx - qx * tz),
            v[2] + qw * tz + (qx * ty - qy * tx))


@njit(cache=True, inline="always")
def quat_rotate_inv(q, v):
    """Rotate vector ``v`` by the inverse of unit quaternion ``q`` (world -> body)."""
    return quat_rotate(quat_conj(q), v)


@njit(cache=True, inline="always")
def quat_to_mat(q):
    """Rotation matrix of unit quaternion ``q`` as a row-major nested tuple (3, 3)."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    return ((1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)),
            (2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)),
            (2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)))


@njit(cache=True)
def quat_from_mat(m):
    """Unit quaternion of a proper rotation matrix ``m`` (3, 3), with w >= 0.

    Shepperd's method: branch on the largest of w, x, y, z so the square root is
    never taken of a small number.
    """
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr >= m[0][0] and tr >= m[1][1] and tr >= m[2][2]:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = ((m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s)
    elif m[0][0] >= m[1][1] and m[0][0] >= m[2][2]:
        s = 2.0 * math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2])
        q = (0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s)
    elif m[1][1] >= m[2][2]:
        s = 2.0 * math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2])
        q = ((m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1])
        q = ((m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s)
    q = quat_normalize(q)
    if q[3] < 0.0:
        return (-q[0], -q[1], -q[2], -q[3])
    return q


@njit(cache=True, inline="always")
def quat_exp(r):
    """Quaternion of the rotation vector ``r`` (axis * angle, radians)."""
    angle = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    half = 0.5 * angle
    if angle < _SMALL_ANGLE:
        s = 0.5 - angle * angle / 48.0          # sin(a/2)/a, series
    else:
        s = math.sin(half) / angle
    return (r[0] * s, r[1] * s, r[2] * s, math.cos(half))


@njit(cache=True, inline="always")
def quat_log(q):
    """Rotation vector (axis * angle, angle in [0, pi]) of unit quaternion ``q``."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    if w < 0.0:                                  # q and -q are the same rotation
        x, y, z, w = -x, -y, -z, -w
    s = math.sqrt(x * x + y * y + z * z)
    if s < _SMALL_ANGLE:
        k = 2.0 / w                              # angle / sin(angle/2) -> 2 / cos(angle/2)
    else:
        k = 2.0 * math.atan2(s, w) / s
    return (x * k, y * k, z * k)


@njit(cache=True, inline="always")
def quat_from_axis_angle(axis, angle):
    """Quaternion rotating by ``angle`` (radians) about ``axis`` (normalised here)."""
    n = math.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
    s = math.sin(0.5 * angle) / n
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(0.5 * angle))


@njit(cache=True, inline="always")
def quat_integrate_linear(q, w, h):
    """The lecture's update ``q + h/2 (w, 0) * q``, normalised.

    ``w`` is the world-frame angular velocity (rad/s), ``h`` the step (s).
    First order: the rotation angle is slightly short for large ``|w| h``.
    """
    dq = quat_mul((w[0], w[1], w[2], 0.0), q)
    k = 0.5 * h
    return quat_normalize((q[0] + k * dq[0], q[1] + k * dq[1], q[2] + k * dq[2], q[3] + k * dq[3]))


@njit(cache=True, inline="always")
def quat_integrate_exp(q, w, h):
    """``exp(h w) * q``: exact for a constant world-frame angular velocity ``w``."""
    return quat_normalize(quat_mul(quat_exp((w[0] * h, w[1] * h, w[2] * h)), q))
