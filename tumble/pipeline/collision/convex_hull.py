"""Convex hulls (``CONVEX``): support sets, contact manifolds, AABB, ray cast.

A convex geom is the convex hull of ``verts`` (k, 3), hull vertices in the geom frame
(``m.mesh_vert[adr:adr + num]``). The support function (``shapes.support_core`` with
``verts``) is a linear scan, so GJK/MPR (``gjk``, ``convex``) work unchanged.

Contacts (normal from A to B, midpoint convention of ``primitives``):

* plane-convex: every hull vertex below the plane (depth > -margin) is a candidate;
  up to 4 are kept: the deepest, the farthest from it, and the two farthest either
  side of the line through those two (like ``box_box``'s reduction). Exact.
  Feature = vertex index.
* convex against sphere, capsule, box, cylinder or convex: one deepest contact
  (:func:`hull_contact`): GJK when apart (exact); when the cores overlap, EPA (``epa``)
  on the cores if both are polytopes (point, segment, box, hull: the global least
  penetration, exact), else (cylinders) ``convex.convex_contact``'s MPR with
  refinement. When a *face* is found along the contact normal (a box face, a hull
  support face, or a cylinder cap; within about 1.8 degrees, see ``COS_FACE``), it
  becomes the reference face and the other shape's support feature is clipped
  against it (Sutherland-Hodgman), up to 4 points; the GJK/MPR point is added when it
  is deeper than all of them.

Hull support *faces* carry no topology: the support set along ``u`` is the deepest
vertex plus the vertices within a slope of ``TAN_FACE`` from it; its convex outline
(in the plane orthogonal to ``u``) is the face polygon, and its Newell normal the face
normal.

Feature ids of clipped contacts: ``1 + FEAT_SIDE * (1 if the reference face is on B
else 0) + code`` with ``code`` = incident vertex index (a box corner index
``bx + 2 by + 4 bz``, a hull vertex index, or a ``manifold`` candidate of a round
shape), ``256 + reference vertex index`` for a reference corner inside the incident
polygon, ``512 + 256 * (256 * i_lo + i_hi) + r`` for the crossing of incident edge
``(i_lo, i_hi)`` with reference edge starting at reference vertex ``r``. 0 is the
GJK/MPR point.

Approximations: against a cylinder cap (disc reference) only hull vertices inside
the disc are contacts (no polygon-circle crossings); a round shape on a hull face
contributes its ``manifold`` candidates inside the face (as for boxes).

Scratch arrays of the size of the hull are allocated per call (no topology is stored).
"""
import math

import numpy as np
from numba import njit

from ...math.quat import quat_rotate, quat_rotate_inv
from ._vec import (any_perp, local_to_world, madd, mid, norm, normalize_or, q4, sub, v3, vcross,
                   vdot, write_contact)
from .convex import COS_FACE, convex_contact
from .epa import epa_penetration, polytope_core
from .gjk import gjk_distance
from .manifold import add_single_contact, candidate_frame, incident_point, num_candidates
from .shapes import BOX, CONVEX, CYLINDER, SPHERE, core_radius, shape_scale

#: Slope (tangent of ~1.8 degrees, matching ``COS_FACE``) below which a vertex joins
#: the support face of the deepest vertex.
TAN_FACE = 0.0316
#: Feature offset of contacts whose reference face is on geom B.
FEAT_SIDE = 1 << 25
_FEAT_REF = 256
_FEAT_CROSS = 512
_IDENT = (0.0, 0.0, 0.0, 1.0)
_Z3 = (0.0, 0.0, 0.0)


# -------------------------------------------------------------------- polytope access

@njit(cache=True)
def is_polytope(gtype):
    return gtype == BOX or gtype == CONVEX


@njit(cache=True)
def poly_count(gtype, verts):
    """Number of vertices of a box (8) or hull."""
    if gtype == BOX:
        return 8
    return verts.shape[0]


@njit(cache=True)
def poly_local(gtype, size, verts, k):
    """Vertex ``k`` in the geom frame (box corner ``bx + 2 by + 4 bz``)."""
    if gtype == BOX:
        return (float(size[0] if (k & 1) else -size[0]), float(size[1] if (k & 2) else -size[1]),
                float(size[2] if (k & 4) else -size[2]))
    return (float(verts[k, 0]), float(verts[k, 1]), float(verts[k, 2]))


