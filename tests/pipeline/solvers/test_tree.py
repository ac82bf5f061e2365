"""The linear-time tree factorisation against dense linear algebra.

Rows are random (random Jacobians, CFM, bounds) on random body trees, so every
configuration of the graph is met: chains hanging from the world, several world-rooted
parts, free-floating parts, kinematic bodies, several joints between one pair, rows on
the ground alone. The tree path must give the dense path's impulses to 1e-9 (relative
to the largest impulse) and the same number of active-set iterations; graphs with loops
must be refused by the planner and still solved (densely).
"""
import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

import tumble
from tumble.apps import benchmarks
from tumble.pipeline.contacts.arrays import ContactArrays
from tumble.pipeline.solve import make_solver_caches
from tumble.pipeline.contacts.rows import build_contact_rows
from tumble.pipeline.joints.common import INF
from tumble.pipeline.joints.rows import build_joint_rows
from tumble.pipeline.joints.servo import JointDrive
from tumble.pipeline.solvers.common import make_rows_nb, world_inverse_inertia
from tumble.pipeline.solvers.direct import solve_active_set
from tumble.pipeline.solvers.guess import (SLIDE_NEG, SLIDE_POS, guess_states,
                                           guessed_active_set, make_held_scratch, solve_held)
from tumble.pipeline.solvers.mlcp import (FAST_NOT_HANDLED, FAST_SOLVED, guess_on_tree_fast,
                                         make_fast_scratch, mixed_lcp, solve_mlcp)
from tumble.pipeline.solvers.partition import partition_rows
from tumble.pipeline.solvers.pyramid import pyramid_lcp
from tumble.pipeline.solvers.tree import (cached_tree_plan, make_plan_cache, plan_capacity,
                                         tree_body_inverse, tree_factor, tree_plan, tree_solve)

FAST = settings(max_examples=60, deadline=None)


def random_system(rng, parents, kinematic=(), bounds=True, max_rows=6):
    """Rows for joints ``child i -- parents[i]`` (-1: the world, None: no joint), random
    everything.

    Returns (rows, nrow, inv_mass (nb,), inv_inertia (nb, 3, 3)); bodies in ``kinematic``
    get zero inverse mass and inertia, as the pipeline gives kinematic bodies."""
    nb = len(parents)
    spec = [(parents[c], c, int(rng.integers(1, max_rows + 1))) for c in range(nb)
            if parents[c] is not None]
    nrow = sum(s[2] for s in spec)
    rows = make_rows_nb(nrow)
    inv_mass = 1.0 / rng.uniform(0.2, 10.0, nb)
    inv_inertia = np.zeros((nb, 3, 3))
    for b in range(nb):
        q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        inv_inertia[b] = q @ np.diag(1.0 / rng.uniform(0.01, 1.0, 3)) @ q.T
    for b in kinematic:
        inv_mass[b] = 0.0
        inv_inertia[b] = 0.0
    r = 0
    for a, b, count in spec:
        for _ in range(count):
            rows.body_a[r], rows.body_b[r] = a, b
            J = rng.normal(size=12)
            if a < 0:
                J[:6] = 0.0
            rows.J[r] = J
            rows.rhs[r] = rng.normal()
            rows.cfm[r] = 10.0 ** rng.uniform(-8, -2)
            rows.lo[r], rows.hi[r] = -INF, INF
            kind = rng.random() if bounds else 1.0
            if kind < 0.2:
                rows.lo[r] = 0.0                               # a limit
            elif kind < 0.35:
                f = 0.3 * abs(rng.normal())                      # a motor or dry friction
                rows.lo[r], rows.hi[r] = -f, f
            r += 1
    inv_mass.flags.writeable = False          # as the model hands it to the solvers
    return rows, nrow, inv_mass, inv_inertia


def solve_both(rows, nrow, inv_mass, inv_inertia, rng):
    """(impulse, vel, angvel, iterations) from the tree path and from the dense path."""
    nb = len(inv_mass)
    v0, w0 = rng.normal(size=(nb, 3)), rng.normal(size=(nb, 3))
    out = []
    for allow_tree in (True, False):
        v, w, imp = v0.copy(), w0.copy(), np.zeros(nrow)
        it = solve_active_set(rows, nrow, inv_mass, inv_inertia, v, w, imp, 1e-12, allow_tree)
        out.append((imp, v, w, it))
    return out


def assert_same(tree, dense, tol=1e-9):
    (i1, v1, w1, it1), (i2, v2, w2, it2) = tree, dense
    scale = max(np.abs(i2).max(), 1e-300)
    assert np.abs(i1 - i2).max() <= tol * scale
    assert np.abs(v1 - v2).max() <= tol * max(1.0, np.abs(v2).max())
    assert np.abs(w1 - w2).max() <= tol * max(1.0, np.abs(w2).max())
    assert it1 == it2


def random_parents(rng, nb, shape):
    """Parent of each body: 'hanging' (body 0 on the world, the rest below), 'forest'
    (several world-rooted parts) or 'floating' (body 0 has no joint: a free ragdoll)."""
    parents = [None if shape == "floating" else -1]
    for i in range(1, nb):
        if shape == "forest" and rng.random() < 0.3:
            parents.append(-1)
        else:
            parents.append(int(rng.integers(0, i)))
    return parents


