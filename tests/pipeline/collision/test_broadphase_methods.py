"""Every broad phase (sort and sweep, hashed grid) returns exactly the brute-force pairs,
in the same order, and a World steps identically with either."""
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import tumble
from tumble.errors import ModelError
from tumble.pipeline.collision import (BOX, BROADPHASES, CAPSULE, CYLINDER, PLANE, SPHERE,
                                       find_pairs, geom_aabb, grid_pairs, overlapping_pairs)

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)
METHODS = list(BROADPHASES)


def brute_force(lo, hi, body=None):
    """Sorted list of (i, j), i < j, whose closed AABBs overlap (and bodies differ)."""
    out = []
    for i, j in itertools.combinations(range(len(lo)), 2):
        if np.all(lo[i] <= hi[j]) and np.all(lo[j] <= hi[i]):
            if body is None or body[i] != body[j]:
                out.append((i, j))
    return out


def distinct_bodies(n):
    """A body per geom (nothing filtered), typed as the pipeline's ``geom_body``."""
    body = np.arange(n, dtype=np.int32)
    body.flags.writeable = False
    return body


def random_geoms(rng, n, nplanes, nstatic, spread, size_scale):
    """AABBs (with margin) of ``n`` randomly posed spheres, capsules, boxes and cylinders
    of sizes over two decades, ``nplanes`` planes and ``nstatic`` large static boxes
    (walls); returns lo, hi (n + nplanes + nstatic, 3) and geom_body."""
    lo, hi, body = [], [], []
    types = [SPHERE, CAPSULE, BOX, CYLINDER]
    for i in range(n):
        t = types[rng.integers(4)]
        size = rng.uniform(0.02, 0.3, 3) * size_scale * (10.0 if rng.random() < 0.1 else 1.0)
        pos = rng.uniform(-spread, spread, 3) * rng.uniform(0.1, 1.0, 3)
        q = Rotation.random(random_state=rng).as_quat()
        a, b = geom_aabb(t, pos, q, size, rng.choice([0.0, 0.01]))
        lo.append(a)
        hi.append(b)
        body.append(rng.integers(-1, max(2, n // 3)))      # shared bodies and world geoms
    for i in range(nplanes):
        a, b = geom_aabb(PLANE, np.zeros(3), np.array([0, 0, 0, 1.0]), np.zeros(3), 0.0)
        lo.append(a)
        hi.append(b)
        body.append(-1)
    for i in range(nstatic):
        half = np.array([spread, 0.1, spread]) if i % 2 else np.array([0.1, spread, spread])
        pos = rng.uniform(-spread, spread, 3)
        a, b = geom_aabb(BOX, pos, np.array([0, 0, 0, 1.0]), half, 0.0)
        lo.append(a)
        hi.append(b)
        body.append(-1 if i % 3 else rng.integers(0, max(2, n // 3)))
    order = rng.permutation(len(lo))            # large geoms anywhere in the index order
    lo, hi = np.array(lo, float).reshape(-1, 3), np.array(hi, float).reshape(-1, 3)
    return lo[order], hi[order], np.array(body, np.int64)[order]


@pytest.mark.parametrize("method", METHODS)
@settings(max_examples=60, deadline=None)
@given(seed=SEEDS, n=st.integers(0, 60), nplanes=st.integers(0, 2), nstatic=st.integers(0, 4),
       spread=st.sampled_from([0.5, 3.0, 30.0]), size_scale=st.sampled_from([0.1, 1.0, 5.0]))
def test_every_method_equals_brute_force(method, seed, n, nplanes, nstatic, spread,
                                         size_scale):
    rng = np.random.default_rng(seed)
    lo, hi, body = random_geoms(rng, n, nplanes, nstatic, spread, size_scale)
    for filt in (None, body):
        expect = brute_force(lo, hi, filt)
        got = [tuple(r) for r in find_pairs(lo, hi, filt, method)]
        assert got == expect                       # same set, sorted, i < j, no repeats


@settings(max_examples=40, deadline=None)
@given(seed=SEEDS, n=st.integers(2, 80), scale=st.sampled_from([0.5, 1.0, 1.01, 2.0, 4.0]))
def test_grid_exact_for_any_cell_size(seed, n, scale):
    """Whatever the cell size (hence whichever geoms are large), the pairs are exact;
    boxes on a lattice make many exactly touching faces."""
    rng = np.random.default_rng(seed)
    c = rng.integers(-4, 5, (n, 3)) * 0.25
    half = rng.choice([0.125, 0.25, 0.5], (n, 3))
    lo, hi = c - half, c + half
    expect = brute_force(lo, hi)
    out = np.zeros((len(expect) + 1, 2), np.int32)
    cnt = grid_pairs(lo, hi, out, distinct_bodies(n), scale)
    assert cnt == len(expect) and [tuple(r) for r in out[:cnt]] == expect


def test_grid_edge_cases():
    # zero-size boxes (points, no margin): cell size falls back, exact anyway
    p = np.array([[0, 0, 0], [0, 0, 0], [1, 0, 0.0], [1e-300, 0, 0], [1, 0, 0]])
    assert [tuple(r) for r in find_pairs(p, p, method="grid")] == [(0, 1), (2, 4)]
    # far beyond the hashed range: treated as large, still exact
    lo = np.array([[1e12, 0, 0], [1e12 + 0.5, 0, 0], [0, 0, 0], [0.5, 0, 0]])
    assert [tuple(r) for r in find_pairs(lo, lo + 1.0, method="grid")] == [(0, 1), (2, 3)]
    # overflow: the total is returned and only ``cap`` rows written
    lo = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]])
    out = np.full((1, 2), -1, np.int32)
    for code in BROADPHASES.values():
        assert overlapping_pairs(code, lo, lo + 1.0, out, distinct_bodies(3)) == 2
        assert out[0, 0] >= 0
    assert find_pairs(lo[:1], lo[:1] + 1.0, method="grid").shape == (0, 2)
    assert find_pairs(np.zeros((0, 3)), np.zeros((0, 3)), method="grid").shape == (0, 2)


def test_grid_large_geoms_by_cells_and_by_scan():
    """A wall covering few cells is tested cell by cell, a huge one against every small
    geom; both, and many large geoms among themselves, give the brute-force pairs."""
    rng = np.random.default_rng(5)
    c = rng.uniform(-10, 10, (400, 3))
    lo, hi = c - 0.1, c + 0.1
    walls_lo = np.array([[-1, -1, -1], [-20, -20, -0.2], [0.5, 0.5, 0.5], [-3, 2, -3.0]])
    walls_hi = np.array([[1, 1, 1], [20, 20, 0.2], [2, 2, 2], [3, 2.3, 3.0]])
    lo, hi = np.vstack([lo, walls_lo]), np.vstack([hi, walls_hi])
    expect = brute_force(lo, hi)
    assert any(j >= 400 for _, j in expect)
    assert [tuple(r) for r in find_pairs(lo, hi, method="grid")] == expect


def test_find_pairs_rejects_unknown_method():
    with pytest.raises(ModelError, match="method"):
        find_pairs(np.zeros((2, 3)), np.ones((2, 3)), method="bvh")


# ------------------------------------------------------------------ in a World ---

CROWD = 12          # spheres that push the scene past collide.LISTED_PAIRS_MAX pairs

def scene(broadphase, crowd=0):
    """Plane, a heightfield, a static wall, a static body, jointed capsules (the joint
    pair excluded), boxes, spheres and cylinders with collision bits that rule some out;
    ``crowd`` small spheres more, resting in a row on the ground away from the rest (enough
    of them leave more pairs that may touch than ``collide.LISTED_PAIRS_MAX``, so that a
    step runs the broad phase)."""
    rng = np.random.default_rng(11)
    b = tumble.ModelBuilder(timestep=1.0 / 240.0)
    b.add_geom(None, "plane", name="ground")
    x = np.linspace(-1, 1, 5)
    b.add_geom(None, "heightfield", size=(1.0, 1.0, 0.05), pos=(3.0, 0.0, 0.0),
               heights=0.1 * np.outer(np.cos(x), np.sin(x)) + 0.1)
    b.add_geom(None, "box", size=(0.1, 2.0, 1.0), pos=(-1.6, 0, 1.0), name="wall")
    shelf = b.add_body("shelf", pos=(0, 1.2, 0.3), kind="static")
    b.add_geom(shelf, "box", size=(1.0, 0.2, 0.05))
    a = b.add_body("a", pos=(0, 0, 0.6), mass=1.0)
    b.add_geom(a, "capsule", radius=0.05, half_length=0.2, quat=(0, 0.7071068, 0, 0.7071068))
    c = b.add_body("c", pos=(0.45, 0, 0.6), mass=1.0)
    b.add_geom(c, "capsule", radius=0.05, half_length=0.2, quat=(0, 0.7071068, 0, 0.7071068))
    b.add_joint("j", "ball", a, c, anchor=(0.225, 0, 0.6))
    for i in range(24):
        p = (rng.uniform(-1.2, 3.5), rng.uniform(-1, 1.2), rng.uniform(0.2, 1.5))
        body = b.add_body("g%d" % i, pos=p, mass=1.0, quat=Rotation.random(
            random_state=rng).as_quat())
        kind = ("sphere", "box", "cylinder")[i % 3]
        bits = dict(contype=2, conaffinity=2) if i % 5 == 0 else {}
        if kind == "sphere":
            b.add_geom(body, "sphere", radius=rng.uniform(0.05, 0.2), **bits)
        elif kind == "box":
            b.add_geom(body, "box", size=rng.uniform(0.05, 0.2, 3), **bits)
        else:
            b.add_geom(body, "cylinder", radius=0.1, half_length=0.1, **bits)
    for i in range(crowd):
        b.add_geom(b.add_body("crowd%d" % i, pos=(6.0 + 0.25 * i, 3.0, 0.1), mass=1.0), "sphere",
                   radius=0.1)
    return tumble.World(b.build(), contact="pgs", iterations=20, broadphase=broadphase)


def test_worlds_step_identically_with_every_broadphase():
    from tumble.pipeline.collide import listed_pairs
    worlds = {m: scene(m, crowd=CROWD) for m in METHODS}
    model = worlds["sap"].model
    assert listed_pairs(model.arrays, model.nbody).shape[0] == 0      # the broad phase runs
    for _ in range(6):
        for w in worlds.values():
            w.step(20)
        ref = worlds["sap"]
        rc = ref.contacts
        assert len(rc.depth) > 0
        for m, w in worlds.items():
            assert np.array_equal(w.body_pos, ref.body_pos), m
            assert np.array_equal(w.body_quat, ref.body_quat), m
            wc = w.contacts
            assert np.array_equal(wc.geoms, rc.geoms) and np.array_equal(wc.force, rc.force)


def test_world_broadphase_option():
    w = scene("grid")
    assert w.broadphase == "grid"
    w.step(5)
    w.broadphase = "sap"                           # may change between steps
    w.step(5)
    with pytest.raises(ModelError, match="broadphase"):
        w.broadphase = "octree"
    with pytest.raises(ModelError, match="broadphase"):
        scene(None)


# ------------------------------------------------------- listed pairs (small scenes) ---

def _collide(world, route):
    """Contacts (geoms, depths, points) of ``world``'s current state by one collision
    route: 'sap' or 'grid' (the broad phase), 'listed' (collide_world over the listed
    pairs) or 'listed-noalloc' (collide_listed)."""
    from tumble.pipeline.collide import collide_listed, collide_world, listed_pairs
    from tumble.pipeline.contacts.arrays import make_contacts
    m, s = world.model.arrays, world.state_arrays
    ng = world.model.ngeom
    con = make_contacts(1, 256)
    view = type(con)(*(a[0] for a in con))
    prev = type(con)(*(a[0].copy() for a in con))
    lo, hi = np.zeros((ng, 3)), np.zeros((ng, 3))
    pairs = np.zeros((ng * ng, 2), np.int32)
    listed = listed_pairs(m, world.model.nbody)
    args = (m, s.body_pos[0], s.body_quat[0], np.zeros((ng, 3)), np.zeros((ng, 4)), lo, hi,
            pairs, view, np.int64(0), prev, world.contact_margin)
    rest = (np.zeros(world.model.nbody), 0.0)
    if route == "listed-noalloc":
        status, n = collide_listed(*args, listed, *rest)
    elif route == "listed":
        status, n = collide_world(*args, BROADPHASES["sap"], listed, *rest)
    else:
        status, n = collide_world(*args, BROADPHASES[route], np.zeros((0, 2), np.int32),
                                  *rest)
    assert status == 0
    return view.geom[:n].copy(), view.depth[:n].copy(), view.point[:n].copy()


def test_listed_pairs_are_the_pairs_that_may_touch():
    from tumble.pipeline.collide import listed_pairs, listed_primitives, may_collide
    w = scene("sap")
    m, nb = w.model.arrays, w.model.nbody
    listed = [tuple(p) for p in listed_pairs(m, nb)]
    expect = [(i, j) for i, j in itertools.combinations(range(w.model.ngeom), 2)
              if may_collide(m, i, j, nb)]
    assert listed == expect and 0 < len(listed) < w.model.ngeom * (w.model.ngeom - 1) // 2
    assert not listed_primitives(m, listed_pairs(m, nb))          # the heightfield's pairs


def test_too_many_pairs_are_left_to_the_broad_phase():
    from tumble.pipeline.collide import LISTED_PAIRS_MAX, listed_pairs
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    n = 40                                          # 40 * 41 / 2 = 820 pairs > 512
    for i in range(n):
        b.add_geom(b.add_body("s%d" % i, pos=(0.3 * i, 0, 1), mass=1.0), "sphere", radius=0.1)
    model = b.build()
    assert n * (n + 1) // 2 > LISTED_PAIRS_MAX
    assert listed_pairs(model.arrays, model.nbody).shape == (0, 2)


@pytest.mark.parametrize("heightfield", [True, False])
def test_listed_route_finds_the_broad_phases_contacts(heightfield):
    """The same contacts, in the same order, whichever route finds the pairs; with only
    primitives the allocation-free route (collide_listed) too."""
    w = scene("sap")
    if not heightfield:             # the same kinds of bodies, primitives only
        b = tumble.ModelBuilder(timestep=1.0 / 240.0)
        b.add_geom(None, "plane")
        rng = np.random.default_rng(5)
        for i in range(12):
            body = b.add_body("g%d" % i, pos=(rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4),
                                             0.15 + 0.1 * i), mass=1.0,
                              quat=Rotation.random(random_state=rng).as_quat())
            if i % 2:
                b.add_geom(body, "box", size=rng.uniform(0.05, 0.15, 3))
            else:
                b.add_geom(body, "capsule", radius=0.05, half_length=0.1)
        w = tumble.World(b.build(), contact="pgs", iterations=20)
    routes = ["sap", "grid", "listed"] + ([] if heightfield else ["listed-noalloc"])
    seen = 0
    for _ in range(8):
        w.step(30)
        ref = _collide(w, "sap")
        seen += len(ref[1])
        for route in routes[1:]:
            got = _collide(w, route)
            for a, b_ in zip(ref, got):
                assert np.array_equal(a, b_), route
    assert seen > 0
