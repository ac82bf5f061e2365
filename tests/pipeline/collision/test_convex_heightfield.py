"""Convex hulls (CONVEX) and heightfields (HEIGHTFIELD) through the model-level kernels
``collide_geoms``, ``geom_aabb_any``, ``raycast_any`` and ``geom_distance_any``.

The reference answers are the primitive routines (a cube hull must act like a box, a
flat or planar heightfield like a plane) and closed forms. Tolerances: 1e-9 where both
sides are closed forms, 1e-6 where GJK/MPR is involved.
"""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tumble.model.builder import ModelBuilder
from tumble.model.types import GEOM_TYPES
from tumble.pipeline.collision.dispatch import (collide_geoms, geom_aabb_any, geom_distance_any,
                                                raycast_any)
from tumble.pipeline.collision.shapes import (BOX, CAPSULE, CONVEX, CYLINDER, HEIGHTFIELD,
                                              PLANE, SPHERE)

I4 = np.array([0.0, 0.0, 0.0, 1.0])
Z3 = np.zeros(3)
EZ = np.array([0.0, 0.0, 1.0])
SEEDS = st.integers(min_value=0, max_value=2**32 - 1)
TOL = 1e-9
TOL_GJK = 1e-6


def build(geoms):
    """The compiled arrays of a model whose world holds ``[(type, size, data)]`` in that
    order: data is the hull points (k, 3) for CONVEX, the heights (nrow, ncol) for
    HEIGHTFIELD, None otherwise. Built by ``ModelBuilder`` so that the kernels see the
    array types the pipeline gives them (and compile once for both)."""
    b = ModelBuilder()
    names = {code: name for name, code in GEOM_TYPES.items()}
    for t, size, data in geoms:
        if t == CONVEX:
            b.add_geom(None, "convex", vertices=np.asarray(data, float))
        elif t == HEIGHTFIELD:
            b.add_geom(None, "heightfield", size=size, heights=np.asarray(data, float))
        elif t == PLANE:
            b.add_geom(None, "plane")
        else:
            b.add_geom(None, names[t], size=size)
    return b.build().arrays


def collide(m, ga, pa, qa, gb, pb, qb, margin=1e-3):
    """collide_geoms into NaN-filled arrays from row 2 (rows outside untouched)."""
    P = np.full((8, 3), np.nan)
    N = np.full((8, 3), np.nan)
    D = np.full(8, np.nan)
    F = np.full(8, -99, dtype=np.int64)
    f = lambda x: np.asarray(x, dtype=float)  # noqa: E731
    # geom indices as the pipeline's pair buffer holds them (int32): one compilation for both
    n = collide_geoms(m, np.int32(ga), f(pa), f(qa), np.int32(gb), f(pb), f(qb), float(margin),
                      P, N, D, F, 2)
    assert 0 <= n <= 4
    assert np.all(np.isnan(D[:2])) and np.all(np.isnan(D[2 + n:]))
    assert np.all(F[:2] == -99) and np.all(F[2 + n:] == -99)
    sl = slice(2, 2 + n)
    if n:
        assert np.allclose(np.linalg.norm(N[sl], axis=1), 1.0, atol=1e-12)
        assert np.all(D[sl] > -margin)
        assert np.all(np.isfinite(P[sl]))
    return P[sl].copy(), N[sl].copy(), D[sl].copy(), F[sl].copy()


def dist(m, ga, pa, qa, gb, pb, qb):
    f = lambda x: np.asarray(x, dtype=float)  # noqa: E731
    d, xa, xb = geom_distance_any(m, ga, f(pa), f(qa), gb, f(pb), f(qb))
    return d, np.array(xa), np.array(xb)


def rot(rv):
    return Rotation.from_rotvec(np.asarray(rv, float)).as_quat()


def rmat(q):
    return Rotation.from_quat(q).as_matrix()


def box_corners(h):
    return np.array([[sx * h[0], sy * h[1], sz * h[2]]
                     for sz in (-1, 1) for sy in (-1, 1) for sx in (-1, 1)])


