"""Box-box contacts: separating axis test over 15 axes, then reference-face clipping
(up to 4 points) or one edge-edge point.

Feature ids:

* face contact: ``((ref_box * 6 + ref_face) * 6 + inc_face) * 24 + c`` where
  ``ref_box`` is 0 when A holds the reference face, 1 for B; a face is
  ``2 * axis + (1 if its outward normal is +axis else 0)``; ``c`` is the candidate:
  0-3 an incident-face vertex, 4-7 a reference-face corner, ``8 + 4 e + s`` the
  crossing of incident edge ``e`` with reference side ``s``. Range 0..1727.
* edge-edge contact: ``2000 + 12 * edge_a + edge_b`` with ``edge = 4 * axis + b1 + 2 b2``
  (``b1``, ``b2`` the sides of the edge along the two other axes, in cyclic order).
  When the boxes are apart (within the margin) the point, normal and depth come from
  GJK's exact closest points, keeping the edge pair's feature id.
* 3000: boxes apart whose clipped reference face gave no point (GJK closest points).
"""
import math

import numpy as np
from numba import njit

from ..._jit import noalloc

from ._vec import (frame_axes, madd, mid, norm, normalize_or, q4, sub, v3, vcross, vdot,
                   write_contact)
from .gjk import gjk_distance
from .primitives import segment_closest
from .shapes import BOX

EDGE_FEATURE_BASE = 2000
#: Feature of the single closest-point contact of boxes apart, when no face or edge
#: pair is identified.
GJK_FEATURE = 3000
# An edge axis must beat the best face axis by 5 % of the depth (plus a hair) to be
# used: face contacts give stable multi-point manifolds.
_EDGE_REL = 0.05
_EDGE_ABS = 1e-9


@noalloc
def _sgn(x):
    return 1.0 if x >= 0.0 else -1.0


@noalloc
def box_sat(pa, A, ha, pb, B, hb):
    """Separating axis test. ``A``, ``B`` are the world axes of the boxes.

    Returns ``(sep_f, kind_f, idx_f, n_f, sep_e, ie, je, n_e, has_edge)``: the best
    (largest) separation over the 6 face axes, which box (0 = A, 1 = B) and axis, its
    unit direction from A to B, then the same for the 9 edge-pair axes. Separation is
    the gap along the axis, negative when the projections overlap.
    """
    d = sub(pb, pa)
    sep_f = -math.inf
    kind_f = 0
    idx_f = 0
    n_f = (0.0, 0.0, 1.0)
    for i in range(3):
        ai = A[i]
        dist = vdot(d, ai)
        rb = hb[0] * abs(vdot(ai, B[0])) + hb[1] * abs(vdot(ai, B[1])) + hb[2] * abs(vdot(ai, B[2]))
        sep = abs(dist) - ha[i] - rb
        if sep > sep_f:
            sep_f = sep
            kind_f = 0
            idx_f = i
            s = _sgn(dist)
            n_f = (s * ai[0], s * ai[1], s * ai[2])
    for j in range(3):
        bj = B[j]
        dist = vdot(d, bj)
        ra = ha[0] * abs(vdot(bj, A[0])) + ha[1] * abs(vdot(bj, A[1])) + ha[2] * abs(vdot(bj, A[2]))
        sep = abs(dist) - ra - hb[j]
        if sep > sep_f:
            sep_f = sep
            kind_f = 1
            idx_f = j
            s = _sgn(dist)
            n_f = (s * bj[0], s * bj[1], s * bj[2])
    sep_e = -math.inf
    ie = 0
    je = 0
    n_e = (0.0, 0.0, 1.0)
    has_edge = False
    for i in range(3):
        for j in range(3):
            L = vcross(A[i], B[j])
            ln = norm(L)
            if ln < 1e-6:
                continue
            L = (L[0] / ln, L[1] / ln, L[2] / ln)
            ra = (ha[0] * abs(vdot(L, A[0])) + ha[1] * abs(vdot(L, A[1]))
                  + ha[2] * abs(vdot(L, A[2])))
            rb = (hb[0] * abs(vdot(L, B[0])) + hb[1] * abs(vdot(L, B[1]))
                  + hb[2] * abs(vdot(L, B[2])))
            dist = vdot(d, L)
            sep = abs(dist) - ra - rb
            if sep > sep_e:
                sep_e = sep
                ie = i
                je = j
                s = _sgn(dist)
                n_e = (s * L[0], s * L[1], s * L[2])
                has_edge = True
    return sep_f, kind_f, idx_f, n_f, sep_e, ie, je, n_e, has_edge


