"""Type dispatch for contacts and distances.

``collide_pair`` and ``geom_distance`` take two primitive geoms (plane .. cylinder).
Routines exist for ``type_a <= type_b``; for the reverse order the geoms are swapped
and the normals flipped (points and depths are symmetric by the midpoint convention).

``collide_geoms``, ``geom_aabb_any``, ``raycast_any`` and ``geom_distance_any`` take a
model (any namedtuple with ``geom_type``, ``geom_size``, ``geom_dataid``, the
``mesh_*`` and ``hfield_*`` arrays) and geom indices, and cover all 7 types including
``CONVEX`` (``convex_hull``) and ``HEIGHTFIELD`` (``heightfield``).
"""
import math

import numpy as np
from numba import njit

from ..._jit import noalloc
from ...math.quat import quat_rotate, quat_rotate_inv
from ._vec import clamp, local_to_world, madd, norm, normalize_or, q4, sub, v3, vdot
from .box_box import box_box_deepest, collide_box_box
from .convex import (collide_box_cylinder, collide_capsule_cylinder, collide_cylinder_cylinder,
                     convex_contact)
from .primitives import (box_sdf, collide_capsule_box, collide_capsule_capsule,
                         collide_plane_box, collide_plane_capsule, collide_plane_cylinder,
                         collide_plane_sphere, collide_sphere_box, collide_sphere_capsule,
                         collide_sphere_cylinder, collide_sphere_sphere, cylinder_sdf,
                         segment_box_deepest, segment_closest)
from .convex_hull import (collide_convex_general, collide_plane_convex, convex_distance,
                          hull_aabb, plane_convex_distance, raycast_convex)
from .heightfield import collide_hfield, hfield_aabb, hfield_distance, raycast_hfield
from .raycast import raycast_geom
from .shapes import BOX, CAPSULE, CONVEX, CYLINDER, HEIGHTFIELD, PLANE, SPHERE, geom_aabb, support


@noalloc
def _collide_ordered(ta, pos_a, quat_a, size_a, tb, pos_b, quat_b, size_b, margin, out_point,
                     out_normal, out_depth, out_feature, start):
    if ta == PLANE:
        if tb == SPHERE:
            return collide_plane_sphere(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                        out_point, out_normal, out_depth, out_feature, start)
        if tb == CAPSULE:
            return collide_plane_capsule(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                         out_point, out_normal, out_depth, out_feature, start)
        if tb == BOX:
            return collide_plane_box(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                     out_point, out_normal, out_depth, out_feature, start)
        if tb == CYLINDER:
            return collide_plane_cylinder(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                          out_point, out_normal, out_depth, out_feature, start)
        return 0
    if ta == SPHERE:
        if tb == SPHERE:
            return collide_sphere_sphere(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                         out_point, out_normal, out_depth, out_feature, start)
        if tb == CAPSULE:
            return collide_sphere_capsule(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                          out_point, out_normal, out_depth, out_feature, start)
        if tb == BOX:
            return collide_sphere_box(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                      out_point, out_normal, out_depth, out_feature, start)
        if tb == CYLINDER:
            return collide_sphere_cylinder(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                           out_point, out_normal, out_depth, out_feature, start)
        return 0
    if ta == CAPSULE:
        if tb == CAPSULE:
            return collide_capsule_capsule(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                           out_point, out_normal, out_depth, out_feature, start)
        if tb == BOX:
            return collide_capsule_box(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                       out_point, out_normal, out_depth, out_feature, start)
        if tb == CYLINDER:
            return collide_capsule_cylinder(pos_a, quat_a, size_a, pos_b, quat_b, size_b,
                                            margin, out_point, out_normal, out_depth,
                                            out_feature, start)
        return 0
    if ta == BOX:
        if tb == BOX:
            return collide_box_box(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                   out_point, out_normal, out_depth, out_feature, start)
        if tb == CYLINDER:
            return collide_box_cylinder(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                        out_point, out_normal, out_depth, out_feature, start)
        return 0
    if ta == CYLINDER and tb == CYLINDER:
        return collide_cylinder_cylinder(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                                         out_point, out_normal, out_depth, out_feature, start)
    return 0