def same_rows(a, b, tol):
    a = np.asarray(a)
    b = np.asarray(b)
    if a.shape != b.shape:
        return False
    used = set()
    for row in a:
        for j, other in enumerate(b):
            if j not in used and np.allclose(row, other, atol=tol):
                used.add(j)
                break
        else:
            return False
    return True


def hexprism(r, hz):
    ang = np.arange(6) * np.pi / 3
    ring = np.c_[r * np.cos(ang), r * np.sin(ang)]
    return np.vstack([np.c_[ring, np.full(6, -hz)], np.c_[ring, np.full(6, hz)]])


# ------------------------------------------------------------ a cube hull is a box

@settings(max_examples=40, deadline=None)
@given(seed=SEEDS)
def test_cube_hull_matches_box(seed):
    rng = np.random.default_rng(seed)
    h = rng.uniform(0.1, 0.5, 3)
    pts = box_corners(h)[rng.permutation(8)]
    m = build([(PLANE, None, None), (SPHERE, [rng.uniform(0.1, 0.4)], None),
               (BOX, [2.0, 2.0, 0.5], None), (BOX, h, None), (CONVEX, None, pts)])
    q = rot(rng.normal(size=3))
    R = rmat(q)
    low = (R @ box_corners(h).T)[2].min()
    # on a plane: lowest vertex depth in [-0.5, 2] x 1e-2 (few vertices within the margin)
    pos = np.array([*rng.uniform(-1, 1, 2), -low - rng.uniform(-0.005, 0.02)])
    box = collide(m, 0, Z3, I4, 3, pos, q)
    hull = collide(m, 0, Z3, I4, 4, pos, q)
    assert len(box[2]) == len(hull[2])
    assert np.allclose(np.sort(box[2]), np.sort(hull[2]), atol=TOL)
    assert same_rows(box[0], hull[0], TOL) and np.allclose(hull[1], EZ, atol=TOL)
    # a sphere anywhere around it (outside, touching, centre inside)
    r = m.geom_size[1, 0]
    c = pos + R @ (rng.uniform(-1.4, 1.4, 3) * (h + r))
    for swap in (False, True):
        if swap:
            box = collide(m, 3, pos, q, 1, c, I4, margin=0.05)
            hull = collide(m, 4, pos, q, 1, c, I4, margin=0.05)
        else:
            box = collide(m, 1, c, I4, 3, pos, q, margin=0.05)
            hull = collide(m, 1, c, I4, 4, pos, q, margin=0.05)
        assert len(box[2]) == len(hull[2]) <= 1
        if len(box[2]):
            assert abs(box[2][0] - hull[2][0]) < TOL_GJK
            assert np.allclose(box[1][0], hull[1][0], atol=TOL_GJK)
            assert np.allclose(box[0][0], hull[0][0], atol=TOL_GJK)
    # resting on a big box's top face, anywhere in its interior
    pos = np.array([*rng.uniform(-1, 1, 2), 0.5 - low - rng.uniform(0.0, 0.02)])
    box = collide(m, 2, Z3, I4, 3, pos, q)
    hull = collide(m, 2, Z3, I4, 4, pos, q)
    assert len(hull[2]) >= 1
    assert abs(box[2].max() - hull[2].max()) < TOL_GJK
    assert np.allclose(hull[1], EZ, atol=TOL_GJK) and np.allclose(box[1], EZ, atol=TOL_GJK)
    if len(box[2]) == len(hull[2]):
        assert np.allclose(np.sort(box[2]), np.sort(hull[2]), atol=TOL_GJK)