@njit(cache=True)
def hull_aabb(verts, pos, quat, margin):
    """World AABB ``(lo, hi)`` of a hull (exact: the extreme vertices), grown by margin."""
    lx = ly = lz = math.inf
    hx = hy = hz = -math.inf
    q = q4(quat)
    for i in range(verts.shape[0]):
        w = quat_rotate(q, (verts[i, 0], verts[i, 1], verts[i, 2]))
        lx = min(lx, w[0])
        ly = min(ly, w[1])
        lz = min(lz, w[2])
        hx = max(hx, w[0])
        hy = max(hy, w[1])
        hz = max(hz, w[2])
    return ((pos[0] + lx - margin, pos[1] + ly - margin, pos[2] + lz - margin),
            (pos[0] + hx + margin, pos[1] + hy + margin, pos[2] + hz + margin))


@njit(cache=True)
def hull_contact(ta, pa, qa, sa, va, tb, pb, qb, sb, vb):
    """Deepest/nearest contact of two shapes, one at least a hull, as
    ``convex.convex_contact`` (``(depth, normal A -> B, point_a, point_b)``), but with
    EPA on the cores when they overlap and both are polytopes (points, segments,
    boxes, hulls): the global least penetration, exact. Cylinders keep MPR with
    refinement."""
    if polytope_core(ta) and polytope_core(tb):
        ra = core_radius(ta, sa)
        rb = core_radius(tb, sb)
        sc = shape_scale(ta, sa, va) + shape_scale(tb, sb, vb)
        dist, ca, cb, overlap = gjk_distance(ta, pa, qa, sa, tb, pb, qb, sb, va, vb)
        if not overlap and dist > 1e-9 * sc:
            n = normalize_or(sub(cb, ca), (0.0, 0.0, 1.0))
            return ra + rb - dist, n, madd(ca, n, ra), madd(cb, n, -rb)
        ok, depth, n, xa, xb = epa_penetration(ta, pa, qa, sa, va, tb, pb, qb, sb, vb,
                                               1e-13 * sc)
        if ok:
            return depth + ra + rb, n, madd(xa, n, ra), madd(xb, n, -rb)
    return convex_contact(ta, pa, qa, sa, tb, pb, qb, sb, va, vb)


# ----------------------------------------------------------------- support polygons

@njit(cache=True)
def _support_ids(gtype, quat, size, verts, u, tol, ids):
    """Vertices of the support feature along world direction ``u`` (unit): the deepest
    vertex and those within slope ``TAN_FACE`` (plus ``tol``) of it. Writes vertex
    indices into ``ids``, returns the count (deepest first)."""
    ul = quat_rotate_inv(quat, u)
    nv = poly_count(gtype, verts)
    best = -math.inf
    kmax = np.int64(0)
    for k in range(nv):
        s = vdot(poly_local(gtype, size, verts, k), ul)
        if s > best:
            best = s
            kmax = k
    vm = poly_local(gtype, size, verts, kmax)
    ids[0] = kmax
    c = 1
    for k in range(nv):
        if k == kmax:
            continue
        rel = sub(poly_local(gtype, size, verts, k), vm)
        drop = -vdot(rel, ul)
        lat = norm(madd(rel, ul, drop))
        if drop <= tol + TAN_FACE * lat:
            ids[c] = k
            c += 1
    return c


