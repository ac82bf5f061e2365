"""The LCP of the non-bilateral rows with friction pyramids, solved by Lemke's method.

Once the bilateral rows are eliminated, the other rows of a ``RowPartition`` (positions
``oth``) see ``w = S p - c`` with ``S`` (nn, nn) their Schur complement. Friction rows
of a contact take the friction pyramid of Stewart and Trinkle: each tangent row gives
two variables ``beta+-`` (impulse ``beta+ - beta-``), and each group of rows
(``rows.group``: a contact's two tangents, its two rolling rows, its torsional row
alone) one slack ``lambda`` with ``w_beta+- = +-(row velocity) + lambda`` and
``w_lambda = mu p_n - sum(beta)``: four directions, the Coulomb cone's inscribed pyramid
(two for a lone row: a box). Box rows take the same construction with the constant
bound ``F``. With ``p_N = G z`` the LCP is ``w = M z + q``, ``M = P S G`` plus the
pyramid couplings.
"""
import numpy as np
from numba import njit

from ..._jit import noalloc
from .lemke import LEMKE_INACCURATE, LEMKE_SOLVED, VERIFY_TOL, lemke, lemke_warm
from .partition import KIND_BOX, KIND_FRICTION, KIND_UNILATERAL, normal_of


@njit(cache=True, inline="always")
def slack(tol, cmax, smax, pmax):
    """(velocity, impulse) slack of the complementarity checks for a problem whose
    largest ``|c|``, diagonal of ``S`` and impulse are these: ``tol`` of its scale."""
    tol_w = tol * (cmax + smax * pmax)
    return tol_w, tol_w / smax


@noalloc
def problem_scale(S, cvec, p, nn):
    """(largest |c|, diagonal of ``S`` and |p|) of an LCP of ``nn`` rows: the scale its
    checks' slack is relative to (``slack``)."""
    cmax = 1e-300
    smax = 1e-300
    pmax = 0.0
    for a in range(nn):
        cmax = max(cmax, abs(cvec[a]))
        smax = max(smax, abs(S[a, a]))
        pmax = max(pmax, abs(p[a]))
    return cmax, smax, pmax


@njit(cache=True)
def pyramid_lcp(rows, part, S, cvec, impulse, max_pivots, warm, p_n):
    """Lemke on the friction-pyramid LCP of ``S``, ``c`` (module docstring); with ``warm``
    last step's active set is tried first (``lemke_warm``). ``p_n`` (nn,) out.
    Returns Lemke's status."""
    idx, where, kind, oth, nn = part.idx, part.where, part.kind, part.oth, part.nn
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
        guess = _active_guess(rows, part, var_row, var_sign, group_of, nz, impulse)
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
    if not complementary(rows, part, S, cvec, p_n, VERIFY_TOL, np.empty(nn)):
        return LEMKE_INACCURATE
    return LEMKE_SOLVED


@noalloc
def complementary(rows, part, S, cvec, p, tol, w):
    """Whether ``p`` (nn,) solves the mixed LCP of ``S p - c`` (module docstring) to ``tol``
    of the problem's scale: normals and limits push or let go, box rows keep their
    bounds, each friction group stays in its pyramid and slips only on its edge, against
    the direction of its impulse. ``w`` (nn,) receives ``S p - c``."""
    idx, kind, oth, nn = part.idx, part.kind, part.oth, part.nn
    cmax, smax, pmax = problem_scale(S, cvec, p, nn)
    for a in range(nn):
        acc = -cvec[a]
        for c in range(nn):
            acc += S[a, c] * p[c]
        w[a] = acc
    tol_w, tol_p = slack(tol, cmax, smax, pmax)
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
            normal = normal_of(rows, part, r)
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
def _active_guess(rows, part, var_row, var_sign, group_of, nz, impulse):
    """Which LCP variables the warm-start impulses (last step's, carried by each contact
    and joint row) say are positive: a pushing normal or limit, the signed half of a
    friction or box row that carries impulse, and the slack of a group at its bound (a
    sliding contact, a saturated motor). While the contacts keep their state this is
    the answer, and Lemke's path is skipped (see ``lemke_warm``)."""
    idx, kind, oth = part.idx, part.kind, part.oth
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