def test_cube_hull_flat_on_box_and_on_hull_same_manifold():
    h = np.array([0.3, 0.2, 0.1])
    slab = np.array([1.0, 1.0, 0.2])
    m = build([(BOX, slab, None), (CONVEX, None, box_corners(slab)), (BOX, h, None),
               (CONVEX, None, box_corners(h))])
    for yaw in (0.0, 0.3, 1.2):
        q = rot([0, 0, yaw])
        pos = np.array([0.85, -0.1, 0.2 + 0.1 - 0.004])     # overhangs the +x edge
        ref = collide(m, 0, Z3, I4, 2, pos, q)
        for ga, gb in ((0, 3), (1, 2), (1, 3)):
            got = collide(m, ga, Z3, I4, gb, pos, q)
            assert len(got[2]) == len(ref[2]) >= 3
            assert np.allclose(np.sort(got[2]), np.sort(ref[2]), atol=TOL_GJK)
            assert same_rows(got[0], ref[0], TOL_GJK)
            assert np.allclose(got[1], EZ, atol=TOL_GJK)
        # swapped order: same points and depths, flipped normals
        got = collide(m, 3, pos, q, 1, Z3, I4)
        assert same_rows(got[0], ref[0], TOL_GJK) and np.allclose(got[1], -EZ, atol=TOL_GJK)


# ------------------------------------------------------------------ hulls on planes

@settings(max_examples=40, deadline=None)
@given(seed=SEEDS)
def test_tetrahedron_on_plane_lowest_vertex(seed):
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(4, 3)) * 0.3
    m = build([(PLANE, None, None), (CONVEX, None, pts)])
    qp = rot(rng.normal(size=3) * 0.3)
    n = rmat(qp)[:, 2]
    q = rot(rng.normal(size=3))
    w = (rmat(q) @ pts.T).T
    hts = w @ n
    k = int(np.argmin(hts))
    depth = rng.uniform(-5e-4, 0.05)
    if np.sort(hts)[1] - hts[k] < depth + 2e-3:
        return                                   # a second vertex within the margin
    pp = np.array([0.3, -0.2, 0.1])
    pos = pp - n * (hts[k] + depth)
    P, N, D, F = collide(m, 0, pp, qp, 1, pos, q, margin=1e-3)
    assert len(D) == 1 and abs(D[0] - depth) < TOL and F[0] == k
    assert np.allclose(N[0], n, atol=TOL)
    assert np.allclose(P[0], pos + w[k] + 0.5 * depth * n, atol=TOL)
    P2, N2, D2, F2 = collide(m, 1, pos, q, 0, pp, qp, margin=1e-3)
    assert np.allclose(D2, D) and np.allclose(N2, -N) and np.allclose(P2, P)


def test_convex_resting_flat_gives_four_points():
    pts = hexprism(0.3, 0.1)
    big = hexprism(2.0, 0.25)
    m = build([(PLANE, None, None), (CONVEX, None, pts), (BOX, [2, 2, 0.25], None),
               (CONVEX, None, big)])
    hex_area = 1.5 * math.sqrt(3) * 0.3 ** 2
    for ga, top in ((0, 0.0), (2, 0.25), (3, 0.25)):
        for yaw in (0.0, 0.4, 2.0):
            pos = np.array([0.2, -0.3, top + 0.1 - 0.01])
            P, N, D, F = collide(m, ga, Z3, I4, 1, pos, rot([0, 0, yaw]))
            assert len(D) == 4 and np.allclose(D, 0.01, atol=TOL_GJK)
            assert np.allclose(N, EZ, atol=TOL_GJK)
            assert np.allclose(P[:, 2], top - 0.005, atol=TOL_GJK)
            assert len(set(F.tolist())) == 4
            # the four points span most of the hexagon (at least 2/3 of it)
            xy = P[:, :2]
            c = xy.mean(axis=0)
            o = np.argsort(np.arctan2(xy[:, 1] - c[1], xy[:, 0] - c[0]))
            x, y = xy[o, 0], xy[o, 1]
            area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
            assert area > 0.66 * hex_area
            # stable feature ids under a small motion
            P2, N2, D2, F2 = collide(m, ga, Z3, I4, 1, pos + [1e-4, -1e-4, 1e-5],
                                     rot([0, 0, yaw + 1e-5]))
            assert sorted(F2.tolist()) == sorted(F.tolist())


