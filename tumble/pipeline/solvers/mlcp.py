"""Contacts and joints as one mixed LCP, solved exactly with Lemke's algorithm.

The rows are sorted by kind once (``partition.py``): bilateral rows (joints, dampers)
are eliminated first by a direct solve, leaving the Schur complement
``S = A_NN - A_NB A_BB^-1 A_BN`` on the others (``schur.py``): contact normals and joint
limits (``[0, inf)``), friction rows (``-+ mu p_n``) and box rows (motors, dry joint
friction), whose LCP takes the friction pyramid of Stewart and Trinkle (``pyramid.py``).
Lemke's answer is exact up to round-off (see ``lemke.py``); the caller falls back to PGS
when Lemke reports failure, which it never hides.

When the bilateral rows form a tree (a character's joints) they are factorised in linear
time (``tree.py``) and the plan of that factorisation is kept across steps
(``PlanCache``). Before any pivoting, last step's contact state is tried as it stands on
the tree (``guess.guess_on_tree``), which is the LCP's answer whenever every other row
passes the complementarity checks -- what a resting character mostly meets. When it is
not (a walking foot that starts or stops sliding, a corner that lands or lifts), up to
``schur_pgs.SWEEP_ROWS`` rows get ``S`` from their tree columns and the state that sweeps
of Gauss-Seidel on it find, solved exactly and checked (``schur_pgs.py``);
``guess_on_tree_fast`` does all that without allocating. Otherwise ``S`` for every row
comes from the constrained inverse mass of the few bodies they touch
(``schur.complement``), a few primal-dual corrections handle contacts that come or go
(``guess.guessed_active_set``), then the sweeps. Sliding contacts are held at their
pyramid's bound, and a dependent row of redundant contacts (a box face's fourth) is
dropped from the held system (``direct.cholesky_factor_dropping``) when the others
satisfy it; anything else goes to Lemke. Where Lemke fails on a small problem (a few
redundant contacts without CFM can end its pivots in a nearly singular basis), it runs
once more with a slight compliance on the contact rows (``_regularised_lcp``).
"""
from collections import namedtuple

import numpy as np
from numba import njit

from ..._jit import noalloc
from .common import Bodies, apply_impulses, row_velocity
from .direct import assemble
from .guess import (ZERO, guess_on_tree, guess_states, guessed_active_set, make_guess_scratch,
                    make_held_scratch, tree_work)
from .lemke import LEMKE_BAD_INPUT, LEMKE_INACCURATE, LEMKE_RAY, LEMKE_SOLVED, LEMKE_TOO_LARGE
from .partition import KIND_FRICTION, KIND_UNILATERAL, load_slot, partition_rows
from .pyramid import pyramid_lcp
from .schur import complement, respond, schur_dense
from .schur_pgs import SWEEP_ROWS, schur_pgs_exact, sweep_on_tree
from .tree import cached_tree_plan, make_plan_cache, plan_kept, tree_factor, tree_solve


# Most contact, limit and box rows solved exactly. The exact path is dense in them (their
# Schur complement, Lemke's tableau of up to three variables a row, O(n^3) pivoting): the
# 210-box pyramid's 4,800 rows took 6.5 s and 2.6 GB for one step. Above this the caller's
# fallback (PGS) stands in at once, and nothing is allocated.
EXACT_MAX_ROWS = 512
# When Lemke fails on at most this many contact, limit and box rows (where a second try
# costs tens of microseconds, not the milliseconds of a character lying in a heap), it
# runs once more with the contact and limit rows given a compliance of REGULARISED_CFM of
# the largest diagonal entry of S (``_regularised_lcp``). Measured on the passive bench
# ragdoll landing at 600 Hz (no CFM anywhere): PGS stood in on 26 of 1,800 steps before,
# none with it; 1e-7 and 1e-6 left 17 and 6.
REGULARISED_ROWS = 48
REGULARISED_CFM = 1e-5


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@njit(cache=True, inline="always")
def solve_mlcp(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, max_pivots, cache,
               guess=True):
    """Solve the rows exactly; apply the impulses. Returns Lemke's status (0: solved).

    ``max_pivots`` caps Lemke's pivots (<= 0: ten times the LCP size). ``cache``
    (``tree.make_plan_cache``) keeps the bilateral rows' tree plan from step to step.
    ``guess`` False skips the first try on the tree (last step's contact state), for a
    caller whose ``guess_on_tree_fast`` already tried it (FAST_GUESS_FAILED).

    On failure nothing is applied and ``impulse`` is left as it came (warm start for
    the caller's fallback). LEMKE_TOO_LARGE, without trying, for more than
    ``EXACT_MAX_ROWS`` contact, limit and box rows.
    """
    return mixed_lcp_cached(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse,
                            max_pivots, np.bool_(True), cache, guess)


