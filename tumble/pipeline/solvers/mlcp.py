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

from ..._jit import noalloc
from ..joints.common import INF
from .common import active_rows, apply_impulses, make_rows_nb
from .direct import assemble, cholesky_apply, cholesky_factor, row_dot, row_responses
from .lemke import LEMKE_SOLVED, lemke_warm
from .tree import tree_factor, tree_inverse_mass_rows, tree_plan, tree_solve

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
    where = np.empty(nrow, np.int64)             # row -> position among active rows
    # (the impulses stay as they came until Lemke has solved: a scratch copy is zeroed)
    n = active_rows(rows, nrow, idx, where, np.empty(nrow))
    if n == 0:
        return LEMKE_SOLVED
    nbody = vel.shape[0]
    dv = np.zeros((n, 12))
    b = np.zeros(n)
    row_responses(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, b)
    kind = np.empty(n, np.int64)
    nb = np.int64(0)                 # not a literal: one compilation of its callees
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
    # Schur complement S = A_NN - A_NB A_BB^-1 A_BN and c = b_N - A_NB A_BB^-1 b_B; the
    # bilateral impulses follow from the others once Lemke has them
    S = np.empty((nn, nn))
    cvec = np.empty(nn)
    bsel = np.empty(nb, np.int64)
    for u in range(nb):
        bsel[u] = idx[bil[u]]
    tree, plan = False, _no_plan(inv_mass)
    if allow_tree:
        tree, plan = _schur_tree(rows, idx, bil, nb, oth, nn, bsel, dv, b, inv_mass, inv_inertia,
                                 nbody, S, cvec)
    X = np.zeros((0 if tree else nb, nn + 1))     # dense path: A_BB^-1 [A_BN | b_B]
    if not tree and not _schur_dense(rows, idx, n, bil, nb, oth, nn, inv_mass, inv_inertia,
                                     vel, angvel, X, S, cvec):
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
    guess = _active_guess(rows, idx, oth, kind, var_row, var_sign, group_of, nz, impulse)
    status, _ = lemke_warm(M, q, guess, max_pivots if max_pivots > 0 else 10 * (nz + 1),
                           1e-12, z)
    if status != LEMKE_SOLVED:
        return status
    p = np.zeros(n)
    for a in range(nz):
        if var_sign[a] != 0.0:
            p[oth[var_row[a]]] += var_sign[a] * z[a]
    if tree:
        _bilateral_tree(plan, rows, idx, n, bil, nb, bsel, dv, b, p, nbody, np.zeros((nbody, 6)),
                        np.empty(nb), np.empty(nb))
    else:
        for u in range(nb):
            s = X[u, nn]
            for j in range(nn):
                s -= X[u, j] * p[oth[j]]
            p[bil[u]] = s
    for r in range(nrow):
        impulse[r] = 0.0
    for i in range(n):
        impulse[idx[i]] = p[i]
    apply_impulses(rows, idx, n, dv, p, vel, angvel)
    return LEMKE_SOLVED


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


@njit(cache=True)
def _no_plan(inv_mass):
    """An empty plan, to give the variable its type when the tree path is not taken."""
    zero = np.int64(0)          # not a literal: the same compiled tree_plan as the others
    return tree_plan(make_rows_nb(zero), np.empty(zero, np.int64), zero, inv_mass, zero)[1]


@njit(cache=True)
def _schur_tree(rows, idx, bil, nb, oth, nn, bsel, dv, b, inv_mass, inv_inertia, nbody, S,
                cvec):
    """The Schur complement with the bilateral rows factorised over their tree (tree.py):
    ``S = J_N M_B^-1 J_N^T + C_N`` with ``M_B^-1`` the jointed bodies' inverse mass
    (``tree_inverse_mass_rows``), and ``c = b_N + J_N u`` where ``u = -M^-1 J_B^T A_BB^-1
    b_B`` is one tree solve. Returns (ok, plan); ok is False when the bilateral rows do not
    form a tree (or do not factorise)."""
    cfm = np.empty(nb)
    for u in range(nb):
        cfm[u] = rows.cfm[bsel[u]]
    ok, plan = tree_plan(rows, bsel, nb, inv_mass, nbody)
    if not ok or not tree_factor(plan, rows, bsel, cfm, inv_mass, inv_inertia, nbody):
        return False, plan
    nnode = nbody + nb
    cols = np.empty(nn, np.int64)
    dvc = np.empty((nn, 12))
    for c in range(nn):
        cols[c] = idx[oth[c]]
        dvc[c] = dv[oth[c]]
    tree_inverse_mass_rows(plan, rows, cols, nn, dvc, nbody, np.zeros((nn, 6 * nbody + nb)),
                           np.zeros((nn, nnode), np.bool_), np.empty((nn, nnode), np.int64),
                           np.zeros(nn, np.int64), S)
    _schur_rhs(plan, rows, bil, nb, cols, nn, b, oth, nbody, S, cvec, np.zeros((nbody, 6)),
               np.empty(nb), np.empty(nb))
    return True, plan


@noalloc
def _schur_rhs(plan, rows, bil, nb, cols, nn, b, oth, nbody, S, cvec, u, g, y):
    """CFM on the diagonal of S, and ``c = b_N + J_N u`` with ``K [u; y] = [0; -b_B]``."""
    for c in range(nn):
        S[c, c] += rows.cfm[cols[c]]
    for k in range(nb):
        g[k] = -b[bil[k]]
    tree_solve(plan, nbody, u, g, u, y)          # f = u = 0 on entry
    for c in range(nn):
        cvec[c] = b[oth[c]] + row_dot(rows, cols[c], u)


@noalloc
def _bilateral_tree(plan, rows, idx, n, bil, nb, bsel, dv, b, p, nbody, acc, g, y):
    """Bilateral impulses from the others: ``A_BB p_B = b_B - J_B M^-1 J_N^T p_N``, one
    tree solve (``p`` holds p_N on entry, zero at the bilateral rows)."""
    acc[:] = 0.0
    for i in range(n):
        if p[i] == 0.0:
            continue
        r = idx[i]
        for side in range(2):
            body = rows.body_a[r] if side == 0 else rows.body_b[r]
            if body >= 0:
                for k in range(6):
                    acc[body, k] += dv[i, 6 * side + k] * p[i]
    for k in range(nb):
        g[k] = b[bil[k]] - row_dot(rows, bsel[k], acc)
    acc[:] = 0.0
    tree_solve(plan, nbody, acc, g, acc, y)
    for k in range(nb):
        p[bil[k]] = -y[k]


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
