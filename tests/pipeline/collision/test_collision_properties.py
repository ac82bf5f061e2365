"""Property tests (hypothesis) of the contact routines against independent answers.

Configurations are drawn from a seeded NumPy generator so that they are in general
position (hypothesis' shrinking towards 0.0 would otherwise produce exactly aligned,
tie-breaking cases). Tolerances: 1e-9 for closed forms, 1e-5 for MPR-based contacts.
"""
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tumble.pipeline.collision import (BOX, CAPSULE, CYLINDER, PLANE, SPHERE, box_box_deepest,
                                       collide_pair, gjk_distance)

TYPES = [PLANE, SPHERE, CAPSULE, BOX, CYLINDER]
PAIRS = [(a, b) for a, b in itertools.product(TYPES, TYPES) if not (a == PLANE and b == PLANE)]
ROUND = {SPHERE, CAPSULE}
SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


def run(ta, pa, qa, sa, tb, pb, qb, sb, margin):
    P = np.zeros((4, 3))
    N = np.zeros((4, 3))
    D = np.zeros(4)
    F = np.zeros(4, np.int64)
    n = collide_pair(ta, pa, qa, sa, tb, pb, qb, sb, float(margin), P, N, D, F, 0)
    assert 0 <= n <= 4
    return P[:n].copy(), N[:n].copy(), D[:n].copy(), F[:n].copy()


# --------------------------------------------------- independent signed distances

def sdf(t, pos, q, size, x):
    R = Rotation.from_quat(q).as_matrix()
    p = R.T @ (np.asarray(x) - pos)
    if t == PLANE:
        return p[2]
    if t == SPHERE:
        return np.linalg.norm(p) - size[0]
    if t == CAPSULE:
        z = np.clip(p[2], -size[1], size[1])
        return np.linalg.norm(p - [0, 0, z]) - size[0]
    if t == BOX:
        d = np.abs(p) - size
        return np.linalg.norm(np.maximum(d, 0)) + min(d.max(), 0.0)
    d = np.array([np.hypot(p[0], p[1]) - size[0], abs(p[2]) - size[1]])
    return np.linalg.norm(np.maximum(d, 0)) + min(d.max(), 0.0)


def extent(t, size):
    if t == BOX:
        return float(np.linalg.norm(size))
    if t == CYLINDER:
        return float(np.hypot(size[0], size[1]))
    return float(size[0] + size[1])


def random_size(rng, t):
    if t == PLANE:
        return np.zeros(3)
    if t == SPHERE:
        return np.array([rng.uniform(0.1, 0.5), 0, 0])
    if t == CAPSULE:
        return np.array([rng.uniform(0.05, 0.3), rng.uniform(0.05, 0.5), 0])
    if t == BOX:
        return rng.uniform(0.05, 0.5, 3)
    return np.array([rng.uniform(0.1, 0.4), rng.uniform(0.05, 0.5), 0])


def random_config(rng, ta, tb):
    """Two geoms that overlap or nearly overlap about half of the time."""
    sa, sb = random_size(rng, ta), random_size(rng, tb)
    qa = Rotation.random(random_state=rng).as_quat()
    qb = Rotation.random(random_state=rng).as_quat()
    pa = rng.uniform(-0.2, 0.2, 3)
    if ta == PLANE:
        n = Rotation.from_quat(qa).as_matrix()[:, 2]
        lateral = rng.uniform(-1, 1, 3)
        lateral -= n * (n @ lateral)
        pb = pa + lateral + n * rng.uniform(-0.8, 1.2) * extent(tb, sb)
    else:
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        # not nearly concentric: very deep overlaps have several equally deep exits
        pb = pa + u * rng.uniform(0.3, 1.1) * (extent(ta, sa) + extent(tb, sb))
    return pa, qa, sa, pb, qb, sb


def is_mpr_pair(ta, tb):
    return CYLINDER in (ta, tb) and not (SPHERE in (ta, tb) or PLANE in (ta, tb))


# --------------------------------------------------------------------- exact tests

@settings(max_examples=50, deadline=None)
@given(c1=st.tuples(*[st.floats(-1, 1)] * 3), c2=st.tuples(*[st.floats(-1, 1)] * 3),
       r1=st.floats(0.05, 1.0), r2=st.floats(0.05, 1.0))