@njit(cache=True)
def _hull2d(xy, ids, cnt, tol, out):
    """Counter-clockwise convex outline of the 2-D points ``xy[i]`` for ``i`` in
    ``ids[:cnt]`` (monotone chain; collinear and duplicate points dropped). Writes
    entries of ``ids`` into ``out`` and returns their number (1 or 2 for degenerate
    sets)."""
    # insertion sort of ids by (x, y)
    for a in range(1, cnt):
        k = ids[a]
        b = a - 1
        while b >= 0 and (xy[ids[b], 0] > xy[k, 0] or
                          (xy[ids[b], 0] == xy[k, 0] and xy[ids[b], 1] > xy[k, 1])):
            ids[b + 1] = ids[b]
            b -= 1
        ids[b + 1] = k
    if cnt == 1:
        out[0] = ids[0]
        return 1
    h = 0
    for pas in range(2):
        lo = h
        for a in range(cnt):
            k = ids[a] if pas == 0 else ids[cnt - 1 - a]
            while h >= lo + 2:
                o = out[h - 2]
                p = out[h - 1]
                cr = ((xy[p, 0] - xy[o, 0]) * (xy[k, 1] - xy[o, 1])
                      - (xy[p, 1] - xy[o, 1]) * (xy[k, 0] - xy[o, 0]))
                ln = math.hypot(xy[k, 0] - xy[o, 0], xy[k, 1] - xy[o, 1])
                if cr <= tol * ln:
                    h -= 1
                else:
                    break
            out[h] = k
            h += 1
        h -= 1   # the last point of each chain starts the other one
    if h == 2 and out[0] == out[1]:
        h = 1
    if h == 2:
        dx = xy[out[0], 0] - xy[out[1], 0]
        dy = xy[out[0], 1] - xy[out[1], 1]
        if math.hypot(dx, dy) <= tol:
            h = 1
    return h


@njit(cache=True)
def _frame(n):
    t1 = any_perp(n)
    return t1, vcross(n, t1)


@njit(cache=True)
def support_polygon(gtype, pos, quat, size, verts, u, tol, ids, xy, poly):
    """Support face of a polytope along world ``u``: its vertex indices in
    counter-clockwise order about ``u`` in ``poly``. Returns ``(count, normal, area)``:
    the Newell normal (world, unit; ``u`` when count < 3) and area of the polygon."""
    c = _support_ids(gtype, quat, size, verts, u, tol, ids)
    ul = quat_rotate_inv(quat, u)
    t1, t2 = _frame(ul)
    for a in range(c):
        p = poly_local(gtype, size, verts, ids[a])
        xy[ids[a], 0] = vdot(p, t1)
        xy[ids[a], 1] = vdot(p, t2)
    h = _hull2d(xy, ids, c, tol, poly)
    if h < 3:
        return h, u, 0.0
    nx = ny = nz = 0.0
    for a in range(h):
        p = poly_local(gtype, size, verts, poly[a])
        q = poly_local(gtype, size, verts, poly[(a + 1) % h])
        nx += (p[1] - q[1]) * (p[2] + q[2])
        ny += (p[2] - q[2]) * (p[0] + q[0])
        nz += (p[0] - q[0]) * (p[1] + q[1])
    nl = (nx, ny, nz)
    area = 0.5 * norm(nl)
    return h, quat_rotate(quat, normalize_or(nl, ul)), area


# ------------------------------------------------------------------ 4-point reduction

@njit(cache=True)
def _better(v, f, bv, bf, tol):
    """``v`` beats ``bv`` by more than ``tol``, or ties it with a smaller feature id."""
    return v > bv + tol or (v >= bv - tol and f < bf)


@njit(cache=True)
def _gap(cand, i, k, wn):
    d = math.hypot(cand[i, 0] - cand[k, 0], cand[i, 1] - cand[k, 1])
    if wn > 0.0:
        dn = math.sqrt((cand[i, 8] - cand[k, 8]) ** 2 + (cand[i, 9] - cand[k, 9]) ** 2
                       + (cand[i, 10] - cand[k, 10]) ** 2)
        d = math.hypot(d, wn * dn)
    return d


