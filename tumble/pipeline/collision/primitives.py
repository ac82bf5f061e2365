"""Closed-form pair routines: planes, spheres, capsules, spheres and capsules on boxes,
spheres on cylinders.

Every ``collide_X_Y`` has the signature::

    collide_X_Y(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                out_point, out_normal, out_depth, out_feature, start) -> int

and writes contacts into rows ``start, start + 1, ...`` (at most 4) of the output
arrays, returning how many it wrote. Conventions:

* ``normal`` is a unit vector from A to B;
* ``depth > 0`` is penetration; a contact is written only when ``depth > -margin``;
* the contact point is midway between the two surfaces: with ``p_a`` the point of A
  deepest in B (or nearest to B) and ``p_b`` that of B, ``p_a - p_b = depth * normal``
  and the point is ``(p_a + p_b) / 2``. Swapping A and B flips the normal and keeps the
  point and depth. (For a capsule's end-cap or clipped contacts ``p_a`` is the deepest
  point of the ball around one point of its segment, which may lie inside the capsule.)
"""
import math

import numpy as np
from numba import njit

from ..._jit import noalloc

from ...math.quat import quat_rotate, quat_rotate_inv
from ._vec import (any_perp, clamp, local_to_world, madd, mid, norm, normalize_or, q4, scale,
                   sub, v3, vcross, vdot, write_contact)
from .manifold import face_manifold
from .shapes import BOX, CAPSULE, CYLINDER, SPHERE

_INF = math.inf
# Below this sine of the angle between two capsule axes they count as parallel.
_PARALLEL_SIN = 1e-3


# --------------------------------------------------------------------------- helpers

@noalloc
def round_contact(pa, pb, ra, rb, fallback):
    """Contact between the balls of radius ``ra`` at ``pa`` and ``rb`` at ``pb``.

    Returns ``(depth, normal, point)``; ``fallback`` is the normal used when the centres
    coincide.
    """
    d = sub(pb, pa)
    dist = norm(d)
    n = normalize_or(d, fallback)
    depth = ra + rb - dist
    sa = madd(pa, n, ra)
    sb = madd(pb, n, -rb)
    return depth, n, mid(sa, sb)


@noalloc
def segment_closest(ca, ua, ha, cb, ub, hb):
    """Parameters ``(s, t)`` of the closest points of the segments ``ca + s ua``,
    ``|s| <= ha`` and ``cb + t ub``, ``|t| <= hb`` (``ua``, ``ub`` unit).

    Minimises ``|ca + s ua - cb - t ub|^2``: solve the unconstrained stationarity
    conditions, clamp ``s``, re-solve ``t`` for it and clamp, and when ``t`` was clamped
    re-solve ``s``. For parallel segments ``s`` starts at 0.
    """
    r = sub(ca, cb)
    b = vdot(ua, ub)
    c = vdot(ua, r)
    f = vdot(ub, r)
    denom = 1.0 - b * b
    if denom > 1e-14:
        s = clamp((b * f - c) / denom, -ha, ha)
    else:
        s = 0.0
    t = b * s + f
    if t < -hb:
        t = -hb
        s = clamp(b * t - c, -ha, ha)
    elif t > hb:
        t = hb
        s = clamp(b * t - c, -ha, ha)
    return s, t


@noalloc
def box_sdf(p, h):
    """Signed distance of local point ``p`` to the box of half extents ``h``.

    Returns ``(sdf, g, q, n_out)``: the outward unit direction ``g`` from the box to
    ``p`` (the face normal when inside), the nearest surface point ``q`` and the number
    of coordinates outside the box slab (0 inside, 1 face region, 2 edge, 3 vertex).
    """
    ax = abs(p[0]) - h[0]
    ay = abs(p[1]) - h[1]
    az = abs(p[2]) - h[2]
    nout = (1 if ax > 0.0 else 0) + (1 if ay > 0.0 else 0) + (1 if az > 0.0 else 0)
    if nout > 0:
        q = (clamp(p[0], -h[0], h[0]), clamp(p[1], -h[1], h[1]), clamp(p[2], -h[2], h[2]))
        d = sub(p, q)
        return norm(d), normalize_or(d, (1.0, 0.0, 0.0)), q, nout
    if ax >= ay and ax >= az:
        s = 1.0 if p[0] >= 0.0 else -1.0
        return ax, (s, 0.0, 0.0), (s * h[0], p[1], p[2]), 0
    if ay >= az:
        s = 1.0 if p[1] >= 0.0 else -1.0
        return ay, (0.0, s, 0.0), (p[0], s * h[1], p[2]), 0
    s = 1.0 if p[2] >= 0.0 else -1.0
    return az, (0.0, 0.0, s), (p[0], p[1], s * h[2]), 0