@njit(cache=True)
def mixed_lcp(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, max_pivots, allow_tree):
    """``solve_mlcp`` without a plan kept between calls; with ``allow_tree`` False the Schur
    complement is always formed densely (the reference the tree path is tested against)."""
    cache = make_plan_cache(np.int64(0), np.int64(vel.shape[0]), np.int64(0))
    return mixed_lcp_cached(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse,
                            max_pivots, allow_tree, cache, np.bool_(True))


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@njit(cache=True, inline="always")
def mixed_lcp_cached(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, max_pivots,
                     allow_tree, cache, guess):
    """``mixed_lcp`` with the tree plan kept in ``cache`` (``guess``: see solve_mlcp)."""
    # (the impulses stay as they came until Lemke has solved: none is zeroed here)
    part = partition_rows(rows, nrow, np.empty(6 * nrow, np.int64))
    if part.n == 0:
        return LEMKE_SOLVED
    if part.nn > EXACT_MAX_ROWS:
        return LEMKE_TOO_LARGE
    bodies = Bodies(inv_mass, inv_inertia, vel, angvel)
    if allow_tree and part.nb > 0:
        ok, plan = cached_tree_plan(cache, rows, part.bsel, part.nb, inv_mass, vel.shape[0])
        if ok and _factor_tree(rows, part, plan, bodies, np.empty(part.nb)):
            return _mlcp_tree(rows, part, plan, bodies, impulse, max_pivots, guess)
    return _mlcp_dense(rows, part, bodies, impulse, max_pivots)


@noalloc
def _factor_tree(rows, part, plan, bodies, cfm):
    """``tree_factor`` of every bilateral row of ``part`` on ``plan``; ``cfm`` (nb,) out."""
    for u in range(part.nb):
        cfm[u] = rows.cfm[part.bsel[u]]
        plan.use[u] = 1
    return tree_factor(plan, rows, part.bsel, cfm, bodies.inv_mass, bodies.inv_inertia,
                       bodies.vel.shape[0])


# Scratch of ``guess_on_tree_fast`` for rows of a given capacity (``make_fast_scratch``).
FastScratch = namedtuple("FastScratch", [
    "ints",     # (8 rows,) int64: the RowPartition (6 rows), then TreeWork's state and sub
    "floats",   # (7 rows + 6 nbody,): the bilateral rows' cfm (rows), then TreeWork's vectors
    "guess",    # GuessScratch for up to FAST_HELD held rows
])
# Held rows the fast path has room for; a step holding more takes the allocating path.
FAST_HELD = 48


@njit(cache=True)
def make_fast_scratch(nrow, nbody, cache):
    """Scratch for ``guess_on_tree_fast`` on rows of capacity ``nrow`` and ``cache``'s plan."""
    return FastScratch(np.zeros(8 * max(nrow, 1), np.int64), np.zeros(7 * max(nrow, 1) + 6 * nbody),
                       make_guess_scratch(np.int64(FAST_HELD), nbody, cache.plan))


