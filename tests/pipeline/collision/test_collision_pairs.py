"""Contact pair routines on analytic configurations.

Tolerances: 1e-9 for closed forms (exact up to rounding), 1e-7 for the GJK/MPR based
cylinder pairs.
"""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tumble.pipeline.collision import (BOX, CAPSULE, CYLINDER, PLANE, SPHERE, collide_box_box,
                                       collide_box_cylinder, collide_capsule_box,
                                       collide_capsule_capsule, collide_capsule_cylinder,
                                       collide_cylinder_cylinder, collide_pair,
                                       collide_plane_box, collide_plane_capsule,
                                       collide_plane_cylinder, collide_plane_plane,
                                       collide_plane_sphere, collide_sphere_box,
                                       collide_sphere_capsule, collide_sphere_cylinder,
                                       collide_sphere_sphere)

I = np.array([0.0, 0.0, 0.0, 1.0])
Z3 = np.zeros(3)
EX, EY, EZ = np.eye(3)
TOL = 1e-9
TOL_GJK = 1e-7
TOL_PT = 1e-5      # points and normals of MPR contacts on curved surfaces


def rot(rotvec):
    return Rotation.from_rotvec(np.asarray(rotvec, dtype=float)).as_quat()


def rmat(q):
    return Rotation.from_quat(q).as_matrix()


def _readonly(x):
    a = np.array(x, dtype=float)
    a.flags.writeable = False
    return a


def collide(ta, pa, qa, sa, tb, pb, qb, sb, margin=1e-3):
    """collide_pair into arrays pre-filled with NaN, from row 2; checks the rows
    outside the written range are untouched. Returns (points, normals, depths, features)."""
    P = np.full((8, 3), np.nan)
    N = np.full((8, 3), np.nan)
    D = np.full(8, np.nan)
    F = np.full(8, -99, dtype=np.int64)
    f = lambda x: np.asarray(x, dtype=float)  # noqa: E731
    # sizes read-only, as the model's arrays reach the kernel (one compilation for both)
    n = collide_pair(ta, f(pa), f(qa), _readonly(sa), tb, f(pb), f(qb), _readonly(sb),
                     float(margin), P, N, D, F, 2)
    assert 0 <= n <= 4
    assert np.all(np.isnan(D[:2])) and np.all(np.isnan(D[2 + n:]))
    assert np.all(F[:2] == -99) and np.all(F[2 + n:] == -99)
    sl = slice(2, 2 + n)
    if n:
        assert np.allclose(np.linalg.norm(N[sl], axis=1), 1.0, atol=1e-12)
        assert np.all(D[sl] > -margin)
    return P[sl].copy(), N[sl].copy(), D[sl].copy(), F[sl].copy()


def same_rows(a, b, tol):
    """Rows of a and b equal as sets (order free)."""
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


# ------------------------------------------------------------------------ plane pairs

def test_plane_sphere_resting_and_penetrating():
    P, N, D, F = collide(PLANE, Z3, I, Z3, SPHERE, [0.3, -0.2, 0.5], I, [0.5, 0, 0])
    assert len(D) == 1 and abs(D[0]) < TOL
    assert np.allclose(N[0], EZ, atol=TOL) and np.allclose(P[0], [0.3, -0.2, 0.0], atol=TOL)
    assert F[0] == 0
    P, N, D, F = collide(PLANE, Z3, I, Z3, SPHERE, [0.3, -0.2, 0.4], I, [0.5, 0, 0])
    assert np.isclose(D[0], 0.1, atol=TOL) and np.allclose(P[0], [0.3, -0.2, -0.05], atol=TOL)


def test_plane_sphere_rotated_plane_and_margin():
    q = rot([0.3, -0.2, 0.1])
    p0 = np.array([1.0, 2.0, 3.0])
    R = rmat(q)
    n, t1 = R[:, 2], R[:, 0]
    c = p0 + 0.7 * t1 + 0.4 * n
    P, N, D, F = collide(PLANE, p0, q, Z3, SPHERE, c, I, [0.5, 0, 0])
    assert np.isclose(D[0], 0.1, atol=TOL) and np.allclose(N[0], n, atol=TOL)
    assert np.allclose(P[0], p0 + 0.7 * t1 - 0.05 * n, atol=TOL)
    c = p0 + 0.6 * n
    assert len(collide(PLANE, p0, q, Z3, SPHERE, c, I, [0.5, 0, 0], margin=0.05)[2]) == 0
    P, N, D, F = collide(PLANE, p0, q, Z3, SPHERE, c, I, [0.5, 0, 0], margin=0.2)
    assert np.isclose(D[0], -0.1, atol=TOL)


