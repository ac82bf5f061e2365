"""Heightfields (``HEIGHTFIELD``): static terrain.

Layout: ``H`` (nrow * ncol,) heights, row-major; ``hsize = (half_x, half_y, base)``.
Sample ``(i, j)`` sits at geom-local ``x = -half_x + j dx``, ``y = -half_y + i dy``
(``dx = 2 half_x / (ncol - 1)``, ``dy = 2 half_y / (nrow - 1)``), ``z = H[i, j]``. The
solid is everything below the surface down to ``z = -base``.

Each cell ``(i, j)`` holds two triangles split along the diagonal from sample
``(i, j)`` to ``(i + 1, j + 1)``: triangle 0 ``(i,j), (i,j+1), (i+1,j+1)`` (local
``u >= v`` in the cell) and triangle 1 ``(i,j), (i+1,j+1), (i+1,j)``; triangle id
``T = 2 (i (ncol - 1) + j) + t``. Normals point up.

Contacts (a shape B against the heightfield): the solid is split into the vertical
columns under the triangles. For each triangle ``T`` under B's AABB (in the
heightfield frame), the contact normal is ``T``'s face normal ``n`` and the depth is
the penetration along ``n`` of the part of B inside ``T``'s column:

    depth_T = n . v0 - min { n . x : x in B, (x, y) of x inside T }

(columns are unbounded below). It is found exactly from B's support function: the
unconstrained support point if it lies in the column, else the minimum over each
column wall (a bisection over support directions tilted about the wall, exact for
polytopes), else the lowest point of B on a column edge (a vertical ray cast). The
largest ``depth_T`` is continuous as B moves across cells. Candidates are also taken
at B's features (box corners, hull vertices, capsule end caps, cylinder rim points,
the sphere's lowest point along ``n``) in the column they fall in, so a box on a flat
field gets exactly the plane contacts. A column contact is dropped when a deeper
contact with the same normal (within ``COS_FACE``) exists (so a sphere on a flat field
gets one contact). Up to 4 are kept: the deepest, then the farthest from it, then the
farthest either side of their line (in the heightfield's x, y).

Feature ids: hull vertex or box corner index (< 256) for feature candidates of
polytopes; ``256 + 8 T + k`` for candidate ``k`` (``manifold`` numbering) of a round
shape over triangle ``T``; ``256 + 8 T + 7`` for a column contact.

Cost: per triangle under B's AABB a few support calls; triangles B cannot reach
are skipped by bounds (B's box above the triangle, B above its plane, GJK between B
and the triangle's solid piece) before the exact column minimum (about 3 x 34
support calls, plus vertical ray casts at column edges when needed).

The solid's vertical sides and bottom are not contact surfaces (they are for ray
casts and distances). Scratch arrays sized by the number of triangles under B are
allocated per call.
"""
import math

import numpy as np
from numba import njit

from ...math.quat import quat_conj, quat_mul, quat_rotate, quat_rotate_inv
from ._vec import local_to_world, madd, normalize_or, q4, sub, v3, vcross, vdot
from .convex import COS_FACE
from .convex_hull import hull_aabb, is_polytope, poly_count, poly_local, raycast_convex, select4
from .gjk import gjk_distance
from .manifold import candidate_frame, incident_point, num_candidates
from .raycast import raycast_geom
from .shapes import CONVEX, core_radius, geom_aabb, shape_scale, support

_Z3 = (0.0, 0.0, 0.0)
_IDENT = (0.0, 0.0, 0.0, 1.0)
_WALL_ITER = 34
_FEAT_TRI = 256


# ------------------------------------------------------------------------- geometry

@njit(cache=True)
def hfield_cell(hsize, nr, nc):
    """Cell size ``(dx, dy)``."""
    return 2.0 * hsize[0] / (nc - 1), 2.0 * hsize[1] / (nr - 1)


@njit(cache=True)
def hfield_triangle(H, nr, nc, hsize, i, j, t):
    """Vertices (counter-clockwise from above) and unit upward normal of triangle
    ``t`` of cell ``(i, j)``, in the heightfield frame."""
    hx = hsize[0]
    hy = hsize[1]
    dx, dy = hfield_cell(hsize, nr, nc)
    xa = -hx + j * dx
    xb = -hx + (j + 1) * dx
    ya = -hy + i * dy
    yb = -hy + (i + 1) * dy
    h00 = float(H[i * nc + j])
    h01 = float(H[i * nc + j + 1])
    h10 = float(H[(i + 1) * nc + j])
    h11 = float(H[(i + 1) * nc + j + 1])
    if t == 0:
        p0 = (xa, ya, h00)
        p1 = (xb, ya, h01)
        p2 = (xb, yb, h11)
    else:
        p0 = (xa, ya, h00)
        p1 = (xb, yb, h11)
        p2 = (xa, yb, h10)
    n = normalize_or(vcross(sub(p1, p0), sub(p2, p0)), (0.0, 0.0, 1.0))
    return p0, p1, p2, n


