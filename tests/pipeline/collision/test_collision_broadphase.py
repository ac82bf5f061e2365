"""Bounding boxes and the sort-and-sweep broad phase (exact set comparison)."""
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tumble.pipeline.collision import (BOX, CAPSULE, CYLINDER, PLANE, SPHERE, broadphase_pairs,
                                       find_pairs, geom_aabb, geom_aabbs, support, sweep_axis)

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


def brute_force(lo, hi, body=None):
    out = set()
    for i, j in itertools.combinations(range(len(lo)), 2):
        if np.all(lo[i] <= hi[j]) and np.all(lo[j] <= hi[i]):
            if body is None or body[i] != body[j]:
                out.add((i, j))
    return out


@pytest.mark.parametrize("gtype, size", [(SPHERE, [0.3, 0, 0]), (CAPSULE, [0.2, 0.5, 0]),
                                         (BOX, [0.3, 0.1, 0.6]), (CYLINDER, [0.25, 0.4, 0])])
@settings(max_examples=20, deadline=None)
@given(seed=SEEDS)
def test_aabb_is_tight_bound_of_support(gtype, size, seed):
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-2, 2, 3)
    q = Rotation.random(random_state=rng).as_quat()
    size = np.array(size, float)
    margin = 0.01
    lo, hi = geom_aabb(gtype, pos, q, size, margin)
    lo, hi = np.array(lo), np.array(hi)
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1.0
        top = np.array(support(gtype, tuple(pos), tuple(q), tuple(size), tuple(e)))
        bot = np.array(support(gtype, tuple(pos), tuple(q), tuple(size), tuple(-e)))
        assert abs(hi[k] - margin - top[k]) < 1e-12 and abs(lo[k] + margin - bot[k]) < 1e-12
    for _ in range(20):
        d = rng.normal(size=3)
        p = np.array(support(gtype, tuple(pos), tuple(q), tuple(size), tuple(d)))
        assert np.all(p >= lo) and np.all(p <= hi)


def test_plane_aabb_is_infinite_and_batch():
    lo, hi = geom_aabb(PLANE, np.zeros(3), np.array([0, 0, 0, 1.0]), np.zeros(3), 0.1)
    assert np.all(np.isneginf(lo)) and np.all(np.isposinf(hi))
    types = np.array([PLANE, SPHERE, BOX], dtype=np.int64)
    pos = np.array([[0, 0, 0], [1, 2, 3], [0, 0, 1.0]])
    quat = np.tile([0, 0, 0, 1.0], (3, 1))
    size = np.array([[0, 0, 0], [0.5, 0, 0], [1, 2, 3.0]])
    out_lo = np.zeros((3, 3))
    out_hi = np.zeros((3, 3))
    geom_aabbs(types, pos, quat, size, np.full(3, 0.1), out_lo, out_hi)
    assert np.allclose(out_lo[1], [0.4, 1.4, 2.4]) and np.allclose(out_hi[2], [1.1, 2.1, 4.1])
    assert np.all(np.isinf(out_lo[0]))


def random_scene(rng, n, nplanes):
    c = rng.uniform(-3, 3, (n, 3)) * rng.uniform(0.2, 1.0, 3)   # anisotropic scenes
    half = rng.uniform(0.05, 0.8, (n, 3))
    lo, hi = c - half, c + half
    for i in rng.choice(n, size=nplanes, replace=False):
        lo[i], hi[i] = -np.inf, np.inf
    return lo, hi


@settings(max_examples=50, deadline=None)
@given(seed=SEEDS, n=st.integers(0, 40), nplanes=st.integers(0, 3))
def test_broadphase_equals_brute_force(seed, n, nplanes):
    rng = np.random.default_rng(seed)
    nplanes = min(nplanes, n)
    lo, hi = random_scene(rng, n, nplanes)
    expect = brute_force(lo, hi)
    out = np.full((max(1, len(expect)), 2), -1, dtype=np.int64)
    cnt = broadphase_pairs(lo, hi, out)
    assert cnt == len(expect)
    got = [tuple(r) for r in out[:cnt]]
    assert set(got) == expect and len(got) == len(set(got))
    assert got == sorted(got)                            # lexicographic order
    assert all(i < j for i, j in got)
    # planes pair with everything
    for p in np.flatnonzero(np.isinf(lo[:, 0])):
        assert all((min(p, j), max(p, j)) in expect for j in range(n) if j != p)


@settings(max_examples=50, deadline=None)
@given(seed=SEEDS, n=st.integers(2, 30))
def test_broadphase_body_filter(seed, n):
    rng = np.random.default_rng(seed)
    lo, hi = random_scene(rng, n, min(2, n))
    body = rng.integers(-1, 4, n)
    body[np.isinf(lo[:, 0])] = -1                        # planes belong to the world
    expect = brute_force(lo, hi, body)
    pairs = find_pairs(lo, hi, body)
    assert {tuple(r) for r in pairs} == expect and len(pairs) == len(expect)
    assert all(body[i] != body[j] for i, j in pairs)


def test_broadphase_overflow_and_touching():
    lo = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]])
    hi = np.array([[1, 1, 1], [2, 1, 1], [3, 1, 1.0]])  # touching faces count as overlap
    out = np.zeros((1, 2), dtype=np.int64)
    assert broadphase_pairs(lo, hi, out) == 2          # the total, one row written
    assert [tuple(r) for r in find_pairs(lo, hi)] == [(0, 1), (1, 2)]
    assert find_pairs(lo[:1], hi[:1]).shape == (0, 2)


def test_sweep_axis_is_largest_variance():
    rng = np.random.default_rng(3)
    c = rng.normal(size=(50, 3)) * [0.1, 5.0, 1.0]
    assert sweep_axis(c - 0.1, c + 0.1) == 1
    lo = np.vstack([c - 0.1, [[-np.inf] * 3]])
    hi = np.vstack([c + 0.1, [[np.inf] * 3]])
    assert sweep_axis(lo, hi) == 1                      # unbounded boxes ignored
