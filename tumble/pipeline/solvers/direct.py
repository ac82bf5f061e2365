"""Direct solver: solve ``(J M^-1 J^T + CFM) p = rhs - J v`` exactly.

Rows with finite bounds (limits, motors, friction) make a box-bounded LCP, solved by
an active-set method: solve with the free rows, clamp the worst row outside its bounds
or release the worst clamped row whose velocity pushes back, repeat.

Each solve of the free rows is, when the rows form a tree over the bodies (an
articulated character, a chain hanging from the world), the linear-time factorisation
of ``tree.py`` (Baraff 1996), redone for every active set in O(rows); otherwise (loops
of joints) a dense Cholesky factorisation, O(n^3) in the active row count. If the active
set does not settle within its iteration cap, or a factorisation fails (redundant rows
with zero CFM), the result is polished by projected Gauss-Seidel and the fallback is
reported.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from ..._jit import noalloc
from .common import (Bodies, active_rows, apply_impulse, apply_impulses, minv_jt, row_active,
                     row_velocity)
from .pgs import solve_pgs
from .tree import cached_tree_plan, make_plan_cache, tree_factor, tree_solve


@njit(cache=True, inline="always")
def cholesky_factor(a, n, work, redundant=0.0):
    """Lower Cholesky factor of the symmetric positive definite ``a[:n, :n]`` into ``work``.
    Returns False when ``a`` is not positive definite (to working precision), or when a
    pivot falls below ``redundant`` times its diagonal entry (rows that depend on others)."""
    return _cholesky(a, n, work, redundant, False) == 0


@njit(cache=True, inline="always")
def cholesky_factor_dropping(a, n, work, redundant):
    """``cholesky_factor`` of a positive semi-definite ``a[:n, :n]`` whose dependent rows
    are dropped: a row whose pivot falls to ``redundant`` times its diagonal entry (it
    depends on the rows before it, as the fourth contact of a box face does on the other
    three) gets a zero row and column and an infinite pivot, so ``cholesky_apply`` gives
    it 0 and solves the others. Returns the number of rows dropped, or -1 when ``a`` is
    not positive semi-definite. Whether the dropped rows' equations hold is the caller's
    to check (they do when ``b`` is consistent)."""
    return _cholesky(a, n, work, redundant, True)


@noalloc
def _cholesky(a, n, work, redundant, drop):
    """Both factorisations above: the number of rows dropped (only with ``drop``), or -1
    when a pivot fails. The factor of a row keeps the row's leading zeros (its envelope:
    rows sorted by body pair make a band), so the work is skipped there and each dot
    product starts at the row's first entry; the products skipped are exact zeros, so
    the factor is the dense one to the bit."""
    dropped = 0
    for i in range(n):
        first = _first_entry(a, i)
        for k in range(first):
            work[i, k] = 0.0
        for k in range(first, i + 1):
            s = a[i, k]
            for t in range(first, k):
                s -= work[i, t] * work[k, t]
            if i != k:
                work[i, k] = s / work[k, k]
            elif drop and abs(s) <= redundant * a[i, i]:
                for t in range(first, i):          # (before first: zero already)
                    work[i, t] = 0.0
                work[i, i] = np.inf
                dropped += 1
            elif s <= 1e-300 or s <= redundant * a[i, i]:
                return -1
            else:
                work[i, i] = np.sqrt(s)
    return dropped


@njit(cache=True, inline="always")
def _first_entry(m, i):
    """The column of row ``i``'s first nonzero entry left of the diagonal (``i`` if none)."""
    k = 0
    while k < i and m[i, k] == 0.0:
        k += 1
    return k