@noalloc
def cylinder_sdf(p, r, h):
    """Signed distance of local point ``p`` to the cylinder (radius ``r``, half length
    ``h``, axis z). Returns ``(sdf, g, q)`` as :func:`box_sdf` (without the count)."""
    rad = math.sqrt(p[0] * p[0] + p[1] * p[1])
    e = normalize_or((p[0], p[1], 0.0), (1.0, 0.0, 0.0))
    ex, ey = e[0], e[1]
    dr = rad - r
    dz = abs(p[2]) - h
    sz = 1.0 if p[2] >= 0.0 else -1.0
    if dr > 0.0 or dz > 0.0:
        if dr > 0.0:
            qx, qy = ex * r, ey * r
        else:
            qx, qy = p[0], p[1]
        q = (qx, qy, clamp(p[2], -h, h))
        d = sub(p, q)
        return norm(d), normalize_or(d, (1.0, 0.0, 0.0)), q
    if dr >= dz:
        return dr, (ex, ey, 0.0), (ex * r, ey * r, p[2])
    return dz, (0.0, 0.0, sz), (p[0], p[1], sz * h)


# ------------------------------------------------------------------------ plane pairs

@noalloc
def _plane_frame(pos, quat):
    n = quat_rotate(quat, (0.0, 0.0, 1.0))
    t1 = quat_rotate(quat, (1.0, 0.0, 0.0))
    t2 = quat_rotate(quat, (0.0, 1.0, 0.0))
    return v3(pos), n, t1, t2


@noalloc
def _plane_any(gtype, pos_a, quat_a, pos_b, quat_b, size_b, margin, out_point, out_normal,
               out_depth, out_feature, start):
    p, n, t1, t2 = _plane_frame(pos_a, q4(quat_a))
    cnt, _ = face_manifold(gtype, v3(pos_b), q4(quat_b), v3(size_b), p, n, t1, t2, _INF, _INF,
                           np.bool_(False), margin, np.bool_(False), np.int64(0), out_point,
                           out_normal, out_depth, out_feature, start)
    return cnt


@noalloc
def collide_plane_sphere(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                         out_normal, out_depth, out_feature, start):
    """Plane A, sphere B: one contact, feature 0."""
    return _plane_any(np.int64(SPHERE), pos_a, quat_a, pos_b, quat_b, size_b, margin, out_point,
                      out_normal, out_depth, out_feature, start)


@noalloc
def collide_plane_capsule(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                          out_normal, out_depth, out_feature, start):
    """Plane A, capsule B: the two end caps, features 0 (``-half_length``) and 1."""
    return _plane_any(np.int64(CAPSULE), pos_a, quat_a, pos_b, quat_b, size_b, margin, out_point,
                      out_normal, out_depth, out_feature, start)


@noalloc
def collide_plane_box(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                      out_normal, out_depth, out_feature, start):
    """Plane A, box B: the (up to) 4 deepest vertices, feature = vertex index."""
    return _plane_any(np.int64(BOX), pos_a, quat_a, pos_b, quat_b, size_b, margin, out_point,
                      out_normal, out_depth, out_feature, start)


