"""Ray casts and signed distances against analytic answers.

Tolerances: 1e-9 for closed forms and GJK on polytopes, 1e-6 for GJK between curved
shapes.
"""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tumble.pipeline.collision import (BOX, CAPSULE, CYLINDER, PLANE, SPHERE, collide_pair,
                                       geom_distance, raycast_geom)

I = np.array([0.0, 0.0, 0.0, 1.0])
Z3 = np.zeros(3)
SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


def rot(rv):
    return Rotation.from_rotvec(np.asarray(rv, float)).as_quat()


def ray(t, pos, q, size, o, d, max_dist=100.0):
    d = np.asarray(d, float)
    d = d / np.linalg.norm(d)
    dist, n = raycast_geom(t, np.asarray(pos, float), np.asarray(q, float), np.asarray(size, float),
                           np.asarray(o, float), d, max_dist)
    return dist, np.array(n)


def sdf(t, pos, q, size, x):
    R = Rotation.from_quat(q).as_matrix()
    p = R.T @ (np.asarray(x) - pos)
    if t == PLANE:
        return p[2]
    if t == SPHERE:
        return np.linalg.norm(p) - size[0]
    if t == CAPSULE:
        return np.linalg.norm(p - [0, 0, np.clip(p[2], -size[1], size[1])]) - size[0]
    if t == BOX:
        d = np.abs(p) - size
        return np.linalg.norm(np.maximum(d, 0)) + min(d.max(), 0.0)
    d = np.array([np.hypot(p[0], p[1]) - size[0], abs(p[2]) - size[1]])
    return np.linalg.norm(np.maximum(d, 0)) + min(d.max(), 0.0)


# ----------------------------------------------------------------------------- rays

def test_ray_plane():
    q = rot([0.3, 0, 0])
    n = Rotation.from_quat(q).as_matrix()[:, 2]
    d, nn = ray(PLANE, [0, 0, 1], q, Z3, [0, 0, 1] + 2 * n, -n)
    assert abs(d - 2) < 1e-12 and np.allclose(nn, n)
    assert ray(PLANE, Z3, I, Z3, [0, 0, 1], [0, 0, 1])[0] == -1.0           # away
    assert ray(PLANE, Z3, I, Z3, [0, 0, 1], [1, 0, 0])[0] == -1.0           # parallel
    d, nn = ray(PLANE, Z3, I, Z3, [0, 0, -1], [1, 0, 0])                    # inside
    assert d == 0.0 and np.allclose(nn, [-1, 0, 0])


def test_ray_sphere():
    d, n = ray(SPHERE, [1, 2, 3], I, [0.5, 0, 0], [1, 2, 0], [0, 0, 1])
    assert abs(d - 2.5) < 1e-12 and np.allclose(n, [0, 0, -1])
    # oblique: grazing offset 0.3 -> entry at sqrt(r^2 - 0.3^2) before the centre plane
    d, n = ray(SPHERE, Z3, I, [0.5, 0, 0], [-3, 0.3, 0], [1, 0, 0])
    assert abs(d - (3 - 0.4)) < 1e-12 and np.allclose(n, [-0.8, 0.6, 0])
    assert ray(SPHERE, Z3, I, [0.5, 0, 0], [-3, 0.6, 0], [1, 0, 0])[0] == -1.0
    assert ray(SPHERE, Z3, I, [0.5, 0, 0], [3, 0, 0], [1, 0, 0])[0] == -1.0   # behind
    assert ray(SPHERE, Z3, I, [0.5, 0, 0], [-3, 0, 0], [1, 0, 0], max_dist=2.0)[0] == -1.0
    assert ray(SPHERE, Z3, I, [0.5, 0, 0], [0.1, 0, 0], [1, 0, 0])[0] == 0.0  # inside