@noalloc
def cholesky_apply(work, b, n, x):
    """``x[:n] = (L L^T)^-1 b[:n]`` with the factor ``L`` of ``cholesky_factor`` (or of
    ``cholesky_factor_dropping``: a dropped row's infinite pivot makes its ``x`` 0). The
    forward pass starts each row at its first entry (a banded factor's work is O(n b))."""
    for i in range(n):
        s = b[i]
        for t in range(_first_entry(work, i), i):
            s -= work[i, t] * x[t]
        x[i] = s / work[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for t in range(i + 1, n):
            s -= work[t, i] * x[t]
        x[i] = s / work[i, i]


@njit(cache=True)
def cholesky_solve(a, b, n, work):
    """Solve ``a[:n, :n] x = b[:n]`` for symmetric positive definite ``a``.

    ``work`` (n, n) receives the factor. Returns (x, ok); ok is False when ``a`` is not
    positive definite (to working precision).
    """
    x = np.zeros(n)
    if not cholesky_factor(a, n, work):
        return x, False
    cholesky_apply(work, b, n, x)
    return x, True


@noalloc
def row_responses(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, b):
    """Fill ``dv`` (n, 12) with ``M^-1 J^T`` and ``b`` (n,) with ``rhs - J v`` for the rows
    ``idx[:n]``."""
    for i in range(n):
        ri = idx[i]
        minv_jt(rows, ri, inv_mass, inv_inertia, dv[i])
        b[i] = rows.rhs[ri] - row_velocity(rows, ri, vel, angvel)


@noalloc
def assemble(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, A, b):
    """Fill ``dv`` (n, 12) with ``M^-1 J^T``, ``A`` (n, n) with ``J M^-1 J^T + CFM`` and
    ``b`` (n,) with ``rhs - J v`` for the rows ``idx[:n]``. Rows come in runs on the same
    two bodies (a contact's, a joint's): which sides of two runs share a body is found
    once per block of runs, and a block sharing none is zero."""
    row_responses(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, b)
    i0 = np.int64(0)
    while i0 < n:
        i1 = _run_end(rows, idx, i0, n)
        k0 = np.int64(0)
        while k0 <= i0:
            k1 = _run_end(rows, idx, k0, n)
            # the (row side, column side) pairs on a common body: none, one or two
            ri, rk = idx[i0], idx[k0]
            nshared = 0
            oi0 = ok0 = oi1 = ok1 = 0
            for side_i in range(2):
                bi = rows.body_a[ri] if side_i == 0 else rows.body_b[ri]
                for side_k in range(2):
                    bk = rows.body_a[rk] if side_k == 0 else rows.body_b[rk]
                    if bi >= 0 and bi == bk:
                        if nshared == 0:
                            oi0, ok0 = 6 * side_i, 6 * side_k
                        else:
                            oi1, ok1 = 6 * side_i, 6 * side_k
                        nshared += 1
            for i in range(i0, i1):
                r = idx[i]
                for k in range(k0, min(k1, i + 1)):
                    s = 0.0
                    if nshared > 0:
                        for t in range(6):
                            s += rows.J[r, oi0 + t] * dv[k, ok0 + t]
                    if nshared > 1:
                        for t in range(6):
                            s += rows.J[r, oi1 + t] * dv[k, ok1 + t]
                    A[i, k] = s
                    A[k, i] = s
            k0 = k1
        for i in range(i0, i1):
            A[i, i] += rows.cfm[idx[i]]
        i0 = i1


@njit(cache=True, inline="always")
def _run_end(rows, idx, i, n):
    """One past the last of the rows ``idx[i:n]`` on the same two bodies as ``idx[i]``."""
    a, b = rows.body_a[idx[i]], rows.body_b[idx[i]]
    j = i + 1
    while j < n and rows.body_a[idx[j]] == a and rows.body_b[idx[j]] == b:
        j += 1
    return j


@noalloc
def accumulate_response(rows, idx, n, dv, p, state, clamped_only, acc):
    """``acc`` (nbody, 6) = sum of ``dv[i] p[i]`` over the rows (only those with
    ``state[i] != 0`` if ``clamped_only``): the velocity change [linear, angular] of the
    bodies under those impulses."""
    acc[:] = 0.0
    for i in range(n):
        if (clamped_only and state[i] == 0) or p[i] == 0.0:
            continue
        r = idx[i]
        for side in range(2):
            body = rows.body_a[r] if side == 0 else rows.body_b[r]
            if body < 0:
                continue
            o = 6 * side
            for k in range(6):
                acc[body, k] += dv[i, o + k] * p[i]


@njit(cache=True, inline="always")
def row_dot(rows, r, acc):
    """``J_r`` times the per-body velocity change ``acc`` (nbody, 6)."""
    s = 0.0
    for side in range(2):
        body = rows.body_a[r] if side == 0 else rows.body_b[r]
        if body < 0:
            continue
        o = 6 * side
        jr, ab = rows.J[r], acc[body]
        for k in range(6):
            s += jr[o + k] * ab[k]
    return s


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@njit(cache=True, inline="always")
def solve_direct(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, tolerance, cache):
    """Solve the rows exactly; returns the number of active-set iterations, negative if it
    fell back to projected Gauss-Seidel.

    rows : Rows; nrow : rows in use; inv_mass (nbody,) 1/kg; inv_inertia (nbody, 3, 3)
    world frame; vel, angvel (nbody, 3) updated in place; impulse (nrow,) N s out;
    cache : ``tree.make_plan_cache``, the rows' tree plan kept from call to call."""
    return solve_active_set_cached(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse,
                                   tolerance, np.bool_(True), cache)


@njit(cache=True)
def solve_active_set(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, tolerance,
                     allow_tree):
    """``solve_direct`` planning afresh; with ``allow_tree`` False always factorise
    densely (reference)."""
    cache = make_plan_cache(np.int64(0), np.int64(vel.shape[0]), np.int64(0))
    return solve_active_set_cached(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse,
                                   tolerance, allow_tree, cache)


@njit(cache=True)
def solve_active_set_cached(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse,
                            tolerance, allow_tree, cache):
    """``solve_active_set`` with the tree plan kept in ``cache``."""
    idx = np.empty(nrow, np.int64)
    where = np.empty(nrow, np.int64)
    n = active_rows(rows, nrow, idx, where, impulse)
    if n == 0:
        return 0
    nbody = vel.shape[0]
    dv = np.zeros((n, 12))
    b = np.zeros(n)
    tree, plan = cached_tree_plan(cache, rows, idx, n, inv_mass, nbody)
    tree = tree and allow_tree
    nd = 0 if tree else n
    A = np.zeros((nd, nd))
    if tree:
        row_responses(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, b)
    else:
        assemble(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, A, b)
    work = ActiveSetWork(A, dv, b, np.zeros(n, np.int64), np.zeros(n), np.empty(n),
                         np.empty(n, np.int64), np.zeros((nd, nd)), np.zeros(n), np.zeros(n),
                         np.zeros((nd, nd)), np.zeros((nbody, 6)), np.zeros((nbody, 6)))
    iters = _active_set(rows, idx, n, Bodies(inv_mass, inv_inertia, vel, angvel), impulse,
                        tolerance, tree, plan, work)
    if iters > 0:
        return iters
    _polish(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, tolerance)
    return iters


# The system and work arrays of ``_active_set`` for n active rows (nd = n for the dense
# factorisation, 0 on the tree).
ActiveSetWork = namedtuple("ActiveSetWork", [
    "A",        # (nd, nd) J M^-1 J^T + CFM (dense only)
    "dv",       # (n, 12) M^-1 J^T of each row
    "b",        # (n,) rhs - J v
    "state",    # (n,) int64 0 free, -1 at its lower bound, 1 at its upper; zero on entry
    "p",        # (n,) the impulses; zero on entry
    "cfm",      # (n,)
    "free",     # (n,) int64 the free rows' positions
    "sub",      # (nd, nd) the free rows' block of A
    "rhs",      # (n,)
    "x",        # (n,)
    "work",     # (nd, nd) its Cholesky factor
    "acc",      # (nbody, 6) the bodies' velocity change under the clamped rows' impulses
    "fzero",    # (nbody, 6) zero: the tree solve's body right-hand side
])


@noalloc
def _active_set(rows, idx, n, bodies, impulse, tolerance, tree, plan, ws):
    """The active-set iterations of ``solve_active_set`` on the rows ``idx[:n]`` with the
    work arrays ``ws`` (``ActiveSetWork``); applies the impulses. Returns the iteration
    count, negated when it did not converge."""
    inv_mass, inv_inertia = bodies.inv_mass, bodies.inv_inertia
    vel, angvel = bodies.vel, bodies.angvel
    A, dv, b, state, p, cfm = ws.A, ws.dv, ws.b, ws.state, ws.p, ws.cfm
    free, sub, rhs, x, work, acc = ws.free, ws.sub, ws.rhs, ws.x, ws.work, ws.acc
    nbody = vel.shape[0]
    for i in range(n):
        cfm[i] = rows.cfm[idx[i]]
    iters = 0
    converged = False
    for it in range(4 * n + 20):
        iters = it + 1
        nf = np.int64(0)
        for i in range(n):
            if state[i] == 0:
                free[nf] = i
                nf += 1
            else:
                p[i] = rows.lo[idx[i]] if state[i] < 0 else rows.hi[idx[i]]
        if tree:
            # free rows: (A_FF) p_F = b_F - A_FC p_C, with A_FC p_C = J_F (M^-1 J_C^T p_C)
            accumulate_response(rows, idx, n, dv, p, state, np.bool_(True), acc)
            for i in range(n):
                plan.use[i] = 1 if state[i] == 0 else 0
                rhs[i] = b[i] - row_dot(rows, idx[i], acc) if state[i] == 0 else 0.0
            if not tree_factor(plan, rows, idx, cfm, inv_mass, inv_inertia, nbody):
                break
            tree_solve(plan, nbody, ws.fzero, rhs, acc, x)
            for u in range(nf):
                p[free[u]] = -x[free[u]]
        else:
            for u in range(nf):
                i = free[u]
                s = b[i]
                for k in range(n):
                    if state[k] != 0:
                        s -= A[i, k] * p[k]
                rhs[u] = s
                for v in range(nf):
                    sub[u, v] = A[i, free[v]]
            if not cholesky_factor(sub, nf, work):
                break
            cholesky_apply(work, rhs, nf, x)
            for u in range(nf):
                p[free[u]] = x[u]
        # the free row furthest outside its bounds is clamped
        worst, worst_i, worst_side = tolerance, -1, 0
        for u in range(nf):
            i = free[u]
            r = idx[i]
            if p[i] < rows.lo[r] - worst:
                worst, worst_i, worst_side = rows.lo[r] - p[i], i, -1
            elif p[i] > rows.hi[r] + worst:
                worst, worst_i, worst_side = p[i] - rows.hi[r], i, 1
        if worst_i >= 0:
            state[worst_i] = worst_side
            continue
        # a clamped row whose velocity would pull it off its bound is released
        if nf == n:
            converged = True
            break
        if tree:
            accumulate_response(rows, idx, n, dv, p, state, np.bool_(False), acc)
        worst, worst_i = tolerance, -1
        for i in range(n):
            if state[i] == 0:
                continue
            if tree:
                w = -b[i] + row_dot(rows, idx[i], acc) + cfm[i] * p[i]
            else:
                w = -b[i]
                for k in range(n):
                    w += A[i, k] * p[k]
            if (state[i] < 0 and -w > worst) or (state[i] > 0 and w > worst):
                worst, worst_i = abs(w), i
        if worst_i < 0:
            converged = True
            break
        state[worst_i] = 0
    for i in range(n):
        r = idx[i]
        p[i] = min(max(p[i], rows.lo[r]), rows.hi[r])
        impulse[r] = p[i]
    apply_impulses(rows, idx, n, dv, p, vel, angvel)
    return iters if converged else -iters


@njit(cache=True)
def _polish(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, tolerance):
    """PGS sweeps that continue from the impulses already applied to the velocities."""
    _unapply(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, np.zeros(12))
    # (np.int64 / np.bool_: typed like the step's own call, so no second compilation)
    solve_pgs(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, np.int64(200), tolerance,
              0.0, np.bool_(True))


@noalloc
def _unapply(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, dv):
    """Take the impulses back out of the velocities (PGS then warm-starts from them)."""
    for r in range(nrow):
        if row_active(rows, r) and impulse[r] != 0.0:
            minv_jt(rows, r, inv_mass, inv_inertia, dv)
            apply_impulse(rows, r, dv, -impulse[r], vel, angvel)