@noalloc
def collide_plane_cylinder(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                           out_normal, out_depth, out_feature, start):
    """Plane A, cylinder B: up to 4 rim points (see ``manifold`` for feature ids)."""
    return _plane_any(np.int64(CYLINDER), pos_a, quat_a, pos_b, quat_b, size_b, margin, out_point,
                      out_normal, out_depth, out_feature, start)


@noalloc
def collide_plane_plane(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                        out_normal, out_depth, out_feature, start):
    """Two planes never collide."""
    return 0


# ------------------------------------------------------------------- round primitives

@noalloc
def collide_sphere_sphere(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                          out_normal, out_depth, out_feature, start):
    """Sphere A, sphere B: one contact, feature 0 (normal +z when the centres coincide)."""
    depth, n, p = round_contact(v3(pos_a), v3(pos_b), size_a[0], size_b[0], (0.0, 0.0, 1.0))
    if depth <= -margin:
        return 0
    write_contact(out_point, out_normal, out_depth, out_feature, start, p, n, depth, np.int64(0))
    return 1


@noalloc
def collide_sphere_capsule(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                           out_normal, out_depth, out_feature, start):
    """Sphere A, capsule B: one contact, feature 0."""
    c = v3(pos_a)
    cb = v3(pos_b)
    u = quat_rotate(q4(quat_b), (0.0, 0.0, 1.0))
    t = clamp(vdot(sub(c, cb), u), -size_b[1], size_b[1])
    q = madd(cb, u, t)
    depth, n, p = round_contact(c, q, size_a[0], size_b[0], any_perp(u))
    if depth <= -margin:
        return 0
    write_contact(out_point, out_normal, out_depth, out_feature, start, p, n, depth, np.int64(0))
    return 1


@noalloc
def _capsule_fallback_normal(ua, ub, ca, cb):
    """Normal for capsules whose axes touch: perpendicular to both, towards B."""
    d = sub(cb, ca)
    c = vcross(ua, ub)
    nc = norm(c)
    if nc > 1e-9:
        n = (c[0] / nc, c[1] / nc, c[2] / nc)
    else:
        # parallel: the part of the centre offset across the axis
        dp = madd(d, ua, -vdot(d, ua))
        if norm(dp) > 1e-12:
            n = scale(dp, 1.0 / norm(dp))
        else:
            n = any_perp(ua)
    if vdot(n, d) < 0.0:
        n = (-n[0], -n[1], -n[2])
    return n


@noalloc
def collide_capsule_capsule(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                            out_normal, out_depth, out_feature, start):
    """Capsule A, capsule B: closest points of the two segments.

    Non-parallel axes: one contact, feature 0. Parallel axes (sine below 1e-3) whose
    projections overlap: two contacts at the ends of the overlap along A's axis,
    features 1 (lower end along A's axis) and 2 (upper end), plus feature 0 at the
    closest points when that is deeper than both.
    """
    ca = v3(pos_a)
    cb = v3(pos_b)
    ua = quat_rotate(q4(quat_a), (0.0, 0.0, 1.0))
    ub = quat_rotate(q4(quat_b), (0.0, 0.0, 1.0))
    ra, ha = size_a[0], size_a[1]
    rb, hb = size_b[0], size_b[1]
    fb = _capsule_fallback_normal(ua, ub, ca, cb)
    s, t = segment_closest(ca, ua, ha, cb, ub, hb)
    depth0, n0, p0 = round_contact(madd(ca, ua, s), madd(cb, ub, t), ra, rb, fb)
    if depth0 <= -margin:
        return 0
    cnt = 0
    tol = 1e-9 * (ha + hb + ra + rb)
    if norm(vcross(ua, ub)) < _PARALLEL_SIN and ha > 0.0 and hb > 0.0:
        d = sub(cb, ca)
        sb = vdot(d, ua)
        ext = hb * abs(vdot(ua, ub))
        lo = max(-ha, sb - ext)
        hi = min(ha, sb + ext)
        if hi - lo > tol:
            best = -_INF
            for end in range(2):
                se = lo if end == 0 else hi
                pe = madd(ca, ua, se)
                te = clamp(vdot(sub(pe, cb), ub), -hb, hb)
                de, ne, pt = round_contact(pe, madd(cb, ub, te), ra, rb, fb)
                if de > best:
                    best = de
                if de > -margin:
                    write_contact(out_point, out_normal, out_depth, out_feature, start + cnt,
                                  pt, ne, de, 1 + end)
                    cnt += 1
            if cnt > 0 and depth0 <= best + tol:
                return cnt
    write_contact(out_point, out_normal, out_depth, out_feature, start + cnt, p0, n0, depth0,
                  np.int64(0))
    return cnt + 1