def test_ray_box():
    q = rot([0, 0, math.pi / 4])
    s2 = math.sqrt(2)
    # a rotated unit cube seen along x hits the vertical edge at x = -s2/2
    d, n = ray(BOX, Z3, q, [0.5, 0.5, 0.5], [-3, 0, 0.1], [1, 0, 0])
    assert abs(d - (3 - s2 / 2)) < 1e-12
    assert abs(np.linalg.norm(n) - 1) < 1e-12 and n[0] < 0
    h = [1.0, 0.5, 0.25]
    for k in range(3):
        for s in (-1, 1):
            o = np.zeros(3)
            o[k] = 5 * s
            o[(k + 1) % 3] = 0.1 * h[(k + 1) % 3]
            e = np.zeros(3)
            e[k] = s
            dist, n = ray(BOX, [1, 1, 1], I, h, o + 1, -e)
            assert abs(dist - (5 - h[k])) < 1e-12
            assert np.allclose(n, e)
    assert ray(BOX, Z3, I, h, [0, 2, 0], [1, 0, 0])[0] == -1.0
    assert ray(BOX, Z3, I, h, [0.5, 0, 0], [1, 0, 0])[0] == 0.0


def test_ray_capsule_and_cylinder():
    qx = rot([0, math.pi / 2, 0])            # axis along x
    r, hl = 0.2, 0.5
    d, n = ray(CAPSULE, Z3, qx, [r, hl, 0], [0.3, 0, 2], [0, 0, -1])        # side
    assert abs(d - (2 - r)) < 1e-12 and np.allclose(n, [0, 0, 1])
    d, n = ray(CAPSULE, Z3, qx, [r, hl, 0], [3, 0, 0], [-1, 0, 0])          # end cap
    assert abs(d - (3 - hl - r)) < 1e-12 and np.allclose(n, [1, 0, 0])
    d, n = ray(CAPSULE, Z3, qx, [r, hl, 0], [0.6, 0, 2], [0, 0, -1])        # over the cap
    assert abs(d - (2 - math.sqrt(r * r - 0.01))) < 1e-12
    assert np.allclose(n, [0.1 / r, 0, math.sqrt(r * r - 0.01) / r])
    d, n = ray(CYLINDER, Z3, qx, [r, hl, 0], [3, 0.1, 0], [-1, 0, 0])       # flat cap
    assert abs(d - (3 - hl)) < 1e-12 and np.allclose(n, [1, 0, 0])
    d, n = ray(CYLINDER, Z3, qx, [r, hl, 0], [0.3, 0, 2], [0, 0, -1])       # side
    assert abs(d - (2 - r)) < 1e-12 and np.allclose(n, [0, 0, 1])
    assert ray(CYLINDER, Z3, qx, [r, hl, 0], [0.6, 0, 2], [0, 0, -1])[0] == -1.0
    assert ray(CYLINDER, Z3, qx, [r, hl, 0], [0, 0, 0], [0, 0, 1])[0] == 0.0


@pytest.mark.parametrize("gtype, size", [(SPHERE, [0.4, 0, 0]), (CAPSULE, [0.2, 0.5, 0]),
                                         (BOX, [0.3, 0.2, 0.5]), (CYLINDER, [0.3, 0.4, 0]),
                                         (PLANE, [0, 0, 0])])
