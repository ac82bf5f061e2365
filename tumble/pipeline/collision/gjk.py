"""GJK distance and MPR penetration over support functions.

Shapes are given as ``(gtype, pos, quat, size)`` tuples of plain values.

* :func:`gjk_distance` works on the *cores* (sphere centre, capsule segment, box,
  cylinder; see ``shapes.support_core``) and returns their distance and closest
  points. Add the radii for the rounded shapes.
* :func:`mpr_portal` (Minkowski portal refinement, "XenoCollide") finds a portal: a
  triangle of support points of the Minkowski difference ``A - B`` that the ray from
  an interior point through the origin crosses. :func:`mpr_penetration` refines it
  and finds, for overlapping shapes, the penetration normal and depth along the ray
  from ``c_a - c_b`` through the origin. The depth is exact whenever that ray leaves
  through the face of least penetration (flat contacts) and an upper bound
  otherwise. EPA (``epa``) starts from a portal too.

Neither allocates: the simplices live in tuples.
"""
import math

import numpy as np
from numba import njit

from ._vec import add, any_perp, madd, norm, norm2, normalize_or, scale, sub, vcross, vdot
from .shapes import support_core

GJK_MAX_ITER = 128
MPR_MAX_ITER = 128
_Z3 = (0.0, 0.0, 0.0)


# ------------------------------------------------------------- closest point on simplex

@njit(cache=True)
def _closest_segment(a, b):
    ab = sub(b, a)
    den = norm2(ab)
    if den <= 0.0:
        return 1.0, 0.0
    t = -vdot(a, ab) / den
    if t <= 0.0:
        return 1.0, 0.0
    if t >= 1.0:
        return 0.0, 1.0
    return 1.0 - t, t


@njit(cache=True)
def _closest_triangle(a, b, c):
    """Barycentric weights of the point of triangle abc closest to the origin
    (Voronoi-region tests on the vertices, edges and face)."""
    ab = sub(b, a)
    ac = sub(c, a)
    ap = (-a[0], -a[1], -a[2])
    d1 = vdot(ab, ap)
    d2 = vdot(ac, ap)
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0
    bp = (-b[0], -b[1], -b[2])
    d3 = vdot(ab, bp)
    d4 = vdot(ac, bp)
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return 1.0 - v, v, 0.0
    cp = (-c[0], -c[1], -c[2])
    d5 = vdot(ab, cp)
    d6 = vdot(ac, cp)
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return 1.0 - w, 0.0, w
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - w, w
    den = va + vb + vc
    if den <= 0.0:
        # degenerate (zero-area) triangle: best of its edges
        l0, l1 = _closest_segment(a, b)
        m0, m1 = _closest_segment(a, c)
        n0, n1 = _closest_segment(b, c)
        dab = norm2(add(scale(a, l0), scale(b, l1)))
        dac = norm2(add(scale(a, m0), scale(c, m1)))
        dbc = norm2(add(scale(b, n0), scale(c, n1)))
        if dab <= dac and dab <= dbc:
            return l0, l1, 0.0
        if dac <= dbc:
            return m0, 0.0, m1
        return 0.0, n0, n1
    v = vb / den
    w = vc / den
    return 1.0 - v - w, v, w


@njit(cache=True)
def _outside(p0, p1, p2, opp):
    """Is the origin on the other side of plane (p0, p1, p2) than ``opp``?
    Degenerate (flat) tetrahedra count as outside."""
    n = vcross(sub(p1, p0), sub(p2, p0))
    so = -vdot(p0, n)
    sd = vdot(sub(opp, p0), n)
    if sd == 0.0:
        return True
    return so * sd < 0.0