def test_sphere_sphere_contact_iff_overlap(c1, c2, r1, r2):
    c1, c2 = np.array(c1), np.array(c2)
    d = np.linalg.norm(c2 - c1)
    I = np.array([0, 0, 0, 1.0])
    P, N, D, F = run(SPHERE, c1, I, np.array([r1, 0, 0]), SPHERE, c2, I, np.array([r2, 0, 0]), 0.0)
    if abs(d - (r1 + r2)) < 1e-9:
        return
    assert (len(D) == 1) == (d < r1 + r2)
    if len(D):
        assert abs(D[0] - (r1 + r2 - d)) < 1e-9
        assert abs(np.linalg.norm(N[0]) - 1) < 1e-12
        if d > 1e-9:
            assert np.allclose(N[0], (c2 - c1) / d, atol=1e-9)


@settings(max_examples=50, deadline=None)
@given(seed=SEEDS)
def test_sphere_box_contact_iff_overlap(seed):
    rng = np.random.default_rng(seed)
    pa, qa, sa, pb, qb, sb = random_config(rng, SPHERE, BOX)
    dist = sdf(BOX, pb, qb, sb, pa) - sa[0]          # exact signed distance
    P, N, D, F = run(SPHERE, pa, qa, sa, BOX, pb, qb, sb, 0.0)
    if abs(dist) < 1e-9:
        return
    assert (len(D) == 1) == (dist < 0)
    if len(D):
        assert abs(D[0] + dist) < 1e-9


@settings(max_examples=50, deadline=None)
@given(seed=SEEDS)
def test_box_box_sat_agrees_with_gjk(seed):
    rng = np.random.default_rng(seed)
    pa, qa, sa, pb, qb, sb = random_config(rng, BOX, BOX)
    dist, _, _, overlap = gjk_distance(BOX, tuple(pa), tuple(qa), tuple(sa), BOX, tuple(pb),
                                       tuple(qb), tuple(sb))
    P, N, D, F = run(BOX, pa, qa, sa, BOX, pb, qb, sb, 0.0)
    band = 1e-6
    if not overlap and dist > band:
        assert len(D) == 0
        # within a margin larger than the gap there is a (speculative) contact
        P, N, D, F = run(BOX, pa, qa, sa, BOX, pb, qb, sb, dist + 1e-3)
        assert len(D) >= 1 and np.all(D <= -dist + 1e-9)   # no point closer than the gap
    elif overlap:
        shrunk = gjk_distance(BOX, tuple(pa), tuple(qa), tuple(sa - band), BOX, tuple(pb),
                              tuple(qb), tuple(sb - band))[3]
        if shrunk:
            assert len(D) >= 1 and D.max() > 0
            # moving B out along the normal by the SAT depth separates the boxes
            sep, n, _, _ = box_box_deepest(pa, qa, sa, pb, qb, sb)
            moved = tuple(np.asarray(pb) + (-sep + band) * np.asarray(n))
            assert not gjk_distance(BOX, tuple(pa), tuple(qa), tuple(sa), BOX, moved,
                                    tuple(qb), tuple(sb))[3]


# --------------------------------------------------------------- every type pair

def surface_tol(ta, tb, depth):
    """How far p +- depth/2 n may be from the surfaces: rounding (and the golden-section
    search of capsule-box) for closed forms; for GJK/MPR pairs the penetration
    refinement stops within about 1e-3 of the depth (1.05e-3 seen once in 3000 random
    cylinder-box cases; 1e-2 when deep, see DEEP)."""
    if is_mpr_pair(ta, tb):
        return 1e-6 + (2e-3 if depth <= DEEP else 1e-2) * max(depth, 0.0)
    return 1e-8


# GJK/MPR results: depths converge to second order, normals and points to first
# order only (the depth is flat around the optimal direction; observed up to 1e-3 on
# 3000 random shallow cases); closed forms: rounding.
def motion_tol(ta, tb):
    return (1e-6, 5e-3) if is_mpr_pair(ta, tb) else (1e-7, 1e-7)


# Beyond this depth a GJK/MPR pair may have several nearly equally deep local
# penetration directions, and which one the refinement settles in can change with
# rounding: only the depth is compared there (to 0.5 %).
DEEP = 0.1


def deep_mpr(ta, tb, D):
    return is_mpr_pair(ta, tb) and len(D) and D.max() > DEEP