@noalloc
def _use_edge(sep_f, sep_e, has_edge, scale):
    if not has_edge:
        return False
    return sep_e > sep_f + _EDGE_REL * max(-sep_f, 0.0) + _EDGE_ABS * scale


@noalloc
def _face_setup(pa, A, ha, pb, B, hb, kind_f, idx_f, n_f):
    """Reference/incident face frames for a face axis.

    Returns ``(fc, nr, t1, t2, e1, e2, V, mp, prefix, flip)``: reference face centre,
    outward normal (towards the incident box), tangents and half extents; the 4
    incident face vertices in reference coordinates ``(x, y, z)``; the incident face
    normal in those coordinates; the feature prefix; and whether B is the reference.
    """
    if kind_f == 0:
        rp, R, rh, ip, I, ih = pa, A, ha, pb, B, hb
        nr = n_f
        flip = False
    else:
        rp, R, rh, ip, I, ih = pb, B, hb, pa, A, ha
        nr = (-n_f[0], -n_f[1], -n_f[2])
        flip = True
    i = idx_f
    fc = madd(rp, nr, rh[i])
    t1 = R[(i + 1) % 3]
    t2 = R[(i + 2) % 3]
    e1 = rh[(i + 1) % 3]
    e2 = rh[(i + 2) % 3]
    ref_face = 2 * i + (1 if vdot(nr, R[i]) > 0.0 else 0)
    # incident face: most anti-parallel to nr
    j = 0
    best = -1.0
    for k in range(3):
        c = abs(vdot(I[k], nr))
        if c > best:
            best = c
            j = k
    sj = -_sgn(vdot(I[j], nr))
    m = (sj * I[j][0], sj * I[j][1], sj * I[j][2])
    inc_face = 2 * j + (1 if sj > 0.0 else 0)
    ic = madd(ip, m, ih[j])
    s1 = I[(j + 1) % 3]
    s2 = I[(j + 2) % 3]
    f1 = ih[(j + 1) % 3]
    f2 = ih[(j + 2) % 3]
    w0 = sub(madd(madd(ic, s1, f1), s2, f2), fc)
    w1 = sub(madd(madd(ic, s1, -f1), s2, f2), fc)
    w2 = sub(madd(madd(ic, s1, -f1), s2, -f2), fc)
    w3 = sub(madd(madd(ic, s1, f1), s2, -f2), fc)
    V = ((vdot(w0, t1), vdot(w0, t2), vdot(w0, nr)),
         (vdot(w1, t1), vdot(w1, t2), vdot(w1, nr)),
         (vdot(w2, t1), vdot(w2, t2), vdot(w2, nr)),
         (vdot(w3, t1), vdot(w3, t2), vdot(w3, nr)))
    mp = (vdot(m, t1), vdot(m, t2), vdot(m, nr))
    prefix = (((0 if kind_f == 0 else 1) * 6 + ref_face) * 6 + inc_face) * 24
    return fc, nr, t1, t2, e1, e2, V, mp, prefix, flip


@noalloc
def _face_candidate(k, e1, e2, V, mp, tol):
    """Candidate ``k`` (0..23) of the clipped incident face: ``(valid, x, y, z)``."""
    if k < 4:
        v = V[k]
        if abs(v[0]) <= e1 + tol and abs(v[1]) <= e2 + tol:
            return True, v[0], v[1], v[2]
        return False, 0.0, 0.0, 0.0
    if k < 8:
        c = k - 4
        X = e1 if (c == 0 or c == 3) else -e1
        Y = e2 if c < 2 else -e2
        # inside the incident quad (projected along the reference normal)?
        area = 0.0
        for i in range(4):
            p = V[i]
            q = V[(i + 1) % 4]
            area += p[0] * q[1] - q[0] * p[1]
        orient = 1.0 if area >= 0.0 else -1.0
        for i in range(4):
            p = V[i]
            q = V[(i + 1) % 4]
            ex = q[0] - p[0]
            ey = q[1] - p[1]
            le = math.sqrt(ex * ex + ey * ey)
            if le <= 0.0:
                continue
            side = orient * (ex * (Y - p[1]) - ey * (X - p[0])) / le
            if side < -tol:
                return False, 0.0, 0.0, 0.0
        v0 = V[0]
        z = v0[2] - (mp[0] * (X - v0[0]) + mp[1] * (Y - v0[1])) / mp[2]
        return True, X, Y, z
    e = (k - 8) // 4
    s = (k - 8) % 4
    P = V[e]
    Q = V[(e + 1) % 4]
    if s == 0 or s == 2:
        lim = e1 if s == 0 else -e1
        den = Q[0] - P[0]
        if abs(den) < 1e-14:
            return False, 0.0, 0.0, 0.0
        u = (lim - P[0]) / den
        if u < 0.0 or u > 1.0:
            return False, 0.0, 0.0, 0.0
        y = P[1] + u * (Q[1] - P[1])
        if abs(y) > e2 + tol:
            return False, 0.0, 0.0, 0.0
        return True, lim, y, P[2] + u * (Q[2] - P[2])
    lim = e2 if s == 1 else -e2
    den = Q[1] - P[1]
    if abs(den) < 1e-14:
        return False, 0.0, 0.0, 0.0
    u = (lim - P[1]) / den
    if u < 0.0 or u > 1.0:
        return False, 0.0, 0.0, 0.0
    x = P[0] + u * (Q[0] - P[0])
    if abs(x) > e1 + tol:
        return False, 0.0, 0.0, 0.0
    return True, x, lim, P[2] + u * (Q[2] - P[2])