@njit(cache=True)
def hfield_locate(nr, nc, hsize, x, y):
    """Triangle ``(i, j, t)`` whose column holds the local point ``(x, y)``, or
    ``(-1, -1, -1)`` outside the field (points on shared edges go to one of them)."""
    hx = hsize[0]
    hy = hsize[1]
    if not (-hx <= x <= hx and -hy <= y <= hy):
        return -1, -1, -1
    dx, dy = hfield_cell(hsize, nr, nc)
    j = min(max(int(math.floor((x + hx) / dx)), 0), nc - 2)
    i = min(max(int(math.floor((y + hy) / dy)), 0), nr - 2)
    u = (x - (-hx + j * dx)) / dx
    v = (y - (-hy + i * dy)) / dy
    return i, j, (0 if u >= v else 1)


@njit(cache=True)
def hfield_height(H, nr, nc, hsize, x, y):
    """Surface height at local ``(x, y)`` (clamped into the field)."""
    x = min(max(x, -hsize[0]), hsize[0])
    y = min(max(y, -hsize[1]), hsize[1])
    i, j, t = hfield_locate(nr, nc, hsize, x, y)
    p0, p1, p2, n = hfield_triangle(H, nr, nc, hsize, i, j, t)
    return p0[2] - (n[0] * (x - p0[0]) + n[1] * (y - p0[1])) / n[2]


@njit(cache=True)
def hfield_zrange(H, hsize):
    """``(lowest point of the solid, highest surface point)`` (a scan of all heights)."""
    lo = math.inf
    hi = -math.inf
    for k in range(H.shape[0]):
        lo = min(lo, H[k])
        hi = max(hi, H[k])
    lo = min(lo, -hsize[2])
    return lo, max(hi, lo)


@njit(cache=True)
def hfield_aabb(H, hsize, pos, quat, margin):
    """World AABB of the heightfield solid, grown by ``margin``."""
    zlo, zhi = hfield_zrange(H, hsize)
    q = q4(quat)
    lo = (math.inf, math.inf, math.inf)
    hi = (-math.inf, -math.inf, -math.inf)
    for c in range(8):
        loc = (hsize[0] if (c & 1) else -hsize[0], hsize[1] if (c & 2) else -hsize[1],
               zhi if (c & 4) else zlo)
        w = local_to_world(v3(pos), q, loc)
        lo = (min(lo[0], w[0]), min(lo[1], w[1]), min(lo[2], w[2]))
        hi = (max(hi[0], w[0]), max(hi[1], w[1]), max(hi[2], w[2]))
    return ((lo[0] - margin, lo[1] - margin, lo[2] - margin),
            (hi[0] + margin, hi[1] + margin, hi[2] + margin))


# ----------------------------------------------------------- the shape, locally

@njit(cache=True)
def _local_pose(pos_h, quat_h, pos_b, quat_b):
    qh = q4(quat_h)
    pl = quat_rotate_inv(qh, sub(v3(pos_b), v3(pos_h)))
    ql = quat_mul(quat_conj(qh), q4(quat_b))
    return pl, ql


@njit(cache=True)
def _shape_aabb(tb, pl, ql, sb, vb, margin):
    if tb == CONVEX:
        return hull_aabb(vb, pl, ql, margin)
    return geom_aabb(tb, pl, ql, sb, margin)


@njit(cache=True)
def _cell_range(lo, hi, nr, nc, hsize):
    """Cells ``i0..i1``, ``j0..j1`` under the local box, or ``i0 > i1`` when none."""
    hx = hsize[0]
    hy = hsize[1]
    if hi[0] < -hx or lo[0] > hx or hi[1] < -hy or lo[1] > hy:
        return 1, 0, 1, 0
    dx, dy = hfield_cell(hsize, nr, nc)
    j0 = min(max(int(math.floor((lo[0] + hx) / dx)), 0), nc - 2)
    j1 = min(max(int(math.floor((hi[0] + hx) / dx)), 0), nc - 2)
    i0 = min(max(int(math.floor((lo[1] + hy) / dy)), 0), nr - 2)
    i1 = min(max(int(math.floor((hi[1] + hy) / dy)), 0), nr - 2)
    return i0, i1, j0, j1