# ------------------------------------------------------------- sphere/capsule vs boxes

@noalloc
def collide_sphere_box(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                       out_normal, out_depth, out_feature, start):
    """Sphere A, box B: one contact, feature 0 (exact signed distance of the centre)."""
    c = v3(pos_a)
    qb = q4(quat_b)
    pb = v3(pos_b)
    r = size_a[0]
    pl = quat_rotate_inv(qb, sub(c, pb))
    sdf, g, q, _ = box_sdf(pl, v3(size_b))
    depth = r - sdf
    if depth <= -margin:
        return 0
    gw = quat_rotate(qb, g)
    n = (-gw[0], -gw[1], -gw[2])
    sa = madd(c, n, r)
    sb = local_to_world(pb, qb, q)
    write_contact(out_point, out_normal, out_depth, out_feature, start, mid(sa, sb), n, depth,
                  np.int64(0))
    return 1


@noalloc
def _outside_sq(c, u, h, t):
    """Squared distance from ``c + t u`` to the box (0 inside)."""
    acc = 0.0
    for k in range(3):
        e = abs(c[k] + t * u[k]) - h[k]
        if e > 0.0:
            acc += e * e
    return acc


@noalloc
def _inside_sdf(c, u, h, t):
    """``max_k |c_k + t u_k| - h_k``: the signed distance wherever it is <= 0 (inside)."""
    return max(abs(c[0] + t * u[0]) - h[0], abs(c[1] + t * u[1]) - h[1],
               abs(c[2] + t * u[2]) - h[2])


@noalloc
def _slab_crossing(c, u, h, i):
    """Where the line ``c + t u`` crosses face plane ``i`` (axis ``i // 2``, side
    ``i % 2``): ``t``, or NaN when the line is parallel to it."""
    k = i // 2
    if abs(u[k]) < 1e-300:
        return math.nan
    side = h[k] if i % 2 else -h[k]
    return (side - c[k]) / u[k]


@noalloc
def segment_box_deepest(c, u, hl, h, beyond):
    """Parameter ``t`` in ``[-hl, hl]`` minimising the box signed distance of ``c + t u``
    (all in box-local coordinates), found exactly.

    Outside the box the squared distance is a convex quadratic between the crossings of
    the six face planes, so its least value is at a piece's stationary point or at a
    crossing. If the segment reaches the box, the distance inside is the largest of
    ``|c_k + t u_k| - h_k``, convex and piecewise linear: least at an end, where one of
    them turns (``c_k + t u_k = 0``) or where two of them meet. Ties go to the ends.

    beyond : (m) return NaN when the segment stays farther than this from the box
        (``math.inf``: never)."""
    if hl <= 0.0:
        return 0.0
    best_t = -hl
    best = _outside_sq(c, u, h, -hl)
    d_hi = _outside_sq(c, u, h, hl)
    if d_hi < best:
        best_t, best = hl, d_hi
    # each piece runs from its start (the segment's end or a crossing) to the next crossing
    for i in range(-1, 6):
        lo = -hl if i < 0 else _slab_crossing(c, u, h, i)
        if not (lo >= -hl and lo < hl):
            continue
        hi = hl
        for q in range(6):
            tq = _slab_crossing(c, u, h, q)
            if tq > lo and tq < hi:
                hi = tq
        mid = 0.5 * (lo + hi)
        num = 0.0
        den = 0.0
        for k in range(3):
            x = c[k] + mid * u[k]
            if x > h[k]:
                num += u[k] * (c[k] - h[k])
                den += u[k] * u[k]
            elif x < -h[k]:
                num += u[k] * (c[k] + h[k])
                den += u[k] * u[k]
        t = min(max(-num / den, lo), hi) if den > 0.0 else mid
        dt = _outside_sq(c, u, h, t)
        if dt < best:
            best_t, best = t, dt
    if best > 0.0:
        return math.nan if math.sqrt(best) > beyond else best_t
    # the segment reaches the box: the least of the piecewise linear inside distance
    best_t = -hl
    best = _inside_sdf(c, u, h, -hl)
    f_hi = _inside_sdf(c, u, h, hl)
    if f_hi < best:
        best_t, best = hl, f_hi
    for a in range(3):
        if abs(u[a]) > 1e-300:
            t = -c[a] / u[a]
            if -hl < t < hl:
                f = _inside_sdf(c, u, h, t)
                if f < best:
                    best_t, best = t, f
        for b in range(a + 1, 3):
            for sa in (-1.0, 1.0):
                for sb in (-1.0, 1.0):
                    # sa x_a - h_a = sb x_b - h_b
                    den = sa * u[a] - sb * u[b]
                    if abs(den) < 1e-300:
                        continue
                    t = (h[a] - h[b] - sa * c[a] + sb * c[b]) / den
                    if -hl < t < hl:
                        f = _inside_sdf(c, u, h, t)
                        if f < best:
                            best_t, best = t, f
    return best_t


