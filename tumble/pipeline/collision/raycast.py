"""Ray casts against single geoms.

``raycast_geom(type, pos, quat, size, origin, direction, max_dist)`` returns
``(distance, normal)``: the distance along the unit ``direction`` to the first
surface hit (``0 <= distance <= max_dist``) and the outward surface normal there
(world frame), or ``(-1.0, (0, 0, 0))`` for a miss. A ray starting strictly inside a
solid (planes are solid below) hits at distance 0 with normal ``-direction``.
"""
import math

from numba import njit

from ...math.quat import quat_rotate, quat_rotate_inv
from ._vec import clamp, q4, sub, v3
from .shapes import BOX, CAPSULE, PLANE, SPHERE

_MISS = (-1.0, (0.0, 0.0, 0.0))


@njit(cache=True)
def _sphere_entry(o, d, cz, r):
    """Entry ``t`` of the ray into the ball of radius r centred at (0, 0, cz), or -1."""
    ox, oy, oz = o[0], o[1], o[2] - cz
    b = ox * d[0] + oy * d[1] + oz * d[2]
    c = ox * ox + oy * oy + oz * oz - r * r
    disc = b * b - c
    if disc < 0.0:
        return -1.0
    t = -b - math.sqrt(disc)
    return t


@njit(cache=True)
def _side_entry(o, d, r):
    """Entry ``t`` into the infinite cylinder x^2 + y^2 <= r^2, or -1."""
    a = d[0] * d[0] + d[1] * d[1]
    if a <= 1e-300:
        return -1.0
    b = o[0] * d[0] + o[1] * d[1]
    c = o[0] * o[0] + o[1] * o[1] - r * r
    disc = b * b - a * c
    if disc < 0.0:
        return -1.0
    return (-b - math.sqrt(disc)) / a


@njit(cache=True)
def _ray_local(gtype, o, d, size):
    """Hit in the geom frame: ``(t, local normal)``, t < 0 for a miss, t = 0 and a zero
    normal when the origin is inside."""
    z3 = (0.0, 0.0, 0.0)
    if gtype == PLANE:
        if o[2] < 0.0:
            return 0.0, z3
        if d[2] >= 0.0:
            return -1.0, z3
        return -o[2] / d[2], (0.0, 0.0, 1.0)
    if gtype == SPHERE:
        r = size[0]
        if o[0] * o[0] + o[1] * o[1] + o[2] * o[2] < r * r:
            return 0.0, z3
        t = _sphere_entry(o, d, 0.0, r)
        if t < 0.0:
            return -1.0, z3
        return t, ((o[0] + t * d[0]) / r, (o[1] + t * d[1]) / r, (o[2] + t * d[2]) / r)
    if gtype == BOX:
        if abs(o[0]) < size[0] and abs(o[1]) < size[1] and abs(o[2]) < size[2]:
            return 0.0, z3
        tnear = -math.inf
        tfar = math.inf
        ax = 0
        for i in range(3):
            h = size[i]
            if abs(d[i]) <= 1e-300:
                if abs(o[i]) > h:
                    return -1.0, z3
                continue
            t1 = (-h - o[i]) / d[i]
            t2 = (h - o[i]) / d[i]
            if t1 > t2:
                t1, t2 = t2, t1
            if t1 > tnear:
                tnear = t1
                ax = i
            if t2 < tfar:
                tfar = t2
        if tnear > tfar or tfar < 0.0:
            return -1.0, z3
        t = max(tnear, 0.0)
        s = -1.0 if d[ax] > 0.0 else 1.0
        return t, (s if ax == 0 else 0.0, s if ax == 1 else 0.0, s if ax == 2 else 0.0)
    r = size[0]
    h = size[1]
    if gtype == CAPSULE:
        z = clamp(o[2], -h, h)
        if o[0] * o[0] + o[1] * o[1] + (o[2] - z) * (o[2] - z) < r * r:
            return 0.0, z3
    else:
        if o[0] * o[0] + o[1] * o[1] < r * r and abs(o[2]) < h:
            return 0.0, z3
    best = math.inf
    n = z3
    t = _side_entry(o, d, r)
    if t >= 0.0:
        zz = o[2] + t * d[2]
        if abs(zz) <= h:
            best = t
            n = ((o[0] + t * d[0]) / r, (o[1] + t * d[1]) / r, 0.0)
    for s in (-1.0, 1.0):
        if gtype == CAPSULE:
            t = _sphere_entry(o, d, s * h, r)
            if t >= 0.0 and t < best:
                p = (o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2])
                if s * (p[2] - s * h) >= 0.0:
                    best = t
                    n = (p[0] / r, p[1] / r, (p[2] - s * h) / r)
        else:
            if s * d[2] < 0.0:
                t = (s * h - o[2]) / d[2]
                if t >= 0.0 and t < best:
                    x = o[0] + t * d[0]
                    y = o[1] + t * d[1]
                    if x * x + y * y <= r * r:
                        best = t
                        n = (0.0, 0.0, s)
    if best == math.inf:
        return -1.0, z3
    return best, n


@njit(cache=True)
def raycast_geom(gtype, pos, quat, size, origin, direction, max_dist):
    """First hit of the ray ``origin + t direction`` (unit direction) with a geom:
    ``(t, world normal)`` or ``(-1.0, (0, 0, 0))``; see the module doc."""
    q = q4(quat)
    o = quat_rotate_inv(q, sub(v3(origin), v3(pos)))
    d = quat_rotate_inv(q, v3(direction))
    t, nl = _ray_local(gtype, o, d, v3(size))
    if t < 0.0 or t > max_dist:
        return _MISS
    if t == 0.0 and nl[0] == 0.0 and nl[1] == 0.0 and nl[2] == 0.0:
        return 0.0, (-float(direction[0]), -float(direction[1]), -float(direction[2]))
    return t, quat_rotate(q, nl)