@noalloc
def _face_deepest(e1, e2, V, mp, tol, margin):
    """Deepest clipped candidate with depth > -margin: ``(index or -1, x, y, z)``.
    Near ties (within ``tol``) go to the lower index, so the choice does not flip
    with rounding."""
    best = -1
    bx = 0.0
    by = 0.0
    bz = math.inf
    for k in range(24):
        ok, x, y, z = _face_candidate(k, e1, e2, V, mp, tol)
        if ok and -z > -margin and z < bz - tol:
            best = k
            bx, by, bz = x, y, z
    return best, bx, by, bz


@noalloc
def _edge_contact(pa, A, ha, pb, B, hb, ie, je, n):
    """Closest points of the two crossing edges: ``(point_a, point_b, feature)``."""
    ka1 = (ie + 1) % 3
    ka2 = (ie + 2) % 3
    sa1 = _sgn(vdot(A[ka1], n))
    sa2 = _sgn(vdot(A[ka2], n))
    ea = madd(madd(pa, A[ka1], sa1 * ha[ka1]), A[ka2], sa2 * ha[ka2])
    kb1 = (je + 1) % 3
    kb2 = (je + 2) % 3
    sb1 = _sgn(-vdot(B[kb1], n))
    sb2 = _sgn(-vdot(B[kb2], n))
    eb = madd(madd(pb, B[kb1], sb1 * hb[kb1]), B[kb2], sb2 * hb[kb2])
    s, t = segment_closest(ea, A[ie], ha[ie], eb, B[je], hb[je])
    qa = madd(ea, A[ie], s)
    qb = madd(eb, B[je], t)
    edge_a = 4 * ie + (1 if sa1 > 0.0 else 0) + (2 if sa2 > 0.0 else 0)
    edge_b = 4 * je + (1 if sb1 > 0.0 else 0) + (2 if sb2 > 0.0 else 0)
    return qa, qb, EDGE_FEATURE_BASE + 12 * edge_a + edge_b


@noalloc
def box_box_deepest(pos_a, quat_a, size_a, pos_b, quat_b, size_b):
    """Signed separation of two boxes and the deepest (or nearest) point pair.

    Returns ``(sep, normal A->B, point_a, point_b)`` with ``sep = -depth``. Exact for
    penetrating boxes (the SAT axis of least penetration); for separated boxes ``sep``
    is the largest axis gap, a lower bound of the distance (use GJK for distances).
    """
    pa = v3(pos_a)
    pb = v3(pos_b)
    A = frame_axes(q4(quat_a))
    B = frame_axes(q4(quat_b))
    ha = v3(size_a)
    hb = v3(size_b)
    sc = ha[0] + ha[1] + ha[2] + hb[0] + hb[1] + hb[2]
    sep_f, kind_f, idx_f, n_f, sep_e, ie, je, n_e, has_edge = box_sat(pa, A, ha, pb, B, hb)
    if not _use_edge(sep_f, sep_e, has_edge, sc):
        fc, nr, t1, t2, e1, e2, V, mp, prefix, flip = _face_setup(pa, A, ha, pb, B, hb,
                                                                 kind_f, idx_f, n_f)
        k, x, y, z = _face_deepest(e1, e2, V, mp, 1e-9 * sc, math.inf)
        if k >= 0:
            inc = madd(madd(madd(fc, t1, x), t2, y), nr, z)
            ref = madd(madd(fc, t1, x), t2, y)
            if flip:
                return sep_f, n_f, inc, ref
            return sep_f, n_f, ref, inc
        if not has_edge:
            return sep_f, n_f, pa, pb
    qa, qb, _ = _edge_contact(pa, A, ha, pb, B, hb, ie, je, n_e)
    return sep_e, n_e, qa, qb