@njit(cache=True)
def _wall(p, q):
    """Outward horizontal unit normal and offset of the column wall over edge p -> q
    (counter-clockwise triangle)."""
    ex = q[0] - p[0]
    ey = q[1] - p[1]
    le = math.hypot(ex, ey)
    a = (ey / le, -ex / le, 0.0)
    return a, a[0] * p[0] + a[1] * p[1]


@njit(cache=True)
def _wall_min(tb, pl, ql, sb, vb, n, a, b):
    """Minimum of ``n . x`` over B on the wall plane ``a . x = b``.

    Returns ``(status, x)``: status 0 when B lies strictly inside the half-space
    ``a . x < b``, 2 when strictly outside, 1 with the minimiser ``x`` otherwise. The
    support directions ``-cos(th) n_perp - sin(th) a`` are bisected on ``th`` for the
    one whose support point crosses the plane; the minimiser is interpolated between
    the two last support points on either side (exact for polytopes).
    """
    xp = support(tb, pl, ql, sb, a, vb)
    gp = vdot(a, xp) - b
    if gp < 0.0:
        return 0, xp
    xm = support(tb, pl, ql, sb, (-a[0], -a[1], -a[2]), vb)
    gm = vdot(a, xm) - b
    if gm > 0.0:
        return 2, xm
    nperp = normalize_or(madd(n, a, -vdot(n, a)), (0.0, 0.0, 1.0))
    lo = -0.5 * math.pi
    hi = 0.5 * math.pi
    x_lo = xp
    g_lo = gp
    x_hi = xm
    g_hi = gm
    for _ in range(_WALL_ITER):
        th = 0.5 * (lo + hi)
        c = math.cos(th)
        s = math.sin(th)
        w = (-c * nperp[0] - s * a[0], -c * nperp[1] - s * a[1], -c * nperp[2] - s * a[2])
        x = support(tb, pl, ql, sb, w, vb)
        g = vdot(a, x) - b
        if g >= 0.0:
            lo = th
            x_lo = x
            g_lo = g
        else:
            hi = th
            x_hi = x
            g_hi = g
    den = g_lo - g_hi
    if den > 0.0:
        return 1, madd(x_lo, sub(x_hi, x_lo), g_lo / den)
    return 1, x_lo


@njit(cache=True)
def _in_column(x, A0, b0, A1, b1, A2, b2, tol):
    return (A0[0] * x[0] + A0[1] * x[1] <= b0 + tol and A1[0] * x[0] + A1[1] * x[1] <= b1 + tol
            and A2[0] * x[0] + A2[1] * x[1] <= b2 + tol)


@njit(cache=True)
def _lowest_on_vertical(tb, pl, ql, sb, vb, x, y, zstart):
    """Lowest point of B on the vertical line through ``(x, y)``: ``(hit, z)``."""
    o = (x, y, zstart)
    d = (0.0, 0.0, 1.0)
    if tb == CONVEX:
        t, nn = raycast_convex(vb, pl, ql, o, d, math.inf)
    else:
        t, nn = raycast_geom(tb, pl, ql, sb, o, d, math.inf)
    if t < 0.0:
        return False, 0.0
    return True, zstart + t