def test_plane_capsule_lying_two_points():
    q = rot([0, math.pi / 2, 0])          # capsule axis along +x
    P, N, D, F = collide(PLANE, Z3, I, Z3, CAPSULE, [0.1, 0.2, 0.15], q, [0.2, 0.5, 0])
    assert len(D) == 2 and np.allclose(D, 0.05, atol=TOL)
    assert sorted(F) == [0, 1]
    assert same_rows(P, [[-0.4, 0.2, -0.025], [0.6, 0.2, -0.025]], TOL)
    assert np.allclose(N, EZ, atol=TOL)
    # resting: depth 0
    P, N, D, F = collide(PLANE, Z3, I, Z3, CAPSULE, [0.1, 0.2, 0.2], q, [0.2, 0.5, 0])
    assert len(D) == 2 and np.allclose(D, 0.0, atol=TOL)


def test_plane_capsule_tilted_one_point():
    th = 0.6
    q = rot([0, th, 0])                   # axis (sin th, 0, cos th)
    r, hl = 0.2, 0.5
    zc = hl * math.cos(th) + r - 0.03
    P, N, D, F = collide(PLANE, Z3, I, Z3, CAPSULE, [0, 0, zc], q, [r, hl, 0])
    assert len(D) == 1 and np.isclose(D[0], 0.03, atol=TOL) and F[0] == 0
    low_end = np.array([-hl * math.sin(th), 0, zc - hl * math.cos(th)])
    assert np.allclose(P[0], [low_end[0], 0, -0.015], atol=TOL)


def test_plane_box_face_four_points():
    h = np.array([0.3, 0.2, 0.1])
    q = rot([0, 0, 0.4])
    pos = np.array([0.5, -0.3, 0.09])
    P, N, D, F = collide(PLANE, Z3, I, Z3, BOX, pos, q, h)
    assert len(D) == 4 and np.allclose(D, 0.01, atol=TOL)
    assert sorted(F) == [0, 1, 2, 3]       # the bottom vertices (bz = 0)
    R = rmat(q)
    verts = [pos + R @ (np.array([sx, sy, -1]) * h) for sx in (-1, 1) for sy in (-1, 1)]
    expect = [[v[0], v[1], -0.005] for v in verts]
    assert same_rows(P, expect, TOL)
    assert np.allclose(N, EZ, atol=TOL)
    # touching: depth 0 on all four
    P, N, D, F = collide(PLANE, Z3, I, Z3, BOX, [0, 0, 0.1], q, h)
    assert len(D) == 4 and np.allclose(D, 0.0, atol=TOL)


def test_plane_box_edge_corner_and_deep():
    h = np.array([0.3, 0.2, 0.2])
    q = rot([math.pi / 4, 0, 0])          # lowest edge along x at depth 0.2 sqrt 2
    zc = 0.2 * math.sqrt(2) - 0.01
    P, N, D, F = collide(PLANE, Z3, I, Z3, BOX, [0, 0, zc], q, h)
    assert len(D) == 2 and np.allclose(D, 0.01, atol=TOL)
    assert same_rows(P, [[-0.3, 0, -0.005], [0.3, 0, -0.005]], TOL)
    # a corner: rotate so that the vertex (-hx, -hy, -hz) points straight down
    qc = Rotation.align_vectors([[0, 0, -1]], [-h])[0].as_quat()
    corner = np.linalg.norm(h)
    P, N, D, F = collide(PLANE, Z3, I, Z3, BOX, [0, 0, corner - 0.02], qc, h)
    assert len(D) == 1 and np.isclose(D[0], 0.02, atol=TOL) and F[0] == 0
    # deep: the 4 deepest of the 8 vertices are the bottom ones
    P, N, D, F = collide(PLANE, Z3, I, Z3, BOX, [0, 0, -0.05], I, [0.1, 0.1, 0.1])
    assert len(D) == 4 and np.allclose(D, 0.15, atol=TOL) and sorted(F) == [0, 1, 2, 3]