@settings(max_examples=40, deadline=None)
@given(seed=SEEDS)
def test_ray_against_sampled_signed_distance(gtype, size, seed):
    """A hit lies on the surface and the ray is outside before it; a miss never
    passes clearly inside the shape."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-0.3, 0.3, 3)
    q = Rotation.random(random_state=rng).as_quat()
    size = np.array(size, float)
    o = rng.normal(size=3)
    o = 2.0 * o / np.linalg.norm(o)
    d = pos - o + rng.uniform(-0.6, 0.6, 3)             # aim near the shape
    d /= np.linalg.norm(d)
    if sdf(gtype, pos, q, size, o) < 0:
        assert ray(gtype, pos, q, size, o, d)[0] == 0.0
        return
    dist, n = ray(gtype, pos, q, size, o, d, 5.0)
    ts = np.linspace(0, 5.0, 2001)
    inside = [sdf(gtype, pos, q, size, o + t * d) for t in ts]
    if dist < 0:
        assert min(inside) > -1e-6
        return
    hit = o + dist * d
    assert abs(sdf(gtype, pos, q, size, hit)) < 1e-9
    assert all(v > -1e-9 for t, v in zip(ts, inside) if t < dist)
    assert abs(np.linalg.norm(n) - 1) < 1e-9 and n @ d <= 1e-9
    # the normal is the outward surface normal: stepping along it leaves the shape
    assert sdf(gtype, pos, q, size, hit + 1e-4 * n) > 0.5e-4


# ------------------------------------------------------------------------ distances

def dist(ta, pa, qa, sa, tb, pb, qb, sb):
    f = lambda x: np.asarray(x, float)  # noqa: E731
    d, xa, xb = geom_distance(ta, f(pa), f(qa), f(sa), tb, f(pb), f(qb), f(sb))
    return d, np.array(xa), np.array(xb)


def test_distance_sphere_sphere():
    u = np.array([2.0, -1.0, 2.0]) / 3
    d, xa, xb = dist(SPHERE, Z3, I, [0.5, 0, 0], SPHERE, 3 * u, I, [0.7, 0, 0])
    assert abs(d - 1.8) < 1e-12 and np.allclose(xa, 0.5 * u) and np.allclose(xb, 2.3 * u)
    d, xa, xb = dist(SPHERE, Z3, I, [0.5, 0, 0], SPHERE, u, I, [0.7, 0, 0])
    assert abs(d + 0.2) < 1e-12                          # penetration 0.2


@pytest.mark.parametrize("qb", [[0, 0, 0], [0.7, 0, 0], [1.3, 0, 0]])
def test_distance_boxes_apart_along_x(qb):
    """Rotating B about the x axis (the separation axis) keeps its x extent only if it
    stays inside its bounding slab: the gap stays 1.5 - 0.5 = 1.0 for a yz-square."""
    d, xa, xb = dist(BOX, Z3, I, [0.5, 0.5, 0.5], BOX, [2.5, 0.2, 0], rot(qb), [0.5, 0.3, 0.3])
    assert abs(d - 1.5) < 1e-9
    assert abs(xa[0] - 0.5) < 1e-9 and abs(xb[0] - 2.0) < 1e-9
    assert abs(np.linalg.norm(xb - xa) - d) < 1e-9


def test_distance_box_corner_and_rotated():
    # box B's corner region: nearest points vertex to vertex
    d, xa, xb = dist(BOX, Z3, I, [0.5, 0.5, 0.5], BOX, [1.5, 1.5, 1.5], I, [0.3, 0.3, 0.3])
    assert abs(d - math.sqrt(3) * 0.7) < 1e-9 and np.allclose(xa, 0.5) and np.allclose(xb, 1.2)
    # a cube rotated 45 degrees about z above another: its lower edge is the nearest
    d, xa, xb = dist(BOX, Z3, I, [1, 1, 0.5], BOX, [0, 0, 2], rot([math.pi / 4, 0, 0]), [0.5] * 3)
    assert abs(d - (1.5 - 0.5 * math.sqrt(2))) < 1e-9
    # penetrating: minus the SAT depth
    d, xa, xb = dist(BOX, Z3, I, [1, 1, 0.5], BOX, [0.2, 0, 0.9], I, [0.5, 0.5, 0.5])
    assert abs(d + 0.1) < 1e-9 and abs(xa[2] - 0.5) < 1e-9 and abs(xb[2] - 0.4) < 1e-9


def test_distance_round_and_plane_pairs():
    qx = rot([0, math.pi / 2, 0])
    d, xa, xb = dist(CAPSULE, Z3, qx, [0.2, 1, 0], CAPSULE, [0.3, 0.4, 1], rot([math.pi / 2, 0, 0]),
                     [0.1, 1, 0])
    assert abs(d - 0.7) < 1e-12
    assert np.allclose(xa, [0.3, 0, 0.2]) and np.allclose(xb, [0.3, 0, 0.9])
    d, xa, xb = dist(PLANE, Z3, I, Z3, BOX, [0, 0, 2], rot([math.pi / 4, 0, 0]), [0.5] * 3)
    assert abs(d - (2 - 0.5 * math.sqrt(2))) < 1e-12 and abs(xa[2]) < 1e-12
    d, xa, xb = dist(CYLINDER, [0, 0, 3], rot([0.5, 0, 0]), [0.3, 0.4, 0], PLANE, Z3, I, Z3)
    assert abs(d - (3 - 0.3 * math.sin(0.5) - 0.4 * math.cos(0.5))) < 1e-12
    d, xa, xb = dist(SPHERE, [0.5, 0.0, 0.1], I, [0.2, 0, 0], BOX, Z3, I, [0.25, 0.25, 0.25])
    assert abs(d - 0.05) < 1e-12
    assert np.allclose(xa, [0.3, 0, 0.1]) and np.allclose(xb, [0.25, 0, 0.1])
    d, xa, xb = dist(SPHERE, [0, 0, 1], I, [0.2, 0, 0], CYLINDER, Z3, I, [0.3, 0.5, 0])
    assert abs(d - 0.3) < 1e-12
    d, xa, xb = dist(CAPSULE, [0, 0, 1], qx, [0.1, 0.5, 0], BOX, Z3, I, [1, 1, 0.5])
    assert abs(d - 0.4) < 1e-12
    # anti-parallel planes 2 apart; others always intersect
    assert abs(dist(PLANE, Z3, I, Z3, PLANE, [0, 0, 2], rot([math.pi, 0, 0]), Z3)[0] - 2) < 1e-12
    assert dist(PLANE, Z3, I, Z3, PLANE, [0, 0, 2], I, Z3)[0] == -math.inf


def test_distance_gjk_curved_pairs():
    qx = rot([0, math.pi / 2, 0])
    qy = rot([math.pi / 2, 0, 0])
    # crossed cylinders: side to side
    d, xa, xb = dist(CYLINDER, Z3, qx, [0.3, 1, 0], CYLINDER, [0.1, 0.2, 1.0], qy, [0.2, 1, 0])
    assert abs(d - 0.5) < 1e-6 and np.allclose(xa, [0.1, 0, 0.3], atol=1e-6)
    # box below a standing cylinder, offset sideways
    d, xa, xb = dist(BOX, Z3, I, [1, 1, 0.5], CYLINDER, [0.5, 0.5, 1.5], I, [0.3, 0.4, 0])
    assert abs(d - 0.6) < 1e-9
    # capsule beside a cylinder
    d, xa, xb = dist(CAPSULE, [1, 0, 0.1], I, [0.1, 0.2, 0], CYLINDER, Z3, I, [0.3, 0.5, 0])
    assert abs(d - 0.6) < 1e-9 and np.allclose(xb[:2], [0.3, 0], atol=1e-6)   # parallel: any z


@pytest.mark.parametrize("ta, tb", [(SPHERE, BOX), (BOX, BOX), (CAPSULE, CYLINDER),
                                    (BOX, CYLINDER), (CYLINDER, CYLINDER), (CAPSULE, BOX),
                                    (SPHERE, CAPSULE), (PLANE, CYLINDER)])
@settings(max_examples=30, deadline=None)
@given(seed=SEEDS)
def test_distance_consistent_with_contacts_and_swap(ta, tb, seed):
    rng = np.random.default_rng(seed)
    size = {PLANE: Z3, SPHERE: [0.3, 0, 0], CAPSULE: [0.15, 0.3, 0], BOX: [0.3, 0.2, 0.25],
            CYLINDER: [0.25, 0.3, 0]}
    qa = Rotation.random(random_state=rng).as_quat()
    qb = Rotation.random(random_state=rng).as_quat()
    pb = rng.uniform(-1.2, 1.2, 3)
    d, xa, xb = dist(ta, Z3, qa, size[ta], tb, pb, qb, size[tb])
    d2, xb2, xa2 = dist(tb, pb, qb, size[tb], ta, Z3, qa, size[ta])
    assert abs(d - d2) < 1e-6
    if d > 1e-6:
        # closest points: on the surfaces, |xa - xb| = d
        assert abs(np.linalg.norm(xb - xa) - d) < 1e-7
        assert abs(sdf(ta, Z3, qa, size[ta], xa)) < 1e-7
        assert abs(sdf(tb, pb, qb, size[tb], xb)) < 1e-7
    # a contact exists within a margin iff the distance is below it
    P = np.zeros((4, 3))
    N = np.zeros((4, 3))
    D = np.zeros(4)
    F = np.zeros(4, np.int64)
    f = lambda x: np.asarray(x, float)  # noqa: E731
    for margin in (0.0, 0.1):
        if abs(d - margin) < 1e-6:
            continue
        n = collide_pair(ta, Z3, f(qa), f(size[ta]), tb, f(pb), f(qb), f(size[tb]), margin,
                         P, N, D, F, 0)
        assert (n > 0) == (d < margin), (margin, d)