@njit(cache=True)
def _closest_simplex(n, W):
    """Barycentric weights (4,) of the closest point of the first ``n`` vertices of
    ``W`` to the origin, and whether the origin is inside the tetrahedron."""
    if n == 1:
        return (1.0, 0.0, 0.0, 0.0), False
    if n == 2:
        l0, l1 = _closest_segment(W[0], W[1])
        return (l0, l1, 0.0, 0.0), False
    if n == 3:
        l0, l1, l2 = _closest_triangle(W[0], W[1], W[2])
        return (l0, l1, l2, 0.0), False
    a, b, c, d = W[0], W[1], W[2], W[3]
    best = math.inf
    L = (0.0, 0.0, 0.0, 0.0)
    found = False
    # a nearly flat tetrahedron (GJK on curved shapes piles up close support points)
    # cannot decide inside/outside reliably: then all four faces are candidates
    ab = sub(b, a)
    ac = sub(c, a)
    ad = sub(d, a)
    vol = abs(vdot(ab, vcross(ac, ad)))
    ext = max(norm2(ab), max(norm2(ac), max(norm2(ad), max(norm2(sub(c, b)),
              max(norm2(sub(d, b)), norm2(sub(d, c)))))))
    flat = vol <= 1e-9 * ext * math.sqrt(ext)
    if flat or _outside(a, b, c, d):
        l0, l1, l2 = _closest_triangle(a, b, c)
        dd = norm2(add(add(scale(a, l0), scale(b, l1)), scale(c, l2)))
        if dd < best:
            best = dd
            L = (l0, l1, l2, 0.0)
            found = True
    if flat or _outside(a, c, d, b):
        l0, l1, l2 = _closest_triangle(a, c, d)
        dd = norm2(add(add(scale(a, l0), scale(c, l1)), scale(d, l2)))
        if dd < best:
            best = dd
            L = (l0, 0.0, l1, l2)
            found = True
    if flat or _outside(a, d, b, c):
        l0, l1, l2 = _closest_triangle(a, d, b)
        dd = norm2(add(add(scale(a, l0), scale(d, l1)), scale(b, l2)))
        if dd < best:
            best = dd
            L = (l0, l2, 0.0, l1)
            found = True
    if flat or _outside(b, d, c, a):
        l0, l1, l2 = _closest_triangle(b, d, c)
        dd = norm2(add(add(scale(b, l0), scale(d, l1)), scale(c, l2)))
        if dd < best:
            best = dd
            L = (0.0, l0, l2, l1)
            found = True
    if not found:
        return (0.25, 0.25, 0.25, 0.25), True
    return L, False


@njit(cache=True)
def _combine(L, P):
    return (L[0] * P[0][0] + L[1] * P[1][0] + L[2] * P[2][0] + L[3] * P[3][0],
            L[0] * P[0][1] + L[1] * P[1][1] + L[2] * P[2][1] + L[3] * P[3][1],
            L[0] * P[0][2] + L[1] * P[1][2] + L[2] * P[2][2] + L[3] * P[3][2])


@njit(cache=True)
def _set(T, i, v):
    """``T`` (a homogeneous 4-tuple) with entry ``i`` replaced by ``v``."""
    if i == 0:
        return (v, T[1], T[2], T[3])
    if i == 1:
        return (T[0], v, T[2], T[3])
    if i == 2:
        return (T[0], T[1], v, T[3])
    return (T[0], T[1], T[2], v)


@njit(cache=True)
def gjk_distance(ta, pa, qa, sa, tb, pb, qb, sb, va=None, vb=None):
    """Distance between the cores of two convex shapes.

    Returns ``(dist, point_a, point_b, overlap)``; when ``overlap`` the cores intersect
    (or are closer than about 1e-12 of their size) and the points are unreliable.
    ``va``, ``vb``: hull vertices of ``CONVEX`` shapes (see ``shapes.support_core``).
    """
    W = (_Z3, _Z3, _Z3, _Z3)
    PA = (_Z3, _Z3, _Z3, _Z3)
    PB = (_Z3, _Z3, _Z3, _Z3)
    v = sub(pa, pb)
    if norm2(v) < 1e-24:
        v = (1.0, 0.0, 0.0)
    a0 = support_core(ta, pa, qa, sa, (-v[0], -v[1], -v[2]), va)
    b0 = support_core(tb, pb, qb, sb, v, vb)
    w = sub(a0, b0)
    W = _set(W, np.int64(0), w)
    PA = _set(PA, np.int64(0), a0)
    PB = _set(PB, np.int64(0), b0)
    L = (1.0, 0.0, 0.0, 0.0)
    n = np.int64(1)
    v = w
    sc = max(norm(sub(support_core(ta, pa, qa, sa, (1.0, 1.0, 1.0), va),
                      support_core(ta, pa, qa, sa, (-1.0, -1.0, -1.0), va))),
             norm(sub(support_core(tb, pb, qb, sb, (1.0, 1.0, 1.0), vb),
                      support_core(tb, pb, qb, sb, (-1.0, -1.0, -1.0), vb)))) + norm(sub(pa, pb))
    tiny = (1e-12 * sc) ** 2
    overlap = False
    for _ in range(GJK_MAX_ITER):
        vv = norm2(v)
        if vv <= tiny:
            overlap = True
            break
        a = support_core(ta, pa, qa, sa, (-v[0], -v[1], -v[2]), va)
        b = support_core(tb, pb, qb, sb, v, vb)
        w = sub(a, b)
        if vv - vdot(v, w) <= 1e-13 * vv:
            break
        dup = False
        for i in range(n):
            if norm2(sub(W[i], w)) <= 1e-26 * (1.0 + vv):
                dup = True
        if dup:
            break
        W = _set(W, n, w)
        PA = _set(PA, n, a)
        PB = _set(PB, n, b)
        n += 1
        Lnew, inside = _closest_simplex(n, W)
        if inside:
            overlap = True
            L = Lnew
            break
        vnew = _combine(Lnew, W)
        if norm2(vnew) >= vv:
            # no progress (numerical): keep the previous simplex
            n -= 1
            break
        L = Lnew
        v = vnew
        # keep only the vertices that support the closest point
        m = np.int64(0)
        W2 = (_Z3, _Z3, _Z3, _Z3)
        A2 = (_Z3, _Z3, _Z3, _Z3)
        B2 = (_Z3, _Z3, _Z3, _Z3)
        L2 = (0.0, 0.0, 0.0, 0.0)
        for i in range(n):
            if L[i] > 0.0:
                W2 = _set(W2, m, W[i])
                A2 = _set(A2, m, PA[i])
                B2 = _set(B2, m, PB[i])
                L2 = _set(L2, m, L[i])
                m += 1
        W, PA, PB, L, n = W2, A2, B2, L2, m
    ca = _combine(L, PA)
    cb = _combine(L, PB)
    if overlap:
        return 0.0, ca, cb, True
    return norm(v), ca, cb, False