def test_plane_cylinder_standing_lying_tilted():
    r, h = 0.3, 0.5
    P, N, D, F = collide(PLANE, Z3, I, Z3, CYLINDER, [0.2, 0.1, h - 0.01], I, [r, h, 0])
    assert len(D) == 4 and np.allclose(D, 0.01, atol=TOL)
    rel = P - [0.2, 0.1, 0]
    assert np.allclose(np.hypot(rel[:, 0], rel[:, 1]), r, atol=TOL)
    assert np.allclose(P[:, 2], -0.005, atol=TOL)
    dists = sorted(np.linalg.norm(rel[i] - rel[j]) for i in range(4) for j in range(i + 1, 4))
    assert np.allclose(dists, [r * math.sqrt(2)] * 4 + [2 * r] * 2, atol=TOL)   # a square
    # lying along y
    q = rot([math.pi / 2, 0, 0])
    P, N, D, F = collide(PLANE, Z3, I, Z3, CYLINDER, [0, 0, r - 0.01], q, [r, h, 0])
    assert len(D) == 2 and np.allclose(D, 0.01, atol=TOL)
    assert same_rows(P, [[0, -h, -0.005], [0, h, -0.005]], TOL)
    # tilted by th about x: the deepest rim point alone
    th = 0.5
    q = rot([th, 0, 0])
    zc = r * math.sin(th) + h * math.cos(th) - 0.02
    P, N, D, F = collide(PLANE, Z3, I, Z3, CYLINDER, [0, 0, zc], q, [r, h, 0])
    assert len(D) == 1 and np.isclose(D[0], 0.02, atol=TOL)


def test_plane_plane_never():
    P, N, D, F = collide(PLANE, Z3, I, Z3, PLANE, [0, 0, -1], rot([0.1, 0, 0]), Z3)
    assert len(D) == 0


# ------------------------------------------------------------------- round primitives

def test_sphere_sphere():
    u = np.array([1.0, 2.0, -2.0]) / 3.0
    c1 = np.array([0.1, 0.2, 0.3])
    P, N, D, F = collide(SPHERE, c1, I, [0.5, 0, 0], SPHERE, c1 + 0.8 * u, I, [0.3, 0, 0])
    assert abs(D[0]) < TOL and np.allclose(N[0], u, atol=TOL) and np.allclose(P[0], c1 + 0.5 * u)
    P, N, D, F = collide(SPHERE, c1, I, [0.5, 0, 0], SPHERE, c1 + 0.7 * u, I, [0.3, 0, 0])
    assert np.isclose(D[0], 0.1, atol=TOL) and np.allclose(P[0], c1 + 0.45 * u, atol=TOL)
    # deep: coincident centres still give a unit normal
    P, N, D, F = collide(SPHERE, c1, I, [0.5, 0, 0], SPHERE, c1, I, [0.3, 0, 0])
    assert np.isclose(D[0], 0.8, atol=TOL)


def test_sphere_capsule_side_and_cap():
    q = rot([0.0, 0.0, 0.0])
    P, N, D, F = collide(SPHERE, [0.45, 0, 0.7], I, [0.3, 0, 0], CAPSULE, Z3, q, [0.2, 1.0, 0])
    assert np.isclose(D[0], 0.05, atol=TOL) and np.allclose(N[0], -EX, atol=TOL)
    assert np.allclose(P[0], [0.175, 0, 0.7], atol=TOL)
    P, N, D, F = collide(SPHERE, [0, 0, 1.45], I, [0.3, 0, 0], CAPSULE, Z3, q, [0.2, 1.0, 0])
    assert np.isclose(D[0], 0.05, atol=TOL) and np.allclose(N[0], -EZ, atol=TOL)


def test_capsule_capsule_crossed_parallel_and_end_to_end():
    qx = rot([0, math.pi / 2, 0])          # along x
    qy = rot([-math.pi / 2, 0, 0])         # along y
    P, N, D, F = collide(CAPSULE, Z3, qx, [0.2, 1, 0], CAPSULE, [0, 0, 0.35], qy, [0.2, 1, 0])
    assert len(D) == 1 and np.isclose(D[0], 0.05, atol=TOL) and np.allclose(N[0], EZ, atol=TOL)
    assert np.allclose(P[0], [0, 0, 0.175], atol=TOL)
    # parallel, overlapping on x in [-0.5, 1]: two points
    P, N, D, F = collide(CAPSULE, Z3, qx, [0.2, 1, 0], CAPSULE, [0.5, 0, 0.35], qx, [0.2, 1, 0])
    assert len(D) == 2 and np.allclose(D, 0.05, atol=TOL) and np.allclose(N, EZ, atol=TOL)
    assert same_rows(P, [[-0.5, 0, 0.175], [1.0, 0, 0.175]], TOL)
    assert sorted(F) == [1, 2]
    # end to end along x, touching
    P, N, D, F = collide(CAPSULE, Z3, qx, [0.2, 1, 0], CAPSULE, [2.4, 0, 0], qx, [0.2, 1, 0])
    assert len(D) == 1 and abs(D[0]) < TOL and np.allclose(N[0], EX, atol=TOL)
    assert np.allclose(P[0], [1.2, 0, 0], atol=TOL)