@njit(cache=True)
def select4(cand, n, tol, wn):
    """Indices of up to 4 rows of ``cand`` (columns: x, y, depth, px, py, pz, feature,
    and with ``wn > 0`` the normal in columns 8..10): the deepest, the farthest from it,
    and the farthest either side of the line through those two. Distances are in
    (x, y), plus ``wn`` times the normal difference. Near ties (within ``tol``) go to
    the smaller feature id, so the choice is stable. -1 for unused slots."""
    k0 = -1
    bv = -math.inf
    for i in range(n):
        if k0 < 0 or _better(cand[i, 2], cand[i, 6], bv, cand[k0, 6], tol):
            bv = cand[i, 2]
            k0 = i
    if k0 < 0:
        return -1, -1, -1, -1
    k1 = -1
    bv = 10.0 * tol
    for i in range(n):
        d = _gap(cand, i, k0, wn)
        if d > 10.0 * tol and (k1 < 0 or _better(d, cand[i, 6], bv, cand[k1, 6], tol)):
            bv = d
            k1 = i
    if k1 < 0:
        return k0, -1, -1, -1
    lx = cand[k1, 0] - cand[k0, 0]
    ly = cand[k1, 1] - cand[k0, 1]
    ll = math.hypot(lx, ly)
    if ll <= 10.0 * tol:
        return k0, k1, -1, -1
    k2 = -1
    k3 = -1
    amax = 10.0 * tol
    amin = 10.0 * tol
    for i in range(n):
        if i == k0 or i == k1:
            continue
        a = (lx * (cand[i, 1] - cand[k0, 1]) - ly * (cand[i, 0] - cand[k0, 0])) / ll
        if a > 10.0 * tol and (k2 < 0 or _better(a, cand[i, 6], amax, cand[k2, 6], tol)):
            amax = a
            k2 = i
        if -a > 10.0 * tol and (k3 < 0 or _better(-a, cand[i, 6], amin, cand[k3, 6], tol)):
            amin = -a
            k3 = i
    return k0, k1, k2, k3


@njit(cache=True)
def _put(cand, i, x, y, depth, p, feature):
    cand[i, 0] = x
    cand[i, 1] = y
    cand[i, 2] = depth
    cand[i, 3] = p[0]
    cand[i, 4] = p[1]
    cand[i, 5] = p[2]
    cand[i, 6] = feature


@njit(cache=True)
def write_selected(cand, n, tol, nref, flip, out_point, out_normal, out_depth, out_feature,
                   start):
    """Write the rows chosen by :func:`select4`. Column 3..5 is the incident surface
    point, ``nref`` the reference normal towards the incident shape; the written
    normal is ``nref`` (or ``-nref`` when ``flip``), the point midway.
    Returns ``(count, deepest depth or -inf)``."""
    k0, k1, k2, k3 = select4(cand, n, tol, 0.0)
    sg = -1.0 if flip else 1.0
    nn = (sg * nref[0], sg * nref[1], sg * nref[2])
    cnt = 0
    dmax = -math.inf
    for slot in range(4):
        k = k0 if slot == 0 else (k1 if slot == 1 else (k2 if slot == 2 else k3))
        if k < 0:
            continue
        d = cand[k, 2]
        p = madd((cand[k, 3], cand[k, 4], cand[k, 5]), nref, 0.5 * d)
        write_contact(out_point, out_normal, out_depth, out_feature, start + cnt, p, nn, d,
                      int(cand[k, 6]))
        dmax = max(dmax, d)
        cnt += 1
    return cnt, dmax


# ------------------------------------------------------------------------- plane-hull

@njit(cache=True)
def collide_plane_convex(pos_a, quat_a, pos_b, quat_b, verts, margin, out_point, out_normal,
                         out_depth, out_feature, start):
    """Plane A, hull B: up to 4 vertices below the plane (see module doc)."""
    qa = q4(quat_a)
    qb = q4(quat_b)
    pa = v3(pos_a)
    pb = v3(pos_b)
    n = quat_rotate(qa, (0.0, 0.0, 1.0))
    t1 = quat_rotate(qa, (1.0, 0.0, 0.0))
    t2 = quat_rotate(qa, (0.0, 1.0, 0.0))
    nl = quat_rotate_inv(qb, n)
    off = vdot(n, sub(pb, pa))
    nv = verts.shape[0]
    sc = shape_scale(np.int64(CONVEX), _Z3, verts)
    cnt = 0
    for k in range(nv):
        if off + vdot(nl, (verts[k, 0], verts[k, 1], verts[k, 2])) < margin:
            cnt += 1
    if cnt == 0:
        return 0
    cand = np.empty((cnt, 7))
    c = np.int64(0)
    for k in range(nv):
        h = off + vdot(nl, (verts[k, 0], verts[k, 1], verts[k, 2]))
        if h < margin:
            p = local_to_world(pb, qb, (verts[k, 0], verts[k, 1], verts[k, 2]))
            rel = sub(p, pa)
            _put(cand, c, vdot(rel, t1), vdot(rel, t2), -h, p, k)
            c += 1
    return write_selected(cand, c, 1e-9 * sc, n, bool(False), out_point, out_normal, out_depth,
                          out_feature, start)[0]