@noalloc
def _segment_box_separated(c, u, hl, h, gap):
    """Whether the segment ``c + t u``, ``|t| <= hl`` (box-local, ``u`` a unit vector) is
    farther than ``gap`` from the box of half extents ``h`` along one of the separating
    axes of a segment and a box: the box's three face normals and the segment's
    direction crossed with each of them. A gap along an axis bounds the distance from
    below, so True means surely apart; False decides nothing."""
    for k in range(3):
        if abs(c[k]) - abs(u[k]) * hl - h[k] > gap:
            return True
    for k in range(3):
        ax = vcross(u, (1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0))
        ln = norm(ax)
        if ln < 1e-9:                    # the segment is parallel to e_k: a face axis
            continue
        # the segment projects to one point on an axis normal to it
        reach = abs(ax[0]) * h[0] + abs(ax[1]) * h[1] + abs(ax[2]) * h[2]
        if abs(vdot(ax, c)) - reach > gap * ln:
            return True
    return False


@noalloc
def _clip_slab(t0, t1, c, u, lo, hi):
    """Restrict ``[t0, t1]`` to the ``t`` with ``lo <= c + t u <= hi``."""
    if abs(u) < 1e-14:
        if c < lo or c > hi:
            return 1.0, -1.0
        return t0, t1
    a = (lo - c) / u
    b = (hi - c) / u
    if a > b:
        a, b = b, a
    return max(t0, a), min(t1, b)