@noalloc
def collide_pair(type_a, pos_a, quat_a, size_a, type_b, pos_b, quat_b, size_b, margin,
                 out_point, out_normal, out_depth, out_feature, start):
    """Contacts between geoms A and B of any types (see ``primitives`` for the output
    convention). Returns the number of rows written from ``start`` (at most 4)."""
    if type_a <= type_b:
        return _collide_ordered(type_a, pos_a, quat_a, size_a, type_b, pos_b, quat_b, size_b,
                                margin, out_point, out_normal, out_depth, out_feature, start)
    cnt = _collide_ordered(type_b, pos_b, quat_b, size_b, type_a, pos_a, quat_a, size_a,
                           margin, out_point, out_normal, out_depth, out_feature, start)
    for i in range(start, start + cnt):
        out_normal[i, 0] = -out_normal[i, 0]
        out_normal[i, 1] = -out_normal[i, 1]
        out_normal[i, 2] = -out_normal[i, 2]
    return cnt


# ------------------------------------------------------------------------- distances

@njit(cache=True)
def _round_distance(pa, pb, ra, rb, fallback):
    d = sub(pb, pa)
    dist = norm(d)
    n = normalize_or(d, fallback)
    return dist - ra - rb, madd(pa, n, ra), madd(pb, n, -rb)


@njit(cache=True)
def _distance_ordered(ta, pa, qa, sa, tb, pb, qb, sb):
    if ta == PLANE:
        n = quat_rotate(qa, (0.0, 0.0, 1.0))
        if tb == PLANE:
            nb = quat_rotate(qb, (0.0, 0.0, 1.0))
            if vdot(n, nb) < -1.0 + 1e-12:
                gap = vdot(n, sub(pb, pa))
                if gap > 0.0:
                    return gap, pa, madd(pa, n, gap)
            return -math.inf, pa, pb
        sp = support(tb, pb, qb, sb, (-n[0], -n[1], -n[2]))
        dist = vdot(n, sub(sp, pa))
        return dist, madd(sp, n, -dist), sp
    if ta == SPHERE and tb == SPHERE:
        return _round_distance(pa, pb, sa[0], sb[0], (0.0, 0.0, 1.0))
    if ta == SPHERE and tb == CAPSULE:
        u = quat_rotate(qb, (0.0, 0.0, 1.0))
        t = clamp(vdot(sub(pa, pb), u), -sb[1], sb[1])
        return _round_distance(pa, madd(pb, u, t), sa[0], sb[0], (0.0, 0.0, 1.0))
    if ta == CAPSULE and tb == CAPSULE:
        ua = quat_rotate(qa, (0.0, 0.0, 1.0))
        ub = quat_rotate(qb, (0.0, 0.0, 1.0))
        s, t = segment_closest(pa, ua, sa[1], pb, ub, sb[1])
        return _round_distance(madd(pa, ua, s), madd(pb, ub, t), sa[0], sb[0], (0.0, 0.0, 1.0))
    if (ta == SPHERE or ta == CAPSULE) and (tb == BOX or tb == CYLINDER):
        # signed distance of the core point deepest in B, minus the radius
        hl = sa[1] if ta == CAPSULE else 0.0
        c = quat_rotate_inv(qb, sub(pa, pb))
        u = quat_rotate_inv(qb, quat_rotate(qa, (0.0, 0.0, 1.0)))
        if tb == BOX:
            t = segment_box_deepest(c, u, hl, sb, math.inf)
            sdf, g, q, _ = box_sdf(madd(c, u, t), sb)
        elif ta == SPHERE:
            t = 0.0
            sdf, g, q = cylinder_sdf(c, sb[0], sb[1])
        else:
            depth, n, xa, xb = convex_contact(ta, pa, qa, sa, tb, pb, qb, sb)
            return -depth, xa, xb
        gw = quat_rotate(qb, g)
        core = local_to_world(pb, qb, madd(c, u, t))
        return sdf - sa[0], madd(core, gw, -sa[0]), local_to_world(pb, qb, q)
    if ta == BOX and tb == BOX:
        depth, n, xa, xb = convex_contact(ta, pa, qa, sa, tb, pb, qb, sb)
        if depth < 0.0:
            return -depth, xa, xb
        sep, n, xa, xb = box_box_deepest(pa, qa, sa, pb, qb, sb)
        return min(sep, 0.0), xa, xb
    depth, n, xa, xb = convex_contact(ta, pa, qa, sa, tb, pb, qb, sb)
    return -depth, xa, xb