# What guess_on_tree_fast reports: solved; declined before trying the guess (no kept plan,
# no room); tried the guess, which does not solve the LCP.
FAST_SOLVED, FAST_NOT_HANDLED, FAST_GUESS_FAILED = 0, 1, 2


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@noalloc(inline="always")
def guess_on_tree_fast(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, cache, fs):
    """``solve_mlcp``'s common case without allocating (so without reference counting):
    the bilateral rows have a tree plan in ``cache`` already, it factorises, and last
    step's contact state solves the LCP (``guess.guess_on_tree``). Returns FAST_SOLVED
    with the impulses and velocities applied as ``solve_mlcp`` would, or else
    FAST_NOT_HANDLED or FAST_GUESS_FAILED (the guess was tried) with ``vel``, ``angvel``
    and ``impulse`` untouched (then call ``solve_mlcp``, which redoes the factorisation;
    with ``guess=False`` after FAST_GUESS_FAILED). ``fs``: ``make_fast_scratch`` for rows
    of capacity >= nrow."""
    nload = 2 * impulse.shape[0]            # guess_states' slots: two per row of capacity
    nbody = vel.shape[0]
    if nrow == 0 or fs.ints.shape[0] < 8 * nrow or \
            fs.floats.shape[0] < nload + 5 * nrow + 6 * nbody:
        return FAST_NOT_HANDLED
    part = partition_rows(rows, nrow, fs.ints)
    if part.n == 0 or part.nb == 0 or not plan_kept(cache, rows, part.bsel, part.nb):
        return FAST_NOT_HANDLED
    plan = cache.plan
    bodies = Bodies(inv_mass, inv_inertia, vel, angvel)
    if not _factor_tree(rows, part, plan, bodies, fs.floats[:part.nb]):
        return FAST_NOT_HANDLED
    tw = tree_work(fs.floats[part.nb:], fs.ints[6 * nrow:], part, nload, nbody)
    _right_hand_side(rows, part, bodies, tw)
    tried = _guess_and_finish(rows, part, plan, bodies, impulse, tw, fs.guess)
    if tried == _GUESS_SOLVED:
        return FAST_SOLVED
    # (more held rows than the scratch has room for: solve_mlcp's guess has room)
    return FAST_GUESS_FAILED if tried == _GUESS_FAILED else FAST_NOT_HANDLED


# What _guess_and_finish reports.
_GUESS_SOLVED, _GUESS_FAILED, _GUESS_NO_ROOM = 0, 1, 2


@noalloc
def _right_hand_side(rows, part, bodies, tw):
    """``tw.b``, the active rows' right-hand side less their velocity, and ``tw.g``, its
    bilateral part: what the guess and the complement both start from."""
    idx, b, g = part.idx, tw.b, tw.g
    for i in range(part.n):
        b[i] = rows.rhs[idx[i]] - row_velocity(rows, idx[i], bodies.vel, bodies.angvel)
    for u in range(part.nb):
        g[u] = b[part.bil[u]]


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@noalloc(inline="always")
def _guess_and_finish(rows, part, plan, bodies, impulse, tw, gs):
    """The tree path's first try, shared by ``_mlcp_tree`` and ``guess_on_tree_fast``
    (after ``_right_hand_side``), and when it solves the LCP, applied (``_finish``):
    _GUESS_SOLVED. Last step's contact state (``guess_states``) on the rows it holds
    alone (``guess_on_tree``); if that fails and there are at most ``SWEEP_ROWS`` LCP
    rows, ``S`` of them all from their tree columns and the state that sweeps of
    Gauss-Seidel find (``sweep_on_tree``). Otherwise (_GUESS_FAILED, or _GUESS_NO_ROOM
    when ``gs`` (``make_guess_scratch``) has no room for the held rows) the bodies'
    velocities and ``impulse`` are left as they came. ``tw`` (``guess.tree_work``) may
    hold anything on entry but ``b``, ``g``."""
    idx, kind, oth, nn = part.idx, part.kind, part.oth, part.nn
    load, state, sub = tw.load, tw.state, tw.sub
    for a in range(nn):                     # only the slots guess_states will sum into
        if kind[oth[a]] == KIND_FRICTION:
            load[load_slot(rows, idx[oth[a]], impulse.shape[0])] = 0.0
    for a in range(nn):
        state[a] = 0
        tw.p[a] = 0.0
    guess_states(rows, part, impulse, state, load, np.bool_(True))    # (always True so)
    ns = np.int64(0)
    for a in range(nn):
        if state[a] != ZERO:
            sub[ns] = a
            ns += 1
    if ns > gs.rsel.shape[0]:
        return _GUESS_NO_ROOM
    if not guess_on_tree(rows, part, plan, bodies, tw, ns, gs) and \
            not sweep_on_tree(rows, part, plan, bodies, tw, gs, impulse):
        return _GUESS_FAILED
    _finish(rows, part, tw.y, tw.p, tw.vn, bodies, impulse)
    return _GUESS_SOLVED


