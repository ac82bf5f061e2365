"""Direct solver: factorise ``A = J M^-1 J^T + CFM`` and solve exactly.

Rows with finite bounds (limits, motors, friction) make a box-bounded LCP, solved by
an active-set method: solve with the free rows, clamp the worst row outside its bounds
or release the worst clamped row whose velocity pushes back, repeat. Each solve is a
dense Cholesky factorisation of the free rows, O(n^3) in the active row count, which is
what pays for the systems of a character (tens of rows). If the active set does not
settle within its iteration cap, or a factorisation fails (redundant rows with zero
CFM), the result is polished by projected Gauss-Seidel and the fallback is reported.
"""
import numpy as np
from numba import njit

from .common import apply_impulse, minv_jt, row_active, row_velocity
from .pgs import solve_pgs


@njit(cache=True)
def cholesky_solve(a, b, n, work):
    """Solve ``a[:n, :n] x = b[:n]`` for symmetric positive definite ``a``.

    ``work`` (n, n) receives the factor. Returns (x, ok); ok is False when ``a`` is not
    positive definite (to working precision).
    """
    x = np.zeros(n)
    for i in range(n):
        for k in range(i + 1):
            s = a[i, k]
            for t in range(k):
                s -= work[i, t] * work[k, t]
            if i == k:
                if s <= 1e-300:
                    return x, False
                work[i, i] = np.sqrt(s)
            else:
                work[i, k] = s / work[k, k]
    for i in range(n):
        s = b[i]
        for t in range(i):
            s -= work[i, t] * x[t]
        x[i] = s / work[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for t in range(i + 1, n):
            s -= work[t, i] * x[t]
        x[i] = s / work[i, i]
    return x, True


@njit(cache=True)
def assemble(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, A, b):
    """Fill ``dv`` (n, 12) with ``M^-1 J^T``, ``A`` (n, n) with ``J M^-1 J^T + CFM`` and
    ``b`` (n,) with ``rhs - J v`` for the rows ``idx[:n]``."""
    for i in range(n):
        minv_jt(rows, idx[i], inv_mass, inv_inertia, dv[i])
    for i in range(n):
        ri = idx[i]
        b[i] = rows.rhs[ri] - row_velocity(rows, ri, vel, angvel)
        for k in range(i + 1):
            rk = idx[k]
            s = 0.0
            for side_i in range(2):
                bi = rows.body_a[ri] if side_i == 0 else rows.body_b[ri]
                if bi < 0:
                    continue
                for side_k in range(2):
                    bk = rows.body_a[rk] if side_k == 0 else rows.body_b[rk]
                    if bk != bi:
                        continue
                    oi, ok = 6 * side_i, 6 * side_k
                    for t in range(6):
                        s += rows.J[ri, oi + t] * dv[k, ok + t]
            A[i, k] = s
            A[k, i] = s
        A[i, i] += rows.cfm[ri]


@njit(cache=True)
def solve_direct(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, tolerance):
    """Solve the rows exactly; returns the number of active-set iterations, negative if it
    fell back to projected Gauss-Seidel."""
    idx = np.empty(nrow, np.int64)
    n = 0
    for r in range(nrow):
        if row_active(rows, r):
            idx[n] = r
            n += 1
        else:
            impulse[r] = 0.0
    if n == 0:
        return 0
    dv = np.zeros((n, 12))
    A = np.zeros((n, n))
    b = np.zeros(n)
    assemble(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, A, b)
    # state: 0 free, -1 clamped at lo, +1 clamped at hi
    state = np.zeros(n, np.int64)
    p = np.zeros(n)
    free = np.empty(n, np.int64)
    sub = np.zeros((n, n))
    rhs = np.zeros(n)
    work = np.zeros((n, n))
    iters = 0
    converged = False
    for it in range(4 * n + 20):
        iters = it + 1
        nf = 0
        for i in range(n):
            if state[i] == 0:
                free[nf] = i
                nf += 1
            else:
                p[i] = rows.lo[idx[i]] if state[i] < 0 else rows.hi[idx[i]]
        for u in range(nf):
            i = free[u]
            s = b[i]
            for k in range(n):
                if state[k] != 0:
                    s -= A[i, k] * p[k]
            rhs[u] = s
            for v in range(nf):
                sub[u, v] = A[i, free[v]]
        x, ok = cholesky_solve(sub, rhs, nf, work)
        if not ok:
            break
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
        worst, worst_i = tolerance, -1
        for i in range(n):
            if state[i] == 0:
                continue
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
        pi = min(max(p[i], rows.lo[r]), rows.hi[r])
        impulse[r] = pi
        apply_impulse(rows, r, dv[i], pi, vel, angvel)
    if converged:
        return iters
    _polish(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, tolerance)
    return -iters


@njit(cache=True)
def _polish(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, tolerance):
    """PGS sweeps that continue from the impulses already applied to the velocities."""
    # The velocities already include the impulses: take them out, then warm-start PGS.
    dv = np.zeros(12)
    for r in range(nrow):
        if row_active(rows, r) and impulse[r] != 0.0:
            minv_jt(rows, r, inv_mass, inv_inertia, dv)
            apply_impulse(rows, r, dv, -impulse[r], vel, angvel)
    solve_pgs(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, 200, tolerance, True)