@pytest.mark.parametrize("ta, tb", PAIRS)
@settings(max_examples=25, deadline=None)
@given(seed=SEEDS)
def test_contacts_lie_on_both_surfaces(ta, tb, seed):
    """Unit normals; p + depth/2 n is on A's surface and p - depth/2 n on B's.

    Exception: a capsule's end-cap or clipped contacts (the deepest point of the ball
    at a point of its segment) may lie inside the capsule.
    """
    rng = np.random.default_rng(seed)
    pa, qa, sa, pb, qb, sb = random_config(rng, ta, tb)
    margin = 0.05
    P, N, D, F = run(ta, pa, qa, sa, tb, pb, qb, sb, margin)
    for i, (p, n, d) in enumerate(zip(P, N, D)):
        tol = surface_tol(ta, tb, d)
        assert abs(np.linalg.norm(n) - 1.0) < 1e-12
        assert d > -margin
        for t, pos, q, size, x in ((ta, pa, qa, sa, p + 0.5 * d * n),
                                   (tb, pb, qb, sb, p - 0.5 * d * n)):
            s = sdf(t, pos, q, size, x)
            if t == CAPSULE:
                assert s < tol      # end-cap contacts may lie inside the capsule
            else:
                assert abs(s) < tol
    # shapes overlapping at the centre of one of them must have contacts
    if len(D) == 0 and ta != PLANE:
        assert sdf(ta, pa, qa, sa, pb) > 0 and sdf(tb, pb, qb, sb, pa) > 0


@pytest.mark.parametrize("ta, tb", PAIRS)
@settings(max_examples=25, deadline=None)
@given(seed=SEEDS)
def test_rigid_motion_invariance(ta, tb, seed):
    rng = np.random.default_rng(seed)
    pa, qa, sa, pb, qb, sb = random_config(rng, ta, tb)
    T = Rotation.random(random_state=rng)
    R = T.as_matrix()
    t = rng.uniform(-3, 3, 3)
    P0, N0, D0, F0 = run(ta, pa, qa, sa, tb, pb, qb, sb, 0.05)
    P1, N1, D1, F1 = run(ta, R @ pa + t, (T * Rotation.from_quat(qa)).as_quat(), sa,
                         tb, R @ pb + t, (T * Rotation.from_quat(qb)).as_quat(), sb, 0.05)
    tol_d, tol_x = motion_tol(ta, tb)
    if deep_mpr(ta, tb, D0) or deep_mpr(ta, tb, D1):
        assert abs(D0.max() - D1.max()) < 5e-3 * D0.max()
        return
    assert len(D0) == len(D1)
    o0, o1 = np.argsort(F0, kind="stable"), np.argsort(F1, kind="stable")
    assert np.array_equal(F0[o0], F1[o1])
    assert np.allclose(D1[o1], D0[o0], atol=tol_d)
    assert np.allclose(N1[o1], N0[o0] @ R.T, atol=tol_x)
    assert np.allclose(P1[o1], P0[o0] @ R.T + t, atol=tol_x)


@pytest.mark.parametrize("ta, tb", PAIRS)
@settings(max_examples=25, deadline=None)
@given(seed=SEEDS)
def test_swap_flips_normals(ta, tb, seed):
    rng = np.random.default_rng(seed)
    pa, qa, sa, pb, qb, sb = random_config(rng, ta, tb)
    P0, N0, D0, F0 = run(ta, pa, qa, sa, tb, pb, qb, sb, 0.05)
    P1, N1, D1, F1 = run(tb, pb, qb, sb, ta, pa, qa, sa, 0.05)
    if ta == tb and (deep_mpr(ta, tb, D0) or deep_mpr(ta, tb, D1)):
        assert abs(D0.max() - D1.max()) < 5e-3 * D0.max()
        return
    assert len(D0) == len(D1)
    if ta != tb:
        assert np.array_equal(P0, P1) and np.array_equal(N0, -N1) and np.array_equal(D0, D1)
        assert np.array_equal(F0, F1)
    elif len(D0):
        # same types: computed with the roles exchanged, compare the contact sets
        tol_d, tol_x = motion_tol(ta, tb)
        for p, n, d in zip(P0, N0, D0):
            k = np.argmin(np.linalg.norm(P1 - p, axis=1))
            assert np.allclose(P1[k], p, atol=tol_x) and np.allclose(N1[k], -n, atol=tol_x)
            assert abs(D1[k] - d) < tol_d