def _box_frame():
    q = rot([0.2, -0.4, 0.7])
    return np.array([0.3, -0.1, 0.2]), q, rmat(q), np.array([1.0, 0.5, 0.25])


@pytest.mark.parametrize("local, r, depth, nloc", [
    ((1.2, 0.1, 0.0), 0.3, 0.1, (-1, 0, 0)),                                  # face
    ((1.1, 0.6, 0.1), 0.2, 0.2 - math.sqrt(0.02), (-1, -1, 0)),               # edge
    ((1.1, 0.6, 0.35), 0.2, 0.2 - math.sqrt(0.03), (-1, -1, -1)),             # corner
    ((0.9, 0.0, 0.0), 0.1, 0.2, (-1, 0, 0)),                                  # centre inside
])
def test_sphere_box_regions(local, r, depth, nloc):
    pos, q, R, h = _box_frame()
    c = pos + R @ np.array(local)
    P, N, D, F = collide(SPHERE, c, I, [r, 0, 0], BOX, pos, q, h)
    nl = np.array(nloc, float) / np.linalg.norm(nloc)
    assert np.isclose(D[0], depth, atol=TOL) and np.allclose(N[0], R @ nl, atol=TOL)
    # the point: midway between the sphere's deepest point and the box surface
    assert np.allclose(P[0], c + (r - depth / 2) * R @ nl, atol=TOL)


def test_capsule_box_lying_overhanging_edge_standing():
    h = np.array([1.0, 1.0, 0.5])
    qx = rot([0, math.pi / 2, 0])
    P, N, D, F = collide(CAPSULE, [0, 0.3, 0.65], qx, [0.2, 0.5, 0], BOX, Z3, I, h)
    assert len(D) == 2 and np.allclose(D, 0.05, atol=TOL) and np.allclose(N, -EZ, atol=TOL)
    assert same_rows(P, [[-0.5, 0.3, 0.475], [0.5, 0.3, 0.475]], TOL)
    # overhanging the x = +1 edge: clipped at the face boundary
    P, N, D, F = collide(CAPSULE, [0.8, 0.3, 0.65], qx, [0.2, 0.5, 0], BOX, Z3, I, h)
    assert len(D) == 2 and np.allclose(D, 0.05, atol=TOL)
    assert same_rows(P, [[0.3, 0.3, 0.475], [1.0, 0.3, 0.475]], TOL)
    # resting: depth 0
    P, N, D, F = collide(CAPSULE, [0, 0.3, 0.7], qx, [0.2, 0.5, 0], BOX, Z3, I, h)
    assert len(D) == 2 and np.allclose(D, 0.0, atol=TOL)
    # standing on the face: one point
    zc = 0.5 + 0.2 + 0.5 - 0.04
    P, N, D, F = collide(CAPSULE, [0.2, 0.1, zc], I, [0.2, 0.5, 0], BOX, Z3, I, h)
    assert len(D) == 1 and np.isclose(D[0], 0.04, atol=TOL) and np.allclose(N[0], -EZ, atol=TOL)
    assert np.allclose(P[0], [0.2, 0.1, 0.48], atol=TOL)


def test_capsule_box_across_an_edge():
    q = rot([math.pi / 4, 0, 0])            # cube's top edge along x at z = 0.5 sqrt 2
    top = 0.5 * math.sqrt(2)
    qy = rot([-math.pi / 2, 0, 0])         # capsule along y, across the edge
    P, N, D, F = collide(CAPSULE, [0.1, 0, top + 0.2 - 0.03], qy, [0.2, 0.6, 0], BOX, Z3, q,
                         [0.5, 0.5, 0.5])
    assert len(D) == 1 and np.isclose(D[0], 0.03, atol=TOL) and F[0] == 0
    assert np.allclose(N[0], -EZ, atol=1e-6) and np.allclose(P[0], [0.1, 0, top - 0.015], atol=1e-6)


def test_sphere_cylinder_regions():
    q = rot([0.3, 0.2, -0.1])
    R = rmat(q)
    pos = np.array([0.1, 0.2, 0.3])
    r, hh = 0.4, 0.6
    cases = [((0.5, 0.0, 0.1), 0.15, 0.05, (-1, 0, 0)),        # side
             ((0.1, 0.1, 0.7), 0.15, 0.05, (0, 0, -1)),        # cap
             ((0.5, 0.0, 0.7), 0.2, 0.2 - math.sqrt(0.02), (-1, 0, -1)),   # rim
             ((0.0, 0.35, 0.0), 0.1, 0.15, (0, -1, 0))]        # centre inside, near the side
    for local, rs, depth, nloc in cases:
        c = pos + R @ np.array(local)
        P, N, D, F = collide(SPHERE, c, I, [rs, 0, 0], CYLINDER, pos, q, [r, hh, 0])
        nl = np.array(nloc, float) / np.linalg.norm(nloc)
        assert np.isclose(D[0], depth, atol=TOL), local
        assert np.allclose(N[0], R @ nl, atol=TOL), local


