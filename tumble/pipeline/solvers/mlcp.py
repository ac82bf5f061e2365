"""Contacts and joints as one mixed LCP, solved exactly with Lemke's algorithm.

Rows (see ``joints/common.py``) fall into four kinds:

* bilateral (unbounded: joint rows, dampers) -- eliminated first by a direct solve,
  leaving the Schur complement ``S = A_NN - A_NB A_BB^-1 A_BN`` on the others;
* unilateral (``[0, inf)``: contact normals, joint limits) -- one LCP variable each;
* friction rows of a contact (bounds ``-+ mu p_n``) -- the friction pyramid of
  Stewart and Trinkle: each tangent row gives two variables ``beta+-`` (impulse
  ``beta+ - beta-``), and each contact one slack ``lambda`` with
  ``w_beta+- = +-(row velocity) + lambda`` and ``w_lambda = mu p_n - sum(beta)``: four
  directions, the Coulomb cone's inscribed pyramid;
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
from .direct import assemble, cholesky_apply, cholesky_factor, row_dot, row_responses
from .lemke import LEMKE_SOLVED, lemke
from .tree import tree_factor, tree_plan, tree_solve

KIND_BILATERAL, KIND_UNILATERAL, KIND_FRICTION, KIND_BOX = 0, 1, 2, 3
_BIG = 0.5 * INF


@njit(cache=True)
def solve_mlcp(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, max_pivots):
    """Solve the rows exactly; apply the impulses. Returns Lemke's status (0: solved).

    ``max_pivots`` caps Lemke's pivots (<= 0: ten times the LCP size).

    On failure nothing is applied and ``impulse`` is left as it came (warm start for
    the caller's fallback).
    """
    return mixed_lcp(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, max_pivots, True)


@njit(cache=True)
def mixed_lcp(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, max_pivots, allow_tree):
    """``solve_mlcp``; with ``allow_tree`` False the Schur complement is always formed
    densely (the reference the tree path is tested against)."""
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
    nbody = vel.shape[0]
    dv = np.zeros((n, 12))
    b = np.zeros(n)
    row_responses(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, b)
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
    # Schur complement S = A_NN - A_NB A_BB^-1 A_BN, c = b_N - A_NB A_BB^-1 b_B, and
    # X = A_BB^-1 [A_BN | b_B] to recover the bilateral impulses
    X = np.zeros((nb, nn + 1))
    S = np.empty((nn, nn))
    cvec = np.empty(nn)
    if not (allow_tree and _schur_tree(rows, idx, n, bil, nb, oth, nn, dv, b, inv_mass,
                                       inv_inertia, nbody, X, S, cvec)):
        if not _schur_dense(rows, idx, n, bil, nb, oth, nn, inv_mass, inv_inertia, vel, angvel,
                            X, S, cvec):
            return 3
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
    # slack per contact (friction rows sharing a parent) or per box row
    for i in range(nn):
        k = kind[oth[i]]
        if k != KIND_FRICTION and k != KIND_BOX:
            continue
        if k == KIND_FRICTION:
            parent = rows.parent[idx[oth[i]]]
            for j in range(i):
                if kind[oth[j]] == KIND_FRICTION and rows.parent[idx[oth[j]]] == parent:
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


@njit(cache=True)
def _schur_tree(rows, idx, n, bil, nb, oth, nn, dv, b, inv_mass, inv_inertia, nbody, X, S,
                cvec):
    """The Schur complement with the bilateral rows factorised over their tree (tree.py).

    Column j of ``A_BB^-1 A_BN`` solves ``A_BB x = J_B dv_j`` (``dv_j = M^-1 J_j^T``); the
    same solve gives ``u = -M^-1 J_B^T x``, so ``dv_j + u`` is the velocity change of the
    jointed bodies per unit impulse on row j and ``S_ij = J_i (dv_j + u) + cfm_i [i == j]``.
    Returns False when the bilateral rows do not form a tree (or do not factorise)."""
    bsel = np.empty(nb, np.int64)
    cfm = np.empty(nb)
    for u in range(nb):
        bsel[u] = idx[bil[u]]
        cfm[u] = rows.cfm[bsel[u]]
    ok, plan = tree_plan(rows, bsel, nb, inv_mass, nbody)
    if not ok or not tree_factor(plan, rows, bsel, cfm, inv_mass, inv_inertia, nbody):
        return False
    f = np.zeros((nbody, 6))
    g = np.empty(nb)
    x = np.empty(nb)
    acc = np.zeros((nbody, 6))
    for c in range(nn + 1):
        if c < nn:
            j = oth[c]
            rj = idx[j]
            for u in range(nb):
                g[u] = -_row_dot_dv(rows, bsel[u], rows.body_a[rj], rows.body_b[rj], dv[j])
        else:
            for u in range(nb):
                g[u] = -b[bil[u]]
        tree_solve(plan, nbody, f, g, acc, x)
        for u in range(nb):
            X[u, c] = x[u]
        if c < nn:
            j = oth[c]
            rj = idx[j]
            for side in range(2):
                body = rows.body_a[rj] if side == 0 else rows.body_b[rj]
                if body >= 0:
                    for k in range(6):
                        acc[body, k] += dv[j, 6 * side + k]
            for i in range(nn):
                S[i, c] = row_dot(rows, idx[oth[i]], acc)
            S[c, c] += rows.cfm[rj]
        else:
            for i in range(nn):
                cvec[i] = b[oth[i]] + row_dot(rows, idx[oth[i]], acc)
    return True


@njit(cache=True, inline="always")
def _row_dot_dv(rows, r, body_a, body_b, dv):
    """``J_r`` times the velocity change ``dv`` (12,) of bodies ``body_a``, ``body_b``."""
    s = 0.0
    for side in range(2):
        body = rows.body_a[r] if side == 0 else rows.body_b[r]
        if body < 0:
            continue
        for side2 in range(2):
            other = body_a if side2 == 0 else body_b
            if other == body:
                for k in range(6):
                    s += rows.J[r, 6 * side + k] * dv[6 * side2 + k]
    return s


@njit(cache=True)
def _schur_dense(rows, idx, n, bil, nb, oth, nn, inv_mass, inv_inertia, vel, angvel, X, S,
                 cvec):
    """The Schur complement from the dense ``A`` (loops of joints): one Cholesky
    factorisation of ``A_BB``, then a solve per column. False if it is not positive
    definite."""
    dv = np.zeros((n, 12))
    A = np.zeros((n, n))
    b = np.zeros(n)
    assemble(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, A, b)
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