# ------------------------------------------------------------------------------ MPR

# What mpr_portal found.
PORTAL_MISS, PORTAL_FOUND, PORTAL_ON_RAY = 0, 1, 2


@njit(cache=True)
def minkowski_support(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, d, va, vb, unit):
    """Support of ``A - B`` in direction ``d``: ``(w, point_a, point_b)``.

    ``unit``: along ``d`` normalised, the cores inflated by the radii ``ra``, ``rb``
    (MPR on the rounded shapes); else along ``d`` as given, on the cores (EPA).
    """
    if unit:
        u = normalize_or(d, (1.0, 0.0, 0.0))
        a = madd(support_core(ta, pa, qa, sa, u, va), u, ra)
        b = madd(support_core(tb, pb, qb, sb, (-u[0], -u[1], -u[2]), vb), u, -rb)
    else:
        a = support_core(ta, pa, qa, sa, d, va)
        b = support_core(tb, pb, qb, sb, (-d[0], -d[1], -d[2]), vb)
    return sub(a, b), a, b


@njit(cache=True)
def mpr_portal(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, va, vb, v0, tol, unit):
    """MPR portal discovery: a triangle ``(v1, v2, v3)`` of support points of ``A - B``
    (``minkowski_support`` with ``unit``) that the ray from the interior point ``v0``
    through the origin crosses.

    Returns ``(status, v0, v1, a1, b1, v2, a2, b2, v3, a3, b3)``: ``v0`` moved off the
    origin by ``tol * 1e-3`` if it was closer, each ``v`` with its witness points on A
    and B. ``status``: PORTAL_FOUND; PORTAL_MISS (a support plane separates the shapes);
    PORTAL_ON_RAY when ``unit`` and the origin lies on the segment ``v0 - v1`` (only
    ``v1`` is set; the ray leaves through it). Without ``unit`` that case turns the
    search aside instead.
    """
    if norm2(v0) < (tol * 1e-3) ** 2:
        v0 = (tol * 1e-3, 0.0, 0.0)
    d = (-v0[0], -v0[1], -v0[2])
    v1, a1, b1 = minkowski_support(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, d, va, vb, unit)
    if vdot(v1, d) <= 0.0:
        return PORTAL_MISS, v0, v1, a1, b1, v1, a1, b1, v1, a1, b1
    d = vcross(v0, v1)
    if norm2(d) <= 1e-30 * norm2(v0) * norm2(v1):
        if unit:
            return PORTAL_ON_RAY, v0, v1, a1, b1, v1, a1, b1, v1, a1, b1
        d = vcross(v0, any_perp(normalize_or(v0, (1.0, 0.0, 0.0))))
    v2, a2, b2 = minkowski_support(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, d, va, vb, unit)
    if vdot(v2, d) <= 0.0:
        return PORTAL_MISS, v0, v1, a1, b1, v2, a2, b2, v2, a2, b2
    d = vcross(sub(v1, v0), sub(v2, v0))
    if vdot(d, v0) > 0.0:
        v1, a1, b1, v2, a2, b2 = v2, a2, b2, v1, a1, b1
        d = (-d[0], -d[1], -d[2])
    v3 = v1
    a3 = a1
    b3 = b1
    for _ in range(MPR_MAX_ITER):
        if norm2(d) == 0.0:
            break
        v3, a3, b3 = minkowski_support(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, d, va, vb, unit)
        if vdot(v3, d) <= 0.0:
            break
        if vdot(vcross(v1, v3), v0) < 0.0:
            v2, a2, b2 = v3, a3, b3
            d = vcross(sub(v1, v0), sub(v2, v0))
            continue
        if vdot(vcross(v3, v2), v0) < 0.0:
            v1, a1, b1 = v3, a3, b3
            d = vcross(sub(v1, v0), sub(v2, v0))
            continue
        return PORTAL_FOUND, v0, v1, a1, b1, v2, a2, b2, v3, a3, b3
    return PORTAL_MISS, v0, v1, a1, b1, v2, a2, b2, v3, a3, b3