# ------------------------------------------------------------------------------ boxes

def test_box_box_face_face_four_points():
    ha = np.array([2.0, 2.0, 0.5])
    hb = np.array([0.5, 0.4, 0.3])
    qb = rot([0, 0, 0.3])
    pb = np.array([0.3, -0.2, 0.5 + 0.3 - 0.02])
    P, N, D, F = collide(BOX, Z3, I, ha, BOX, pb, qb, hb)
    assert len(D) == 4 and np.allclose(D, 0.02, atol=TOL) and np.allclose(N, EZ, atol=TOL)
    R = rmat(qb)
    bottom = [pb + R @ (np.array([sx, sy, -1.0]) * hb) for sx in (-1, 1) for sy in (-1, 1)]
    assert same_rows(P, [[v[0], v[1], 0.49] for v in bottom], TOL)
    # resting (touching): depth 0
    P, N, D, F = collide(BOX, Z3, I, ha, BOX, pb + [0, 0, 0.02], qb, hb)
    assert len(D) == 4 and np.allclose(D, 0.0, atol=TOL)
    # separated by 0.01, within a margin of 0.02
    P, N, D, F = collide(BOX, Z3, I, ha, BOX, pb + [0, 0, 0.03], qb, hb, margin=0.02)
    assert len(D) == 4 and np.allclose(D, -0.01, atol=TOL)
    assert len(collide(BOX, Z3, I, ha, BOX, pb + [0, 0, 0.03], qb, hb, margin=0.005)[2]) == 0


def test_box_box_octagon_overlap():
    h = np.array([0.5, 0.5, 0.5])
    P, N, D, F = collide(BOX, Z3, I, h, BOX, [0, 0, 0.98], rot([0, 0, math.pi / 4]), h)
    assert len(D) == 4 and np.allclose(D, 0.02, atol=TOL) and np.allclose(N, EZ, atol=TOL)
    # the points are octagon vertices: inside both squares, on the boundary of one
    assert np.allclose(P[:, 2], 0.49, atol=TOL)
    xy = P[:, :2]
    rotated = xy @ np.array([[1, 1], [-1, 1]]) / math.sqrt(2)
    assert np.all(np.abs(xy) <= 0.5 + TOL) and np.all(np.abs(rotated) <= 0.5 + TOL)
    on_edge = np.isclose(np.abs(xy).max(axis=1), 0.5) | np.isclose(np.abs(rotated).max(axis=1), 0.5)
    assert np.all(on_edge)
    # they span a large area (not clustered)
    assert np.ptp(xy[:, 0]) > 0.5 and np.ptp(xy[:, 1]) > 0.5


def test_box_box_tilted_edge_on_face():
    h = np.array([0.5, 0.5, 0.5])
    th = 0.2
    q = rot([th, 0, 0])
    low = 0.5 * (math.cos(th) + math.sin(th))       # depth of the lowest edge below the centre
    P, N, D, F = collide(BOX, Z3, I, [2, 2, 0.5], BOX, [0, 0, 0.5 + low - 0.01], q, h)
    assert len(D) == 2 and np.allclose(D, 0.01, atol=TOL) and np.allclose(N, EZ, atol=TOL)
    assert np.allclose(sorted(P[:, 0]), [-0.5, 0.5], atol=TOL)


def test_box_box_edge_edge_crossed():
    qa = rot([math.pi / 4, 0, 0])          # A's top edge along x
    qb = rot([0, math.pi / 4, 0])          # B's bottom edge along y
    h = np.array([0.5, 0.5, 0.5])
    s2 = math.sqrt(2)
    P, N, D, F = collide(BOX, Z3, qa, h, BOX, [0, 0, s2 - 0.1], qb, h)
    assert len(D) == 1 and np.isclose(D[0], 0.1, atol=TOL) and np.allclose(N[0], EZ, atol=TOL)
    assert np.allclose(P[0], [0, 0, 0.5 * s2 - 0.05], atol=TOL)
    assert F[0] >= 2000
    # touching crossed edges: depth 0
    P, N, D, F = collide(BOX, Z3, qa, h, BOX, [0.05, -0.1, s2], qb, h)
    assert len(D) == 1 and abs(D[0]) < TOL and np.allclose(P[0], [0.05, 0, 0.5 * s2], atol=TOL)