@njit(cache=True)
def column_min(tb, pl, ql, sb, vb, p0, p1, p2, n, zstart, tol):
    """``(found, x)``: the point of B inside the column over triangle ``p0 p1 p2``
    minimising ``n . x`` (see the module doc), all in the heightfield frame."""
    A0, b0 = _wall(p0, p1)
    A1, b1 = _wall(p1, p2)
    A2, b2 = _wall(p2, p0)
    # B entirely outside a wall: nothing of it in the column
    for w in range(3):
        a, b = (A0, b0) if w == 0 else ((A1, b1) if w == 1 else (A2, b2))
        if vdot(a, support(tb, pl, ql, sb, (-a[0], -a[1], -a[2]), vb)) > b:
            return False, (0.0, 0.0, 0.0)
    x0 = support(tb, pl, ql, sb, (-n[0], -n[1], -n[2]), vb)
    if _in_column(x0, A0, b0, A1, b1, A2, b2, tol):
        return True, x0
    best = math.inf
    bx = x0
    exists = 0
    infeasible = 0
    for w in range(3):
        if w == 0:
            a, b = A0, b0
        elif w == 1:
            a, b = A1, b1
        else:
            a, b = A2, b2
        st, x = _wall_min(tb, pl, ql, sb, vb, n, a, b)
        if st == 2:
            return False, x0
        if st == 1:
            exists |= 1 << w
            if _in_column(x, A0, b0, A1, b1, A2, b2, tol):
                f = vdot(n, x)
                if f < best:
                    best = f
                    bx = x
            else:
                infeasible |= 1 << w
    # column edges: the vertex between wall w and wall w + 1
    for w in range(3):
        w2 = (w + 1) % 3
        if (infeasible >> w) & 1 and (infeasible >> w2) & 1:
            v = p1 if w == 0 else (p2 if w == 1 else p0)
            hit, z = _lowest_on_vertical(tb, pl, ql, sb, vb, v[0], v[1], zstart)
            if hit:
                x = (v[0], v[1], z)
                f = vdot(n, x)
                if f < best:
                    best = f
                    bx = x
    if best == math.inf:
        return False, x0
    return True, bx


# ------------------------------------------------------------------------- contacts

@njit(cache=True)
def _reaches_piece(tb, pl, ql, sb, vb, p0, p1, p2, n, margin, zbot, rb, prism, tol):
    """Does B reach into the solid piece under triangle ``p0 p1 p2`` (its column below
    the triangle's plane raised by ``margin``)? GJK on B's core and the piece as a
    prism down to ``zbot`` (below B): exact, and cheap when apart."""
    lift = margin / n[2]
    for r in range(3):
        p = p0 if r == 0 else (p1 if r == 1 else p2)
        prism[r, 0] = p[0]
        prism[r, 1] = p[1]
        prism[r, 2] = p[2] + lift
        prism[r + 3, 0] = p[0]
        prism[r + 3, 1] = p[1]
        prism[r + 3, 2] = min(zbot, p[2] - 1.0)
    dist, ca, cb, overlap = gjk_distance(np.int64(CONVEX), _Z3, _IDENT, _Z3, tb, pl, ql, sb, prism,
                                         vb)
    return overlap or dist <= rb + tol


@njit(cache=True)
def _add(cand, m, x, depth, n, feature, kind):
    cand[m, 0] = x[0]
    cand[m, 1] = x[1]
    cand[m, 2] = depth
    cand[m, 3] = x[0]
    cand[m, 4] = x[1]
    cand[m, 5] = x[2]
    cand[m, 6] = feature
    cand[m, 7] = kind
    cand[m, 8] = n[0]
    cand[m, 9] = n[1]
    cand[m, 10] = n[2]
    return m + 1


@njit(cache=True)
def _dominated(cand, m, i, depth, n, tol):
    """Is there a row other than ``i`` with the same normal and at least as deep
    (strictly deeper, or equally deep and a feature row or earlier)?"""
    for k in range(m):
        if k == i or cand[k, 2] == -math.inf:
            continue
        c = cand[k, 8] * n[0] + cand[k, 9] * n[1] + cand[k, 10] * n[2]
        if c < COS_FACE:
            continue
        if cand[k, 2] > depth + tol:
            return True
        if cand[k, 2] >= depth - tol and (cand[k, 7] == 1.0 or k < i or i < 0):
            return True
    return False