def test_round_shapes_on_a_hull_face():
    slab = hexprism(1.0, 0.2)
    m = build([(CONVEX, None, slab), (CAPSULE, [0.1, 0.3], None), (CYLINDER, [0.2, 0.15], None),
               (SPHERE, [0.25], None)])
    # capsule lying on the top face: two end contacts
    P, N, D, F = collide(m, 0, Z3, I4, 1, [0.1, 0.2, 0.2 + 0.1 - 0.02], rot([0, math.pi / 2, 0]))
    assert len(D) == 2 and np.allclose(D, 0.02, atol=TOL_GJK) and np.allclose(N, EZ, atol=TOL_GJK)
    assert same_rows(P, [[-0.2, 0.2, 0.19], [0.4, 0.2, 0.19]], TOL_GJK)
    # cylinder standing on it: four rim points
    P, N, D, F = collide(m, 2, [0.1, 0.2, 0.2 + 0.15 - 0.01], I4, 0, Z3, I4)
    assert len(D) == 4 and np.allclose(D, 0.01, atol=TOL_GJK)
    assert np.allclose(N, -EZ, atol=TOL_GJK)
    assert np.allclose(np.linalg.norm(P[:, :2] - [0.1, 0.2], axis=1), 0.2, atol=TOL_GJK)
    # a sphere: one contact, exact
    P, N, D, F = collide(m, 0, Z3, I4, 3, [0.1, 0.2, 0.2 + 0.25 - 0.03], I4)
    assert len(D) == 1 and abs(D[0] - 0.03) < TOL_GJK and np.allclose(N[0], EZ, atol=TOL_GJK)


# ------------------------------------------------------------------------ heightfields

def grid(nr, nc, hx, hy):
    x = np.linspace(-hx, hx, nc)
    y = np.linspace(-hy, hy, nr)
    return np.meshgrid(x, y)          # X[i, j] = x_j, Y[i, j] = y_i


@settings(max_examples=40, deadline=None)
@given(seed=SEEDS)
def test_flat_and_planar_heightfield_act_like_a_plane(seed):
    rng = np.random.default_rng(seed)
    nr, nc = rng.integers(2, 9, 2)
    hx, hy = 2.0, 1.5
    a, b = (0.0, 0.0) if seed % 2 else rng.uniform(-0.4, 0.4, 2)
    c = rng.uniform(-0.2, 0.5)
    X, Y = grid(nr, nc, hx, hy)
    Hts = a * X + b * Y + c
    hsize = [hx, hy, 0.5]
    hbox = rng.uniform(0.1, 0.3, 3)
    m = build([(PLANE, None, None), (HEIGHTFIELD, hsize, Hts), (SPHERE, [0.3], None),
               (BOX, hbox, None), (CAPSULE, [0.1, 0.25], None),
               (CONVEX, None, box_corners(hbox)), (CYLINDER, [0.2, 0.1], None)])
    # heightfield pose, and the plane z = a x + b y + c in its frame
    qh = rot(rng.normal(size=3) * 0.2)
    ph = rng.normal(size=3)
    Rh = rmat(qh)
    nl = np.array([-a, -b, 1.0]) / math.sqrt(a * a + b * b + 1)
    ql = Rotation.align_vectors([nl], [EZ])[0].as_quat()
    qp = (Rotation.from_quat(qh) * Rotation.from_quat(ql)).as_quat()
    pp = ph + Rh @ [0, 0, c]
    n = Rh @ nl
    for g in (2, 3, 4, 5, 6):
        q = rot(rng.normal(size=3))
        # place it over the interior, lowest point at depth in [-0.5, 5] x 1e-2
        xy = rng.uniform(-0.9, 0.9, 2)
        base = ph + Rh @ [xy[0], xy[1], a * xy[0] + b * xy[1] + c]
        lo = -0.3
        if g in (3, 5):
            lo = ((rmat(q) @ box_corners(hbox).T).T @ n).min()
        elif g == 4:
            u = rmat(q)[:, 2]
            lo = -abs(u @ n) * 0.25 - 0.1
        elif g == 6:
            u = rmat(q)[:, 2]
            lo = -abs(u @ n) * 0.1 - 0.2 * math.sqrt(max(0.0, 1 - (u @ n) ** 2))
        depth = rng.uniform(-0.005, 0.05)
        pos = base - n * (lo + depth)
        ref = collide(m, 0, pp, qp, g, pos, q)
        got = collide(m, 1, ph, qh, g, pos, q)
        assert len(got[2]) == len(ref[2])
        assert np.allclose(np.sort(got[2]), np.sort(ref[2]), atol=TOL)
        assert same_rows(got[0], ref[0], 1e-8) and np.allclose(got[1], n, atol=TOL)
        if g == 2:
            assert len(got[2]) == (1 if depth > -1e-3 else 0)
        swapped = collide(m, g, pos, q, 1, ph, qh)
        assert same_rows(swapped[0], got[0], TOL) and np.allclose(swapped[1], -n, atol=TOL)