def test_box_box_deep():
    P, N, D, F = collide(BOX, Z3, I, [1, 1, 1], BOX, [0.1, 0, 0.9], I, [0.2, 0.2, 0.2])
    assert len(D) == 4 and np.allclose(D, 0.3, atol=TOL) and np.allclose(N, EZ, atol=TOL)


def test_box_box_rotated_pair():
    """A rotated stack: same depths and transformed points."""
    T = rot([0.4, -1.1, 0.3])
    R = rmat(T)
    t = np.array([1.0, -2.0, 0.5])
    ha = np.array([2.0, 2.0, 0.5])
    hb = np.array([0.5, 0.4, 0.3])
    qb = rot([0, 0, 0.3])
    pb = np.array([0.3, -0.2, 0.78])
    P0, N0, D0, F0 = collide(BOX, Z3, I, ha, BOX, pb, qb, hb)
    qa2 = T
    qb2 = (Rotation.from_quat(T) * Rotation.from_quat(qb)).as_quat()
    P, N, D, F = collide(BOX, t, qa2, ha, BOX, t + R @ pb, qb2, hb)
    assert len(D) == len(D0) == 4
    o, o0 = np.argsort(F), np.argsort(F0)          # match the contacts by feature id
    assert np.array_equal(F[o], F0[o0])
    assert np.allclose(D[o], D0[o0], atol=TOL) and np.allclose(N[o], N0[o0] @ R.T, atol=TOL)
    assert np.allclose(P[o], P0[o0] @ R.T + t, atol=TOL)


# -------------------------------------------------------------------- cylinder pairs

def test_box_cylinder_standing_lying_and_box_on_cap():
    hb = np.array([1.0, 1.0, 0.5])
    r, h = 0.3, 0.4
    P, N, D, F = collide(BOX, Z3, I, hb, CYLINDER, [0.2, 0.1, 0.5 + h - 0.01], I, [r, h, 0])
    assert len(D) == 4 and np.allclose(D, 0.01, atol=TOL_GJK) and np.allclose(N, EZ, atol=TOL_GJK)
    assert np.allclose(np.hypot(P[:, 0] - 0.2, P[:, 1] - 0.1), r, atol=TOL_GJK)
    assert np.allclose(P[:, 2], 0.495, atol=TOL_GJK)
    # touching
    P, N, D, F = collide(BOX, Z3, I, hb, CYLINDER, [0.2, 0.1, 0.5 + h], I, [r, h, 0])
    assert len(D) == 4 and np.allclose(D, 0.0, atol=TOL_GJK)
    # lying along y
    q = rot([math.pi / 2, 0, 0])
    P, N, D, F = collide(BOX, Z3, I, hb, CYLINDER, [0, 0, 0.5 + r - 0.01], q, [r, h, 0])
    assert len(D) == 2 and np.allclose(D, 0.01, atol=TOL_GJK)
    assert same_rows(P, [[0, -h, 0.495], [0, h, 0.495]], TOL_GJK)
    # a small box on a big cylinder's cap: the cap is the reference face
    P, N, D, F = collide(BOX, [0.1, 0.2, 0.5 + 0.1 - 0.01], rot([0, 0, 0.5]), [0.1, 0.1, 0.1],
                         CYLINDER, Z3, I, [1.0, 0.5, 0])
    assert len(D) == 4 and np.allclose(D, 0.01, atol=TOL_GJK) and np.allclose(N, -EZ, atol=TOL_GJK)


def test_cylinder_cylinder_stacked_crossed_side_by_side():
    P, N, D, F = collide(CYLINDER, Z3, I, [0.5, 0.2, 0], CYLINDER, [0.05, 0, 0.39], I,
                         [0.3, 0.2, 0])
    assert len(D) == 4 and np.allclose(D, 0.01, atol=TOL_GJK) and np.allclose(N, EZ, atol=TOL_GJK)
    assert np.allclose(np.hypot(P[:, 0] - 0.05, P[:, 1]), 0.3, atol=TOL_GJK)
    qx = rot([0, math.pi / 2, 0])
    qy = rot([math.pi / 2, 0, 0])
    P, N, D, F = collide(CYLINDER, Z3, qx, [0.3, 1, 0], CYLINDER, [0.1, 0.2, 0.48], qy,
                         [0.2, 1, 0])
    assert len(D) == 1 and np.isclose(D[0], 0.02, atol=TOL_GJK)
    assert np.allclose(N[0], EZ, atol=TOL_GJK)
    assert np.allclose(P[0], [0.1, 0.0, 0.29], atol=TOL_PT)
    P, N, D, F = collide(CYLINDER, Z3, I, [0.3, 0.5, 0], CYLINDER, [0.49, 0, 0.1], I, [0.2, 0.5, 0])
    assert len(D) == 1 and np.isclose(D[0], 0.01, atol=TOL_GJK)
    assert np.allclose(N[0], EX, atol=TOL_PT)