@njit(cache=True)
def collide_hfield(H, nr, nc, hsize, pos_h, quat_h, tb, pos_b, quat_b, size_b, vb, margin,
                   flip, out_point, out_normal, out_depth, out_feature, start):
    """Heightfield A (``H``, ``nr`` x ``nc``, ``hsize``) against shape B of type
    sphere, capsule, box, cylinder or convex (``vb`` its hull vertices; any (k, 3)
    array otherwise). Normals from A to B, or from B to A when ``flip`` (heightfield
    passed as the second geom). Returns the number of rows written (at most 4)."""
    sb = v3(size_b)
    qh = q4(quat_h)
    ph = v3(pos_h)
    pl, ql = _local_pose(ph, qh, pos_b, quat_b)
    lo, hi = _shape_aabb(tb, pl, ql, sb, vb, margin)
    if hi[2] < -hsize[2]:
        return 0
    i0, i1, j0, j1 = _cell_range(lo, hi, nr, nc, hsize)
    if i0 > i1 or j0 > j1:
        return 0
    dx, dy = hfield_cell(hsize, nr, nc)
    sc = shape_scale(tb, sb, vb) + dx + dy
    tol = 1e-9 * sc
    zstart = lo[2] - (hi[2] - lo[2]) - 1.0
    ntri = 2 * (i1 - i0 + 1) * (j1 - j0 + 1)
    poly = tb == CONVEX or is_polytope(tb)
    nvp = poly_count(tb, vb) if poly else 0
    nround = 0 if poly else num_candidates(tb)
    cand = np.empty((nvp + (nround + 1) * ntri + 1, 11))
    prism = np.empty((6, 3))
    rb = core_radius(tb, sb)
    m = np.int64(0)
    # feature candidates
    if poly:
        for k in range(nvp):
            p = local_to_world(pl, ql, poly_local(tb, sb, vb, k))
            i, j, t = hfield_locate(nr, nc, hsize, p[0], p[1])
            if i < 0:
                continue
            p0, p1, p2, n = hfield_triangle(H, nr, nc, hsize, i, j, t)
            depth = vdot(n, sub(p0, p))
            if depth > -margin:
                m = _add(cand, m, p, depth, n, k, 1.0)
    else:
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                for t in range(2):
                    p0, p1, p2, n = hfield_triangle(H, nr, nc, hsize, i, j, t)
                    rim_a, rim_s, rim_v, rim_u = candidate_frame(tb, pl, ql, n)
                    T = 2 * (i * (nc - 1) + j) + t
                    for k in range(nround):
                        valid, p, f = incident_point(tb, pl, ql, sb, k, n, rim_a, rim_s, rim_v,
                                                     rim_u)
                        if not valid:
                            continue
                        ii, jj, tt = hfield_locate(nr, nc, hsize, p[0], p[1])
                        if ii != i or jj != j or tt != t:
                            continue
                        depth = vdot(n, sub(p0, p))
                        if depth > -margin:
                            m = _add(cand, m, p, depth, n, _FEAT_TRI + 8 * T + f, 1.0)
    # column contacts
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            for t in range(2):
                p0, p1, p2, n = hfield_triangle(H, nr, nc, hsize, i, j, t)
                if lo[2] > max(p0[2], max(p1[2], p2[2])) + margin:
                    continue        # B's box is above the whole triangle
                x0 = support(tb, pl, ql, sb, (-n[0], -n[1], -n[2]), vb)
                d0 = vdot(n, sub(p0, x0))
                if d0 <= -margin or _dominated(cand, m, int(-1), d0, n, tol):
                    continue
                if not _reaches_piece(tb, pl, ql, sb, vb, p0, p1, p2, n, margin, zstart, rb,
                                      prism, tol):
                    continue
                found, x = column_min(tb, pl, ql, sb, vb, p0, p1, p2, n, zstart, tol)
                if not found:
                    continue
                depth = vdot(n, sub(p0, x))
                if depth > -margin:
                    T = 2 * (i * (nc - 1) + j) + t
                    m = _add(cand, m, x, depth, n, _FEAT_TRI + 8 * T + 7, 2.0)
    if m == 0:
        return 0
    # drop column contacts explained by a deeper one with the same normal
    for i in range(m):
        if cand[i, 7] == 2.0:
            if _dominated(cand, m, i, cand[i, 2], (cand[i, 8], cand[i, 9], cand[i, 10]), tol):
                cand[i, 2] = -math.inf
    keep = np.empty((m, 11))
    mk = np.int64(0)
    for i in range(m):
        if cand[i, 2] != -math.inf:
            for c in range(11):
                keep[mk, c] = cand[i, c]
            mk += 1
    k0, k1, k2, k3 = select4(keep, mk, tol, sc)
    sg = -1.0 if flip else 1.0
    cnt = 0
    for slot in range(4):
        k = k0 if slot == 0 else (k1 if slot == 1 else (k2 if slot == 2 else k3))
        if k < 0:
            continue
        d = keep[k, 2]
        nl = (keep[k, 8], keep[k, 9], keep[k, 10])
        pm = madd((keep[k, 3], keep[k, 4], keep[k, 5]), nl, 0.5 * d)
        pw = local_to_world(ph, qh, pm)
        nw = quat_rotate(qh, nl)
        row = start + cnt
        for c in range(3):
            out_point[row, c] = pw[c]
            out_normal[row, c] = sg * nw[c]
        out_depth[row] = d
        out_feature[row] = int(keep[k, 6])
        cnt += 1
    return cnt