def test_sloped_heightfield_gives_slope_normal():
    X, Y = grid(5, 7, 1.5, 1.0)
    Hts = 0.3 * X - 0.1 * Y + 0.2
    m = build([(HEIGHTFIELD, [1.5, 1.0, 0.3], Hts), (SPHERE, [0.2], None),
               (BOX, [0.1, 0.1, 0.1], None)])
    n = np.array([-0.3, 0.1, 1.0]) / math.sqrt(1.1)
    for x, y in ((0.1, 0.05), (-0.77, 0.33), (1.0, -0.5)):
        s = np.array([x, y, 0.3 * x - 0.1 * y + 0.2]) + n * (0.2 - 0.04)
        P, N, D, F = collide(m, 0, Z3, I4, 1, s, I4)
        assert len(D) == 1 and abs(D[0] - 0.04) < TOL and np.allclose(N[0], n, atol=TOL)
        low = 0.1 * np.abs(n).sum()          # lowest box corner below its centre along n
        P, N, D, F = collide(m, 0, Z3, I4, 2, s - n * (0.2 - 0.04) + n * (low - 0.02), I4)
        assert len(D) >= 1 and np.allclose(N, n, atol=TOL) and abs(D.max() - 0.02) < TOL


def test_sphere_on_ridge_and_in_valley():
    X, Y = grid(5, 9, 2.0, 1.0)
    s = 0.5
    k = math.sqrt(1 + s * s)
    m = build([(HEIGHTFIELD, [2.0, 1.0, 0.2], -s * np.abs(X)), (HEIGHTFIELD, [2.0, 1.0, 0.2],
                                                                   s * np.abs(X)),
               (SPHERE, [0.3], None)])
    cz = 0.25
    P, N, D, F = collide(m, 0, Z3, I4, 2, [0, 0.1, cz], I4)
    assert len(D) == 2 and np.allclose(D, (0.3 - cz) / k, atol=TOL)
    assert same_rows(N, [[s / k, 0, 1 / k], [-s / k, 0, 1 / k]], TOL)
    P, N, D, F = collide(m, 1, Z3, I4, 2, [0, 0.1, cz], I4)
    assert len(D) == 2 and np.allclose(D, 0.3 - cz / k, atol=TOL)
    assert same_rows(N, [[s / k, 0, 1 / k], [-s / k, 0, 1 / k]], TOL)


@pytest.mark.parametrize("shape", [SPHERE, BOX, CONVEX, CAPSULE, CYLINDER])
def test_depth_continuous_across_cells(shape):
    rng = np.random.default_rng(7)
    Hts = rng.uniform(0.0, 0.08, (9, 9))
    size = {SPHERE: [0.3], BOX: [0.2, 0.15, 0.1], CAPSULE: [0.1, 0.2], CYLINDER: [0.15, 0.1],
            CONVEX: None}[shape]
    pts = rng.normal(size=(12, 3)) * 0.15
    m = build([(HEIGHTFIELD, [1.0, 1.0, 0.2], Hts), (shape, size, pts)])
    q = rot([0.3, -0.2, 0.5])
    uz = rmat(q)[2, 2]
    lo = {SPHERE: -0.3, BOX: (rmat(q) @ box_corners(size).T)[2].min() if shape == BOX else 0,
          CONVEX: (rmat(q) @ pts.T)[2].min(), CAPSULE: -(abs(uz) * 0.2 + 0.1),
          CYLINDER: -(abs(uz) * 0.1 + 0.15 * math.sqrt(1 - uz * uz))}[shape]
    step = 2e-3
    xs = np.arange(-0.55, 0.55, step)
    deepest = []
    for x in xs:
        P, N, D, F = collide(m, 0, Z3, I4, 1, [x, 0.37 * x + 0.03, -0.02 - lo], q, margin=0.0)
        assert len(D) >= 1
        deepest.append(D.max())
        assert np.all(N[:, 2] > 0.8)
    jumps = np.abs(np.diff(deepest))
    assert jumps.max() < 4 * step
    assert np.ptp(deepest) > 10 * step        # it did move over bumps


