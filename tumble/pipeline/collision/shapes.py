"""Geometry type codes, support functions and bounding boxes.

Conventions (fixed by the lead engineer):

* ``size`` (3,) per geom: sphere ``(radius, 0, 0)``; capsule ``(radius, half_length, 0)``
  with the axis along geom-local z and ``half_length`` the half length of the
  cylindrical part; box ``(hx, hy, hz)`` half extents; cylinder ``(radius, half_length, 0)``
  with the axis along local z; plane: unused.
* A plane passes through the geom position with normal = geom-local +z in the world;
  it is solid below (``n . (x - p) < 0`` is inside).
* Poses are world poses: ``pos`` (3,), ``quat`` (4,) as (x, y, z, w).
* ``CONVEX``: the convex hull of vertices given in the geom frame (``size`` unused).
  Functions that can handle it take an optional trailing ``verts`` (k, 3) array of
  those vertices (``convex_hull``); without it a convex geom cannot be evaluated.
* ``HEIGHTFIELD``: static terrain, handled in ``heightfield`` (no support function).

Round shapes are split into a *core* and a radius: a sphere is its centre plus its
radius, a capsule its segment plus its radius. Boxes and cylinders have radius 0.
GJK runs on the cores, which keeps it exact and fast for round shapes.
"""
import math

from numba import njit

from ..._jit import noalloc

from ...math.quat import quat_rotate, quat_rotate_inv
# The codes live in model.types; the collision modules import them from here.
from ...model.types import (BOX, CAPSULE, CONVEX, CYLINDER, HEIGHTFIELD,  # noqa: F401
                            NUM_GEOM_TYPES, PLANE, SPHERE)

#: Most contacts any pair routine writes.
MAX_CONTACTS_PER_PAIR = 4

#: AABB bound used for planes (and anything unbounded): IEEE infinity.
INF = math.inf


@noalloc
def core_radius(gtype, size):
    """Rounding radius of the shape around its core (sphere, capsule) or 0."""
    if gtype == SPHERE or gtype == CAPSULE:
        return float(size[0])
    return 0.0


@noalloc
def hull_support_local(verts, dl):
    """Index of the vertex of ``verts`` (k, 3) farthest along local direction ``dl``
    (the first one on ties)."""
    best = -math.inf
    k = 0
    for i in range(verts.shape[0]):
        s = verts[i, 0] * dl[0] + verts[i, 1] * dl[1] + verts[i, 2] * dl[2]
        if s > best:
            best = s
            k = i
    return k


@noalloc
def support_core(gtype, pos, quat, size, d, verts=None):
    """World point of the core of the shape farthest along direction ``d``.

    ``d`` need not be unit. Ties (a face or edge orthogonal to ``d``) resolve to the
    positive side, so the result is deterministic (convex hulls: the first vertex).
    Planes return their position. ``verts``: hull vertices, for ``CONVEX`` only.
    """
    if verts is not None:
        if gtype == CONVEX:
            dl = quat_rotate_inv(quat, d)
            k = hull_support_local(verts, dl)
            w = quat_rotate(quat, (verts[k, 0], verts[k, 1], verts[k, 2]))
            return (pos[0] + w[0], pos[1] + w[1], pos[2] + w[2])
    if gtype == SPHERE or gtype == PLANE:
        return (float(pos[0]), float(pos[1]), float(pos[2]))
    dl = quat_rotate_inv(quat, d)
    if gtype == CAPSULE:
        z = size[1] if dl[2] >= 0.0 else -size[1]
        loc = (0.0, 0.0, float(z))
    elif gtype == BOX:
        loc = (float(size[0] if dl[0] >= 0.0 else -size[0]),
               float(size[1] if dl[1] >= 0.0 else -size[1]),
               float(size[2] if dl[2] >= 0.0 else -size[2]))
    else:  # CYLINDER
        rr = math.sqrt(dl[0] * dl[0] + dl[1] * dl[1])
        if rr > 0.0:
            k = size[0] / rr
            x = dl[0] * k
            y = dl[1] * k
        else:
            x = 0.0
            y = 0.0
        z = size[1] if dl[2] >= 0.0 else -size[1]
        loc = (float(x), float(y), float(z))
    w = quat_rotate(quat, loc)
    return (pos[0] + w[0], pos[1] + w[1], pos[2] + w[2])