# ------------------------------------------------------------------------- clipping

@njit(cache=True)
def _clip_edge(src, ns, dst, ax, ay, bx, by, tol):
    """Keep the part of polygon ``src[:ns]`` (x, y, z rows) left of a -> b."""
    ex = bx - ax
    ey = by - ay
    le = math.hypot(ex, ey)
    if le <= 0.0:
        for i in range(ns):
            for c in range(3):
                dst[i, c] = src[i, c]
        return ns
    nd = 0
    for i in range(ns):
        j = (i + 1) % ns
        si = (ex * (src[i, 1] - ay) - ey * (src[i, 0] - ax)) / le
        sj = (ex * (src[j, 1] - ay) - ey * (src[j, 0] - ax)) / le
        ini = si >= -tol
        inj = sj >= -tol
        if ini:
            for c in range(3):
                dst[nd, c] = src[i, c]
            nd += 1
        if ini != inj and ns > 1:
            t = si / (si - sj)
            for c in range(3):
                dst[nd, c] = src[i, c] + t * (src[j, c] - src[i, c])
            nd += 1
    return nd


@njit(cache=True)
def _seg_dist(px, py, ax, ay, bx, by):
    ex = bx - ax
    ey = by - ay
    ll = ex * ex + ey * ey
    t = 0.0
    if ll > 0.0:
        t = min(1.0, max(0.0, ((px - ax) * ex + (py - ay) * ey) / ll))
    return math.hypot(px - ax - t * ex, py - ay - t * ey)


@njit(cache=True)
def _classify(x, y, inc, ni, inc_id, ref, nr, ref_id, tol):
    """Feature code of a clipped point (see module doc)."""
    for i in range(ni):
        if math.hypot(x - inc[i, 0], y - inc[i, 1]) <= tol:
            return inc_id[i]
    for r in range(nr):
        if math.hypot(x - ref[r, 0], y - ref[r, 1]) <= tol:
            return _FEAT_REF + ref_id[r]
    be = 0
    bd = math.inf
    for i in range(ni):
        j = (i + 1) % ni
        d = _seg_dist(x, y, inc[i, 0], inc[i, 1], inc[j, 0], inc[j, 1])
        if d < bd:
            bd = d
            be = i
    br = 0
    bd = math.inf
    for r in range(nr):
        s = (r + 1) % nr
        d = _seg_dist(x, y, ref[r, 0], ref[r, 1], ref[s, 0], ref[s, 1])
        if d < bd:
            bd = d
            br = r
    a = inc_id[be]
    b = inc_id[(be + 1) % ni]
    lo = min(a, b)
    hi = max(a, b)
    return _FEAT_CROSS + 256 * (256 * lo + hi) + ref_id[br]


# ------------------------------------------------------------------ generic manifold

@njit(cache=True)
def _cap_face(pos, quat, size, u):
    """Cylinder cap facing ``u``: ``(|axis.u|, centre, outward normal)``."""
    a = quat_rotate(quat, (0.0, 0.0, 1.0))
    an = vdot(a, u)
    s = 1.0 if an >= 0.0 else -1.0
    c = (s * a[0], s * a[1], s * a[2])
    return abs(an), madd(pos, c, size[1]), c


@njit(cache=True)
def _world_vertex(gtype, pos, quat, size, verts, k):
    return local_to_world(pos, quat, poly_local(gtype, size, verts, k))


@njit(cache=True)
def _reference_face(gtype, pos, quat, size, verts, u, tol, ids, xy, poly):
    """The shape's candidate reference face along its outward direction ``u`` (unit,
    world): ``(kind, area, normal, centre, count)``. kind 0: none (normal ``u``, centre
    ``pos``); 1: the support polygon of a polytope (its ``count`` vertex ids in ``poly``)
    when it has 3 vertices or more and faces ``u`` within ``COS_FACE``; 2: a cylinder cap
    facing ``u`` as closely (disc at ``centre``)."""
    kind = 0
    area = 0.0
    f = u
    c = pos
    cnt = 0
    if is_polytope(gtype):
        cnt, f, area = support_polygon(gtype, pos, quat, size, verts, u, tol, ids, xy, poly)
        if cnt >= 3 and vdot(f, u) >= COS_FACE:
            kind = 1
    elif gtype == CYLINDER:
        align, c, f = _cap_face(pos, quat, size, u)
        if align >= COS_FACE:
            kind = 2
            area = math.pi * size[0] * size[0]
    return kind, area, f, c, cnt