def test_heightfield_pairs_without_contact():
    Hts = np.zeros((3, 3))
    m = build([(HEIGHTFIELD, [1, 1, 0.5], Hts), (HEIGHTFIELD, [1, 1, 0.5], Hts),
               (PLANE, None, None), (SPHERE, [0.2], None)])
    assert len(collide(m, 0, Z3, I4, 1, Z3, I4)[2]) == 0
    assert len(collide(m, 0, Z3, I4, 2, Z3, I4)[2]) == 0
    assert len(collide(m, 2, Z3, I4, 0, Z3, I4)[2]) == 0
    # beside the field, or under its base: nothing
    assert len(collide(m, 0, Z3, I4, 3, [1.5, 0, 0], I4)[2]) == 0
    assert len(collide(m, 0, Z3, I4, 3, [0, 0, -0.8], I4)[2]) == 0
    assert math.isinf(dist(m, 0, Z3, I4, 2, Z3, I4)[0])


# ------------------------------------------------------------------------- ray casts

def ray(m, g, pos, q, o, d, max_dist=100.0):
    d = np.asarray(d, float)
    d = d / np.linalg.norm(d)
    t, n = raycast_any(m, g, np.asarray(pos, float), np.asarray(q, float),
                       np.asarray(o, float), d, max_dist)
    return t, np.array(n)


def test_raycast_heightfield_analytic():
    X, Y = grid(6, 8, 2.0, 1.0)
    a, b, c = 0.2, -0.3, 0.4
    m = build([(HEIGHTFIELD, [2.0, 1.0, 0.5], a * X + b * Y + c)])
    n = np.array([-a, -b, 1]) / math.sqrt(a * a + b * b + 1)
    rng = np.random.default_rng(3)
    qh = rot([0.1, 0.2, -0.3])
    ph = np.array([1.0, -2.0, 0.5])
    Rh = rmat(qh)
    for _ in range(30):
        target = np.array([*rng.uniform([-1.9, -0.9], [1.9, 0.9])])
        zt = a * target[0] + b * target[1] + c
        d = rng.normal(size=3)
        d[2] = -abs(d[2]) - 0.3
        d /= np.linalg.norm(d)
        tt = rng.uniform(0.1, 1.0)
        o = np.array([*target, zt]) - tt * d
        if not (-2 < o[0] < 2 and -1 < o[1] < 1):
            continue
        t, nn = ray(m, 0, ph, qh, ph + Rh @ o, Rh @ d)
        assert abs(t - tt) < 1e-9 and np.allclose(nn, Rh @ n, atol=1e-12)
    # straight down from above, a side wall, the bottom, a miss, from inside
    t, nn = ray(m, 0, Z3, I4, [0.5, 0.2, 3], [0, 0, -1])
    assert abs(t - (3 - (0.1 - 0.06 + 0.4))) < 1e-12 and np.allclose(nn, n)
    t, nn = ray(m, 0, Z3, I4, [-3, 0, 0], [1, 0, 0])
    assert abs(t - 1.0) < 1e-12 and np.allclose(nn, [-1, 0, 0])
    t, nn = ray(m, 0, Z3, I4, [0.3, 0.1, -2], [0, 0, 1])
    assert abs(t - 1.5) < 1e-12 and np.allclose(nn, [0, 0, -1])
    assert ray(m, 0, Z3, I4, [0.3, 0.1, 2], [0, 0, 1])[0] == -1.0
    assert ray(m, 0, Z3, I4, [-3, 0, 2], [1, 0, 0])[0] == -1.0
    assert ray(m, 0, Z3, I4, [0.5, 0.2, 3], [0, 0, -1], max_dist=2.0)[0] == -1.0
    t, nn = ray(m, 0, Z3, I4, [0.3, 0.1, 0.0], [1, 0, 0])
    assert t == 0.0 and np.allclose(nn, [-1, 0, 0])


