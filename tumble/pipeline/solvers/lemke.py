"""Lemke's complementary pivoting method for the linear complementarity problem (LCP).

Finds ``z >= 0`` with ``w = M z + q >= 0`` and ``z . w = 0``. ``M`` need not be
symmetric. The method either solves the problem or proves it has no solution when ``M``
is copositive-plus (positive semidefinite matrices, for instance), and more generally
when ``M`` is copositive and ``v . q >= 0`` for every ``0 <= v``, ``M v >= 0``,
``v . M v = 0`` -- which covers the Stewart-Trinkle contact matrices with pyramid
friction. For other matrices a ray may end the search on a solvable problem.

Method. The problem is augmented with an artificial variable ``z0`` and the covering
vector ``d = ones(n)``::

    w = M z + q + d z0,      w, z, z0 >= 0,      w . z = 0.

Starting from the basis of all ``w`` with ``z0`` raised just enough to make every ``w``
non-negative, each pivot brings in the complement of the variable that left last and
keeps the basis feasible by the minimum-ratio test. It stops when ``z0`` leaves
(solved), when no entry of the entering column exceeds ``pivot_tol`` (a secondary ray:
no solution, see above) or at the pivot cap. A ray or a failed verification (below) is
retried once with a coarser pivot tolerance (see ``lemke``).

The tableau is held as the dense basis inverse ``B^-1`` (n, n), stored transposed so that
both O(n^2) parts of a pivot -- the matrix-vector product for the entering column and
the rank-one update of ``B^-1`` -- sweep contiguous memory (and skip the zeros of ``M``
and of the pivot row), plus the basic values ``B^-1 q``. Columns of ``M`` are read,
never updated.

Anti-cycling. Ties in the ratio test (degenerate problems: zeros in ``q``, repeated
columns, the paired +-t friction directions and coplanar contacts of rigid bodies) are
broken by the lexicographic rule, i.e. as if ``q`` were perturbed to
``q + (e, e^2, ..., e^n)``: among rows tied on ``x_i / a_i`` the one with the
lexicographically smallest row of ``B^-1 / a_i`` leaves. That row is unique because
``B^-1`` is nonsingular, so no basis repeats and the method is finite in exact
arithmetic. In floating point two values count as tied when they differ by less than
``TIE_TOL * max(1, |value|)`` plus the rounding noise of the tableau (``NOISE`` times
the largest entry it has held, over ``a_i``), and ``z0`` leaves whenever it is among
the tied rows. Two exceptions trade the rule for stability, both bounded by a
feasibility slack ``HARRIS_TOL`` (rows overshot by the step may go that far below
zero): ``z0`` also leaves if its ratio is within that slack of the minimum and its
pivot is not tiny; and if the chosen pivot is below ``STAB_TOL`` times the largest
candidate in its column, a Harris pass takes the largest pivot among rows whose ratio
is within the slack. The pivot cap bounds the loop whatever happens.

Scaling and accuracy. The kernel works on ``M / max|M|`` and ``q / max|q|`` (the
solution scales back exactly), so every tolerance is relative to the size of the data.
The pivots only choose the final basis; ``z`` is then taken both from the tableau and
from one direct solve of that basis (``M_SS z_S = -q_S`` for the set S of positive
``z``, Gaussian elimination with partial pivoting, O(|S|^3), no iteration) and the one
with the smaller residual is kept. That residual is verified: the relative natural
residual of ``lcp_residual`` must be at most ``VERIFY_TOL`` (1e-8), else the call
reports LEMKE_INACCURATE rather than return a wrong z. Typical values are 1e-16 to
1e-14 (contact problems, positive definite M), up to about ``eps * cond(M_SS)`` for
near-singular ones. Tiny negative basic values left by rounding are returned as 0, so
``z >= 0`` holds exactly; ``w`` may be negative by about the residual.

Limits. Floating point can steer the path away from the exact one when bases are
nearly singular: near-ties are then misjudged and the path ends in a ray or in a
complementary basis that is slightly infeasible (caught by the verification). The bad
case is a set of redundant contacts (four coplanar corners per box of a stack)
regularised by a tiny CFM, 1e-8 to 1e-6 of max|M|, whose bases carry entries ~1/CFM:
about 3 % of such problems end in LEMKE_RAY or LEMKE_INACCURATE (after the retry at
``RETRY_PIVOT_TOL``) although a solution exists. Measured on 1000 random problems per
setting: box stacks and random contact sets (including wedged bodies) without CFM,
with CFM <= 1e-10 or >= 1e-4 of max|M|: <= 0.1 % failures; random contact sets at
CFM 1e-8: 0.7 %. A reported LEMKE_SOLVED is always verified.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from ..._jit import noalloc

LEMKE_SOLVED = 0       # z_out holds a verified solution
LEMKE_RAY = 1          # secondary ray: for copositive-plus M, proof that none exists
LEMKE_MAX_ITER = 2     # pivot cap reached
LEMKE_BAD_INPUT = 3    # shape mismatch, non-finite M, q or pivot_tol, or overflow
LEMKE_INACCURATE = 4   # pivoting ended in a basis whose solution fails verification
LEMKE_TOO_LARGE = 5    # not attempted: too many rows for the dense exact path (mlcp.py)

# Values (normalised units) closer than TIE_TOL * max(1, |value|) + NOISE * (largest
# tableau entry so far) / pivot count as tied in the ratio test and lexicographic rule.
TIE_TOL = 1e-9
NOISE = 16 * 2.2e-16
# A pivot below STAB_TOL times its column's largest candidate triggers the Harris pass,
# which may leave basic values negative by up to HARRIS_TOL (normalised units).
STAB_TOL = 1e-4
HARRIS_TOL = 1e-9
# Largest accepted relative natural residual (see lcp_residual).
VERIFY_TOL = 1e-8
WARM_TOL = 1e-12       # a guessed basis is kept only if it solves to round-off
# pivot_tol of the one retry after a ray or a failed verification.
RETRY_PIVOT_TOL = 1e-6


@noalloc
def _entering_column(code, n, bt, mt, col):
    """``col = B^-1 A[:, code]`` for the augmented system ``I w - M z - d z0 = q``.

    code < n is ``w_code`` (column e_code), n <= code < 2n is ``z_(code-n)`` (column
    ``-M[:, code-n]``, read from row ``code-n`` of ``mt = M^T``), 2n is ``z0`` (``-d``).
    ``bt`` is ``B^-1`` transposed (row k = column k of ``B^-1``), so every product below
    runs along contiguous memory; zero entries of ``M`` are skipped. Returns False if the
    column is not finite (the pivoting has broken down).
    """
    if code < n:
        for i in range(n):
            col[i] = bt[code, i]
    elif code < 2 * n:
        j = code - n
        for i in range(n):
            col[i] = 0.0
        for k in range(n):
            a = mt[j, k]
            if a != 0.0:
                for i in range(n):
                    col[i] -= bt[k, i] * a
    else:
        for i in range(n):
            col[i] = 0.0
        for k in range(n):
            for i in range(n):
                col[i] -= bt[k, i]
    for i in range(n):
        if not np.isfinite(col[i]):
            return False
    return True


@noalloc
def _leaving_row(col, x, bt, basis, n, pivot_tol, cand, noise):
    """Row whose basic variable leaves when the variable of ``col`` enters.

    Minimum ratio ``max(x_i, 0) / col_i`` over rows with ``col_i > pivot_tol`` (slightly
    negative values are rounding and count as degenerate zeros); ``z0`` wins if tied or
    within the Harris slack, else the lexicographic rule, with the Harris pass for tiny
    pivots (module docstring).
    ``noise`` is the absolute rounding noise of ``x`` and ``B^-1`` entries. Returns -1
    when no entry exceeds ``pivot_tol`` (ray), -2 on a non-finite ratio. ``cand`` (n,)
    int64 is scratch; ``bt`` is ``B^-1`` transposed.
    """
    m = 0
    theta = np.inf
    theta_h = np.inf                      # largest step keeping every x >= -HARRIS_TOL
    cmax = 0.0
    row_z0 = -1
    for i in range(n):
        if col[i] > pivot_tol:
            r = max(x[i], 0.0) / col[i]
            if not np.isfinite(r):
                return -2
            theta = min(theta, r)
            theta_h = min(theta_h, (max(x[i], 0.0) + HARRIS_TOL) / col[i])
            cmax = max(cmax, col[i])
            if basis[i] == 2 * n:
                row_z0 = i
            cand[m] = i
            m += 1
    if m == 0:
        return -1
    if row_z0 >= 0 and max(x[row_z0], 0.0) / col[row_z0] <= theta_h \
            and col[row_z0] >= STAB_TOL * cmax:
        return row_z0                     # z0 can leave: the next basis is complementary
    lim = theta + TIE_TOL * max(1.0, theta)
    k = 0
    for t in range(m):
        i = cand[t]
        if max(x[i], 0.0) / col[i] <= lim + noise / col[i]:
            if basis[i] == 2 * n:
                return i                  # z0 can leave: the next basis is complementary
            cand[k] = i
            k += 1
    m = k
    # lexicographic rule: column c of B^-1 / col_i, c = 0, 1, ... is the e^(c+1) term
    c = 0
    while m > 1 and c < n:
        lo = np.inf
        for t in range(m):
            i = cand[t]
            lo = min(lo, bt[c, i] / col[i])
        lim = lo + TIE_TOL * max(1.0, abs(lo))
        k = 0
        for t in range(m):
            i = cand[t]
            if bt[c, i] / col[i] <= lim + noise / col[i]:
                cand[k] = i
                k += 1
        m = k
        c += 1
    best = cand[0]                        # rows equal within tolerance: largest pivot
    for t in range(1, m):
        if col[cand[t]] > col[best]:
            best = cand[t]
    if col[best] >= STAB_TOL * cmax:
        return best
    # Harris pass: dividing by a tiny pivot would blow up B^-1 (and every later
    # column); a slightly larger step through a larger pivot costs at most HARRIS_TOL
    # of feasibility in the rows it overshoots.
    for i in range(n):
        if col[i] > pivot_tol and max(x[i], 0.0) / col[i] <= theta_h and col[i] > col[best]:
            best = i
    return best


@noalloc
def _pivot(r, col, bt, x, n):
    """Make the entering variable basic in row ``r``: Gauss-Jordan step on ``B^-1, x``
    (``bt`` = ``B^-1`` transposed: row r of ``B^-1`` is column r of ``bt``).

    Returns a bound on the size of the entries written (row r times the largest
    multiplier), which tracks the growth that sets the rounding noise of the tableau."""
    inv = 1.0 / col[r]
    rmax = 0.0
    for k in range(n):
        bt[k, r] *= inv
        rmax = max(rmax, abs(bt[k, r]))
    x[r] *= inv
    rmax = max(rmax, abs(x[r]))
    fmax = 1.0
    for i in range(n):
        fmax = max(fmax, abs(col[i]))
    # B^-1[i, k] -= col[i] B^-1[r, k] for every row i != r: one contiguous sweep per k
    # (B^-1 starts sparse: columns k where row r is zero have nothing to do)
    for k in range(n):
        brk = bt[k, r]
        if brk == 0.0:
            continue
        for i in range(n):
            bt[k, i] -= col[i] * brk
        bt[k, r] = brk
    for i in range(n):
        f = col[i]
        if i == r or f == 0.0:
            continue
        x[i] -= f * x[r]
    return rmax * fmax


@noalloc
def _residual_normalised(mt, qn, zn, n, w):
    """``max_i |min(z_i, w_i)| / (1 + max|z|)`` for ``w = Mn z + qn`` (``mt = Mn^T``,
    ``w`` (n,) is scratch); NaN anywhere gives inf."""
    zmax = 0.0
    for i in range(n):
        w[i] = qn[i]
        zmax = max(zmax, abs(zn[i]))
    for j in range(n):
        zj = zn[j]
        if zj != 0.0:
            for i in range(n):
                w[i] += mt[j, i] * zj
    res = 0.0
    for i in range(n):
        v = abs(min(zn[i], w[i]))
        if not v <= res:
            res = v if np.isfinite(v) else np.inf
    return res / (1.0 + zmax)


@noalloc
def _solve_final_basis(mt, qn, basis, n, zn, work, idx):
    """Solve ``Mn[S, S] z_S = -qn[S]`` for the set S of basic z's by Gaussian elimination
    with partial pivoting into ``zn`` (other entries 0, negatives clamped to 0).
    ``work`` (n, n + 1) and ``idx`` (n,) are scratch. False if the block is singular."""
    m = 0
    for i in range(n):
        b = basis[i]
        if n <= b < 2 * n:
            idx[m] = b - n
            m += 1
    for a in range(m):                    # work[:m, :m+1] = [Mn_SS | -qn_S]
        for c in range(m):
            work[a, c] = mt[idx[c], idx[a]]
        work[a, m] = -qn[idx[a]]
    for c in range(m):
        p = c
        for a in range(c + 1, m):
            if abs(work[a, c]) > abs(work[p, c]):
                p = a
        if not abs(work[p, c]) > 0.0:
            return False
        if p != c:
            for k in range(c, m + 1):
                work[c, k], work[p, k] = work[p, k], work[c, k]
        for a in range(c + 1, m):
            f = work[a, c] / work[c, c]
            if f != 0.0:
                for k in range(c, m + 1):
                    work[a, k] -= f * work[c, k]
    for j in range(n):
        zn[j] = 0.0
    for a in range(m - 1, -1, -1):
        s = work[a, m]
        for c in range(a + 1, m):
            s -= work[a, c] * zn[idx[c]]
        zn[idx[a]] = s / work[a, a]
    for a in range(m):
        zn[idx[a]] = max(zn[idx[a]], 0.0)  # a wrong sign shows up in the residual
    return True


# The normalised problem and the tableau of one call of ``lemke`` (n variables).
LemkeWork = namedtuple("LemkeWork", [
    "mt",       # (n, n) M^T / max|M|: row j is column j of the normalised M
    "qn",       # (n,) q / max|q|
    "bt",       # (n, n) B^-1 transposed
    "x",        # (n,) basic values B^-1 qn
    "basis",    # (n,) int64 basic variable of each row: w_j = j, z_j = n + j, z0 = 2n
    "col",      # (n,) the entering column
    "cand",     # (n,) int64 rows tied in the ratio test
    "zn",       # (n,) the normalised solution
    "work",     # (n, n + 1) the final direct solve
])


@noalloc
def _try_guess(lw, guess, n):
    """Solve the basis where the ``z`` marked in ``guess`` are basic (the others at zero)
    into ``lw.zn``; True if that solves the normalised LCP to ``WARM_TOL``."""
    mt, qn, basis, zn = lw.mt, lw.qn, lw.basis, lw.zn
    for i in range(n):
        basis[i] = n + i if guess[i] else i
    if not _solve_final_basis(mt, qn, basis, n, zn, lw.work, lw.cand):
        return False
    return _residual_normalised(mt, qn, zn, n, lw.x) <= WARM_TOL


@noalloc
def _path(lw, r0, n, max_iter, pivot_tol):
    """Follow Lemke's path for the normalised problem (``lw.mt = Mn^T``, ``lw.qn``)
    starting with ``z0`` entering in row ``r0``; on success ``lw.zn`` holds the verified
    normalised solution. The other arrays of ``lw`` are scratch.
    Returns (status, pivots)."""
    mt, qn, bt, x, basis = lw.mt, lw.qn, lw.bt, lw.x, lw.basis
    col, cand, zn, work = lw.col, lw.cand, lw.zn, lw.work
    for i in range(n):
        for k in range(n):
            bt[i, k] = 0.0
        bt[i, i] = 1.0
        x[i] = qn[i]                      # basic values B^-1 qn
        basis[i] = i                      # codes: w_j = j, z_j = n + j, z0 = 2n
        zn[i] = 0.0

    # first pivot: z0 enters in the row of the most negative q, making every w >= 0
    _entering_column(2 * n, n, bt, mt, col)
    grown = max(1.0, _pivot(r0, col, bt, x, n))
    leaving = basis[r0]
    basis[r0] = 2 * n
    pivots = 1
    while True:
        entering = leaving + n if leaving < n else leaving - n   # the complement
        if pivots >= max_iter:
            return LEMKE_MAX_ITER, pivots
        if not _entering_column(entering, n, bt, mt, col):
            return LEMKE_BAD_INPUT, pivots
        r = _leaving_row(col, x, bt, basis, n, pivot_tol, cand, NOISE * grown)
        if r == -1:
            return LEMKE_RAY, pivots
        if r < 0:
            return LEMKE_BAD_INPUT, pivots
        grown = max(grown, _pivot(r, col, bt, x, n))
        leaving = basis[r]
        basis[r] = entering
        pivots += 1
        if leaving == 2 * n:
            break

    # z0 has left: the basis is complementary. Take z from the tableau and from a
    # direct solve of the basis, keep the better, and verify it.
    for i in range(n):
        b = basis[i]
        if n <= b < 2 * n:
            zn[b - n] = max(x[i], 0.0)
    res = _residual_normalised(mt, qn, zn, n, x)   # x is free now: scratch for w
    if _solve_final_basis(mt, qn, basis, n, col, work, cand):
        res_direct = _residual_normalised(mt, qn, col, n, x)
        if res_direct <= res:
            res = res_direct
            for j in range(n):
                zn[j] = col[j]
    if not res <= VERIFY_TOL:
        return LEMKE_INACCURATE, pivots
    return LEMKE_SOLVED, pivots


@njit(cache=True)
def lemke(M, q, max_iter, pivot_tol, z_out):
    """Solve the LCP ``(M, q)`` by Lemke's method with covering vector ``d = ones``.
    (``lemke_warm`` first tries a guessed basis.)

    M (n, n) float64, q (n,) float64; z_out (n,) float64 receives ``z`` (units of
    ``q / M``), all zeros unless the status is LEMKE_SOLVED. ``max_iter`` caps the
    number of pivots (the first, ``z0`` entering, counts; a problem that needs exactly
    ``max_iter`` is solved; a retry shares the cap). ``pivot_tol`` is the smallest
    tableau entry accepted as a pivot, relative to ``max|M|``; 1e-12 is a good value.

    If the path ends in a ray or fails verification and ``pivot_tol < RETRY_PIVOT_TOL``,
    it is followed once more with ``pivot_tol = RETRY_PIVOT_TOL``; the first status is
    reported if that does not solve it either.

    Returns (status, pivots over both attempts). ``q >= 0`` gives ``z = 0`` with 0
    pivots. Allocates its (n, n) work arrays once at the start; O(n^2) per pivot plus
    one O(n^3 / 3) solve per attempt.
    """
    return _lemke(M, q, max_iter, pivot_tol, z_out, np.zeros(0, np.bool_))


@njit(cache=True)
def lemke_warm(M, q, guess, max_iter, pivot_tol, z_out):
    """``lemke`` started from a guess: ``guess`` (n,) bool marks the ``z`` expected to be
    positive (say, last step's active set). The guess is solved directly
    (``M_SS z_S = -q_S``) and kept if it solves the LCP to ``WARM_TOL``, which only the
    right complementary basis does (then z is exact to round-off); else Lemke's path runs
    as in ``lemke``. Returns (status, pivots); a guess kept costs 0 pivots."""
    if guess.shape[0] != q.shape[0]:
        return LEMKE_BAD_INPUT, 0
    return _lemke(M, q, max_iter, pivot_tol, z_out, guess)


@njit(cache=True)
def _lemke(M, q, max_iter, pivot_tol, z_out, guess):
    """``lemke``, after trying the basis ``guess`` when it has n entries."""
    n = q.shape[0]
    if M.shape[0] != n or M.shape[1] != n or z_out.shape[0] != n:
        return LEMKE_BAD_INPUT, 0
    for i in range(n):
        z_out[i] = 0.0
    if not (pivot_tol >= 0.0 and np.isfinite(pivot_tol)):
        return LEMKE_BAD_INPUT, 0
    scale_m = 0.0
    for i in range(n):
        for j in range(n):
            a = M[i, j]
            if not np.isfinite(a):
                return LEMKE_BAD_INPUT, 0
            scale_m = max(scale_m, abs(a))
    scale_q = 0.0
    r0 = np.int64(-1)                  # not a literal: one compilation of _path
    for i in range(n):
        if not np.isfinite(q[i]):
            return LEMKE_BAD_INPUT, 0
        scale_q = max(scale_q, abs(q[i]))
        # most negative q; the lexicographic rule sends exact ties to the last index
        if q[i] < 0.0 and (r0 < 0 or q[i] <= q[r0]):
            r0 = i
    if r0 < 0:
        return LEMKE_SOLVED, 0            # q >= 0: z = 0 already solves it
    if max_iter < 1:
        return LEMKE_MAX_ITER, 0
    if scale_m == 0.0:
        scale_m = 1.0
    mt = np.empty((n, n))                 # row j = column j of M / max|M|
    for i in range(n):
        for j in range(n):
            mt[j, i] = M[i, j] / scale_m
    qn = np.empty(n)                      # q / max|q|
    for i in range(n):
        qn[i] = q[i] / scale_q
    lw = LemkeWork(mt, qn, np.empty((n, n)), np.empty(n), np.empty(n, np.int64), np.empty(n),
                   np.empty(n, np.int64), np.empty(n), np.empty((n, n + 1)))
    if guess.shape[0] == n and _try_guess(lw, guess, n):
        status, pivots = LEMKE_SOLVED, 0
    else:
        status, pivots = _path(lw, r0, n, max_iter, pivot_tol)
    if (status == LEMKE_RAY or status == LEMKE_INACCURATE) and pivot_tol < RETRY_PIVOT_TOL \
            and pivots < max_iter:
        # a nearly singular basis (tiny regularisation of redundant rows) can derail the
        # path; treating such pivots as zero usually keeps it on a solvable track
        status2, pivots2 = _path(lw, r0, n, max_iter - pivots, RETRY_PIVOT_TOL)
        pivots += pivots2
        if status2 == LEMKE_SOLVED:
            status = status2
    if status != LEMKE_SOLVED:
        return status, pivots
    back = scale_q / scale_m              # z = (max|q| / max|M|) * z_normalised
    for j in range(n):
        v = lw.zn[j] * back
        if not np.isfinite(v):            # only if z overflows float64
            for k in range(n):
                z_out[k] = 0.0
            return LEMKE_BAD_INPUT, pivots
        z_out[j] = v
    return LEMKE_SOLVED, pivots


@njit(cache=True)
def lcp_residual(M, q, z):
    """Relative natural residual of a candidate ``z``: the check ``lemke`` applies.

    In the normalised units of ``lemke`` (``Mn = M / max|M|``, ``qn = q / max|q|``,
    ``zn = z max|M| / max|q|``, ``wn = Mn zn + qn``) it is
    ``max_i |min(zn_i, wn_i)| / (1 + max|zn|)``: dimensionless, zero iff ``z`` solves,
    near ``n * eps`` for a good solution of a well-conditioned problem."""
    n = q.shape[0]
    scale_m = 0.0
    scale_q = 0.0
    for i in range(n):
        scale_q = max(scale_q, abs(q[i]))
        for j in range(n):
            scale_m = max(scale_m, abs(M[i, j]))
    if scale_m == 0.0:
        scale_m = 1.0
    if scale_q == 0.0:
        scale_q = 1.0
    mt = np.empty((n, n))
    qn = np.empty(n)
    zn = np.empty(n)
    for i in range(n):
        qn[i] = q[i] / scale_q
        zn[i] = (z[i] * scale_m) / scale_q   # (not z * (m / q): that is 0 * inf for a tiny q)
        for j in range(n):
            mt[j, i] = M[i, j] / scale_m
    return _residual_normalised(mt, qn, zn, n, np.empty(n))


def lemke_solve(M, q, max_iter=None, pivot_tol=1e-12):
    """Convenience wrapper: returns (z, status) for the LCP ``(M, q)``.

    ``max_iter`` defaults to ``10 * (n + 1)`` pivots: contact problems need about
    0.7 n (at most ~2 n seen), and the worst cases of the method are exponential
    anyway, so a linear cap reports them as LEMKE_MAX_ITER instead of stalling.
    Raises ValueError if the shapes do not match (M (n, n), q (n,)).
    """
    M = np.ascontiguousarray(M, dtype=np.float64)
    q = np.ascontiguousarray(q, dtype=np.float64).reshape(-1)
    n = q.shape[0]
    if M.shape != (n, n):
        raise ValueError(f"M must be ({n}, {n}) to match q, got {M.shape}")
    if max_iter is None:
        max_iter = 10 * (n + 1)
    z = np.zeros(n)
    status, _ = lemke(M, q, int(max_iter), float(pivot_tol), z)
    return z, status
