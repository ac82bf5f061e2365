"""EPA (expanding polytope algorithm): the least penetration of two overlapping convex
cores, exact for polytopes.

Used by ``convex_hull.hull_contact`` when both cores are polytopes (sphere centre,
capsule segment, box, hull). Shapes are ``(gtype, pos, quat, size, verts)`` as in
``gjk``; lengths in m, world frame. The start is a tetrahedron around the origin from
an MPR portal (``gjk.mpr_portal``). Scratch arrays are allocated per call.
"""
import math

import numpy as np
from numba import njit

from ._vec import local_to_world, madd, norm, norm2, normalize_or, scale, sub, vcross, vdot
from .gjk import (MPR_MAX_ITER, PORTAL_FOUND, _closest_triangle, minkowski_support, mpr_portal,
                  replace_portal_vertex)
from .shapes import BOX, CAPSULE, CONVEX, SPHERE

_EPA_ITER = 96
_EPA_MAXF = 2048
_Z3 = (0.0, 0.0, 0.0)


@njit(cache=True)
def polytope_core(gtype):
    """Cores that are polytopes (point, segment, box, hull): EPA is exact on them."""
    return gtype == SPHERE or gtype == CAPSULE or gtype == BOX or gtype == CONVEX


@njit(cache=True)
def _start_tetra(ta, pa, qa, sa, va, tb, pb, qb, sb, vb, tol):
    """A tetrahedron of core Minkowski-difference points containing the origin: an MPR
    portal, refined until the origin is behind it, and the interior point.
    ``(ok, W (4, 3), A (4, 3), B (4, 3))``: the points and their witnesses on A and B."""
    W = np.zeros((4, 3))
    A = np.zeros((4, 3))
    B = np.zeros((4, 3))
    ca = pa
    cb = pb
    if ta == CONVEX:
        ca = _hull_centre(pa, qa, va)
    if tb == CONVEX:
        cb = _hull_centre(pb, qb, vb)
    # an interior point off the symmetry lines of the shapes (a centre lies on the
    # diagonals of a symmetric hull, which makes EPA faces degenerate)
    s1, p1, q1 = minkowski_support(ta, pa, qa, sa, 0.0, tb, pb, qb, sb, 0.0,
                                   (0.31, 0.52, 0.79), va, vb, False)
    s2, p2, q2 = minkowski_support(ta, pa, qa, sa, 0.0, tb, pb, qb, sb, 0.0,
                                   (-0.68, 0.23, -0.41), va, vb, False)
    a0 = madd(madd(ca, sub(p1, ca), 0.0113), sub(p2, ca), 0.0071)
    b0 = madd(madd(cb, sub(q1, cb), 0.0113), sub(q2, cb), 0.0071)
    status, v0, v1, a1, b1, v2, a2, b2, v3, a3, b3 = mpr_portal(
        ta, pa, qa, sa, 0.0, tb, pb, qb, sb, 0.0, va, vb, sub(a0, b0), tol, False)
    if status != PORTAL_FOUND:
        return False, W, A, B
    hit = False
    for _ in range(MPR_MAX_ITER):
        nn = vcross(sub(v2, v1), sub(v3, v1))
        if norm2(nn) == 0.0:
            return False, W, A, B
        n = normalize_or(nn, (0.0, 0.0, 1.0))
        if vdot(n, v1) >= 0.0:
            hit = True
            break
        v4, a4, b4 = minkowski_support(ta, pa, qa, sa, 0.0, tb, pb, qb, sb, 0.0, n, va, vb,
                                       False)
        if vdot(v4, n) < 0.0:
            return False, W, A, B
        if vdot(v4, n) - vdot(v1, n) <= tol:
            return False, W, A, B
        v1, a1, b1, v2, a2, b2, v3, a3, b3 = replace_portal_vertex(
            v0, v1, a1, b1, v2, a2, b2, v3, a3, b3, v4, a4, b4)
    if not hit:
        return False, W, A, B
    for k in range(3):
        W[0, k] = v0[k]
        W[1, k] = v1[k]
        W[2, k] = v2[k]
        W[3, k] = v3[k]
        A[0, k] = a0[k]
        A[1, k] = a1[k]
        A[2, k] = a2[k]
        A[3, k] = a3[k]
        B[0, k] = b0[k]
        B[1, k] = b1[k]
        B[2, k] = b2[k]
        B[3, k] = b3[k]
    return True, W, A, B