def test_raycast_bumpy_heightfield_matches_marching():
    rng = np.random.default_rng(11)
    Hts = rng.uniform(0, 0.5, (7, 9))
    m = build([(HEIGHTFIELD, [1.0, 0.8, 0.2], Hts)])
    X, Y = grid(7, 9, 1.0, 0.8)
    def surface(x, y):
        j = min(int((x + 1.0) / 0.25), 7)
        i = min(int((y + 0.8) / (1.6 / 6)), 5)
        u = (x - X[0, j]) / 0.25
        v = (y - Y[i, 0]) / (1.6 / 6)
        h00, h01, h10, h11 = Hts[i, j], Hts[i, j + 1], Hts[i + 1, j], Hts[i + 1, j + 1]
        if u >= v:
            return h00 + u * (h01 - h00) + v * (h11 - h01)
        return h00 + v * (h10 - h00) + u * (h11 - h10)

    for _ in range(20):
        o = np.array([*rng.uniform([-0.9, -0.7], [0.9, 0.7]), 1.0])
        d = np.array([*rng.normal(size=2) * 0.5, -1.0])
        d /= np.linalg.norm(d)
        t, nn = ray(m, 0, Z3, I4, o, d)
        ts = np.linspace(0, 3, 30001)
        p = o + ts[:, None] * d
        inside = np.array([abs(x) <= 1 and abs(y) <= 0.8 and z <= surface(x, y)
                           for x, y, z in p])
        if not inside.any():
            assert t == -1.0 or t > 2.99
            continue
        k = int(np.argmax(inside))
        assert ts[k - 1] - 1e-9 <= t <= ts[k] + 1e-9
        assert nn[2] > 0


def test_raycast_convex_matches_box_and_tetrahedron():
    rng = np.random.default_rng(5)
    h = np.array([0.3, 0.5, 0.2])
    tet = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, 0]], float)
    m = build([(BOX, h, None), (CONVEX, None, box_corners(h)), (CONVEX, None, tet)])
    q = rot([0.4, -0.3, 0.8])
    pos = np.array([0.2, 0.1, -0.3])
    hits = 0
    for _ in range(60):
        o = pos + rng.normal(size=3) * 1.5
        d = pos + rng.normal(size=3) * 0.3 - o
        tb, nb = ray(m, 0, pos, q, o, d)
        tc, nc = ray(m, 1, pos, q, o, d)
        assert (tb < 0) == (tc < 0)
        if tb > 0:
            hits += 1
            assert abs(tb - tc) < 1e-9 and np.allclose(nb, nc, atol=1e-6)
        if tb == 0.0:
            assert tc == 0.0
    assert hits > 20
    t, nn = ray(m, 2, Z3, I4, [0.2, 0.2, 5], [0, 0, -1])
    assert abs(t - 4.4) < 1e-9 and np.allclose(nn, np.ones(3) / math.sqrt(3), atol=1e-9)
    t, nn = ray(m, 2, Z3, I4, [0.2, 0.2, -5], [0, 0, 1])
    assert abs(t - 5) < 1e-9 and np.allclose(nn, [0, 0, -1], atol=1e-9)
    assert ray(m, 2, Z3, I4, [0.7, 0.7, 5], [0, 0, -1])[0] == -1.0
    assert ray(m, 2, Z3, I4, [0.2, 0.2, 5], [0, 0, -1], max_dist=4.0)[0] == -1.0
    t, nn = ray(m, 2, Z3, I4, [0.1, 0.1, 0.1], [1, 0, 0])
    assert t == 0.0 and np.allclose(nn, [-1, 0, 0])


# ----------------------------------------------------------------------------- AABBs