@njit(cache=True)
def _mlcp_tree(rows, part, plan, bodies, impulse, max_pivots, guess):
    """The mixed LCP with the bilateral rows factorised over their tree (``plan``).

    Last step's contact state is tried first on the rows it holds alone
    (``guess_on_tree``; unless ``guess`` is False). Only if that fails: one tree solve
    gives the bilateral rows' response to the current velocities (``u0``, and
    ``c = b_N - J_N u0``), ``S`` is assembled from the 6x6 blocks of the constrained
    inverse mass of the bodies the other rows touch, and after the LCP a second tree
    solve adds the response to its impulses ``p_N`` (``u1``), so the bodies' velocities
    change by ``u0 + u1`` and no row's response needs applying one by one."""
    nbody = bodies.vel.shape[0]
    nload = 2 * impulse.shape[0]
    nn, nb = part.nn, part.nb
    # one zeroed block for the vectors (few allocations: each costs about as much as the
    # arithmetic of a small one)
    tw = tree_work(np.zeros(nload + nn + part.n + 2 * nb + 6 * nbody),
                   np.zeros(2 * nn, np.int64), part, nload, nbody)
    _right_hand_side(rows, part, bodies, tw)
    if guess and _guess_and_finish(rows, part, plan, bodies, impulse, tw,
                                   make_guess_scratch(nn, nbody, plan)) == _GUESS_SOLVED:
        return LEMKE_SOLVED
    u0 = np.zeros((nbody, 6))
    y0 = np.empty(nb)
    tree_solve(plan, nbody, u0, tw.g, u0, y0)       # f = u0 = 0 on entry
    sub = tw.sub
    for a in range(nn):
        sub[a] = a
    cpl = complement(rows, part, sub, nn, tw.b, plan, bodies, u0)
    # (up to SWEEP_ROWS rows, last step's state and the sweeps were tried on the tree)
    status = _lcp_on_schur(rows, part, cpl.S, cpl.c, impulse, max_pivots, tw.p,
                           nn > SWEEP_ROWS)
    if status != LEMKE_SOLVED:
        return status
    respond(rows, part, sub, nn, tw.p, plan, cpl, bodies, u0, tw.vn, tw.y)
    for u in range(nb):
        tw.y[u] += y0[u]
    _finish(rows, part, tw.y, tw.p, tw.vn, bodies, impulse)
    return LEMKE_SOLVED


@noalloc
def _finish(rows, part, y, p_n, vn, bodies, impulse):
    """The new velocities ``vn`` (nbody, 6) into the bodies'; every row's impulse: the
    bilateral rows' ``-y`` (nb,), the others' ``p_n`` (nn,), zero for the inactive."""
    vel, angvel = bodies.vel, bodies.angvel
    for body in range(vel.shape[0]):
        for k in range(3):
            vel[body, k] = vn[body, k]
            angvel[body, k] = vn[body, 3 + k]
    for r in range(part.nrow):
        impulse[r] = 0.0
    for u in range(part.nb):
        impulse[part.bsel[u]] = -y[u]
    for c in range(part.nn):
        impulse[part.idx[part.oth[c]]] = p_n[c]


