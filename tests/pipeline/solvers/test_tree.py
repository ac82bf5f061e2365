"""The linear-time tree factorisation against dense linear algebra.

Rows are random (random Jacobians, CFM, bounds) on random body trees, so every
configuration of the graph is met: chains hanging from the world, several world-rooted
parts, free-floating parts, kinematic bodies, several joints between one pair, rows on
the ground alone. The tree path must give the dense path's impulses to 1e-9 (relative
to the largest impulse) and the same number of active-set iterations; graphs with loops
must be refused by the planner and still solved (densely).
"""
import numpy as np
from hypothesis import given, settings, strategies as st

import tumble
from bench import tumble_scenes
from tumble.pipeline import step as pipeline_step
from tumble.pipeline.contacts.rows import build_contact_rows
from tumble.pipeline.joints.common import INF
from tumble.pipeline.joints.rows import build_joint_rows
from tumble.pipeline.joints.servo import JointDrive
from tumble.pipeline.solvers.common import make_rows_nb, world_inverse_inertia
from tumble.pipeline.solvers.direct import solve_active_set
from tumble.pipeline.solvers.mlcp import mixed_lcp
from tumble.pipeline.solvers.tree import (tree_factor, tree_inverse_mass_rows, tree_plan,
                                         tree_solve)

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
    m, s, o = world.model.arrays, world._state, world._options()
    pos, quat, vel, angvel = s.body_pos[0], s.body_quat[0], s.body_vel[0], s.body_angvel[0]
    ncon = int(s.contact_count[0]) if contacts else 0
    nrow = world.model.nrow + 3 * ncon
    rows, imp = make_rows_nb(nrow), np.zeros(nrow)
    drive = JointDrive(s.motor_target[0], s.pd_kp[0], s.pd_kd[0], s.pd_max[0],
                       s.pd_target_quat[0], s.pd_target_q[0], s.pd_target_qd[0],
                       s.joint_applied[0])
    build_joint_rows(m, pos, quat, vel, angvel, drive, world.dt, o.erp, o.cfm, rows, True)
    if ncon:
        cw = pipeline_step.ContactArrays(*[a[0] for a in world._contacts])
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
    world = tumble.World(tumble_scenes.chain())
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
    """The benchmark ragdoll on the ground: Schur complement over its joint tree."""
    world = tumble.World(tumble_scenes.ragdoll(600))
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
            assert_same(*out)
            seen += nrow > world.model.nrow
    assert seen > 0                                      # contacts were present


@FAST
@given(seed=st.integers(0, 2**32 - 1), nb=st.integers(2, 10), extra=st.integers(0, 3))
def test_inverse_mass_of_jointed_bodies_matches_numpy(seed, nb, extra):
    """``J_N M_B^-1 J_N^T`` from the root paths equals the dense Schur complement
    ``J_N (M^-1 - M^-1 J_B^T A_BB^-1 J_B M^-1) J_N^T``, for contact-like rows between
    any two bodies, the ground, and ``extra`` free bodies outside the tree."""
    rng = np.random.default_rng(seed)
    parents = [-1] + [int(rng.integers(0, i)) for i in range(1, nb)] + [None] * extra
    rows, nrow, im, ii = random_system(rng, parents, bounds=False)
    nbody = nb + extra
    ncol = int(rng.integers(1, 8))
    cols = make_rows_nb(ncol)
    for c in range(ncol):
        a, b = rng.choice(np.arange(-1, nbody), size=2, replace=False)
        cols.body_a[c], cols.body_b[c] = a, b
        cols.J[c] = rng.normal(size=12)
    Minv = np.zeros((6 * nbody, 6 * nbody))
    for b in range(nbody):
        Minv[6 * b:6 * b + 3, 6 * b:6 * b + 3] = im[b] * np.eye(3)
        Minv[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = ii[b]

    def jac(rs, count):
        J = np.zeros((count, 6 * nbody))
        for r in range(count):
            for side, body in ((0, rs.body_a[r]), (1, rs.body_b[r])):
                if body >= 0:
                    J[r, 6 * body:6 * body + 6] += rs.J[r, 6 * side:6 * side + 6]
        return J
    JB, JN = jac(rows, nrow), jac(cols, ncol)
    ABB = JB @ Minv @ JB.T + np.diag(rows.cfm)
    MB = Minv - Minv @ JB.T @ np.linalg.solve(ABB, JB @ Minv)
    expected = JN @ MB @ JN.T
    # the tree solver sees both row sets in one Rows: bilateral first, then the others
    allrows = make_rows_nb(nrow + ncol)
    for field, src_b, src_n in zip(allrows, rows, cols):
        field[:nrow] = src_b
        field[nrow:] = src_n
    sel = np.arange(nrow)
    ok, plan = tree_plan(allrows, sel, nrow, im, nbody)
    assert ok and tree_factor(plan, allrows, sel, rows.cfm.copy(), im, ii, nbody)
    dv = (Minv @ JN.T).T                                  # M^-1 J^T of each column row...
    dvc = np.zeros((ncol, 12))                            # ...as the solver stores it
    for c in range(ncol):
        for side, body in ((0, cols.body_a[c]), (1, cols.body_b[c])):
            if body >= 0:
                dvc[c, 6 * side:6 * side + 6] = dv[c, 6 * body:6 * body + 6]
    nnode = nbody + nrow
    out = np.zeros((ncol, ncol))
    tree_inverse_mass_rows(plan, allrows, np.arange(nrow, nrow + ncol), ncol, dvc, nbody,
                           np.zeros((ncol, 6 * nbody + nrow)), np.zeros((ncol, nnode), bool),
                           np.zeros((ncol, nnode), np.int64), np.zeros(ncol, np.int64), out)
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
