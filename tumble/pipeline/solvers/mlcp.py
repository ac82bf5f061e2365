"""Contacts and joints as one mixed LCP, solved exactly with Lemke's algorithm.

Rows (see ``joints/common.py``) fall into four kinds:

* bilateral (unbounded: joint rows, dampers) -- eliminated first by a direct solve,
  leaving the Schur complement ``S = A_NN - A_NB A_BB^-1 A_BN`` on the others;
* unilateral (``[0, inf)``: contact normals, joint limits) -- one LCP variable each;
* friction rows of a contact (bounds ``-+ mu p_n``) -- the friction pyramid of
  Stewart and Trinkle: each tangent row gives two variables ``beta+-`` (impulse
  ``beta+ - beta-``), and each group of rows (``rows.group``: a contact's two tangents,
  its two rolling rows, its torsional row alone) one slack ``lambda`` with
  ``w_beta+- = +-(row velocity) + lambda`` and ``w_lambda = mu p_n - sum(beta)``: four
  directions, the Coulomb cone's inscribed pyramid (two for a lone row: a box);
* symmetric box rows (``[-F, F]``: motors, dry joint friction) -- the same construction
  with the constant bound ``F``.

With ``p_N = G z`` the LCP is ``w = M z + q``, ``M = P S G`` plus the pyramid couplings.
Lemke's answer is exact up to round-off (see ``lemke.py``); the caller falls back to
PGS when Lemke reports failure, which it never hides.

When the bilateral rows form a tree (a character's joints) they are factorised in linear
time (``tree.py``) and the plan of that factorisation is kept across steps
(``PlanCache``). Before any pivoting, last step's contact state is tried as it stands
(``_guess_on_tree``): pushing contacts sticking, the others apart, ``S`` made only for
the rows it holds, from one column of the tree's factor per row, and the velocities
from one forward and one back substitution. Solved with the Cholesky factor of that
``S``, it is the LCP's answer whenever every other row passes the complementarity
checks, which is what a resting or walking character mostly meets. Otherwise ``S`` for
every row comes from the constrained inverse mass of the few bodies they touch
(``tree_body_inverse``: one 6x6 block per pair of those bodies instead of a path per
pair of rows), a few primal-dual corrections handle contacts that come or go
(``_guessed_active_set``), and anything else (a sliding contact, redundant contacts)
goes to Lemke.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from ..._jit import noalloc
from ..joints.common import INF
from .common import apply_impulses, minv_jt, row_velocity
from .direct import assemble, cholesky_apply, cholesky_factor, row_dot
from .lemke import LEMKE_INACCURATE, LEMKE_SOLVED, VERIFY_TOL as _VERIFY_TOL, lemke, lemke_warm
from .tree import (cached_tree_plan, make_plan_cache, plan_kept, tree_add_columns, tree_backward,
                   tree_body_inverse, tree_column_dot, tree_factor, tree_forward, tree_load,
                   tree_row_columns, tree_solve, tree_unload)

KIND_BILATERAL, KIND_UNILATERAL, KIND_FRICTION, KIND_BOX = 0, 1, 2, 3
_BIG = 0.5 * INF
# Feasibility slack of a guessed active set, relative to the problem's scale: a guess is
# the LCP's solution when every inequality holds to this (then p is exact to round-off).
_GUESS_TOL = 1e-10
# Primal-dual corrections of the guess before Lemke takes over.
_GUESS_ROUNDS = 4
# A pivot of the guess's Cholesky factor below this times its diagonal entry marks
# redundant rows (four coplanar contacts of a box): Lemke picks a basis instead.
_REDUNDANT = 1e-10


@njit(cache=True)
def solve_mlcp(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, max_pivots, cache):
    """Solve the rows exactly; apply the impulses. Returns Lemke's status (0: solved).

    ``max_pivots`` caps Lemke's pivots (<= 0: ten times the LCP size). ``cache``
    (``tree.make_plan_cache``) keeps the bilateral rows' tree plan from step to step.

    On failure nothing is applied and ``impulse`` is left as it came (warm start for
    the caller's fallback).
    """
    return mixed_lcp_cached(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse,
                            max_pivots, np.bool_(True), cache)


@njit(cache=True)
def mixed_lcp(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, max_pivots, allow_tree):
    """``solve_mlcp`` without a plan kept between calls; with ``allow_tree`` False the Schur
    complement is always formed densely (the reference the tree path is tested against)."""
    cache = make_plan_cache(np.int64(0), np.int64(vel.shape[0]), np.int64(0))
    return mixed_lcp_cached(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse,
                            max_pivots, allow_tree, cache)


@njit(cache=True)
def mixed_lcp_cached(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, max_pivots,
                     allow_tree, cache):
    """``mixed_lcp`` with the tree plan kept in ``cache``."""
    ints = np.empty(6 * nrow, np.int64)
    idx, where, kind = ints[:nrow], ints[nrow:2 * nrow], ints[2 * nrow:3 * nrow]
    bil, oth, bsel = ints[3 * nrow:4 * nrow], ints[4 * nrow:5 * nrow], ints[5 * nrow:]
    # (the impulses stay as they came until Lemke has solved: none is zeroed here)
    n, nb = _sort_rows(rows, nrow, idx, where, kind, bil, oth, bsel)
    if n == 0:
        return LEMKE_SOLVED
    nbody = vel.shape[0]
    nn = n - nb
    if allow_tree and nb > 0:
        ok, plan = cached_tree_plan(cache, rows, bsel, nb, inv_mass, nbody)
        if ok:
            cfm = np.empty(nb)
            for u in range(nb):
                cfm[u] = rows.cfm[bsel[u]]
                plan.use[u] = 1
            if tree_factor(plan, rows, bsel, cfm, inv_mass, inv_inertia, nbody):
                return _mlcp_tree(rows, nrow, idx, where, n, kind, bil, nb, oth, nn, bsel, plan,
                                  inv_mass, inv_inertia, vel, angvel, impulse, max_pivots)
    return _mlcp_dense(rows, nrow, idx, where, n, kind, bil, nb, oth, nn, inv_mass,
                       inv_inertia, vel, angvel, impulse, max_pivots)


# Scratch of ``guess_on_tree_fast`` for rows of a given capacity (``make_fast_scratch``).
FastScratch = namedtuple("FastScratch", [
    "ints",     # (8 rows,) int64: idx, where, kind, bil, oth, bsel, state, sub
    "floats",   # (7 rows + 6 nbody,) load (2 rows), cfm, p, b, g, y (rows each), vn (nbody, 6)
    "guess",    # GuessScratch for up to FAST_HELD held rows
])
# Held rows the fast path has room for; a step holding more takes the allocating path.
FAST_HELD = 48


@njit(cache=True)
def make_fast_scratch(nrow, nbody, cache):
    """Scratch for ``guess_on_tree_fast`` on rows of capacity ``nrow`` and ``cache``'s plan."""
    return FastScratch(np.zeros(8 * max(nrow, 1), np.int64), np.zeros(7 * max(nrow, 1) + 6 * nbody),
                       make_guess_scratch(np.int64(FAST_HELD), nbody, cache.plan))


# What guess_on_tree_fast reports.
FAST_SOLVED, FAST_NOT_HANDLED = 0, 1


@noalloc
def guess_on_tree_fast(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, cache, fs):
    """``solve_mlcp``'s common case without allocating (so without reference counting):
    the bilateral rows have a tree plan in ``cache`` already, it factorises, and last
    step's contact state solves the LCP (``_guess_on_tree``). Returns FAST_SOLVED with the
    impulses and velocities applied as ``solve_mlcp`` would, or FAST_NOT_HANDLED with
    ``vel``, ``angvel`` and ``impulse`` untouched (then call ``solve_mlcp``, which redoes
    the factorisation). ``fs``: ``make_fast_scratch`` for rows of capacity >= nrow."""
    nload = 2 * impulse.shape[0]            # _guess_states' slots: two per row of capacity
    if nrow == 0 or fs.ints.shape[0] < 8 * nrow or \
            fs.floats.shape[0] < nload + 5 * nrow + 6 * vel.shape[0]:
        return FAST_NOT_HANDLED
    ints = fs.ints
    idx, where, kind = ints[:nrow], ints[nrow:2 * nrow], ints[2 * nrow:3 * nrow]
    bil, oth, bsel = ints[3 * nrow:4 * nrow], ints[4 * nrow:5 * nrow], ints[5 * nrow:6 * nrow]
    n, nb = _sort_rows(rows, nrow, idx, where, kind, bil, oth, bsel)
    if n == 0 or nb == 0:
        return FAST_NOT_HANDLED
    nbody = vel.shape[0]
    plan = cache.plan
    if not plan_kept(cache, rows, bsel, nb):
        return FAST_NOT_HANDLED
    nn = n - nb
    fl = fs.floats
    load, rest = fl[:nload], fl[nload:]
    # each as long as in _mlcp_tree: the tree kernels read y's length
    cfm, p_n, b = rest[:nb], rest[nrow:nrow + nn], rest[2 * nrow:2 * nrow + n]
    g, y = rest[3 * nrow:3 * nrow + nb], rest[4 * nrow:4 * nrow + nb]
    vn = rest[5 * nrow:5 * nrow + 6 * nbody].reshape((nbody, 6))
    for u in range(nb):
        cfm[u] = rows.cfm[bsel[u]]
        plan.use[u] = 1
    if not tree_factor(plan, rows, bsel, cfm, inv_mass, inv_inertia, nbody):
        return FAST_NOT_HANDLED
    state, sub = ints[6 * nrow:6 * nrow + nn], ints[7 * nrow:7 * nrow + nn]
    if _guess_and_finish(rows, nrow, idx, where, n, kind, bil, nb, oth, nn, bsel, plan,
                         inv_mass, inv_inertia, vel, angvel, impulse, load, b, g, p_n, y, vn,
                         state, sub, fs.guess):
        return FAST_SOLVED
    return FAST_NOT_HANDLED


@noalloc
def _guess_and_finish(rows, nrow, idx, where, n, kind, bil, nb, oth, nn, bsel, plan, inv_mass,
                      inv_inertia, vel, angvel, impulse, load, b, g, p, y, vn, state, sub, gs):
    """The tree path's first try, shared by ``_mlcp_tree`` and ``guess_on_tree_fast``:
    ``b`` (n,) the active rows' right-hand side less their velocity and ``g`` (nb,) its
    bilateral part (both kept for the caller), then last step's contact state
    (``_guess_states``) solved and checked (``_guess_on_tree``, scratch ``gs``) and, when
    it solves the LCP, applied (``_finish``). False leaves ``vel``, ``angvel`` and
    ``impulse`` as they came (also when ``gs`` has no room for the held rows).
    load (2 row capacity,), p (nn,), y (nb,), vn (nbody, 6), state, sub (nn,) int64:
    scratch, any content on entry."""
    for a in range(nn):                     # only the slots _guess_states will sum into
        if kind[oth[a]] == KIND_FRICTION:
            load[_load_slot(rows, idx[oth[a]], impulse.shape[0])] = 0.0
    for i in range(n):
        b[i] = rows.rhs[idx[i]] - row_velocity(rows, idx[i], vel, angvel)
    for u in range(nb):
        g[u] = b[bil[u]]
    for a in range(nn):
        state[a] = 0
        p[a] = 0.0
    if not _guess_states(rows, idx, where, kind, oth, nn, impulse, state, load):
        return False
    ns = np.int64(0)
    for a in range(nn):
        if state[a] != _ZERO:
            sub[ns] = a
            ns += 1
    if ns > gs.rsel.shape[0]:
        return False
    if not _guess_on_tree(rows, idx, where, kind, oth, nn, sub, ns, state, b, g, plan,
                          inv_mass, inv_inertia, vel, angvel, p, vn, y, gs):
        return False
    _finish(rows, nrow, idx, oth, nn, bsel, nb, y, p, vn, vel, angvel, impulse)
    return True


@noalloc
def _sort_rows(rows, nrow, idx, where, kind, bil, oth, bsel):
    """One pass over the rows: the active ones (``solvers.common.row_active``) into
    ``idx``, their position among them into ``where`` (-1: inactive), their kind into
    ``kind``, the positions of the bilateral ones into ``bil`` and of the others into
    ``oth``, and the bilateral rows themselves into ``bsel``. All (nrow,) int64.
    Returns (active rows, bilateral rows)."""
    n = np.int64(0)
    nb = np.int64(0)
    no = np.int64(0)
    for r in range(nrow):
        lo, hi = rows.lo[r], rows.hi[r]
        if rows.parent[r] >= 0:
            k = KIND_FRICTION
        elif lo == 0.0 and hi == 0.0:
            where[r] = -1
            continue
        elif lo <= -_BIG and hi >= _BIG:
            k = KIND_BILATERAL
        elif lo == 0.0 and hi >= _BIG:
            k = KIND_UNILATERAL
        else:
            k = KIND_BOX
        idx[n] = r
        where[r] = n
        kind[n] = k
        if k == KIND_BILATERAL:
            bil[nb] = n
            bsel[nb] = r
            nb += 1
        else:
            oth[no] = n
            no += 1
        n += 1
    return n, nb


# ------------------------------------------------------------------- the tree path

@njit(cache=True)
def _mlcp_tree(rows, nrow, idx, where, n, kind, bil, nb, oth, nn, bsel, plan, inv_mass,
               inv_inertia, vel, angvel, impulse, max_pivots):
    """The mixed LCP with the bilateral rows factorised over their tree (``plan``).

    Last step's contact state is tried first on the rows it holds alone
    (``_guess_on_tree``). Only if that fails: one tree solve gives the bilateral rows'
    response to the current velocities (``u0``, and ``c = b_N - J_N u0``), ``S`` is
    assembled from the 6x6 blocks of the constrained inverse mass of the bodies the
    other rows touch, and after the LCP a second tree solve adds the response to its
    impulses ``p_N`` (``u1``), so the bodies' velocities change by ``u0 + u1`` and no
    row's response needs applying one by one."""
    nbody = vel.shape[0]
    nload = 2 * impulse.shape[0]
    # one zeroed block for the vectors below (few allocations: each costs about as much
    # as the arithmetic of a small one)
    floats = np.zeros(nload + nn + n + 2 * nb + 6 * nbody)
    load, p_n = floats[:nload], floats[nload:nload + nn]
    o = nload + nn
    b, g, y = floats[o:o + n], floats[o + n:o + n + nb], floats[o + n + nb:o + n + 2 * nb]
    o += n + 2 * nb
    vn = floats[o:o + 6 * nbody].reshape((nbody, 6))
    ints = np.zeros(2 * nn, np.int64)
    state, sub = ints[:nn], ints[nn:]
    if _guess_and_finish(rows, nrow, idx, where, n, kind, bil, nb, oth, nn, bsel, plan,
                         inv_mass, inv_inertia, vel, angvel, impulse, load, b, g, p_n, y, vn,
                         state, sub, make_guess_scratch(nn, nbody, plan)):
        return LEMKE_SOLVED
    u0 = np.zeros((nbody, 6))
    y0 = np.empty(nb)
    tree_solve(plan, nbody, u0, g, u0, y0)       # f = u0 = 0 on entry
    for a in range(nn):
        sub[a] = a
    S, cvec, slot, alone, dva = _complement(rows, idx, oth, sub, nn, b, plan, nb, inv_mass,
                                            inv_inertia, u0)
    status = _lcp_on_schur(rows, idx, where, kind, oth, nn, S, cvec, impulse, max_pivots, p_n)
    if status != LEMKE_SOLVED:
        return status
    _respond(rows, idx, oth, sub, nn, p_n, plan, nb, slot, alone, dva, vel, angvel, u0, vn, y)
    for u in range(nb):
        y[u] += y0[u]
    _finish(rows, nrow, idx, oth, nn, bsel, nb, y, p_n, vn, vel, angvel, impulse)
    return LEMKE_SOLVED


@njit(cache=True)
def _complement(rows, idx, oth, sub, ns, b, plan, nb, inv_mass, inv_inertia, u0):
    """``S`` and ``c`` of the non-bilateral rows ``oth[sub[:ns]]``: the bodies they touch,
    in the tree (``slot`` >= 0) or on their own (``alone``), those bodies' blocks of the
    constrained inverse mass, then ``_schur_blocks``. Returns (S, c, slot, alone, dva)."""
    nbody = u0.shape[0]
    slot = np.full(nbody, -1, np.int64)
    alone = np.zeros(nbody, np.bool_)
    cb = np.empty(nbody, np.int64)
    nc = np.int64(0)
    for t in range(ns):
        r = idx[oth[sub[t]]]
        for side in range(2):
            body = rows.body_a[r] if side == 0 else rows.body_b[r]
            if body < 0 or inv_mass[body] <= 0.0:
                continue
            if plan.dim[body] == 6:
                if slot[body] < 0:
                    slot[body] = nc
                    cb[nc] = body
                    nc += 1
            else:
                alone[body] = True
    G = np.empty((nc, nc, 6, 6))
    if nc > 0:
        tree_body_inverse(plan, cb, nc, nbody, np.zeros((nc, 6 * nbody + nb, 6)),
                          np.zeros((nc, nbody + nb), np.bool_), G)
    S = np.empty((ns, ns))
    cvec = np.empty(ns)
    dva = np.zeros((ns, 12))                     # M^-1 J^T, for the bodies on their own
    _schur_blocks(rows, idx, oth, sub, ns, slot, nc, alone, G, inv_mass, inv_inertia, u0, b,
                  np.zeros((ns, nc + 1, 6)), dva, S, cvec)
    return S, cvec, slot, alone, dva


@noalloc
def _respond(rows, idx, oth, sub, ns, p, plan, nb, slot, alone, dva, vel, angvel, u0, vn, y1):
    """The second tree solve: the bodies' velocities ``vn`` (nbody, 6) [linear, angular]
    once the rows ``oth[sub[:ns]]`` push with ``p`` (indexed like ``oth``) and the
    bilateral rows answer (their part in ``y1``, ``y = -p``); ``u0`` is the bilateral
    response to the velocities before."""
    nbody = vel.shape[0]
    for body in range(nbody):
        for k in range(6):
            vn[body, k] = 0.0
    _push(rows, idx, oth, sub, ns, p, alone, np.bool_(False), rows.J, vn)   # J^T p, the tree
    for u in range(nb):
        y1[u] = 0.0
    tree_solve(plan, nbody, vn, y1, vn, y1)
    for body in range(nbody):
        for k in range(3):
            vn[body, k] += vel[body, k] + u0[body, k]
            vn[body, 3 + k] += angvel[body, k] + u0[body, 3 + k]
    _push(rows, idx, oth, sub, ns, p, alone, np.bool_(True), dva, vn)   # M^-1 J^T p, the others


@noalloc
def _push(rows, idx, oth, sub, ns, p, alone, on_alone, per_row, out):
    """``out[body] += per_row[.., side] p`` for the rows ``oth[sub[:ns]]`` on the bodies that
    are (``on_alone``) or are not outside the tree; ``per_row`` is indexed by row (J) for
    the tree, by position in ``sub`` (dva) for the others."""
    for t in range(ns):
        a = sub[t]
        pa = p[a]
        if pa == 0.0:
            continue
        r = idx[oth[a]]
        q = t if on_alone else r
        for side in range(2):
            body = rows.body_b[r] if side else rows.body_a[r]
            if body >= 0 and alone[body] == on_alone:
                for k in range(6):
                    out[body, k] += per_row[q, 6 * side + k] * pa


@noalloc
def _finish(rows, nrow, idx, oth, nn, bsel, nb, y, p_n, vn, vel, angvel, impulse):
    """The new velocities ``vn`` into ``vel``, ``angvel``; every row's impulse (the
    bilateral rows' are ``-y``)."""
    for body in range(vel.shape[0]):
        for k in range(3):
            vel[body, k] = vn[body, k]
            angvel[body, k] = vn[body, 3 + k]
    for r in range(nrow):
        impulse[r] = 0.0
    for u in range(nb):
        impulse[bsel[u]] = -y[u]
    for c in range(nn):
        impulse[idx[oth[c]]] = p_n[c]


# Scratch of _guess_on_tree, for up to ``rows`` held rows (``make_guess_scratch``).
GuessScratch = namedtuple("GuessScratch", [
    "rsel",     # (rows,) int64 the held rows
    "alone",    # (nbody,) bool bodies outside the tree
    "dva",      # (rows, 12) M^-1 J^T of the rows on bodies outside the tree
    "H",        # (rows, plan z size) the rows' columns L^-1 J^T
    "member",   # (rows, plan nodes) bool nodes on each column's path
    "path",     # (rows, plan nodes) int64 those nodes, children first
    "plen",     # (rows,) int64 their number
    "S", "mat", "fac",                 # (rows, rows) S and _solve_held's matrix and factor
    "cvec", "rhs", "x", "pt",          # (rows,)
    "free",     # (rows,) int64
])


@njit(cache=True)
def make_guess_scratch(nheld, nbody, plan):
    """Scratch for ``_guess_on_tree`` with up to ``nheld`` held rows on ``plan``."""
    k = max(nheld, 1)
    nz, nnode = plan.z.shape[0], plan.opos.shape[0]
    # no need to zero: _guess_on_tree and tree_row_columns clear what they use
    return GuessScratch(np.empty(k, np.int64), np.empty(nbody, np.bool_), np.empty((k, 12)),
                        np.empty((k, nz)), np.empty((k, nnode), np.bool_),
                        np.empty((k, nnode), np.int64), np.empty(k, np.int64),
                        np.empty((k, k)), np.empty((k, k)), np.empty((k, k)), np.empty(k),
                        np.empty(k), np.empty(k), np.empty(k), np.empty(k, np.int64))


@noalloc
def _guess_on_tree(rows, idx, where, kind, oth, nn, sub, ns, state, b, g, plan, inv_mass,
                   inv_inertia, vel, angvel, p, vn, y, gs):
    """Last step's contact state (``state``, ``_guess_states``) solved with ``S`` of the
    rows it holds or fixes alone (``oth[sub[:ns]]``), and every other row checked against
    the velocities that follow: ``w = J v_new - rhs`` must not pull on a zero normal or
    limit, nor slip a zero friction row of a holding contact. True when ``p`` (nn,), the
    new velocities ``vn`` (nbody, 6) and the bilateral rows' ``y`` (nb,) solve the mixed
    LCP; False leaves the full complement to decide. ``gs`` (``make_guess_scratch``,
    room for at least ``ns`` rows) is scratch.

    One pass of the tree does it all: ``[0; g]`` (``g`` the bilateral rows' right-hand
    side) is forward substituted, each held row's column ``L^-1 J^T`` is made along its
    path (``tree_row_columns``) and gives its row of ``S`` and its ``c``, and once the
    impulses are known their columns are added and one back substitution gives the
    velocities. Bodies outside the tree answer with their own inverse mass."""
    nbody = vel.shape[0]
    rsel, alone, dva, H, member = gs.rsel, gs.alone, gs.dva, gs.H, gs.member
    path, plen, S, cvec = gs.path, gs.plen, gs.S, gs.cvec
    for body in range(nbody):
        alone[body] = False
    for t in range(ns):
        for k in range(12):
            dva[t, k] = 0.0
        for k in range(member.shape[1]):
            member[t, k] = False
    for t in range(ns):
        r = idx[oth[sub[t]]]
        rsel[t] = r
        for side in range(2):
            body = rows.body_b[r] if side else rows.body_a[r]
            if body >= 0 and inv_mass[body] > 0.0 and plan.dim[body] != 6:
                alone[body] = True
                minv_jt(rows, r, inv_mass, inv_inertia, dva[t])
    tree_load(plan, nbody, vn, np.bool_(False), g)
    tree_forward(plan, nbody)
    tree_row_columns(plan, nbody, rows, rsel, ns, H, member, path, plen)
    for t in range(ns):
        ra = rsel[t]
        cvec[t] = b[oth[sub[t]]] - tree_column_dot(plan, nbody, H, path, plen, t, plan.z,
                                                   member[t], np.bool_(False))
        for tb in range(t + 1):
            rb = rsel[tb]
            acc = tree_column_dot(plan, nbody, H, path, plen, t, H[tb], member[tb],
                                  np.bool_(True))
            for sb in range(2):
                body = rows.body_b[rb] if sb else rows.body_a[rb]
                if body < 0 or not alone[body]:
                    continue
                for sa in range(2):
                    if (rows.body_b[ra] if sa else rows.body_a[ra]) == body:
                        for k in range(6):
                            acc += rows.J[rb, 6 * sb + k] * dva[t, 6 * sa + k]
            S[t, tb] = acc
            S[tb, t] = acc
        S[t, t] += rows.cfm[ra]
    ok, pmax = _solve_held(rows, idx, oth, sub, ns, state, S, cvec, p, gs.free, gs.mat, gs.fac,
                           gs.rhs, gs.x)
    if not ok:
        return False
    cmax = 1e-300
    smax = 1e-300
    for t in range(ns):
        smax = max(smax, abs(S[t, t]))
        cmax = max(cmax, abs(cvec[t]))
    for a in range(nn):
        cmax = max(cmax, abs(b[oth[a]]))
    tol_w, tol_p = _slack(_GUESS_TOL, cmax, smax, pmax)
    if not _holding_ok(rows, idx, where, kind, oth, nn, state, p, tol_p):
        return False
    pt = gs.pt
    for t in range(ns):
        pt[t] = p[sub[t]]
    tree_add_columns(plan, H, path, plen, ns, pt)
    tree_backward(plan, nbody)
    tree_unload(plan, nbody, vn, y)
    for body in range(nbody):
        for k in range(3):
            vn[body, k] += vel[body, k]
            vn[body, 3 + k] += angvel[body, k]
    _push(rows, idx, oth, sub, ns, p, alone, np.bool_(True), dva, vn)   # the others
    for a in range(nn):
        st = state[a]
        if st == _EQUAL:
            continue
        i = oth[a]
        r = idx[i]
        w = rows.cfm[r] * p[a] - rows.rhs[r] + row_dot(rows, r, vn)
        k = kind[i]
        if k == KIND_UNILATERAL and w < -tol_w:
            return False
        if (st == _AT_HI and w > tol_w) or (st == _AT_LO and w < -tol_w):
            return False
        if k == KIND_FRICTION and abs(w) > tol_w:
            normal = _normal_of(rows, where, oth, nn, r)
            if normal >= 0 and state[normal] == _EQUAL:
                return False
    _clamp_round_off(kind, oth, nn, p)
    return True


@noalloc
def _solve_held(rows, idx, oth, sub, ns, state, S, cvec, p, free, mat, fac, rhs, x):
    """The impulses of the rows ``oth[sub[:ns]]`` in their ``state`` (indexed like
    ``oth``), ``S`` and ``c`` indexed by position in ``sub``: rows at a bound keep it,
    zero rows nothing, and the held rows solve ``S_HH p_H = c_H - S_HB p_B`` (Cholesky).
    Returns (ok, largest held impulse); ok is False for dependent held rows.
    free (ns,) int64, mat, fac (ns, ns), rhs, x (ns,) are scratch."""
    nf = np.int64(0)
    for t in range(ns):
        a = sub[t]
        r = idx[oth[a]]
        if state[a] == _EQUAL:
            free[nf] = t
            nf += 1
            p[a] = 0.0
        elif state[a] == _AT_HI:
            p[a] = rows.hi[r]
        elif state[a] == _AT_LO:
            p[a] = rows.lo[r]
        else:
            p[a] = 0.0
    for u in range(nf):
        t = free[u]
        acc = cvec[t]
        for v in range(ns):
            if state[sub[v]] == _AT_HI or state[sub[v]] == _AT_LO:
                acc -= S[t, v] * p[sub[v]]
        rhs[u] = acc
        for v in range(nf):
            mat[u, v] = S[t, free[v]]
    if not cholesky_factor(mat, nf, fac, _REDUNDANT):
        return False, 0.0
    cholesky_apply(fac, rhs, nf, x)
    pmax = 0.0
    for u in range(nf):
        p[sub[free[u]]] = x[u]
        pmax = max(pmax, abs(x[u]))
    return True, pmax


@njit(cache=True, inline="always")
def _slack(tol, cmax, smax, pmax):
    """(velocity, impulse) slack of the complementarity checks for a problem whose
    largest ``|c|``, diagonal of ``S`` and impulse are these: ``tol`` of its scale."""
    tol_w = tol * (cmax + smax * pmax)
    return tol_w, tol_w / smax


@noalloc
def _clamp_round_off(kind, oth, nn, p):
    """Normals and limits a hair below zero (round-off inside the slack) to zero."""
    for a in range(nn):
        if kind[oth[a]] == KIND_UNILATERAL and p[a] < 0.0:
            p[a] = 0.0


@noalloc
def _normal_of(rows, where, oth, nn, r):
    """Position in ``oth`` of friction row ``r``'s normal row (-1 if it is not there)."""
    pa = where[rows.parent[r]]
    for c in range(nn):
        if oth[c] == pa:
            return c
    return -1


@noalloc
def _group_load(rows, idx, oth, kind, nn, r, p):
    """Sum of |p| over the friction rows sharing friction row ``r``'s pyramid."""
    load = 0.0
    for c in range(nn):
        rc = idx[oth[c]]
        if kind[oth[c]] == KIND_FRICTION and (
                rc == r or (rows.group[r] >= 0 and rows.group[rc] == rows.group[r])):
            load += abs(p[c])
    return load


@noalloc
def _holding_ok(rows, idx, where, kind, oth, nn, state, p, tol_p):
    """Whether the held rows' impulses keep their bounds: normals and limits push, box
    rows stay inside, every friction group stays inside ``mu p_n``."""
    for a in range(nn):
        if state[a] != _EQUAL:
            continue
        i = oth[a]
        r = idx[i]
        k = kind[i]
        if k == KIND_UNILATERAL and p[a] < -tol_p:
            return False
        if k == KIND_BOX and (p[a] > rows.hi[r] + tol_p or p[a] < rows.lo[r] - tol_p):
            return False
        if k == KIND_FRICTION:
            normal = _normal_of(rows, where, oth, nn, r)
            bound = rows.mu[r] * max(p[normal], 0.0) if normal >= 0 else 0.0
            if _group_load(rows, idx, oth, kind, nn, r, p) > bound + tol_p:
                return False
    return True


@noalloc
def _schur_blocks(rows, idx, oth, sub, ns, slot, nc, alone, G, inv_mass, inv_inertia, u0, b,
                  resp, dva, S, cvec):
    """``S = J_N M_B^-1 J_N^T + C_N`` and ``c = b_N - J_N u0`` for the rows ``oth[sub[:ns]]``
    from the bodies' blocks ``G``. ``resp[t, s]`` is the velocity change of contact body
    slot ``s`` per unit impulse of row ``t`` (zero on entry); rows on a body outside the
    tree use that body's own inverse mass (``dva``)."""
    for t in range(ns):
        r = idx[oth[sub[t]]]
        for side in range(2):
            body = rows.body_a[r] if side == 0 else rows.body_b[r]
            if body < 0 or inv_mass[body] <= 0.0:
                continue
            if alone[body]:
                minv_jt(rows, r, inv_mass, inv_inertia, dva[t])
                continue
            sp = slot[body]
            o = 6 * side
            for q in range(nc):
                for i in range(6):
                    acc = 0.0
                    for k in range(6):
                        acc += G[q, sp, i, k] * rows.J[r, o + k]
                    resp[t, q, i] += acc
    for t in range(ns):
        ra = idx[oth[sub[t]]]
        for tb in range(t + 1):
            rb = idx[oth[sub[tb]]]
            acc = 0.0
            for side in range(2):
                body = rows.body_b[rb] if side else rows.body_a[rb]
                if body < 0 or inv_mass[body] <= 0.0:
                    continue
                o = 6 * side
                if alone[body]:
                    for sa in range(2):
                        other = rows.body_b[ra] if sa else rows.body_a[ra]
                        if other == body:
                            for k in range(6):
                                acc += rows.J[rb, o + k] * dva[t, 6 * sa + k]
                else:
                    q = slot[body]
                    for k in range(6):
                        acc += rows.J[rb, o + k] * resp[t, q, k]
            S[t, tb] = acc
            S[tb, t] = acc
        S[t, t] += rows.cfm[ra]
        cvec[t] = b[oth[sub[t]]] - row_dot(rows, ra, u0)


# ------------------------------------------------------------ the LCP on the complement

@njit(cache=True)
def _lcp_on_schur(rows, idx, where, kind, oth, nn, S, cvec, impulse, max_pivots, p_n):
    """Impulses ``p_n`` (nn,) of the non-bilateral rows: ``S p_N - c`` complementary to the
    rows' bounds. Tries last step's contact state first (``_guessed_active_set``), then
    Lemke on the friction-pyramid LCP. Returns Lemke's status."""
    state = np.zeros(nn, np.int64)
    if _guess_states(rows, idx, where, kind, oth, nn, impulse, state,
                     np.zeros(2 * impulse.shape[0])):
        if _guessed_active_set(rows, idx, where, kind, oth, nn, S, cvec, state, p_n,
                               np.arange(nn), np.empty(nn, np.int64), np.empty((nn, nn)),
                               np.empty((nn, nn)), np.empty(nn), np.empty(nn), np.empty(nn)):
            return LEMKE_SOLVED
        return _pyramid_lcp(rows, idx, where, kind, oth, nn, S, cvec, impulse, max_pivots,
                            np.bool_(False), p_n)
    return _pyramid_lcp(rows, idx, where, kind, oth, nn, S, cvec, impulse, max_pivots,
                        np.bool_(True), p_n)


# states of a row in a guessed active set
_ZERO, _EQUAL, _AT_LO, _AT_HI = 0, 1, 2, 3


@noalloc
def _guess_states(rows, idx, where, kind, oth, nn, impulse, state, load):
    """Each row's state from last step's impulses: a pushing normal or limit holds
    (``_EQUAL``), others are zero; a friction row of a pushing contact holds if it
    carried impulse, else stays zero (sticking contacts of one body are redundant in
    their tangents, and Lemke's basis keeps only some of them); a box row inside its
    bounds holds, at a bound it is fixed there. False if some friction group was at its
    bound (a sliding contact): the guess cannot express it. ``load`` (2 nrow,) zero on
    entry: scratch for the groups' loads."""
    for a in range(nn):
        i = oth[a]
        r = idx[i]
        k = kind[i]
        if k == KIND_UNILATERAL:
            state[a] = _EQUAL if impulse[r] > 0.0 else _ZERO
        elif k == KIND_BOX:
            if impulse[r] >= rows.hi[r] * (1.0 - 1e-9) and rows.hi[r] > 0.0:
                state[a] = _AT_HI
            elif impulse[r] <= rows.lo[r] * (1.0 - 1e-9) and rows.lo[r] < 0.0:
                state[a] = _AT_LO
            else:
                state[a] = _EQUAL
        elif k == KIND_FRICTION:
            # |impulse| summed over each friction pyramid (a lone row: its own slot)
            load[_load_slot(rows, r, impulse.shape[0])] += abs(impulse[r])
    for a in range(nn):
        i = oth[a]
        if kind[i] != KIND_FRICTION:
            continue
        r = idx[i]
        pn = impulse[rows.parent[r]]
        if pn <= 0.0 or where[rows.parent[r]] < 0:
            state[a] = _ZERO
            continue
        if load[_load_slot(rows, r, impulse.shape[0])] >= rows.mu[r] * pn * (1.0 - 1e-9):
            return False
        state[a] = _EQUAL if impulse[r] != 0.0 else _ZERO
    return True


@njit(cache=True, inline="always")
def _load_slot(rows, r, nrow):
    """Friction row ``r``'s slot in a groups' load array (2 nrow,): its group's, or its
    own past ``nrow`` when it has none."""
    return rows.group[r] if rows.group[r] >= 0 else nrow + r


@noalloc
def _guessed_active_set(rows, idx, where, kind, oth, nn, S, cvec, state, p, every, free, mat,
                        fac, rhs, x, w):
    """Solve the rows in ``state`` and check complementarity; on failure correct the
    states (a normal pulling lets go, a row moving into its bound holds) and retry, up
    to ``_GUESS_ROUNDS`` times. True when ``p`` (nn,) solves the mixed LCP, every
    inequality holding to ``_GUESS_TOL`` of the problem's scale. ``every`` (nn,) int64
    holds 0 .. nn-1; free (nn,) int64, mat, fac (nn, nn), rhs, x, w (nn,) are scratch."""
    cmax = 1e-300
    smax = 1e-300
    for a in range(nn):
        cmax = max(cmax, abs(cvec[a]))
        smax = max(smax, abs(S[a, a]))
    for it in range(_GUESS_ROUNDS):
        ok, pmax = _solve_held(rows, idx, oth, every, nn, state, S, cvec, p, free, mat, fac,
                               rhs, x)
        if not ok:
            return False
        for a in range(nn):
            if state[a] == _EQUAL:
                w[a] = 0.0
                continue
            s = -cvec[a]
            for c in range(nn):
                if p[c] != 0.0:
                    s += S[a, c] * p[c]
            w[a] = s
        tol_w, tol_p = _slack(_GUESS_TOL, cmax, smax, pmax)
        changed = False
        for a in range(nn):
            i = oth[a]
            r = idx[i]
            k = kind[i]
            st = state[a]
            if k == KIND_UNILATERAL:
                if st == _EQUAL and p[a] < -tol_p:
                    state[a] = _ZERO
                    changed = True
                elif st == _ZERO and w[a] < -tol_w:
                    state[a] = _EQUAL
                    changed = True
            elif k == KIND_BOX:
                if st == _EQUAL and p[a] > rows.hi[r] + tol_p:
                    state[a] = _AT_HI
                    changed = True
                elif st == _EQUAL and p[a] < rows.lo[r] - tol_p:
                    state[a] = _AT_LO
                    changed = True
                elif (st == _AT_HI and w[a] > tol_w) or (st == _AT_LO and w[a] < -tol_w):
                    state[a] = _EQUAL
                    changed = True
        # friction: rows of a released normal are zero; a zero row of a holding normal
        # must not slip (else it holds too); a group outside its pyramid is sliding,
        # which this method does not do
        for a in range(nn):
            i = oth[a]
            if kind[i] != KIND_FRICTION:
                continue
            r = idx[i]
            normal = _normal_of(rows, where, oth, nn, r)
            holding = normal >= 0 and state[normal] == _EQUAL
            if not holding:
                if state[a] != _ZERO:
                    state[a] = _ZERO
                    changed = True
            elif state[a] == _ZERO:
                if abs(w[a]) > tol_w:
                    state[a] = _EQUAL
                    changed = True
            elif not changed and (_group_load(rows, idx, oth, kind, nn, r, p)
                                  > rows.mu[r] * max(p[normal], 0.0) + tol_p):
                return False
        if not changed:
            _clamp_round_off(kind, oth, nn, p)
            return True
    return False


@njit(cache=True)
def _pyramid_lcp(rows, idx, where, kind, oth, nn, S, cvec, impulse, max_pivots, warm, p_n):
    """Lemke on the friction-pyramid LCP of ``S``, ``c`` (module docstring); with ``warm``
    last step's active set is tried first (``lemke_warm``). ``p_n`` (nn,) out.
    Returns Lemke's status."""
    # LCP variables: one per unilateral row, two per friction/box row, one slack per group
    var_row = np.empty(3 * nn, np.int64)       # position in oth
    var_sign = np.zeros(3 * nn)                # +1 / -1 impulse sign; 0 for slacks
    group_of = np.full(nn, -1, np.int64)       # slack variable of each friction/box row
    nz = np.int64(0)
    for i in range(nn):
        if kind[oth[i]] == KIND_UNILATERAL:
            var_row[nz], var_sign[nz] = i, 1.0
            nz += 1
    for i in range(nn):
        if kind[oth[i]] == KIND_FRICTION or kind[oth[i]] == KIND_BOX:
            var_row[nz], var_sign[nz] = i, 1.0
            var_row[nz + 1], var_sign[nz + 1] = i, -1.0
            nz += 2
    # slack per friction group (rows of one contact sharing a pyramid) or per box row
    for i in range(nn):
        k = kind[oth[i]]
        if k != KIND_FRICTION and k != KIND_BOX:
            continue
        if k == KIND_FRICTION:
            group = rows.group[idx[oth[i]]]
            for j in range(i):
                if group >= 0 and kind[oth[j]] == KIND_FRICTION and \
                        rows.group[idx[oth[j]]] == group:
                    group_of[i] = group_of[j]
                    break
        if group_of[i] < 0:
            var_row[nz], var_sign[nz] = i, 0.0
            group_of[i] = nz
            nz += 1
    M = np.zeros((nz, nz))
    q = np.zeros(nz)
    for a in range(nz):
        sa = var_sign[a]
        if sa == 0.0:
            continue
        ia = var_row[a]
        q[a] = -sa * cvec[ia]
        for c in range(nz):
            sc = var_sign[c]
            if sc != 0.0:
                M[a, c] = sa * S[ia, var_row[c]] * sc
        if kind[oth[ia]] != KIND_UNILATERAL:
            M[a, group_of[ia]] += 1.0                       # + lambda
            M[group_of[ia], a] -= 1.0                       # bound - sum(beta)
    for a in range(nz):                                      # the bounds of each slack
        if var_sign[a] != 0.0:
            continue
        i = var_row[a]
        r = idx[oth[i]]
        if kind[oth[i]] == KIND_BOX:
            q[a] = rows.hi[r]
        else:
            pn = where[rows.parent[r]]                       # the normal row, active index
            for c in range(nz):
                if var_sign[c] == 1.0 and oth[var_row[c]] == pn and kind[pn] == KIND_UNILATERAL:
                    M[a, c] += rows.mu[r]
                    break
    z = np.zeros(nz)
    pivots = max_pivots if max_pivots > 0 else 10 * (nz + 1)
    if warm:
        guess = _active_guess(rows, idx, oth, kind, var_row, var_sign, group_of, nz, impulse)
        status, _ = lemke_warm(M, q, guess, pivots, 1e-12, z)
    else:
        status, _ = lemke(M, q, pivots, 1e-12, z)
    if status != LEMKE_SOLVED:
        return status
    for i in range(nn):
        p_n[i] = 0.0
    for a in range(nz):
        if var_sign[a] != 0.0:
            p_n[var_row[a]] += var_sign[a] * z[a]
    # Lemke verifies its residual relative to the size of z; a basis that pairs two huge,
    # cancelling halves of a friction row passes that and is still wrong, so the impulses
    # are checked once more against the rows themselves
    if not _complementary(rows, idx, where, kind, oth, nn, S, cvec, p_n, _VERIFY_TOL,
                          np.empty(nn)):
        return LEMKE_INACCURATE
    return LEMKE_SOLVED


@noalloc
def _complementary(rows, idx, where, kind, oth, nn, S, cvec, p, tol, w):
    """Whether ``p`` solves the mixed LCP of ``S p - c`` (module docstring) to ``tol``
    of the problem's scale: normals and limits push or let go, box rows keep their
    bounds, each friction group stays in its pyramid and slips only on its edge, against
    the direction of its impulse. ``w`` (nn,) is scratch."""
    cmax = 1e-300
    smax = 1e-300
    pmax = 0.0
    for a in range(nn):
        cmax = max(cmax, abs(cvec[a]))
        smax = max(smax, abs(S[a, a]))
        pmax = max(pmax, abs(p[a]))
    for a in range(nn):
        acc = -cvec[a]
        for c in range(nn):
            acc += S[a, c] * p[c]
        w[a] = acc
    tol_w, tol_p = _slack(tol, cmax, smax, pmax)
    for a in range(nn):
        i = oth[a]
        r = idx[i]
        k = kind[i]
        if k == KIND_UNILATERAL:
            if p[a] < -tol_p or w[a] < -tol_w or min(p[a] * smax, w[a]) > tol_w:
                return False
        elif k == KIND_BOX:
            if p[a] > rows.hi[r] + tol_p or p[a] < rows.lo[r] - tol_p:
                return False
            if p[a] < rows.hi[r] - tol_p and p[a] > rows.lo[r] + tol_p and abs(w[a]) > tol_w:
                return False
            if (p[a] >= rows.hi[r] - tol_p and w[a] > tol_w) or \
                    (p[a] <= rows.lo[r] + tol_p and w[a] < -tol_w):
                return False
        else:
            normal = _normal_of(rows, where, oth, nn, r)
            bound = rows.mu[r] * max(p[normal], 0.0) if normal >= 0 else 0.0
            load = 0.0
            lam = 0.0                   # the group's slip: the largest slip of its rows
            for c in range(nn):
                rc = idx[oth[c]]
                if kind[oth[c]] == KIND_FRICTION and (
                        c == a or (rows.group[r] >= 0 and rows.group[rc] == rows.group[r])):
                    load += abs(p[c])
                    lam = max(lam, abs(w[c]))
            if load > bound + tol_p:
                return False
            if abs(p[a]) > tol_p and abs(w[a] + (lam if p[a] > 0.0 else -lam)) > tol_w:
                return False
            if lam > tol_w and load < bound - tol_p:
                return False
    return True


@njit(cache=True)
def _active_guess(rows, idx, oth, kind, var_row, var_sign, group_of, nz, impulse):
    """Which LCP variables the warm-start impulses (last step's, carried by each contact
    and joint row) say are positive: a pushing normal or limit, the signed half of a
    friction or box row that carries impulse, and the slack of a group at its bound (a
    sliding contact, a saturated motor). While the contacts keep their state this is
    the answer, and Lemke's path is skipped (see ``lemke_warm``)."""
    guess = np.zeros(nz, np.bool_)
    load = np.zeros(nz)                  # per slack: the impulse its group carries
    for a in range(nz):
        i = var_row[a]
        r = idx[oth[i]]
        if var_sign[a] != 0.0:
            guess[a] = var_sign[a] * impulse[r] > 0.0
            if kind[oth[i]] != KIND_UNILATERAL and var_sign[a] > 0.0:
                load[group_of[i]] += abs(impulse[r])
    for a in range(nz):
        if var_sign[a] != 0.0:
            continue
        r = idx[oth[var_row[a]]]
        if kind[oth[var_row[a]]] == KIND_BOX:
            bound = rows.hi[r]
        else:
            bound = rows.mu[r] * impulse[rows.parent[r]]
        guess[a] = bound > 0.0 and load[a] >= bound * (1.0 - 1e-9)
    return guess


# ------------------------------------------------------------- the dense path (loops)

@njit(cache=True)
def _mlcp_dense(rows, nrow, idx, where, n, kind, bil, nb, oth, nn, inv_mass, inv_inertia,
                vel, angvel, impulse, max_pivots):
    """The mixed LCP with the Schur complement from the dense ``A`` (joints in loops)."""
    dv = np.zeros((n, 12))
    A = np.zeros((n, n))
    b = np.zeros(n)
    assemble(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, A, b)
    S = np.empty((nn, nn))
    cvec = np.empty(nn)
    X = np.zeros((nb, nn + 1))                  # A_BB^-1 [A_BN | b_B]
    if not _schur_dense(A, b, bil, nb, oth, nn, X, S, cvec):
        return 3
    p_n = np.zeros(nn)
    status = _lcp_on_schur(rows, idx, where, kind, oth, nn, S, cvec, impulse, max_pivots, p_n)
    if status != LEMKE_SOLVED:
        return status
    p = np.zeros(n)
    for j in range(nn):
        p[oth[j]] = p_n[j]
    for u in range(nb):
        s = X[u, nn]
        for j in range(nn):
            s -= X[u, j] * p_n[j]
        p[bil[u]] = s
    for r in range(nrow):
        impulse[r] = 0.0
    for i in range(n):
        impulse[idx[i]] = p[i]
    apply_impulses(rows, idx, n, dv, p, vel, angvel)
    return LEMKE_SOLVED


@njit(cache=True)
def _schur_dense(A, b, bil, nb, oth, nn, X, S, cvec):
    """The Schur complement of ``A``'s bilateral block: one Cholesky factorisation of
    ``A_BB``, then a solve per column. False if it is not positive definite."""
    Abb = np.empty((nb, nb))
    for u in range(nb):
        for v in range(nb):
            Abb[u, v] = A[bil[u], bil[v]]
    work = np.zeros((nb, nb))
    if not cholesky_factor(Abb, nb, work):
        return False
    col = np.empty(nb)
    x = np.empty(nb)
    for c in range(nn + 1):
        for u in range(nb):
            col[u] = A[bil[u], oth[c]] if c < nn else b[bil[u]]
        cholesky_apply(work, col, nb, x)
        for u in range(nb):
            X[u, c] = x[u]
    for i in range(nn):
        for j in range(nn):
            s = A[oth[i], oth[j]]
            for u in range(nb):
                s -= A[oth[i], bil[u]] * X[u, j]
            S[i, j] = s
        s = b[oth[i]]
        for u in range(nb):
            s -= A[oth[i], bil[u]] * X[u, nn]
        cvec[i] = s
    return True