@settings(max_examples=30, deadline=None)
@given(seed=SEEDS)
def test_aabbs_contain_the_shapes(seed):
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(20, 3)) * rng.uniform(0.1, 1, 3) + rng.normal(size=3)
    nr, nc = rng.integers(2, 8, 2)
    Hts = rng.normal(size=(nr, nc)) * 0.3
    hsize = [rng.uniform(0.2, 2), rng.uniform(0.2, 2), rng.uniform(0, 1)]
    m = build([(CONVEX, None, pts), (HEIGHTFIELD, hsize, Hts)])
    q = rot(rng.normal(size=3))
    pos = rng.normal(size=3)
    margin = rng.uniform(0, 0.1)
    lo, hi = map(np.array, geom_aabb_any(m, 0, pos, q, margin))
    w = pos + (rmat(q) @ pts.T).T
    assert np.all(w >= lo + margin - 1e-12) and np.all(w <= hi - margin + 1e-12)
    assert np.allclose(w.min(axis=0), lo + margin) and np.allclose(w.max(axis=0), hi - margin)
    lo, hi = map(np.array, geom_aabb_any(m, 1, pos, q, margin))
    X, Y = grid(nr, nc, hsize[0], hsize[1])
    top = np.c_[X.ravel(), Y.ravel(), Hts.ravel()]
    bottom = np.c_[X.ravel(), Y.ravel(), np.full(X.size, -hsize[2])]
    w = pos + (rmat(q) @ np.vstack([top, bottom]).T).T
    assert np.all(w >= lo - 1e-12) and np.all(w <= hi + 1e-12)


# ------------------------------------------------------------------------- distances

def test_distances():
    h = np.array([0.3, 0.2, 0.25])
    tet = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, 0]], float) * 0.5
    m = build([(BOX, h, None), (CONVEX, None, box_corners(h)), (PLANE, None, None),
               (CONVEX, None, tet), (HEIGHTFIELD, [1, 1, 0.3], np.full((4, 4), 0.2)),
               (SPHERE, [0.1], None)])
    rng = np.random.default_rng(2)
    for _ in range(10):
        qa, qb = rot(rng.normal(size=3)), rot(rng.normal(size=3))
        pa = rng.normal(size=3)
        pb = pa + rng.normal(size=3) * 2.0
        ref = dist(m, 0, pa, qa, 0, pb, qb)             # box-box: primitives
        got = dist(m, 1, pa, qa, 1, pb, qb)
        if ref[0] > 0:
            assert abs(ref[0] - got[0]) < 1e-9
            assert np.allclose(ref[1], got[1], atol=1e-6) and np.allclose(ref[2], got[2], atol=1e-6)
        else:
            assert abs(ref[0] - got[0]) < TOL_GJK
        got2 = dist(m, 0, pa, qa, 1, pb, qb)
        assert abs(got2[0] - got[0]) < TOL_GJK
    # tetrahedron over a plane: its lowest vertex
    q = rot([0.2, 0.5, -0.1])
    d, pa, pb = dist(m, 2, Z3, I4, 3, [0, 0, 1], q)
    w = (rmat(q) @ tet.T).T + [0, 0, 1]
    assert abs(d - w[:, 2].min()) < 1e-12 and np.allclose(pb, w[np.argmin(w[:, 2])])
    d2, pb2, pa2 = dist(m, 3, [0, 0, 1], q, 2, Z3, I4)
    assert d2 == d and np.allclose(pa2, pa)
    # sphere over a flat heightfield; and sinking into it
    d, pa, pb = dist(m, 4, Z3, I4, 5, [0.3, 0.1, 0.7], I4)
    assert abs(d - 0.4) < 1e-9
    assert np.allclose(pa, [0.3, 0.1, 0.2]) and np.allclose(pb, [0.3, 0.1, 0.6])
    d, pb, pa = dist(m, 5, [0.3, 0.1, 0.25], I4, 4, Z3, I4)
    assert abs(d + 0.05) < 1e-9
    # off to the side of the field: the distance to its side wall
    d, pa, pb = dist(m, 4, Z3, I4, 5, [1.5, 0.0, 0.0], I4)
    assert abs(d - 0.4) < 1e-9 and abs(pa[0] - 1.0) < 1e-9