@noalloc
def collide_box_box(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                    out_normal, out_depth, out_feature, start):
    """Box A, box B: up to 4 face contacts or 1 edge-edge contact (see module doc)."""
    pa = v3(pos_a)
    pb = v3(pos_b)
    A = frame_axes(q4(quat_a))
    B = frame_axes(q4(quat_b))
    ha = v3(size_a)
    hb = v3(size_b)
    sc = ha[0] + ha[1] + ha[2] + hb[0] + hb[1] + hb[2]
    sep_f, kind_f, idx_f, n_f, sep_e, ie, je, n_e, has_edge = box_sat(pa, A, ha, pb, B, hb)
    if max(sep_f, sep_e) >= margin:
        return 0
    if not _use_edge(sep_f, sep_e, has_edge, sc):
        fc, nr, t1, t2, e1, e2, V, mp, prefix, flip = _face_setup(pa, A, ha, pb, B, hb,
                                                                 kind_f, idx_f, n_f)
        tol = 1e-9 * sc
        k0, x0, y0, z0 = _face_deepest(e1, e2, V, mp, tol, margin)
        if k0 >= 0:
            # second: farthest from the first; third and fourth: largest triangle on
            # either side of the line through the first two (near ties, within the
            # tolerance, go to the lower candidate index: rounding does not flip them)
            k1 = -1
            x1 = 0.0
            y1 = 0.0
            z1 = 0.0
            best = (tol * 10.0) ** 2
            for k in range(24):
                ok, x, y, z = _face_candidate(k, e1, e2, V, mp, tol)
                if not ok or -z <= -margin:
                    continue
                dd = (x - x0) ** 2 + (y - y0) ** 2
                if dd > best + tol * sc:
                    best = dd
                    k1, x1, y1, z1 = k, x, y, z
            k2 = -1
            k3 = -1
            x2 = y2 = z2 = x3 = y3 = z3 = 0.0
            if k1 >= 0:
                lx = x1 - x0
                ly = y1 - y0
                ll = math.sqrt(lx * lx + ly * ly)
                amax = tol * 10.0
                amin = -tol * 10.0
                for k in range(24):
                    ok, x, y, z = _face_candidate(k, e1, e2, V, mp, tol)
                    if not ok or -z <= -margin:
                        continue
                    a = (lx * (y - y0) - ly * (x - x0)) / ll
                    if a > amax + tol:
                        amax = a
                        k2, x2, y2, z2 = k, x, y, z
                    if a < amin - tol:
                        amin = a
                        k3, x3, y3, z3 = k, x, y, z
            normal = (-nr[0], -nr[1], -nr[2]) if flip else nr
            cnt = 0
            for slot in range(4):
                if slot == 0:
                    k, x, y, z = k0, x0, y0, z0
                elif slot == 1:
                    k, x, y, z = k1, x1, y1, z1
                elif slot == 2:
                    k, x, y, z = k2, x2, y2, z2
                else:
                    k, x, y, z = k3, x3, y3, z3
                if k < 0:
                    continue
                p = madd(madd(madd(fc, t1, x), t2, y), nr, 0.5 * z)
                write_contact(out_point, out_normal, out_depth, out_feature, start + cnt, p,
                              normal, -z, prefix + k)
                cnt += 1
            return cnt
    if max(sep_f, sep_e) > 0.0:
        # apart (within the margin): one contact at the exact closest points
        dist, qa, qb, overlap = gjk_distance(np.int64(BOX), pa, q4(quat_a), ha, np.int64(BOX), pb,
                                             q4(quat_b), hb)
        if not overlap:
            if dist >= margin:
                return 0
            n = normalize_or(sub(qb, qa), n_e if has_edge else n_f)
            feat = GJK_FEATURE
            if _use_edge(sep_f, sep_e, has_edge, sc):
                feat = _edge_contact(pa, A, ha, pb, B, hb, ie, je, n_e)[2]
            write_contact(out_point, out_normal, out_depth, out_feature, start, mid(qa, qb), n,
                          -dist, feat)
            return 1
    if not has_edge:
        return 0
    qa, qb, feat = _edge_contact(pa, A, ha, pb, B, hb, ie, je, n_e)
    write_contact(out_point, out_normal, out_depth, out_feature, start, mid(qa, qb), n_e,
                  -sep_e, feat)
    return 1