# -------------------------------------------------------------------------- ray cast

@njit(cache=True)
def _tri_hit(H, nr, nc, hsize, i, j, t, o, d, tlo, thi, eps):
    p0, p1, p2, n = hfield_triangle(H, nr, nc, hsize, i, j, t)
    den = vdot(n, d)
    if den >= 0.0:
        return math.inf, n
    tt = vdot(n, sub(p0, o)) / den
    if tt < tlo - eps or tt > thi + eps:
        return math.inf, n
    q = madd(o, d, tt)
    # inside the triangle's projection (edges counter-clockwise)
    for e in range(3):
        a = p0 if e == 0 else (p1 if e == 1 else p2)
        b = p1 if e == 0 else (p2 if e == 1 else p0)
        cr = (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0])
        if cr < -eps * math.hypot(b[0] - a[0], b[1] - a[1]):
            return math.inf, n
    return tt, n


@njit(cache=True)
def raycast_hfield(H, nr, nc, hsize, pos, quat, origin, direction, max_dist):
    """First hit of the ray (unit ``direction``) with the heightfield solid (surface,
    vertical sides, bottom): ``(t, world normal)`` or ``(-1, (0, 0, 0))``; a ray
    starting inside hits at 0 with normal ``-direction``. Cells are walked in order
    along the ray (2-D DDA)."""
    q = q4(quat)
    o = quat_rotate_inv(q, sub(v3(origin), v3(pos)))
    d = quat_rotate_inv(q, v3(direction))
    hx = hsize[0]
    hy = hsize[1]
    zb = -hsize[2]
    miss = (-1.0, (0.0, 0.0, 0.0))
    dx, dy = hfield_cell(hsize, nr, nc)
    eps = 1e-12 * (hx + hy + abs(zb) + 1.0)
    if -hx < o[0] < hx and -hy < o[1] < hy and zb < o[2] < hfield_height(H, nr, nc, hsize,
                                                                          o[0], o[1]):
        return 0.0, (-float(direction[0]), -float(direction[1]), -float(direction[2]))
    t0 = 0.0
    t1 = float(max_dist)
    face = (0.0, 0.0, 0.0)
    for ax in range(2):
        h = hx if ax == 0 else hy
        if abs(d[ax]) < 1e-300:
            if o[ax] < -h or o[ax] > h:
                return miss
            continue
        ta = (-h - o[ax]) / d[ax]
        tb = (h - o[ax]) / d[ax]
        s = -1.0
        if ta > tb:
            ta, tb = tb, ta
            s = 1.0
        if ta > t0:
            t0 = ta
            face = (s, 0.0, 0.0) if ax == 0 else (0.0, s, 0.0)
        t1 = min(t1, tb)
    if d[2] > 0.0:
        tz = (zb - o[2]) / d[2]
        if tz > t0:
            t0 = tz
            face = (0.0, 0.0, -1.0)
    elif d[2] < 0.0:
        t1 = min(t1, (zb - o[2]) / d[2])
    elif o[2] < zb:
        return miss
    if t0 > t1:
        return miss
    e = madd(o, d, t0)
    if t0 > 0.0 and e[2] <= hfield_height(H, nr, nc, hsize, e[0], e[1]):
        return t0, quat_rotate(q, face)
    # walk the cells from the entry point
    j = min(max(int(math.floor((e[0] + hx) / dx)), 0), nc - 2)
    i = min(max(int(math.floor((e[1] + hy) / dy)), 0), nr - 2)
    if d[0] > 0.0:
        tnx = (-hx + (j + 1) * dx - o[0]) / d[0]
        tdx = dx / d[0]
        sj = 1
    elif d[0] < 0.0:
        tnx = (-hx + j * dx - o[0]) / d[0]
        tdx = -dx / d[0]
        sj = -1
    else:
        tnx = math.inf
        tdx = math.inf
        sj = 0
    if d[1] > 0.0:
        tny = (-hy + (i + 1) * dy - o[1]) / d[1]
        tdy = dy / d[1]
        si = 1
    elif d[1] < 0.0:
        tny = (-hy + i * dy - o[1]) / d[1]
        tdy = -dy / d[1]
        si = -1
    else:
        tny = math.inf
        tdy = math.inf
        si = 0
    tcur = t0
    for _ in range(2 * (nr + nc) + 8):
        tend = min(min(tnx, tny), t1)
        best = math.inf
        bn = (0.0, 0.0, 1.0)
        for tri in range(2):
            th, n = _tri_hit(H, nr, nc, hsize, i, j, tri, o, d, tcur, tend, eps * (1.0 + tcur))
            if th < best:
                best = th
                bn = n
        if best < math.inf:
            best = max(best, 0.0)
            if best > max_dist:
                return miss
            return best, quat_rotate(q, bn)
        if tend >= t1:
            break
        if tnx < tny:
            j += sj
            tcur = tnx
            tnx += tdx
        else:
            i += si
            tcur = tny
            tny += tdy
        if i < 0 or i > nr - 2 or j < 0 or j > nc - 2:
            break
    return miss