@njit(cache=True)
def geom_distance(type_a, pos_a, quat_a, size_a, type_b, pos_b, quat_b, size_b):
    """Signed distance between two geoms: ``(distance, point_a, point_b)``.

    ``distance`` > 0 is the gap and ``point_a``/``point_b`` the closest points (on A's
    and B's surfaces); ``distance`` < 0 is minus the penetration depth, with the
    points the deepest points of each shape inside the other. Exact for pairs of
    spheres/capsules, planes, spheres on boxes/cylinders, capsules on boxes (deepest
    point of the segment) and for separated convex pairs (GJK); penetrating boxes use
    the SAT (exact), other penetrating pairs MPR (see ``gjk``). Two planes: ``-inf``
    unless they are anti-parallel and apart.
    """
    pa, qa, sa = v3(pos_a), q4(quat_a), v3(size_a)
    pb, qb, sb = v3(pos_b), q4(quat_b), v3(size_b)
    if type_a <= type_b:
        return _distance_ordered(type_a, pa, qa, sa, type_b, pb, qb, sb)
    d, xb, xa = _distance_ordered(type_b, pb, qb, sb, type_a, pa, qa, sa)
    return d, xa, xb


# ----------------------------------------------------- any geom of a model (all types)

@njit(cache=True, inline="always")
def geom_verts(m, g):
    """Hull vertices of convex geom ``g`` (a view of ``m.mesh_vert``); an empty view for
    other types."""
    if m.geom_type[g] == CONVEX:
        k = m.geom_dataid[g]
        a = m.mesh_vert_adr[k]
        return m.mesh_vert[a:a + m.mesh_vert_num[k]]
    return m.mesh_vert[0:0]


@njit(cache=True, inline="always")
def geom_hfield(m, g):
    """``(heights (nrow * ncol,) view, nrow, ncol)`` of heightfield geom ``g``."""
    k = m.geom_dataid[g]
    a = m.hfield_adr[k]
    nr = m.hfield_nrow[k]
    nc = m.hfield_ncol[k]
    return m.hfield_data[a:a + nr * nc], nr, nc


@noalloc
def _flip_rows(out_normal, start, cnt):
    for i in range(start, start + cnt):
        out_normal[i, 0] = -out_normal[i, 0]
        out_normal[i, 1] = -out_normal[i, 1]
        out_normal[i, 2] = -out_normal[i, 2]


@njit(cache=True)
def collide_geoms(m, ga, pos_a, quat_a, gb, pos_b, quat_b, margin, out_point, out_normal,
                  out_depth, out_feature, start):
    """Contacts between geoms ``ga`` and ``gb`` of model arrays ``m`` (any of the 7
    types), at world poses. Same output convention as :func:`collide_pair` (normal
    from A to B, at most 4 rows from ``start``); returns the number of rows.

    Primitives go to :func:`collide_pair`; convex hulls to ``convex_hull``;
    heightfields to ``heightfield``. Heightfield-heightfield and heightfield-plane
    pairs never collide.
    """
    ta = np.int64(m.geom_type[ga])
    tb = np.int64(m.geom_type[gb])
    if ta < CONVEX and tb < CONVEX:
        return collide_pair(ta, pos_a, quat_a, m.geom_size[ga], tb, pos_b, quat_b,
                            m.geom_size[gb], margin, out_point, out_normal, out_depth,
                            out_feature, start)
    if ta == HEIGHTFIELD or tb == HEIGHTFIELD:
        if ta == tb or ta == PLANE or tb == PLANE:
            return 0
        flip = ta != HEIGHTFIELD
        gh, go = (gb, ga) if flip else (ga, gb)
        ph, qh, po, qo = (pos_b, quat_b, pos_a, quat_a) if flip else (pos_a, quat_a, pos_b,
                                                                      quat_b)
        H, nr, nc = geom_hfield(m, gh)
        return collide_hfield(H, nr, nc, m.geom_size[gh], ph, qh, np.int64(m.geom_type[go]), po, qo,
                              m.geom_size[go], geom_verts(m, go), margin, flip, out_point,
                              out_normal, out_depth, out_feature, start)
    if ta == PLANE:
        return collide_plane_convex(pos_a, quat_a, pos_b, quat_b, geom_verts(m, gb), margin,
                                    out_point, out_normal, out_depth, out_feature, start)
    if tb == PLANE:
        cnt = collide_plane_convex(pos_b, quat_b, pos_a, quat_a, geom_verts(m, ga), margin,
                                   out_point, out_normal, out_depth, out_feature, start)
        _flip_rows(out_normal, start, cnt)
        return cnt
    return collide_convex_general(ta, pos_a, quat_a, m.geom_size[ga], geom_verts(m, ga), tb,
                                  pos_b, quat_b, m.geom_size[gb], geom_verts(m, gb), margin,
                                  out_point, out_normal, out_depth, out_feature, start)