@njit(cache=True)
def collide_convex_general(ta, pos_a, quat_a, size_a, va, tb, pos_b, quat_b, size_b, vb,
                           margin, out_point, out_normal, out_depth, out_feature, start):
    """Contacts of A and B, shapes among sphere, capsule, box, cylinder and convex
    (``va``/``vb`` the hull vertices; any (k, 3) array for other types). Normal A -> B.
    See the module doc."""
    pa, qa, sa = v3(pos_a), q4(quat_a), v3(size_a)
    pb, qb, sb = v3(pos_b), q4(quat_b), v3(size_b)
    depth0, n, xa, xb = hull_contact(ta, pa, qa, sa, va, tb, pb, qb, sb, vb)
    if depth0 <= -margin:
        return 0
    sc = shape_scale(ta, sa, va) + shape_scale(tb, sb, vb)
    tol = 1e-9 * sc
    nva = poly_count(ta, va) if is_polytope(ta) else 8
    nvb = poly_count(tb, vb) if is_polytope(tb) else 8
    nmax = max(nva, nvb)
    ids = np.empty(nmax, np.int64)
    xy = np.empty((nmax, 2))
    polya = np.empty(2 * nmax + 2, np.int64)
    polyb = np.empty(2 * nmax + 2, np.int64)
    kind_a, area_a, fa, ca, cnt_a = _reference_face(ta, pa, qa, sa, va, n, tol, ids, xy, polya)
    kind_b, area_b, fb, cb, cnt_b = _reference_face(tb, pb, qb, sb, vb, (-n[0], -n[1], -n[2]),
                                                    tol, ids, xy, polyb)
    if kind_a == 0 and kind_b == 0:
        write_contact(out_point, out_normal, out_depth, out_feature, start, mid(xa, xb), n,
                      depth0, int(0))
        return 1
    use_b = kind_a == 0 or (kind_b != 0 and area_b > area_a * (1.0 + 1e-9))
    # one call site (no literal arguments): reference r, incident i
    tr, pr, qr, sr, vr = (tb, pb, qb, sb, vb) if use_b else (ta, pa, qa, sa, va)
    ti, pi, qi, si, vi = (ta, pa, qa, sa, va) if use_b else (tb, pb, qb, sb, vb)
    kind = kind_b if use_b else kind_a
    nref = fb if use_b else fa
    cref = cb if use_b else ca
    rpoly = polyb if use_b else polya
    nrp = cnt_b if use_b else cnt_a
    cnt, dmax = _face_contacts(tr, pr, qr, sr, vr, kind, nref, cref, rpoly, nrp, ti, pi, qi, si,
                               vi, use_b, margin, tol, ids, xy, out_point, out_normal, out_depth,
                               out_feature, start)
    return add_single_contact(cnt, dmax, depth0, n, xa, xb, 1e-6 * sc, out_point, out_normal,
                              out_depth, out_feature, start)