@njit(cache=True)
def _lcp_on_schur(rows, part, S, cvec, impulse, max_pivots, p_n, first_tries):
    """Impulses ``p_n`` (nn,) of the non-bilateral rows: ``S p_N - c`` complementary to the
    rows' bounds. With ``first_tries``: last step's contact state (``guessed_active_set``)
    and then the state that sweeps of Gauss-Seidel find (``schur_pgs_exact``); then Lemke
    on the friction-pyramid LCP, and if it fails on at most ``REGULARISED_ROWS`` rows,
    Lemke on that LCP made slightly compliant (``_regularised_lcp``). Returns Lemke's
    status."""
    nn = part.nn
    state = np.zeros(nn, np.int64)
    guessed = guess_states(rows, part, impulse, state, np.zeros(2 * impulse.shape[0]))
    if first_tries:
        every = np.arange(nn)
        hs = make_held_scratch(nn)
        w = np.empty(nn)
        if guessed and guessed_active_set(rows, part, S, cvec, state, p_n, every, hs, w):
            return LEMKE_SOLVED
        links = np.empty(2 * nn, np.int64)
        if schur_pgs_exact(rows, part, S, cvec, impulse, p_n, state, links[:nn], links[nn:],
                           every, hs, w):
            return LEMKE_SOLVED
    status = pyramid_lcp(rows, part, S, cvec, impulse, max_pivots, not guessed, p_n)
    if (status == LEMKE_INACCURATE or status == LEMKE_RAY) and nn <= REGULARISED_ROWS:
        status = _regularised_lcp(rows, part, S, cvec, impulse, max_pivots, p_n)
    return status


@njit(cache=True)
def _regularised_lcp(rows, part, S, cvec, impulse, max_pivots, p_n):
    """Lemke once more, every contact normal, limit and friction row given the compliance
    ``REGULARISED_CFM`` of the largest diagonal entry of ``S`` (``S`` as it came on
    return). Without any CFM, a few contacts of one box (a face's four corners, eight
    tangent rows for three motions in the plane) make an LCP with many answers, and
    Lemke's pivots can end in a nearly singular basis whose answer fails its check; the
    compliance makes the answer unique and the bases well-conditioned. The answer is
    exact for that LCP: a row that holds moves at the compliance times its impulse
    (about 1e-5 / m_eff m/s per N s: micrometres a second for a character's contacts).
    Returns Lemke's status."""
    kind, oth, nn = part.kind, part.oth, part.nn
    diagonal = np.empty(nn)             # restored as it was, bit for bit
    smax = 0.0
    for a in range(nn):
        diagonal[a] = S[a, a]
        smax = max(smax, S[a, a])
    for a in range(nn):
        if kind[oth[a]] == KIND_FRICTION or kind[oth[a]] == KIND_UNILATERAL:
            S[a, a] += REGULARISED_CFM * smax
    status = pyramid_lcp(rows, part, S, cvec, impulse, max_pivots, np.bool_(False), p_n)
    for a in range(nn):
        S[a, a] = diagonal[a]
    return status


@njit(cache=True)
def _mlcp_dense(rows, part, bodies, impulse, max_pivots):
    """The mixed LCP with the Schur complement from the dense ``A`` (joints in loops)."""
    idx, bil, oth = part.idx, part.bil, part.oth
    n, nb, nn = part.n, part.nb, part.nn
    dv = np.zeros((n, 12))
    A = np.zeros((n, n))
    b = np.zeros(n)
    assemble(rows, idx, n, bodies.inv_mass, bodies.inv_inertia, bodies.vel, bodies.angvel,
             dv, A, b)
    X = np.zeros((nb, nn + 1))                  # A_BB^-1 [A_BN | b_B]
    if nb == 0:
        S, cvec = A, b                          # (oth is 0 .. n-1: nothing to eliminate)
    else:
        S = np.empty((nn, nn))
        cvec = np.empty(nn)
        if not schur_dense(A, b, part, X, S, cvec):
            return LEMKE_BAD_INPUT
    p_n = np.zeros(nn)
    status = _lcp_on_schur(rows, part, S, cvec, impulse, max_pivots, p_n, np.bool_(True))
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
    for r in range(part.nrow):
        impulse[r] = 0.0
    for i in range(n):
        impulse[idx[i]] = p[i]
    apply_impulses(rows, idx, n, dv, p, bodies.vel, bodies.angvel)
    return LEMKE_SOLVED