@noalloc
def geom_aabb_any(m, g, pos, quat, margin):
    """World AABB ``(lo, hi)`` of geom ``g`` of any type, grown by ``margin`` (planes
    unbounded; heightfields scan their heights)."""
    t = np.int64(m.geom_type[g])
    if t == CONVEX:
        return hull_aabb(geom_verts(m, g), pos, quat, margin)
    if t == HEIGHTFIELD:
        H, nr, nc = geom_hfield(m, g)
        return hfield_aabb(H, m.geom_size[g], pos, quat, margin)
    return geom_aabb(t, pos, quat, m.geom_size[g], margin)


@njit(cache=True)
def raycast_any(m, g, pos, quat, origin, direction, max_dist):
    """Ray cast against geom ``g`` of any type: ``(t, world normal)`` or
    ``(-1, (0, 0, 0))`` (see ``raycast``)."""
    t = np.int64(m.geom_type[g])
    p, q, o, d = v3(pos), q4(quat), v3(origin), v3(direction)
    if t == CONVEX:
        return raycast_convex(geom_verts(m, g), p, q, o, d, float(max_dist))
    if t == HEIGHTFIELD:
        H, nr, nc = geom_hfield(m, g)
        return raycast_hfield(H, nr, nc, m.geom_size[g], p, q, o, d, float(max_dist))
    return raycast_geom(t, p, q, v3(m.geom_size[g]), o, d, float(max_dist))


@njit(cache=True)
def geom_distance_any(m, ga, pos_a, quat_a, gb, pos_b, quat_b):
    """Signed distance ``(d, point_a, point_b)`` between geoms of any types (see
    :func:`geom_distance`). Convex pairs: GJK when apart (exact), MPR with refinement
    when penetrating. Heightfields: see ``heightfield.hfield_distance``; against a
    plane or another heightfield ``inf``."""
    ta = np.int64(m.geom_type[ga])
    tb = np.int64(m.geom_type[gb])
    if ta < CONVEX and tb < CONVEX:
        return geom_distance(ta, pos_a, quat_a, m.geom_size[ga], tb, pos_b, quat_b,
                             m.geom_size[gb])
    if ta == HEIGHTFIELD or tb == HEIGHTFIELD:
        if ta == tb or ta == PLANE or tb == PLANE:
            return math.inf, v3(pos_a), v3(pos_b)
        flip = ta != HEIGHTFIELD
        gh, go = (gb, ga) if flip else (ga, gb)
        ph, qh, po, qo = (pos_b, quat_b, pos_a, quat_a) if flip else (pos_a, quat_a, pos_b,
                                                                      quat_b)
        H, nr, nc = geom_hfield(m, gh)
        d, xh, xo = hfield_distance(H, nr, nc, m.geom_size[gh], ph, qh,
                                    np.int64(m.geom_type[go]), po, qo, m.geom_size[go],
                                    geom_verts(m, go))
        if flip:
            return d, xo, xh
        return d, xh, xo
    if ta == PLANE:
        return plane_convex_distance(pos_a, quat_a, pos_b, quat_b, geom_verts(m, gb))
    if tb == PLANE:
        d, xb, xa = plane_convex_distance(pos_b, quat_b, pos_a, quat_a, geom_verts(m, ga))
        return d, xa, xb
    return convex_distance(ta, pos_a, quat_a, m.geom_size[ga], geom_verts(m, ga), tb, pos_b,
                           quat_b, m.geom_size[gb], geom_verts(m, gb))
