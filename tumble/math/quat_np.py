"""Vectorised quaternion helpers, (..., 4) arrays (x, y, z, w), broadcast over leading axes.

Plain NumPy, for code that works on whole skeletons and motions at once outside the
compiled step (motion files, the character layer, the viewer); the Numba kernels of
``tumble.math.quat`` do the same for one quaternion at a time. The ``*_one`` helpers
at the end take a single quaternion and skip the broadcasting, for per-step
controller code where that overhead dominates.
"""
import math

import numpy as np

IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])


def qmul(a, b):
    """Hamilton product ``a * b`` (apply b, then a), broadcast over leading axes."""
    ax, ay, az, aw = np.moveaxis(np.asarray(a, float), -1, 0)
    bx, by, bz, bw = np.moveaxis(np.asarray(b, float), -1, 0)
    return np.stack((aw * bx + bw * ax + ay * bz - az * by,
                     aw * by + bw * ay + az * bx - ax * bz,
                     aw * bz + bw * az + ax * by - ay * bx,
                     aw * bw - ax * bx - ay * by - az * bz), axis=-1)


def qconj(q):
    """Conjugate, the inverse of a unit quaternion."""
    return np.asarray(q, float) * np.array([-1.0, -1.0, -1.0, 1.0])


def _cross(a, b):
    """a x b over leading axes, written out (np.cross is slow on small arrays)."""
    return np.stack((a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]), axis=-1)


def qrot(q, v):
    """Rotate vectors ``v`` (..., 3) by unit quaternions ``q`` (..., 4)."""
    q = np.asarray(q, float)
    v = np.asarray(v, float)
    u, w = q[..., :3], q[..., 3:]
    t = 2.0 * _cross(u, v)
    return v + w * t + _cross(u, t)


def qmatrix(q):
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4); (n, 4) gives (n, 3, 3)."""
    x, y, z, w = np.moveaxis(np.asarray(q, float), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def qrotvec(q):
    """Rotation vector (..., 3) of unit quaternions, angle in [0, pi] (rad)."""
    q = np.where(q[..., 3:] < 0.0, -q, q)
    v = q[..., :3]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., 3:])
    # angle / s tends to 2 / w for small rotations; use that limit where s is tiny.
    small = s < 1e-12
    factor = np.where(small, 2.0 / np.maximum(q[..., 3:], 1e-300), angle / np.where(small, 1.0, s))
    return v * factor


def qangle(q):
    """Rotation angle (...,) in [0, pi] of unit quaternions."""
    q = np.asarray(q, float)
    return 2.0 * np.arctan2(np.linalg.norm(q[..., :3], axis=-1), np.abs(q[..., 3]))


def qarc(u, v):
    """Shortest-arc unit quaternion turning the unit vector ``u`` (3,) onto the unit ``v``."""
    c = float(np.dot(u, v))
    if c < -1.0 + 1e-12:
        # Opposite vectors: half turn about any axis perpendicular to u.
        helper = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        axis = np.cross(u, helper)
        axis /= np.linalg.norm(axis)
        return np.array([axis[0], axis[1], axis[2], 0.0])
    axis = np.cross(u, v)
    q = np.array([axis[0], axis[1], axis[2], 1.0 + c])
    return q / np.linalg.norm(q)


def qfrom_matrix(m):
    """Unit quaternion of a rotation matrix (3, 3) (Shepperd's method, w >= 0)."""
    m = np.asarray(m, float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0.0:
        s = 2.0 * np.sqrt(1.0 + tr)
        q = np.array([(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s,
                      (m[1, 0] - m[0, 1]) / s, 0.25 * s])
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = np.zeros(4)
        q[i] = 0.25 * s
        q[j] = (m[j, i] + m[i, j]) / s
        q[k] = (m[k, i] + m[i, k]) / s
        q[3] = (m[k, j] - m[j, k]) / s
    q /= np.linalg.norm(q)
    return q if q[3] >= 0.0 else -q


def qslerp(q0, q1, alpha):
    """Spherical interpolation from q0 (alpha = 0) to q1 (alpha = 1) along the short arc.

    q0, q1: (..., 4); alpha: broadcastable to (..., 1). Returns q0 exactly where alpha == 0.
    """
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0.0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_theta = np.sin(theta)
    # Nearly equal rotations: sin(theta) ~ 0, normalised lerp is exact to rounding.
    near = sin_theta < 1e-9
    safe = np.where(near, 1.0, sin_theta)
    w0 = np.where(near, 1.0 - alpha, np.sin((1.0 - alpha) * theta) / safe)
    w1 = np.where(near, alpha, np.sin(alpha * theta) / safe)
    out = w0 * q0 + w1 * q1
    out /= np.linalg.norm(out, axis=-1, keepdims=True)
    return np.where(np.asarray(alpha) == 0.0, q0, out)


def qmul_one(a, b):
    """Hamilton product ``a * b`` of two single quaternions (4,)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array((aw * bx + bw * ax + ay * bz - az * by, aw * by + bw * ay + az * bx - ax * bz,
                     aw * bz + bw * az + ax * by - ay * bx, aw * bw - ax * bx - ay * by - az * bz))


def qconj_one(q):
    """Conjugate of a single quaternion (4,)."""
    return np.array((-q[0], -q[1], -q[2], q[3]))


def qrot_one(q, v):
    """Rotate one vector (3,) by one unit quaternion (4,)."""
    x, y, z, w = q
    vx, vy, vz = v
    tx, ty, tz = 2 * (y * vz - z * vy), 2 * (z * vx - x * vz), 2 * (x * vy - y * vx)
    return np.array((vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz,
                     vz + w * tz + x * ty - y * tx))


def qaxis_angle_one(axis, angle):
    """Unit quaternion (4,) of ``angle`` rad about the unit ``axis`` (3,)."""
    s = math.sin(0.5 * angle)
    return np.array([axis[0] * s, axis[1] * s, axis[2] * s, math.cos(0.5 * angle)])