@noalloc
def collide_capsule_box(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                        out_normal, out_depth, out_feature, start):
    """Capsule A, box B.

    The point of the capsule segment deepest in the box (minimum signed distance) is
    found; when its nearest box feature is a face, the segment is clipped to that
    face's prism and both clip ends become contacts (a capsule lying on a face gets
    two points), features ``1 + 2 * face + end`` with ``face = 2 * axis + (sign > 0)``
    and end 0/1 along the capsule axis; otherwise (edge or vertex nearest) one contact,
    feature 0, at the deepest point.
    """
    qb = q4(quat_b)
    pb = v3(pos_b)
    h = v3(size_b)
    r = size_a[0]
    hl = size_a[1]
    c = quat_rotate_inv(qb, sub(v3(pos_a), pb))
    u = quat_rotate_inv(qb, quat_rotate(q4(quat_a), (0.0, 0.0, 1.0)))
    if _segment_box_separated(c, u, hl, h, r + margin):
        return 0
    # a capsule surely farther than the margin from the box ends the search early
    t = segment_box_deepest(c, u, hl, h, r + margin)
    if t != t:
        return 0
    p = madd(c, u, t)
    sdf, g, q, nout = box_sdf(p, h)
    depth = r - sdf
    if depth <= -margin:
        return 0
    if nout <= 1:
        tol = 1e-9 * (h[0] + h[1] + h[2] + hl)
        # face axis k and side s of g
        if abs(g[0]) >= abs(g[1]) and abs(g[0]) >= abs(g[2]):
            k = 0
        elif abs(g[1]) >= abs(g[2]):
            k = 1
        else:
            k = 2
        if nout == 0:
            # inside, the deepest point usually sits where two faces are equally near:
            # among those (within tol) take the face the axis is most parallel to
            qm = max(abs(p[0]) - h[0], max(abs(p[1]) - h[1], abs(p[2]) - h[2]))
            k = -1
            for i in range(3):
                if abs(p[i]) - h[i] >= qm - tol:
                    if k < 0 or abs(u[i]) < abs(u[k]) - 1e-9:
                        k = i
        if nout == 1:
            s = 1.0 if g[k] > 0.0 else -1.0
        elif abs(p[k]) > tol:
            s = 1.0 if p[k] > 0.0 else -1.0
        else:
            # deepest point on the mid-plane (a deep capsule through a thin box): push
            # out towards the side of the capsule's centre
            s = 1.0 if c[k] >= 0.0 else -1.0
        t0 = -hl
        t1 = hl
        for i in range(3):
            if i == k:
                # never past the opposite face
                if s > 0.0:
                    t0, t1 = _clip_slab(t0, t1, c[i], u[i], -h[i] - tol, _INF)
                else:
                    t0, t1 = _clip_slab(t0, t1, c[i], u[i], -_INF, h[i] + tol)
            else:
                t0, t1 = _clip_slab(t0, t1, c[i], u[i], -h[i] - tol, h[i] + tol)
        if t1 >= t0:
            face = 2 * k + (1 if s > 0.0 else 0)
            gl = (s if k == 0 else 0.0, s if k == 1 else 0.0, s if k == 2 else 0.0)
            gw = quat_rotate(qb, gl)
            n = (-gw[0], -gw[1], -gw[2])
            nend = 1 if t1 - t0 <= tol else 2
            cnt = 0
            for e in range(nend):
                te = t0 if e == 0 else t1
                pe = madd(c, u, te)
                height = s * pe[k] - h[k]
                de = r - height
                if de <= -margin:
                    continue
                pw = local_to_world(pb, qb, pe)
                sa = madd(pw, gw, -r)            # capsule surface point
                sb = madd(pw, gw, -height)       # its projection on the face
                write_contact(out_point, out_normal, out_depth, out_feature, start + cnt,
                              mid(sa, sb), n, de, 1 + 2 * face + e)
                cnt += 1
            if cnt > 0:
                return cnt
    gw = quat_rotate(qb, g)
    n = (-gw[0], -gw[1], -gw[2])
    pw = local_to_world(pb, qb, p)
    sa = madd(pw, gw, -r)
    sb = local_to_world(pb, qb, q)
    write_contact(out_point, out_normal, out_depth, out_feature, start, mid(sa, sb), n, depth,
                  np.int64(0))
    return 1


@noalloc
def collide_sphere_cylinder(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                            out_normal, out_depth, out_feature, start):
    """Sphere A, cylinder B: one contact, feature 0 (exact signed distance of the centre)."""
    c = v3(pos_a)
    qb = q4(quat_b)
    pb = v3(pos_b)
    r = size_a[0]
    pl = quat_rotate_inv(qb, sub(c, pb))
    sdf, g, q = cylinder_sdf(pl, size_b[0], size_b[1])
    depth = r - sdf
    if depth <= -margin:
        return 0
    gw = quat_rotate(qb, g)
    n = (-gw[0], -gw[1], -gw[2])
    sa = madd(c, n, r)
    sb = local_to_world(pb, qb, q)
    write_contact(out_point, out_normal, out_depth, out_feature, start, mid(sa, sb), n, depth,
                  np.int64(0))
    return 1