def test_capsule_cylinder_lying_on_cap_and_beside():
    qx = rot([0, math.pi / 2, 0])
    P, N, D, F = collide(CAPSULE, [0.1, 0, 0.5 + 0.1 - 0.01], qx, [0.1, 0.3, 0], CYLINDER, Z3, I,
                         [1.0, 0.5, 0])
    assert len(D) == 2 and np.allclose(D, 0.01, atol=TOL_GJK) and np.allclose(N, -EZ, atol=TOL_GJK)
    assert same_rows(P, [[-0.2, 0, 0.495], [0.4, 0, 0.495]], TOL_GJK)
    P, N, D, F = collide(CAPSULE, [0.39, 0, 0.1], I, [0.1, 0.2, 0], CYLINDER, Z3, I, [0.3, 0.5, 0])
    assert len(D) == 1 and np.isclose(D[0], 0.01, atol=TOL_GJK)
    assert np.allclose(N[0], -EX, atol=TOL_GJK)
    # deep: the capsule axis inside the cylinder (MPR)
    P, N, D, F = collide(CAPSULE, [0.25, 0, 0.0], I, [0.1, 0.2, 0], CYLINDER, Z3, I, [0.3, 0.5, 0])
    assert len(D) == 1 and np.isclose(D[0], 0.15, atol=TOL_GJK)
    assert np.allclose(N[0], -EX, atol=1e-6)


# ------------------------------------------------------------------- direct routines

ROUTINES = [
    (collide_plane_sphere, PLANE, SPHERE), (collide_plane_capsule, PLANE, CAPSULE),
    (collide_plane_box, PLANE, BOX), (collide_plane_cylinder, PLANE, CYLINDER),
    (collide_plane_plane, PLANE, PLANE), (collide_sphere_sphere, SPHERE, SPHERE),
    (collide_sphere_capsule, SPHERE, CAPSULE), (collide_sphere_box, SPHERE, BOX),
    (collide_sphere_cylinder, SPHERE, CYLINDER), (collide_capsule_capsule, CAPSULE, CAPSULE),
    (collide_capsule_box, CAPSULE, BOX), (collide_capsule_cylinder, CAPSULE, CYLINDER),
    (collide_box_box, BOX, BOX), (collide_box_cylinder, BOX, CYLINDER),
    (collide_cylinder_cylinder, CYLINDER, CYLINDER),
]
SIZES = {PLANE: [0, 0, 0], SPHERE: [0.3, 0, 0], CAPSULE: [0.2, 0.3, 0], BOX: [0.3, 0.2, 0.25],
         CYLINDER: [0.3, 0.25, 0]}


@pytest.mark.parametrize("fn, ta, tb", ROUTINES)
def test_direct_routine_matches_dispatch(fn, ta, tb):
    qa = rot([0.1, 0.2, 0.3]) if ta != PLANE else I
    qb = rot([-0.3, 0.5, 0.2])
    pa = np.array([0.0, 0.0, 0.0])
    pb = np.array([0.1, -0.05, 0.25])
    sa = np.array(SIZES[ta], float)
    sb = np.array(SIZES[tb], float)
    P = np.zeros((4, 3))
    N = np.zeros((4, 3))
    D = np.zeros(4)
    F = np.zeros(4, np.int64)
    n = fn(pa, qa, sa, pb, qb, sb, 0.01, P, N, D, F, 0)
    P2, N2, D2, F2 = collide(ta, pa, qa, sa, tb, pb, qb, sb, margin=0.01)
    assert n == len(D2)
    assert np.allclose(P[:n], P2) and np.allclose(N[:n], N2) and np.allclose(D[:n], D2)
    assert np.array_equal(F[:n], F2)
    if ta != PLANE or tb != PLANE:
        assert n >= 1


@pytest.mark.parametrize("fn, ta, tb", [r for r in ROUTINES if r[1] != r[2]])
def test_swap_flips_normal(fn, ta, tb):
    qa = rot([0.1, 0.2, 0.3]) if ta != PLANE else rot([0.2, 0.1, 0])
    qb = rot([-0.3, 0.5, 0.2])
    pa, pb = np.zeros(3), np.array([0.1, -0.05, 0.25])
    sa, sb = np.array(SIZES[ta], float), np.array(SIZES[tb], float)
    P, N, D, F = collide(ta, pa, qa, sa, tb, pb, qb, sb, margin=0.01)
    P2, N2, D2, F2 = collide(tb, pb, qb, sb, ta, pa, qa, sa, margin=0.01)
    assert len(D) >= 1
    assert np.allclose(P, P2) and np.allclose(N, -N2) and np.allclose(D, D2)
    assert np.array_equal(F, F2)