# ------------------------------------------------------------------------- distance

@njit(cache=True)
def hfield_distance(H, nr, nc, hsize, pos_h, quat_h, tb, pos_b, quat_b, size_b, vb):
    """Signed distance ``(d, point on the heightfield, point on B)``.

    Penetrating: minus the deepest contact depth (``collide_hfield``). Apart: the
    smallest GJK distance from B to the triangular prisms (surface triangle down to
    the base) near B, searched outwards until the range covers the distance found.
    ``inf`` if B is beyond the field everywhere within its size.
    """
    qh = q4(quat_h)
    ph = v3(pos_h)
    P = np.empty((4, 3))
    N = np.empty((4, 3))
    D = np.empty(4)
    F = np.empty(4, np.int64)
    cnt = collide_hfield(H, nr, nc, hsize, pos_h, quat_h, tb, pos_b, quat_b, size_b, vb, 0.0,
                         bool(False), P, N, D, F, np.int64(0))
    if cnt > 0:
        k = 0
        for r in range(1, cnt):
            if D[r] > D[k]:
                k = r
        pk = (P[k, 0], P[k, 1], P[k, 2])
        nk = (N[k, 0], N[k, 1], N[k, 2])
        return -D[k], madd(pk, nk, -0.5 * D[k]), madd(pk, nk, 0.5 * D[k])
    sb = v3(size_b)
    pl, ql = _local_pose(ph, qh, pos_b, quat_b)
    lo, hi = _shape_aabb(tb, pl, ql, sb, vb, 0.0)
    rb = core_radius(tb, sb)
    dx, dy = hfield_cell(hsize, nr, nc)
    prism = np.empty((6, 3))
    grow = 0.5 * (dx + dy)
    best = math.inf
    ba = _Z3
    bb = _Z3
    span = 2.0 * (hsize[0] + hsize[1]) + (hi[2] - lo[2]) + abs(lo[2]) + abs(hi[2])
    for _ in range(64):
        glo = (lo[0] - grow, lo[1] - grow, lo[2])
        ghi = (hi[0] + grow, hi[1] + grow, hi[2])
        i0, i1, j0, j1 = _cell_range(glo, ghi, nr, nc, hsize)
        if i0 <= i1 and j0 <= j1:
            for i in range(i0, i1 + 1):
                for j in range(j0, j1 + 1):
                    for t in range(2):
                        p0, p1, p2, n = hfield_triangle(H, nr, nc, hsize, i, j, t)
                        zb = min(-hsize[2], min(p0[2], min(p1[2], p2[2])))
                        for r in range(3):
                            p = p0 if r == 0 else (p1 if r == 1 else p2)
                            prism[r, 0] = p[0]
                            prism[r, 1] = p[1]
                            prism[r, 2] = p[2]
                            prism[r + 3, 0] = p[0]
                            prism[r + 3, 1] = p[1]
                            prism[r + 3, 2] = zb
                        dist, ca, cb, overlap = gjk_distance(np.int64(CONVEX), _Z3, _IDENT, _Z3,
                                                             tb, pl, ql, sb, prism, vb)
                        if overlap:
                            dist = 0.0
                        dist -= rb
                        if dist < best:
                            best = dist
                            u = normalize_or(sub(cb, ca), n)
                            ba = ca
                            bb = madd(cb, u, -rb)
        if best <= grow or grow > span:
            break
        grow = 2.0 * grow if best == math.inf else best * (1.0 + 1e-12) + 1e-12
    return best, local_to_world(ph, qh, ba), local_to_world(ph, qh, bb)