@noalloc
def support(gtype, pos, quat, size, d, verts=None):
    """World point of the whole shape (core plus radius) farthest along ``d`` (non-zero)."""
    c = support_core(gtype, pos, quat, size, d, verts)
    r = core_radius(gtype, size)
    if r == 0.0:
        return c
    m = max(abs(d[0]), max(abs(d[1]), abs(d[2])))
    x, y, z = d[0] / m, d[1] / m, d[2] / m
    k = r / math.sqrt(x * x + y * y + z * z)
    return (c[0] + x * k, c[1] + y * k, c[2] + z * k)


@noalloc
def geom_aabb(gtype, pos, quat, size, margin):
    """World axis-aligned bounding box ``(lo, hi)`` of a geom, grown by ``margin``.

    Planes are unbounded: ``lo = (-inf, -inf, -inf)``, ``hi = (inf, inf, inf)``
    (IEEE infinities, so the broad phase pairs them with everything).
    """
    if gtype == PLANE:
        return ((-INF, -INF, -INF), (INF, INF, INF))
    if gtype == SPHERE:
        r = size[0] + margin
        ex, ey, ez = r, r, r
    elif gtype == CAPSULE or gtype == CYLINDER:
        a = quat_rotate(quat, (0.0, 0.0, 1.0))
        r = size[0]
        h = size[1]
        if gtype == CAPSULE:
            ex = abs(a[0]) * h + r + margin
            ey = abs(a[1]) * h + r + margin
            ez = abs(a[2]) * h + r + margin
        else:
            # a disc of radius r with unit normal a spans r sqrt(1 - a_i^2) along axis i
            ex = abs(a[0]) * h + r * math.sqrt(max(0.0, 1.0 - a[0] * a[0])) + margin
            ey = abs(a[1]) * h + r * math.sqrt(max(0.0, 1.0 - a[1] * a[1])) + margin
            ez = abs(a[2]) * h + r * math.sqrt(max(0.0, 1.0 - a[2] * a[2])) + margin
    else:  # BOX
        cx = quat_rotate(quat, (1.0, 0.0, 0.0))
        cy = quat_rotate(quat, (0.0, 1.0, 0.0))
        cz = quat_rotate(quat, (0.0, 0.0, 1.0))
        hx, hy, hz = size[0], size[1], size[2]
        ex = abs(cx[0]) * hx + abs(cy[0]) * hy + abs(cz[0]) * hz + margin
        ey = abs(cx[1]) * hx + abs(cy[1]) * hy + abs(cz[1]) * hz + margin
        ez = abs(cx[2]) * hx + abs(cy[2]) * hy + abs(cz[2]) * hz + margin
    return ((pos[0] - ex, pos[1] - ey, pos[2] - ez), (pos[0] + ex, pos[1] + ey, pos[2] + ez))


@noalloc
def shape_scale(gtype, size, verts=None):
    """A length typical of the shape (largest half extent, or radius plus half length;
    1 for planes; the largest vertex distance from the geom origin for convex hulls),
    used to scale tolerances. Never below 1e-9."""
    if verts is not None:
        if gtype == CONVEX:
            s = 0.0
            for i in range(verts.shape[0]):
                s = max(s, math.sqrt(verts[i, 0] ** 2 + verts[i, 1] ** 2 + verts[i, 2] ** 2))
            return max(s, 1e-9)
    if gtype == PLANE:
        return 1.0
    if gtype == BOX:
        s = max(size[0], max(size[1], size[2]))
    else:
        s = size[0] + size[1]
    return max(float(s), 1e-9)