@njit(cache=True)
def _face_contacts(tr, pr, qr, sr, vr, kind, nref, cap_c, rpoly, nrp, ti, pi, qi, si, vi,
                   ref_is_b, margin, tol, ids, xy, out_point, out_normal, out_depth,
                   out_feature, start):
    """Contacts of the incident shape ``i`` against the reference face of ``r``
    (polygon ``rpoly[:nrp]`` of vertex indices, or the cap disc at ``cap_c``), face
    normal ``nref`` pointing towards ``i``. Returns ``(count, deepest)``."""
    t1, t2 = _frame(nref)
    side = FEAT_SIDE if ref_is_b else 0
    if kind == 1:
        # reference polygon in (t1, t2) about its first vertex; plane at its highest vertex
        o = _world_vertex(tr, pr, qr, sr, vr, rpoly[0])
        ref = np.empty((nrp, 2))
        ref_id = np.empty(nrp, np.int64)
        dref = -math.inf
        for r in range(nrp):
            p = sub(_world_vertex(tr, pr, qr, sr, vr, rpoly[r]), o)
            ref[r, 0] = vdot(p, t1)
            ref[r, 1] = vdot(p, t2)
            ref_id[r] = rpoly[r]
            dref = max(dref, vdot(p, nref))
    else:
        o = cap_c
        ref = np.empty((0, 2))
        ref_id = np.empty(0, np.int64)
        dref = 0.0
    rad = sr[0]
    if is_polytope(ti):
        nneg = (-nref[0], -nref[1], -nref[2])
        c = _support_ids(ti, qi, si, vi, nneg, tol, ids)
        for a in range(c):
            p = sub(_world_vertex(ti, pi, qi, si, vi, ids[a]), o)
            xy[ids[a], 0] = vdot(p, t1)
            xy[ids[a], 1] = vdot(p, t2)
        ipoly = np.empty(2 * c + 2, np.int64)
        ni = _hull2d(xy, ids, c, tol, ipoly)
        inc = np.empty((ni, 3))
        inc_id = np.empty(ni, np.int64)
        for a in range(ni):
            p = sub(_world_vertex(ti, pi, qi, si, vi, ipoly[a]), o)
            inc[a, 0] = vdot(p, t1)
            inc[a, 1] = vdot(p, t2)
            inc[a, 2] = vdot(p, nref) - dref
            inc_id[a] = ipoly[a]
        if kind == 1:
            cap = ni + nrp + 4
            b1 = np.empty((2 * cap, 3))
            b2 = np.empty((2 * cap, 3))
            for a in range(ni):
                for k in range(3):
                    b1[a, k] = inc[a, k]
            ns = ni
            for r in range(nrp):
                s = (r + 1) % nrp
                if r % 2 == 0:
                    ns = _clip_edge(b1, ns, b2, ref[r, 0], ref[r, 1], ref[s, 0], ref[s, 1], tol)
                else:
                    ns = _clip_edge(b2, ns, b1, ref[r, 0], ref[r, 1], ref[s, 0], ref[s, 1], tol)
                if ns == 0:
                    break
            res = b2 if nrp % 2 == 1 else b1
            cand = np.empty((max(ns, 1), 7))
            m = np.int64(0)
            for a in range(ns):
                depth = -res[a, 2]
                if depth <= -margin:
                    continue
                x = res[a, 0]
                y = res[a, 1]
                dup = False
                for b in range(m):
                    if math.hypot(cand[b, 0] - x, cand[b, 1] - y) <= 10.0 * tol:
                        dup = True
                if dup:
                    continue
                p = madd(madd(madd(o, t1, x), t2, y), nref, res[a, 2] + dref)
                f = _classify(x, y, inc, ni, inc_id, ref, nrp, ref_id, 100.0 * tol)
                _put(cand, m, x, y, depth, p, 1 + side + f)
                m += 1
        else:
            cand = np.empty((max(ni, 1), 7))
            m = np.int64(0)
            for a in range(ni):
                x = inc[a, 0]
                y = inc[a, 1]
                depth = -inc[a, 2]
                if depth <= -margin or math.hypot(x, y) > rad * (1.0 + 1e-9) + tol:
                    continue
                p = madd(madd(madd(o, t1, x), t2, y), nref, inc[a, 2] + dref)
                _put(cand, m, x, y, depth, p, 1 + side + inc_id[a])
                m += 1
    else:
        if ti == SPHERE:
            return 0, -math.inf
        # round incident shape: its manifold candidates inside the polygon
        rim_a, rim_s, rim_v, rim_u = candidate_frame(ti, pi, qi, nref)
        nc = num_candidates(ti)
        cand = np.empty((nc, 7))
        m = np.int64(0)
        for k in range(nc):
            valid, pw, f = incident_point(ti, pi, qi, si, k, nref, rim_a, rim_s, rim_v, rim_u)
            if not valid:
                continue
            p = sub(pw, o)
            x = vdot(p, t1)
            y = vdot(p, t2)
            depth = dref - vdot(p, nref)
            if depth <= -margin:
                continue
            inside = True
            if kind == 1:
                for r in range(nrp):
                    s = (r + 1) % nrp
                    ex = ref[s, 0] - ref[r, 0]
                    ey = ref[s, 1] - ref[r, 1]
                    le = math.hypot(ex, ey)
                    if le > 0.0 and (ex * (y - ref[r, 1]) - ey * (x - ref[r, 0])) / le < -tol:
                        inside = False
            elif math.hypot(x, y) > rad * (1.0 + 1e-9) + tol:
                inside = False
            if inside:
                _put(cand, m, x, y, depth, pw, 1 + side + f)
                m += 1
    if m == 0:
        return 0, -math.inf
    return write_selected(cand, m, tol, nref, ref_is_b, out_point, out_normal, out_depth,
                          out_feature, start)