@njit(cache=True)
def _tri_normal(a, b, c):
    return vcross(sub(b, a), sub(c, a))


@njit(cache=True, inline="always")
def replace_portal_vertex(v0, v1, a1, b1, v2, a2, b2, v3, a3, b3, v4, a4, b4):
    """MPR portal refinement: the new support point ``v4`` (with its witness points ``a4``,
    ``b4``) replaces the portal vertex on the side of the plane through ``v0`` and ``v4``
    that keeps the origin ray inside the portal. Returns the three updated vertices."""
    c = vcross(v4, v0)
    if vdot(v1, c) > 0.0:
        if vdot(v2, c) > 0.0:
            return v4, a4, b4, v2, a2, b2, v3, a3, b3
        return v1, a1, b1, v2, a2, b2, v4, a4, b4
    if vdot(v3, c) > 0.0:
        return v1, a1, b1, v4, a4, b4, v3, a3, b3
    return v4, a4, b4, v2, a2, b2, v3, a3, b3


@njit(cache=True)
def mpr_penetration(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, tol, va=None, vb=None):
    """Penetration of two convex shapes (cores inflated by ``ra``, ``rb``).

    Returns ``(hit, normal A->B, depth, point_a, point_b)`` where ``point_a`` is the
    point of A deepest in B and ``point_b`` that of B (``point_a - point_b`` is about
    ``depth * normal``). ``hit`` is False when the shapes do not overlap. ``tol`` is
    the absolute length tolerance of the portal refinement. ``va``, ``vb``: hull
    vertices of ``CONVEX`` shapes.
    """
    miss = (False, (0.0, 0.0, 1.0), 0.0, _Z3, _Z3)
    status, v0, v1, a1, b1, v2, a2, b2, v3, a3, b3 = mpr_portal(
        ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, va, vb, sub(pa, pb), tol, True)
    if status == PORTAL_MISS:
        return miss
    if status == PORTAL_ON_RAY:
        nv = norm(v0)
        n = (-v0[0] / nv, -v0[1] / nv, -v0[2] / nv)
        return True, n, vdot(v1, n), a1, b1
    # portal refinement
    hit = False
    n = (0.0, 0.0, 1.0)
    for _ in range(MPR_MAX_ITER):
        nn = _tri_normal(v1, v2, v3)
        if norm2(nn) == 0.0:
            break
        n = normalize_or(nn, n)
        if not hit and vdot(n, v1) >= 0.0:
            hit = True
        v4, a4, b4 = minkowski_support(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, n, va, vb, True)
        d4 = vdot(v4, n)
        if not hit and d4 < 0.0:
            return miss
        gap = min(d4 - vdot(v1, n), min(d4 - vdot(v2, n), d4 - vdot(v3, n)))
        if gap <= tol:
            break
        v1, a1, b1, v2, a2, b2, v3, a3, b3 = replace_portal_vertex(
            v0, v1, a1, b1, v2, a2, b2, v3, a3, b3, v4, a4, b4)
    if not hit:
        return miss
    depth = vdot(n, v1)
    # barycentric weights of the origin's projection on the portal, clamped to it
    l0, l1, l2 = _closest_triangle(sub(v1, scale(n, depth)), sub(v2, scale(n, depth)),
                                   sub(v3, scale(n, depth)))
    ca = add(add(scale(a1, l0), scale(a2, l1)), scale(a3, l2))
    cb = add(add(scale(b1, l0), scale(b2, l1)), scale(b3, l2))
    return True, n, depth, ca, cb