@njit(cache=True)
def _hull_centre(pos, quat, verts):
    sx = sy = sz = 0.0
    for i in range(verts.shape[0]):
        sx += verts[i, 0]
        sy += verts[i, 1]
        sz += verts[i, 2]
    k = 1.0 / max(verts.shape[0], 1)
    return local_to_world(pos, quat, (sx * k, sy * k, sz * k))


@njit(cache=True)
def _row(M, i):
    return (M[i, 0], M[i, 1], M[i, 2])


@njit(cache=True)
def _face_plane(W, F, f):
    a = _row(W, F[f, 0])
    n = vcross(sub(_row(W, F[f, 1]), a), sub(_row(W, F[f, 2]), a))
    ln = norm(n)
    if not ln > 0.0:
        return (0.0, 0.0, 0.0), math.inf
    n = (n[0] / ln, n[1] / ln, n[2] / ln)
    return n, vdot(n, a)


@njit(cache=True)
def _add_face(W, F, FN, FD, alive, nf, i, j, k):
    """Store face ``nf`` = vertices ``(i, j, k)`` of ``W`` (counter-clockwise seen from
    outside) with its unit normal and plane offset; returns the face count ``nf + 1``."""
    F[nf, 0] = i
    F[nf, 1] = j
    F[nf, 2] = k
    n, dd = _face_plane(W, F, nf)
    FN[nf, 0] = n[0]
    FN[nf, 1] = n[1]
    FN[nf, 2] = n[2]
    FD[nf] = dd
    alive[nf] = True
    return nf + 1