# -------------------------------------------------------------------------- ray cast

@njit(cache=True)
def raycast_convex(verts, pos, quat, origin, direction, max_dist):
    """First hit of the ray ``origin + t direction`` (unit) with a hull:
    ``(t, world normal)`` or ``(-1, (0, 0, 0))``; ``(0, -direction)`` from inside.

    GJK ray cast by conservative advancement: step to the separating plane of the
    current point and the hull until the distance vanishes (exact for flat faces after
    a few steps; converges linearly at edges and vertices). Accuracy about 1e-10 of
    the hull size.
    """
    q = q4(quat)
    p = v3(pos)
    o = quat_rotate_inv(q, sub(v3(origin), p))
    d = quat_rotate_inv(q, v3(direction))
    sc = shape_scale(np.int64(CONVEX), _Z3, verts)
    eps = 1e-11 * sc
    t = 0.0
    x = o
    nh = (0.0, 0.0, 0.0)
    for it in range(200):
        dist, ca, cb, overlap = gjk_distance(np.int64(SPHERE), x, _IDENT, _Z3, np.int64(CONVEX),
                                             _Z3, _IDENT, _Z3, verts, verts)
        if overlap or dist <= eps:
            if it == 0:
                return 0.0, (-float(direction[0]), -float(direction[1]), -float(direction[2]))
            return t, quat_rotate(q, nh)
        v = sub(x, cb)
        vd = vdot(v, d)
        if vd >= -1e-15 * dist:
            return -1.0, (0.0, 0.0, 0.0)
        t += dist * dist / (-vd)
        if t > max_dist:
            return -1.0, (0.0, 0.0, 0.0)
        x = madd(o, d, t)
        nh = (v[0] / dist, v[1] / dist, v[2] / dist)
    return t, quat_rotate(q, nh)


# ------------------------------------------------------------------------- distances

@njit(cache=True)
def convex_distance(ta, pos_a, quat_a, size_a, va, tb, pos_b, quat_b, size_b, vb):
    """Signed distance ``(d, point_a, point_b)`` of two shapes (sphere..convex) by GJK
    (apart, exact) or MPR with refinement (penetrating: minus the depth)."""
    depth, n, xa, xb = hull_contact(ta, v3(pos_a), q4(quat_a), v3(size_a), va, tb, v3(pos_b),
                                    q4(quat_b), v3(size_b), vb)
    return -depth, xa, xb


@njit(cache=True)
def plane_convex_distance(pos_a, quat_a, pos_b, quat_b, verts):
    """Signed distance of a hull above a plane: ``(d, point on plane, hull vertex)``."""
    n = quat_rotate(q4(quat_a), (0.0, 0.0, 1.0))
    qb = q4(quat_b)
    nl = quat_rotate_inv(qb, (-n[0], -n[1], -n[2]))
    from_k = 0
    best = -math.inf
    for k in range(verts.shape[0]):
        s = verts[k, 0] * nl[0] + verts[k, 1] * nl[1] + verts[k, 2] * nl[2]
        if s > best:
            best = s
            from_k = k
    sp = local_to_world(v3(pos_b), qb, (verts[from_k, 0], verts[from_k, 1], verts[from_k, 2]))
    dist = vdot(n, sub(sp, v3(pos_a)))
    return dist, madd(sp, n, -dist), sp