@FAST
@given(seed=st.integers(0, 2**32 - 1), nb=st.integers(1, 14),
       shape=st.sampled_from(["hanging", "forest", "floating"]), bounds=st.booleans())
def test_tree_and_dense_active_set_agree(seed, nb, shape, bounds):
    rng = np.random.default_rng(seed)
    parents = random_parents(rng, nb, shape)
    if nb == 1 and shape == "floating":
        return                                           # no rows at all
    rows, nrow, im, ii = random_system(rng, parents, bounds=bounds)
    ok, _ = tree_plan(rows, np.arange(nrow), nrow, im, nb)
    assert ok
    assert_same(*solve_both(rows, nrow, im, ii, rng))


@FAST
@given(seed=st.integers(0, 2**32 - 1), nb=st.integers(2, 12))
def test_kinematic_bodies_count_as_ground(seed, nb):
    """A kinematic body inside a chain splits it into parts that each hang from it."""
    rng = np.random.default_rng(seed)
    parents = [-1] + list(range(nb - 1))              # a chain 0 - 1 - ... - nb-1
    kin = [int(rng.integers(0, nb))]
    # at most 3 rows a joint: link 0's two ground joints may merge into one node, which
    # must not hold more rows than link 0 has degrees of freedom
    rows, nrow, im, ii = random_system(rng, parents, kinematic=kin, max_rows=3)
    ok, _ = tree_plan(rows, np.arange(nrow), nrow, im, nb)
    # the kinematic body and the world are both ground: the links between them touch the
    # ground twice (a loop through the ground) unless the kinematic body is link 0, or
    # link 1, when link 0's two ground joints form one node
    assert ok == (kin[0] <= 1)
    assert_same(*solve_both(rows, nrow, im, ii, rng))


