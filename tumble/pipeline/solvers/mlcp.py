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
"""
import numpy as np
from numba import njit

from ..joints.common import INF
from .common import apply_impulse, row_active
from .direct import assemble, cholesky_solve
from .lemke import LEMKE_SOLVED, lemke

KIND_BILATERAL, KIND_UNILATERAL, KIND_FRICTION, KIND_BOX = 0, 1, 2, 3
_BIG = 0.5 * INF


@njit(cache=True)
def solve_mlcp(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, max_pivots):
    """Solve the rows exactly; apply the impulses. Returns Lemke's status (0: solved).

    ``max_pivots`` caps Lemke's pivots (<= 0: ten times the LCP size).

    On failure nothing is applied and ``impulse`` is left as it came (warm start for
    the caller's fallback).
    """
    idx = np.empty(nrow, np.int64)
    where = np.full(nrow, -1, np.int64)          # row -> position among active rows
    n = 0
    for r in range(nrow):
        if row_active(rows, r):
            where[r] = n
            idx[n] = r
            n += 1
    if n == 0:
        return LEMKE_SOLVED
    dv = np.zeros((n, 12))
    A = np.zeros((n, n))
    b = np.zeros(n)
    assemble(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, A, b)
    kind = np.empty(n, np.int64)
    nb = 0
    for i in range(n):
        r = idx[i]
        if rows.parent[r] >= 0:
            kind[i] = KIND_FRICTION
        elif rows.lo[r] <= -_BIG and rows.hi[r] >= _BIG:
            kind[i] = KIND_BILATERAL
            nb += 1
        elif rows.lo[r] == 0.0 and rows.hi[r] >= _BIG:
            kind[i] = KIND_UNILATERAL
        else:
            kind[i] = KIND_BOX
    bil = np.empty(nb, np.int64)
    oth = np.empty(n - nb, np.int64)
    k1 = k2 = 0
    for i in range(n):
        if kind[i] == KIND_BILATERAL:
            bil[k1] = i
            k1 += 1
        else:
            oth[k2] = i
            k2 += 1
    nn = n - nb
    # Schur complement: X = A_BB^-1 [A_BN | b_B]
    Abb = np.empty((nb, nb))
    for u in range(nb):
        for v in range(nb):
            Abb[u, v] = A[bil[u], bil[v]]
    work = np.zeros((nb, nb))
    X = np.zeros((nb, nn + 1))
    col = np.empty(nb)
    for c in range(nn + 1):
        for u in range(nb):
            col[u] = A[bil[u], oth[c]] if c < nn else b[bil[u]]
        x, ok = cholesky_solve(Abb, col, nb, work)
        if not ok:
            return 3
        for u in range(nb):
            X[u, c] = x[u]
    S = np.empty((nn, nn))
    cvec = np.empty(nn)
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
    # LCP variables: one per unilateral row, two per friction/box row, one slack per group
    var_row = np.empty(3 * nn, np.int64)       # position in oth
    var_sign = np.zeros(3 * nn)                # +1 / -1 impulse sign; 0 for slacks
    group_of = np.full(nn, -1, np.int64)       # slack variable of each friction/box row
    nz = 0
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
    status, _ = lemke(M, q, max_pivots if max_pivots > 0 else 10 * (nz + 1), 1e-12, z)
    if status != LEMKE_SOLVED:
        return status
    p = np.zeros(n)
    for a in range(nz):
        if var_sign[a] != 0.0:
            p[oth[var_row[a]]] += var_sign[a] * z[a]
    for u in range(nb):
        s = X[u, nn]
        for j in range(nn):
            s -= X[u, j] * p[oth[j]]
        p[bil[u]] = s
    for r in range(nrow):
        impulse[r] = 0.0
    for i in range(n):
        impulse[idx[i]] = p[i]
        apply_impulse(rows, idx[i], dv[i], p[i], vel, angvel)
    return LEMKE_SOLVED