@njit(cache=True)
def epa_penetration(ta, pa, qa, sa, va, tb, pb, qb, sb, vb, tol):
    """Penetration of overlapping polytope cores by the expanding polytope algorithm.

    Returns ``(ok, depth, normal A -> B, point_a, point_b)`` (cores only, radii not
    added): the closest face of the Minkowski difference to the origin is grown by
    support points until no support point lies more than ``tol`` beyond it. Exact (up
    to ``tol``) for polytopes: global, unlike the local refinement of MPR.
    """
    bad = (False, 0.0, (0.0, 0.0, 1.0), _Z3, _Z3)
    ok, W0, A0, B0 = _start_tetra(ta, pa, qa, sa, va, tb, pb, qb, sb, vb, tol)
    if not ok:
        return bad
    maxv = 4 + _EPA_ITER
    W = np.empty((maxv, 3))
    WA = np.empty((maxv, 3))
    WB = np.empty((maxv, 3))
    for i in range(4):
        for k in range(3):
            W[i, k] = W0[i, k]
            WA[i, k] = A0[i, k]
            WB[i, k] = B0[i, k]
    nv = 4
    F = np.empty((_EPA_MAXF, 3), np.int64)
    FN = np.empty((_EPA_MAXF, 3))
    FD = np.empty(_EPA_MAXF)
    alive = np.zeros(_EPA_MAXF, np.bool_)
    nf = np.int64(0)
    # the four faces, oriented away from the opposite vertex
    for f in range(4):
        i = (f + 1) % 4
        j = (f + 2) % 4
        k = (f + 3) % 4
        a = _row(W, i)
        n = vcross(sub(_row(W, j), a), sub(_row(W, k), a))
        if vdot(n, sub(_row(W, f), a)) > 0.0:
            j, k = k, j
        nf = _add_face(W, F, FN, FD, alive, nf, i, j, k)
    E = np.empty((3 * _EPA_MAXF, 2), np.int64)
    mark = np.zeros(_EPA_MAXF, np.int64)
    stack = np.empty(_EPA_MAXF, np.int64)
    best = -1
    for it in range(_EPA_ITER + 1):
        best = -1
        bd = math.inf
        for f in range(nf):
            if alive[f] and FD[f] < bd:
                bd = FD[f]
                best = f
        if best < 0:
            return bad
        n = (FN[best, 0], FN[best, 1], FN[best, 2])
        if nv == maxv:
            break
        w, a, b = minkowski_support(ta, pa, qa, sa, 0.0, tb, pb, qb, sb, 0.0, n, va, vb, False)
        if vdot(w, n) - bd <= tol:
            break
        dup = False
        for i in range(nv):
            if norm2(sub(w, _row(W, i))) <= tol * tol:
                dup = True
        if dup:
            break
        for k in range(3):
            W[nv, k] = w[k]
            WA[nv, k] = a[k]
            WB[nv, k] = b[k]
        # faces seen from w (or nearly coplanar with it), grown from the closest face
        # over shared edges so that the removed region stays one patch
        eps = 10.0 * tol
        mark[best] = it + 1
        stack[0] = best
        ns = 1
        while ns > 0:
            ns -= 1
            f = stack[ns]
            for e in range(3):
                i = F[f, e]
                j = F[f, (e + 1) % 3]
                for g in range(nf):
                    if not alive[g] or mark[g] == it + 1:
                        continue
                    if (F[g, 0] == j and F[g, 1] == i) or (F[g, 1] == j and F[g, 2] == i) or \
                            (F[g, 2] == j and F[g, 0] == i):
                        if FN[g, 0] * (w[0] - W[F[g, 0], 0]) + FN[g, 1] * (w[1] - W[F[g, 0], 1]) \
                                + FN[g, 2] * (w[2] - W[F[g, 0], 2]) > -eps or FD[g] == math.inf:
                            mark[g] = it + 1
                            stack[ns] = g
                            ns += 1
                        break
        ne = 0
        for f in range(nf):
            if not alive[f] or mark[f] != it + 1:
                continue
            alive[f] = False
            for e in range(3):
                i = F[f, e]
                j = F[f, (e + 1) % 3]
                found = -1
                for r in range(ne):
                    if E[r, 0] == j and E[r, 1] == i:
                        found = r
                        break
                if found >= 0:
                    E[found, 0] = E[ne - 1, 0]
                    E[found, 1] = E[ne - 1, 1]
                    ne -= 1
                else:
                    E[ne, 0] = i
                    E[ne, 1] = j
                    ne += 1
        if nf + ne > _EPA_MAXF:
            return bad
        for r in range(ne):
            nf = _add_face(W, F, FN, FD, alive, nf, E[r, 0], E[r, 1], nv)
        nv += 1
    if best < 0 or not FD[best] >= -tol:
        return bad      # lost the origin (degenerate faces): the caller falls back to MPR
    n = (FN[best, 0], FN[best, 1], FN[best, 2])
    depth = FD[best]
    p = (n[0] * depth, n[1] * depth, n[2] * depth)
    # a face of the Minkowski difference may be split in coplanar triangles: take the
    # one holding the origin's projection
    pick = best
    for f in range(nf):
        if not alive[f] or abs(FD[f] - depth) > tol or \
                FN[f, 0] * n[0] + FN[f, 1] * n[1] + FN[f, 2] * n[2] < 1.0 - 1e-12:
            continue
        a0 = sub(_row(W, F[f, 0]), p)
        a1 = sub(_row(W, F[f, 1]), p)
        a2 = sub(_row(W, F[f, 2]), p)
        if vdot(vcross(a0, a1), n) >= 0.0 and vdot(vcross(a1, a2), n) >= 0.0 and \
                vdot(vcross(a2, a0), n) >= 0.0:
            pick = f
            break
    i, j, k = F[pick, 0], F[pick, 1], F[pick, 2]
    l0, l1, l2 = _closest_triangle(sub(_row(W, i), p), sub(_row(W, j), p), sub(_row(W, k), p))
    xa = madd(madd(scale(_row(WA, i), l0), _row(WA, j), l1), _row(WA, k), l2)
    xb = madd(madd(scale(_row(WB, i), l0), _row(WB, j), l1), _row(WB, k), l2)
    return True, depth, n, xa, xb