@pytest.mark.parametrize("t, sa, sb", [
    (CAPSULE, [0.2, 0.3, 0], [0.15, 0.5, 0]),
    (BOX, [0.3, 0.2, 0.25], [0.2, 0.35, 0.1]),
    (CYLINDER, [0.3, 0.25, 0], [0.2, 0.3, 0]),
    (SPHERE, [0.3, 0, 0], [0.2, 0, 0]),
])
@pytest.mark.parametrize("pb, qb", [
    ([0.1, -0.05, 0.35], [-0.3, 0.5, 0.2]),
    ([0.3, 0.0, 0.34], [0.0, 0.0, 0.4]),       # resting-like: parallel faces/axes
    ([0.3, 0.2, 0.1], [1.2, 0.1, -0.4]),
])
def test_swap_same_type(t, sa, sb, pb, qb):
    qa = rot([0.1, 0.2, 0.3]) if pb[2] != 0.34 else I
    pa = np.zeros(3)
    P, N, D, F = collide(t, pa, qa, sa, t, pb, rot(qb), sb, margin=0.05)
    P2, N2, D2, F2 = collide(t, pb, rot(qb), sb, t, pa, qa, sa, margin=0.05)
    assert len(D) >= 1
    A = np.hstack([P, N, D[:, None]])
    B = np.hstack([P2, -N2, D2[:, None]])
    assert same_rows(A, B, 1e-3 if t == CYLINDER else 1e-7)   # cylinders: GJK/MPR


def test_features_persist_under_small_motion():
    h = np.array([0.5, 0.4, 0.3])
    qb = rot([0, 0, 0.3])
    pb = np.array([0.3, -0.2, 0.78])
    cases = [(PLANE, Z3, I, Z3, BOX, pb - [0, 0, 0.49], qb, h),
             (BOX, Z3, I, [2, 2, 0.5], BOX, pb, qb, h),
             (BOX, Z3, I, [2, 2, 0.5], CYLINDER, [0.1, 0, 0.73], qb, [0.3, 0.25, 0]),
             (PLANE, Z3, I, Z3, CYLINDER, [0.1, 0, 0.23], qb, [0.3, 0.25, 0])]
    for ta, pa, qa, sa, tb, p, q, s in cases:
        F0 = collide(ta, pa, qa, sa, tb, p, q, s)[3]
        dq = (Rotation.from_rotvec([0.002, -0.001, 0.01]) * Rotation.from_quat(q)).as_quat()
        F1 = collide(ta, pa, qa, sa, tb, np.asarray(p) + [0.003, -0.002, 0.001], dq, s)[3]
        assert len(F0) >= 2 and sorted(F0) == sorted(F1), (ta, tb)


@pytest.mark.parametrize("ta, pa, qa, sa, tb, pb, qb, sb, count", [
    (BOX, Z3, I, [1, 1, 0.5], CYLINDER, [0.2, 0.1, 0.9], I, [0.3, 0.4, 0], 4),        # standing
    (BOX, Z3, I, [1, 1, 0.5], CYLINDER, [0, 0, 0.8], [math.sin(math.pi / 4), 0, 0,
                                                       math.cos(math.pi / 4)], [0.3, 0.4, 0], 2),
    (CYLINDER, Z3, I, [0.5, 0.2, 0], CYLINDER, [0.05, 0, 0.4], I, [0.3, 0.2, 0], 4),  # stacked
    (CYLINDER, Z3, I, [0.3, 0.5, 0], CYLINDER, [0.5, 0, 0.1], I, [0.2, 0.5, 0], 1),   # side
    (CAPSULE, [0.1, 0, 0.6], [0, math.sin(math.pi / 4), 0, math.cos(math.pi / 4)],
     [0.1, 0.3, 0], CYLINDER, Z3, I, [1, 0.5, 0], 2),                                  # on cap
])
def test_cylinder_pairs_touching(ta, pa, qa, sa, tb, pb, qb, sb, count):
    """Exactly touching cylinder pairs (GJK/MPR path) report depth 0."""
    P, N, D, F = collide(ta, pa, qa, sa, tb, pb, qb, sb)
    assert len(D) == count and np.allclose(D, 0.0, atol=TOL)