@FAST
@given(seed=st.integers(0, 2**32 - 1), nb=st.integers(2, 10))
def test_equality_rows_match_numpy(seed, nb):
    """Without bounds one factorisation solves ``(J M^-1 J^T + C) p = r``; the body
    unknowns are ``M^-1 J^T p``."""
    rng = np.random.default_rng(seed)
    parents = [-1] + [int(rng.integers(0, i)) for i in range(1, nb)]
    rows, nrow, im, ii = random_system(rng, parents, bounds=False)
    Minv = np.zeros((6 * nb, 6 * nb))
    for b in range(nb):
        Minv[6 * b:6 * b + 3, 6 * b:6 * b + 3] = im[b] * np.eye(3)
        Minv[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = ii[b]
    J = np.zeros((nrow, 6 * nb))
    for r in range(nrow):
        for side, body in ((0, rows.body_a[r]), (1, rows.body_b[r])):
            if body >= 0:
                J[r, 6 * body:6 * body + 6] += rows.J[r, 6 * side:6 * side + 6]
    A = J @ Minv @ J.T + np.diag(rows.cfm)
    g = rng.normal(size=nrow)
    p = np.linalg.solve(A, g)
    sel = np.arange(nrow)
    ok, plan = tree_plan(rows, sel, nrow, im, nb)
    assert ok and tree_factor(plan, rows, sel, rows.cfm.copy(), im, ii, nb)
    u, y = np.zeros((nb, 6)), np.zeros(nrow)
    tree_solve(plan, nb, np.zeros((nb, 6)), g, u, y)
    np.testing.assert_allclose(-y, p, rtol=0, atol=1e-9 * np.abs(p).max())
    np.testing.assert_allclose(u.reshape(-1), Minv @ J.T @ p, rtol=0,
                               atol=1e-9 * np.abs(Minv @ J.T @ p).max())


def test_loops_are_refused_and_solved_densely():
    rng = np.random.default_rng(7)
    cases = {
        "ring": [(0, 1), (1, 2), (2, 0)],                 # three bodies in a loop
        "two world joints": [(-1, 0), (0, 1), (-1, 1)],   # a part hanging twice
        "self": [(1, 1)],                                 # a row on one body twice
    }
    for name, pairs in cases.items():
        nb = 3
        rows = make_rows_nb(3 * len(pairs))
        for k, (a, b) in enumerate(pairs):
            for t in range(3):
                r = 3 * k + t
                rows.body_a[r], rows.body_b[r] = a, b
                rows.J[r] = rng.normal(size=12)
                rows.cfm[r] = 1e-6
                rows.lo[r], rows.hi[r] = -INF, INF
        nrow = 3 * len(pairs)
        im = np.ones(nb)
        ii = np.tile(np.eye(3), (nb, 1, 1))
        ok, _ = tree_plan(rows, np.arange(nrow), nrow, im, nb)
        assert not ok, name
        tree, dense = solve_both(rows, nrow, im, ii, rng)
        np.testing.assert_array_equal(tree[0], dense[0])   # both took the dense path


def test_two_joints_between_one_pair_form_one_node():
    """A hinge built as two ball joints on one axis is one constraint node of 6 rows."""
    rng = np.random.default_rng(3)
    rows, nrow, im, ii = random_system(rng, [-1, 0, 0, 1], bounds=True)
    rows2 = make_rows_nb(nrow + 3)
    for field, src in zip(rows2, rows):
        field[:nrow] = src
    for t in range(3):
        r = nrow + t
        rows2.body_a[r], rows2.body_b[r] = 1, 0           # the reverse orientation
        rows2.J[r] = rng.normal(size=12)
        rows2.cfm[r] = 1e-5
        rows2.lo[r], rows2.hi[r] = -INF, INF
    ok, plan = tree_plan(rows2, np.arange(nrow + 3), nrow + 3, im, 4)
    assert ok and plan.meta[0] == 4                       # pairs: w-0, 0-1, 0-2, 1-3
    assert_same(*solve_both(rows2, nrow + 3, im, ii, rng))


def scene_rows(world, contacts=False):
    """The rows a step of ``world`` would solve now, and the solver inputs."""
    m, s, c, o = world.model.arrays, world.state_arrays, world.control_arrays, world.step_options()
    pos, quat, vel, angvel = s.body_pos[0], s.body_quat[0], s.body_vel[0], s.body_angvel[0]
    ncon = int(s.contact_count[0]) if contacts else 0
    nrow = world.model.nrow + 3 * ncon
    rows, imp = make_rows_nb(nrow), np.zeros(nrow)
    drive = JointDrive(c.motor_target[0], c.pd_kp[0], c.pd_kd[0], c.pd_max[0],
                       c.pd_target_quat[0], c.pd_target_q[0], c.pd_target_qd[0],
                       c.joint_applied[0])
    build_joint_rows(m, pos, quat, vel, angvel, drive, world.dt, o.erp, o.cfm, rows, True)
    if ncon:
        cw = ContactArrays(*[a[0] for a in world.contact_arrays])
        build_contact_rows(m, pos, vel, angvel, cw, ncon, world.model.nrow, 3, world.dt,
                           o.contact_erp, o.contact_cfm, o.slop, o.bounce_threshold, rows, imp)
    ii = np.zeros((world.model.nbody, 3, 3))
    world_inverse_inertia(m, quat, ii)
    return rows, nrow, m.body_inv_mass, ii, vel.copy(), angvel.copy(), imp


def direct_both_ways(world):
    """The direct solve of the world's current rows over the tree and densely:
    [(impulses, vel, angvel, iterations)] for each."""
    rows, nrow, im, ii, vel, angvel, _ = scene_rows(world)
    out = []
    for allow_tree in (True, False):
        v, w, imp = vel.copy(), angvel.copy(), np.zeros(nrow)
        it = solve_active_set(rows, nrow, im, ii, v, w, imp, 1e-12, allow_tree)
        out.append((imp, v, w, it))
    return out


def test_chain_scene_tree_matches_dense():
    """The benchmark chain (30 ball joints from the world) at several moments of its fall."""
    world = tumble.World(benchmarks.chain())
    for _ in range(5):
        world.step(60)
        out = direct_both_ways(world)
        assert_same(*out)


def test_limited_hinge_chain_tree_matches_dense():
    """Hinges with limits, motors and dampers: the active set clamps and releases rows.
    (Dry friction is left out: with a motor on the same axis and no CFM on either, the
    system is singular and both paths hand it to PGS.)"""
    b = tumble.ModelBuilder()
    for i in range(6):
        b.add_body(f"l{i}", pos=(0.5 + i, 0, 0), mass=1.0, inertia=(0.01, 0.1, 0.1))
        b.add_joint(f"j{i}", "hinge", None if i == 0 else f"l{i - 1}", f"l{i}",
                    anchor=(float(i), 0, 0), axis=(0, 1, 0), limit=(-0.2, 0.2),
                    motor_max_force=2.0, damping=0.1 * (i % 2))
    world = tumble.World(b.build(), dt=1 / 240)
    world.joint_motor_target[:, 0] = 1.0
    clamped = 0
    for _ in range(8):
        world.step(30)
        out = direct_both_ways(world)
        assert_same(*out)
        assert out[0][3] > 0                             # no fallback to PGS
        clamped += out[0][3] > 1
    assert clamped > 0                                   # the active set was exercised


def test_ragdoll_mixed_lcp_tree_matches_dense():
    """The benchmark ragdoll on the ground: Schur complement over its joint tree. The two
    paths reach the LCP's answer by different tries (the tree's guess and sweeps on the
    rows' columns, the dense path's corrections and sweeps on ``S``), so the impulses of
    redundant corners may differ; the velocities may not."""
    world = tumble.World(benchmarks.ragdoll(600))
    seen = 0
    for _ in range(6):
        world.step(150)
        rows, nrow, im, ii, vel, angvel, imp0 = scene_rows(world, contacts=True)
        out = []
        for allow_tree in (True, False):
            v, w, imp = vel.copy(), angvel.copy(), imp0.copy()
            status = mixed_lcp(rows, nrow, im, ii, v, w, imp, 0, allow_tree)
            out.append((imp, v, w, status))
        assert out[0][3] == out[1][3]
        if out[0][3] == 0:
            assert_same_velocities(*out)
            seen += nrow > world.model.nrow
    assert seen > 0                                      # contacts were present


def assert_same_velocities(tree, dense, tol=1e-9):
    """Two answers of one mixed LCP that may split redundant impulses differently."""
    for a, b in zip(tree[1:3], dense[1:3]):
        assert np.abs(a - b).max() <= tol * max(1.0, np.abs(b).max())


def boxes_on_a_free_box(slide=0.0):
    """Two boxes joined by a hinge lying on a free box (sliding at ``slide`` m/s along x)
    on the ground: contact rows on bodies in the joint tree and on one outside it."""
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", friction=0.9)
    b.add_body("base", pos=(0, 0, 0.1), mass=5.0, vel=(slide, 0, 0))
    b.add_geom("base", "box", size=(0.6, 0.3, 0.1), friction=0.9)
    for i, x in enumerate((-0.2, 0.2)):
        b.add_body(f"l{i}", pos=(x, 0, 0.25), mass=1.0)
        b.add_geom(f"l{i}", "box", size=(0.2, 0.05, 0.05), friction=0.9)
    b.add_joint("hinge", "hinge", "l0", "l1", anchor=(0, 0, 0.25), axis=(0, 1, 0))
    return tumble.World(b.build(), dt=1 / 120)


def test_tree_on_a_free_box_matches_dense():
    """Two jointed boxes lying on a free box on the ground: the contact rows touch bodies
    in the tree and one outside it (the free box answers with its own inverse mass), and
    last step's contacts are tried first. The tree path gives the dense path's answer."""
    world = boxes_on_a_free_box()
    seen = 0
    for _ in range(5):
        world.step(12)
        rows, nrow, im, ii, vel, angvel, imp0 = scene_rows(world, contacts=True)
        live = world.state_arrays.contact_count[0]
        bodies = {int(x) for x in world.contact_arrays.body[0, :live].ravel()}
        out = []
        for allow_tree in (True, False):
            v, w, imp = vel.copy(), angvel.copy(), imp0.copy()
            status = mixed_lcp(rows, nrow, im, ii, v, w, imp, 0, allow_tree)
            out.append((imp, v, w, status))
        assert out[0][3] == out[1][3] == 0
        assert_same(*out)
        seen += {0, 1, 2} <= bodies          # box on the ground, the links on the box
    assert seen > 0


def test_the_tree_path_without_the_guess_matches_dense():
    """``solve_mlcp(guess=False)`` (what a step runs after its fast path's guess and sweeps
    failed) goes from the complement on the tree straight to Lemke; the dense path tries
    the guess and the sweeps first. On the jointed boxes riding a free box both solve,
    with the same velocities (the impulses of redundant corners may differ: each is a
    solution of the LCP)."""
    world = boxes_on_a_free_box()
    for cache, _ in steps_with_contacts(world, 60, 12):
        rows, nrow, im, ii, vel, angvel, imp0 = rows_with_gravity(world)
        out = []
        for guess in (False, None):
            v, w, imp = vel.copy(), angvel.copy(), imp0.copy()
            status = (solve_mlcp(rows, nrow, im, ii, v, w, imp, 0, cache, False) if guess is False
                      else mixed_lcp(rows, nrow, im, ii, v, w, imp, 0, False))
            out.append((imp, v, w, status))
        assert out[0][3] == out[1][3] == 0
        assert_same_velocities(*out)


def fast_and_full(world, cache, fast):
    """The mixed LCP of the world's current rows and contacts by the allocation-free fast
    path (``guess_on_tree_fast``) and by ``solve_mlcp``, both on the plan kept in
    ``cache``: (fast status, (impulses, vel, angvel) of each, the inputs). Where Lemke
    fails (the caller's PGS then stands in) the fast path must have declined."""
    rows, nrow, im, ii, vel, angvel, imp0 = scene_rows(world, contacts=True)
    out = []
    v, w, imp = vel.copy(), angvel.copy(), imp0.copy()
    status = guess_on_tree_fast(rows, nrow, im, ii, v, w, imp, cache, fast)
    out.append((imp, v, w))
    v, w, imp = vel.copy(), angvel.copy(), imp0.copy()
    full = solve_mlcp(rows, nrow, im, ii, v, w, imp, 0, cache)
    assert full == 0 or status != FAST_SOLVED
    out.append((imp, v, w))
    return status, out, (imp0, vel, angvel)


def steps_with_contacts(world, steps, every):
    """Step ``world`` ``every`` steps at a time, ``steps`` in all; yield the mixed LCP's
    plan cache and fast-path scratch (made once) after each call that left contacts."""
    m = world.model
    cache = make_solver_caches(m.arrays, np.zeros(0, np.int64), m.nbody)[1]
    fast = make_fast_scratch(m.nrow + 3 * world.contact_capacity, m.nbody, cache)
    for _ in range(steps // every):
        world.step(every)
        if world.state_arrays.contact_count[0] > 0:
            yield cache, fast


def rows_with_gravity(world):
    """``scene_rows`` with contacts and with this step's gravity in the velocities, as a
    step solves them (without it, resting contacts see no approach and carry nothing)."""
    rows, nrow, im, ii, vel, angvel, imp0 = scene_rows(world, contacts=True)
    vel = vel + world.dt * np.asarray(world.model.gravity) * (im > 0)[:, None]
    return rows, nrow, im, ii, vel, angvel, imp0


def check_fast_path(world, steps, every):
    """Step ``world``; every ``every`` steps the fast path either solves exactly as
    ``solve_mlcp`` does (bit for bit: the same kernels in the same order) or declines and
    leaves its inputs untouched. Returns how many times it solved and was tried."""
    solved = tried = 0
    for cache, fast in steps_with_contacts(world, steps, every):
        status, (got, want), inputs = fast_and_full(world, cache, fast)
        tried += 1
        if status == FAST_SOLVED:
            solved += 1
            for a, b in zip(got, want):
                np.testing.assert_array_equal(a, b)
        else:
            for a, b in zip(got, inputs):
                np.testing.assert_array_equal(a, b)
    return solved, tried


def test_fast_path_solves_the_standing_pd_ragdoll_as_solve_mlcp_does():
    """The benchmark's PD ragdoll at 60 Hz (implicit servos: every joint a six-row node)
    falls, lands and stands: once its plan is kept, the fast path takes nearly every step."""
    model = benchmarks.build("ragdoll60pd")
    world = tumble.World(model, dt=model.timestep, pd="implicit")
    for name, (kp, kd) in benchmarks.ragdoll_pd_gains(benchmarks.ragdoll_parts(), "spec").items():
        world.set_pd_gains(name, kp, kd)
    solved, tried = check_fast_path(world, 150, 3)
    assert tried == 50
    assert solved >= 45                     # the first call only plans; landing may decline


def test_fast_path_declines_what_it_cannot_guess():
    """Jointed boxes on a free box that starts sliding: sliding contacts, then four
    coplanar contacts per box whose held rows are dependent (Lemke picks the basis). The
    fast path declines some of those steps and leaves its inputs as they were; whatever it
    does solve it solves as ``solve_mlcp`` does."""
    world = boxes_on_a_free_box(slide=0.5)
    solved, tried = check_fast_path(world, 60, 2)
    assert tried == 30 and solved < tried


def fast_against_lemke(world, steps, every):
    """Step ``world``; every ``every`` steps solve its rows (velocities with this step's
    gravity, as the step solves them) by the fast path and by Lemke on the dense complement
    (``mixed_lcp`` without the tree, which never guesses a sliding contact). Where the fast
    path solves, its velocities must be the dense path's. Returns (solved, tried)."""
    solved = tried = 0
    for cache, fast in steps_with_contacts(world, steps, every):
        rows, nrow, im, ii, vel, angvel, imp0 = rows_with_gravity(world)
        solve_mlcp(rows, nrow, im, ii, vel.copy(), angvel.copy(), imp0.copy(), 0, cache)
        got = [imp0.copy(), vel.copy(), angvel.copy()]
        status = guess_on_tree_fast(rows, nrow, im, ii, got[1], got[2], got[0], cache, fast)
        want = [imp0.copy(), vel.copy(), angvel.copy()]
        assert mixed_lcp(rows, nrow, im, ii, want[1], want[2], want[0], 0, False) == 0
        tried += 1
        if status == FAST_SOLVED:
            solved += 1
            # (the tree's complement and the dense one differ in round-off; redundant
            # corners' impulses may be split differently by the two paths' tries)
            assert_same_velocities((*got, 0), (*want, 0), tol=1e-7)
    return solved, tried


def test_fast_path_solves_sliding_contacts_as_lemke_does():
    """Balls sliding on the ground (friction at its pyramid's bound, slipping at rate
    lambda), and jointed boxes riding a sliding box: last step's sliding state, kept at
    the bound, solves most steps on the fast path, with the dense path's velocities."""
    solved, tried = fast_against_lemke(sliding_chain(2.0, mu=0.1), 20, 2)
    assert tried == 10 and solved >= 8                # the first call only plans
    solved, tried = fast_against_lemke(boxes_on_a_free_box(slide=0.5), 60, 2)
    assert tried == 30 and solved >= 20


def test_fast_path_declines_without_a_kept_plan():
    """A cache that never planned these rows: the fast path leaves everything to
    ``solve_mlcp`` (which plans), then takes the next call."""
    world = tumble.World(benchmarks.ragdoll(600))
    world.step(300)
    m = world.model
    cache = make_solver_caches(m.arrays, np.zeros(0, np.int64), m.nbody)[1]
    fast = make_fast_scratch(m.nrow + 3 * world.contact_capacity, m.nbody, cache)
    status, (got, _), inputs = fast_and_full(world, cache, fast)
    assert status == FAST_NOT_HANDLED
    for a, b in zip(got, inputs):
        np.testing.assert_array_equal(a, b)
    assert fast_and_full(world, cache, fast)[0] == FAST_SOLVED


@FAST
@given(seed=st.integers(0, 2**32 - 1), nb=st.integers(2, 10), extra=st.integers(0, 3),
       shape=st.sampled_from(["hanging", "forest", "floating"]))
def test_inverse_mass_of_jointed_bodies_matches_numpy(seed, nb, extra, shape):
    """The 6x6 blocks of ``M_B^-1`` between bodies of the tree (``tree_body_inverse``)
    equal the dense ``M^-1 - M^-1 J_B^T A_BB^-1 J_B M^-1``: the velocity change of one body
    per unit impulse on another with every joint row holding, for bodies in one part or
    in different ones (then zero), with ``extra`` free bodies around."""
    rng = np.random.default_rng(seed)
    parents = random_parents(rng, nb, shape) + [None] * extra
    rows, nrow, im, ii = random_system(rng, parents, bounds=False)
    nbody = nb + extra
    Minv = np.zeros((6 * nbody, 6 * nbody))
    for b in range(nbody):
        Minv[6 * b:6 * b + 3, 6 * b:6 * b + 3] = im[b] * np.eye(3)
        Minv[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = ii[b]
    JB = np.zeros((nrow, 6 * nbody))
    for r in range(nrow):
        for side, body in ((0, rows.body_a[r]), (1, rows.body_b[r])):
            if body >= 0:
                JB[r, 6 * body:6 * body + 6] += rows.J[r, 6 * side:6 * side + 6]
    ABB = JB @ Minv @ JB.T + np.diag(rows.cfm)
    MB = Minv - Minv @ JB.T @ np.linalg.solve(ABB, JB @ Minv)
    sel = np.arange(nrow)
    ok, plan = tree_plan(rows, sel, nrow, im, nbody)
    assert ok and tree_factor(plan, rows, sel, rows.cfm.copy(), im, ii, nbody)
    in_tree = [b for b in range(nbody) if plan.dim[b] == 6]
    assert in_tree == list(range(nb))                    # the free extra bodies are not
    bodies = np.array(rng.permutation(in_tree)[:int(rng.integers(1, len(in_tree) + 1))],
                      np.int64)
    nc = len(bodies)
    H = np.zeros((nc, 6 * nbody + nrow, 6))
    member = np.zeros((nc, nbody + nrow), bool)
    G = np.zeros((nc, nc, 6, 6))
    tree_body_inverse(plan, bodies, nc, nbody, H, member, G)
    scale = np.abs(MB).max()
    for a, ba in enumerate(bodies):
        for c, bc in enumerate(bodies):
            np.testing.assert_allclose(G[a, c], MB[6 * ba:6 * ba + 6, 6 * bc:6 * bc + 6],
                                       rtol=0, atol=1e-9 * scale)
    assert not H.any() and not member.any()              # work arrays handed back clean


def test_plan_cache_keeps_and_renews_plans():
    """The cached plan is the fresh plan's twin, reused while the same rows come back and
    made again when they change; rows that do not fit get a fresh plan instead."""
    rng = np.random.default_rng(11)
    rows, nrow, im, ii = random_system(rng, [-1, 0, 1, 1, 3], bounds=False)
    cap_rows, cap_fac = plan_capacity(np.array([-1, 0, 1, 1, 3]), np.arange(5),
                                      np.bincount(rows.body_b[:nrow], minlength=5),
                                      np.zeros(0, np.int64), im, 5)
    assert cap_rows == nrow
    cache = make_plan_cache(cap_rows, 5, cap_fac)
    g = rng.normal(size=nrow)

    def solve(plan, sel, n):
        assert tree_factor(plan, rows, sel, rows.cfm[sel].copy(), im, ii, 5)
        u, y = np.zeros((5, 6)), np.zeros(n)
        tree_solve(plan, 5, np.zeros((5, 6)), g[:n], u, y)
        return u, y
    sel = np.arange(nrow)
    ok, fresh = tree_plan(rows, sel, nrow, im, 5)
    ok1, plan1 = cached_tree_plan(cache, rows, sel, nrow, im, 5)
    assert ok and ok1 and cache.meta[0] == nrow
    for a, b in zip(solve(fresh, sel, nrow), solve(plan1, sel, nrow)):
        np.testing.assert_array_equal(a, b)
    order = plan1.order.copy()
    plan1.order[:] = -7                        # a reused plan is not planned again
    cached_tree_plan(cache, rows, sel, nrow, im, 5)
    assert (plan1.order == -7).all()
    plan1.order[:] = order
    sub = sel[:nrow - 2]                       # other rows: planned anew
    ok2, plan2 = cached_tree_plan(cache, rows, sub, nrow - 2, im, 5)
    assert ok2 and np.shares_memory(plan2.fac, plan1.fac) and cache.meta[0] == nrow - 2
    ok3, fresh2 = tree_plan(rows, sub, nrow - 2, im, 5)
    for a, b in zip(solve(fresh2, sub, nrow - 2), solve(plan2, sub, nrow - 2)):
        np.testing.assert_array_equal(a, b)
    small = make_plan_cache(2, 5, 40)          # too small: a fresh plan, nothing cached
    ok4, plan4 = cached_tree_plan(small, rows, sel, nrow, im, 5)
    assert ok4 and small.meta[0] == -1 and plan4.fac.shape[0] > small.plan.fac.shape[0]


def pyramid_residual(rows, n, S, c, p):
    """How far ``p`` is from solving the mixed LCP on ``S p - c`` with the friction pyramid
    (mlcp.py): 0 for a solution. Unilateral rows: p >= 0, w >= 0, p w = 0; box rows
    inside their bounds with w = 0, or at a bound with w pushing into it; a friction group
    inside ``mu p_n`` with w = 0, or on it with ``w_i = -lambda sign(p_i)`` and
    ``|w_i| <= lambda`` where ``p_i = 0``."""
    w = S @ p - c
    # a row is at a bound, or a group slips, beyond the round-off of p and of S p - c
    at_tol = 1e-12 * max(1.0, np.abs(p).max())
    slip_tol = 1e-9 * (np.abs(c).max() + np.abs(S).max() * max(1.0, np.abs(p).max()))
    worst = 0.0
    groups = {}
    for i in range(n):
        if rows.parent[i] >= 0:
            groups.setdefault(rows.group[i], []).append(i)
        elif rows.hi[i] >= 0.5 * INF:
            worst = max(worst, -p[i], -w[i], abs(min(p[i], w[i])))
        else:
            F = rows.hi[i]
            worst = max(worst, abs(p[i]) - F)
            if p[i] >= F - at_tol:
                worst = max(worst, w[i])
            elif p[i] <= -F + at_tol:
                worst = max(worst, -w[i])
            else:
                worst = max(worst, abs(w[i]))
    for g, members in groups.items():
        bound = rows.mu[members[0]] * p[rows.parent[members[0]]]
        load = sum(abs(p[i]) for i in members)
        worst = max(worst, load - bound)
        lam = max(abs(w[i]) for i in members)
        for i in members:
            if abs(p[i]) > at_tol:
                worst = max(worst, abs(w[i] + lam * np.sign(p[i])))
        if lam > slip_tol:
            worst = max(worst, abs(load - bound))
    return worst


def scratch(n):
    """The work arrays ``guess.guessed_active_set`` takes after ``p``."""
    return np.arange(n), make_held_scratch(n), np.empty(n)


def contact_problem(rng, ncontact, nbox, nbody):
    """Rows of ``ncontact`` contacts (a normal and two tangents in one pyramid group) and
    ``nbox`` box rows, acting on ``nbody`` random bodies, and their ``S``, ``c``."""
    n = 3 * ncontact + nbox
    rows = make_rows_nb(n)
    for k in range(ncontact):
        r = 3 * k
        rows.lo[r], rows.hi[r] = 0.0, INF
        mu = rng.uniform(0.2, 1.0)               # one coefficient per contact, as the rows have
        for t in (1, 2):
            rows.parent[r + t], rows.group[r + t] = r, r + 1
            rows.mu[r + t] = mu
    for k in range(nbox):
        r = 3 * ncontact + k
        rows.lo[r] = -rng.uniform(0.1, 2.0)
        rows.hi[r] = -rows.lo[r]
    J = rng.normal(size=(n, 6 * nbody))
    S = J @ J.T + np.diag(10.0 ** rng.uniform(-8, -3, n))
    c = rng.normal(size=n) * 3.0
    return rows, n, S, c


def partitioned(rows, n):
    """The ``RowPartition`` of contact rows that are all active and none bilateral."""
    part = partition_rows(rows, n, np.zeros(6 * n, np.int64))
    assert (part.n, part.nb, part.nn) == (n, 0, n)
    np.testing.assert_array_equal(part.idx, np.arange(n))
    return part


@FAST
@given(seed=st.integers(0, 2**32 - 1), ncontact=st.integers(1, 6), nbox=st.integers(0, 2),
       nbody=st.integers(1, 3), guess=st.sampled_from(["right", "perturbed", "zero", "random"]))
# huge, sticking impulses on one body: the slip test must allow for the round-off of S p
@example(seed=327960338, ncontact=5, nbox=2, nbody=1, guess="right")
def test_guessed_active_set_solves_the_lcp(seed, ncontact, nbox, nbody, guess):
    """Whatever last step's impulses say, the complement's LCP gets a solution (to 1e-8
    of its scale); from the right guess the active-set path takes it without Lemke
    unless a contact slides, and matches Lemke's answer."""
    from tumble.pipeline.solvers import mlcp as ML
    rng = np.random.default_rng(seed)
    rows, n, S, c = contact_problem(rng, ncontact, nbox, nbody)
    part = partitioned(rows, n)
    scale = np.abs(c).max() + np.abs(S).max()
    p_ref = np.zeros(n)
    status = pyramid_lcp(rows, part, S, c, np.zeros(n), 0, False, p_ref)
    if status != 0:
        return                                       # (a failure Lemke reports; rare)
    assert pyramid_residual(rows, n, S, c, p_ref) <= 1e-8 * scale
    last = {"right": p_ref, "perturbed": p_ref * rng.uniform(0.5, 1.5, n),
            "zero": np.zeros(n), "random": rng.normal(size=n)}[guess]
    p = np.zeros(n)
    assert ML._lcp_on_schur(rows, part, S, c, last, 0, p, np.bool_(True)) == 0
    assert pyramid_residual(rows, n, S, c, p) <= 1e-8 * scale
    if guess == "right":
        state = np.zeros(n, np.int64)
        if guess_states(rows, part, p_ref, state, np.zeros(2 * n)):
            p2 = np.zeros(n)
            took = guessed_active_set(rows, part, S, c, state, p2, *scratch(n))
            if took:
                np.testing.assert_allclose(p2, p_ref, rtol=0,
                                           atol=1e-8 * max(1.0, np.abs(p_ref).max()))


@FAST
@given(seed=st.integers(0, 2**32 - 1), ncontact=st.integers(1, 5), nbody=st.integers(1, 3))
def test_a_sliding_guess_solves_as_lemke(seed, ncontact, nbody):
    """From Lemke's own solution, the guess with its sliding groups kept at their bound
    (``allow_bound``) solves to Lemke's impulses, with each group's slip rate ``lambda``
    >= 0 equal to ``-s w`` of its sliding rows; the guess without ``allow_bound`` declines
    any sliding group."""
    rng = np.random.default_rng(seed)
    rows, n, S, c = contact_problem(rng, ncontact, 0, nbody)
    part = partitioned(rows, n)
    p_ref = np.zeros(n)
    if pyramid_lcp(rows, part, S, c, np.zeros(n), 0, False, p_ref) != 0:
        return
    state = np.zeros(n, np.int64)
    assert guess_states(rows, part, p_ref, state, np.zeros(2 * n), True)
    sliding = (state == SLIDE_POS) | (state == SLIDE_NEG)
    if sliding.any():
        assert not guess_states(rows, part, p_ref, np.zeros(n, np.int64), np.zeros(2 * n))
    sub = np.flatnonzero(state != 0)
    hs = make_held_scratch(n)
    p = np.zeros(n)
    ok, _ = solve_held(rows, part, sub, len(sub), state, S[np.ix_(sub, sub)], c[sub], p, hs)
    if not ok:
        return                                       # dependent held rows: Lemke decides
    scale = max(1.0, np.abs(p_ref).max())
    np.testing.assert_allclose(p, p_ref, rtol=0, atol=1e-7 * scale)
    w = S @ p - c
    for t, a in enumerate(sub):
        if sliding[a]:
            sign = 1.0 if state[a] == SLIDE_POS else -1.0
            assert hs.lam[t] >= -1e-7 * (np.abs(c).max() + 1.0)
            assert -sign * w[a] == pytest.approx(hs.lam[t], abs=1e-7 * (np.abs(c).max() + 1.0))


def test_right_guess_skips_lemke():
    """Non-redundant contacts (fewer rows than degrees of freedom) guessed from their own
    solution are solved by the active-set path alone, unless one slides."""
    rng = np.random.default_rng(5)
    took = sliding = 0
    for _ in range(40):
        rows, n, S, c = contact_problem(rng, 2, 1, 3)
        part = partitioned(rows, n)
        p_ref = np.zeros(n)
        assert pyramid_lcp(rows, part, S, c, np.zeros(n), 0, False, p_ref) == 0
        state = np.zeros(n, np.int64)
        if not guess_states(rows, part, p_ref, state, np.zeros(2 * n)):
            sliding += 1
            continue
        p = np.zeros(n)
        assert guessed_active_set(rows, part, S, c, state, p, *scratch(n))
        took += 1
    assert took >= 10 and took + sliding == 40


# -- Coulomb friction on a jointed chain --------------------------------------------------

def sliding_chain(speed, mu=0.4):
    """Three balls joined by ball joints, resting on the ground in a row along y and
    pushed along x at ``speed`` m/s: one contact a ball,
    none redundant; they slide until friction has spun them up to roll."""
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", friction=mu)
    for i in range(3):
        b.add_body(f"b{i}", pos=(0.0, 0.3 * i, 0.1), mass=1.0 + 0.5 * i,
                   vel=(speed, 0.0, 0.0))
        b.add_geom(f"b{i}", "sphere", size=0.1, friction=mu)
    for i in range(2):
        b.add_joint(f"j{i}", "ball", f"b{i}", f"b{i + 1}", anchor=(0.0, 0.3 * i + 0.15, 0.1))
    return tumble.World(b.build(), dt=1 / 120)


def test_a_sliding_ball_decelerates_as_coulomb_says():
    """Balls sliding at 2 m/s with mu 0.1 lose mu g = 0.98 m/s every second until they
    roll (at 5/7 of their speed, after 0.58 s)."""
    world = sliding_chain(2.0, mu=0.1)
    world.step(12)
    v0 = world.body_vel[:, 0].mean()
    world.step(30)
    v1 = world.body_vel[:, 0].mean()
    assert (v0 - v1) / 0.25 == pytest.approx(0.1 * 9.81, rel=0.02)
