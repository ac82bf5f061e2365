"""Last step's contact state as the mixed LCP's active set, solved and checked.

Each non-bilateral row of a ``RowPartition`` gets a state from last step's impulses
(``guess_states``): pushing contacts sticking, the others apart. The rows the guess holds
are solved alone (``solve_held``: the Cholesky factor of their block of ``S``), and the
guess is the LCP's answer when every other row passes the complementarity checks, to
``GUESS_TOL`` of the problem's scale -- what a resting or walking character mostly meets.
Two forms:

* ``guess_on_tree``: before any complement is formed, ``S`` only for the rows the guess
  holds, from one column of the tree's factor per row, and the velocities from one
  forward and one back substitution;
* ``guessed_active_set``: on a complement ``S`` of every row, with a few primal-dual
  corrections for contacts that come or go.

A contact whose friction was at its pyramid's bound last step (sliding, or Lemke's basis
putting a redundant corner's friction at the bound) is guessed at the bound again by
``guess_on_tree`` (``allow_bound``): its friction rows that carried impulse keep their signs,
their impulses sum to ``mu p_n``, and they slip at the group's common rate ``lambda >= 0``
(the pyramid's slack, ``pyramid.py``), which makes the held system unsymmetric (solved by
Gaussian elimination). Redundant held rows (four coplanar contacts of a box) are dropped
by the factorisation (impulse 0) when the others satisfy them.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from ..._jit import noalloc
from .common import minv_jt
from .direct import cholesky_apply, cholesky_factor_dropping, row_dot
from .partition import (KIND_BOX, KIND_FRICTION, KIND_UNILATERAL, group_load, load_slot,
                        normal_of, same_group)
from .pyramid import slack
from .schur import push
from .tree import (RowColumns, tree_add_columns, tree_backward, tree_column_dot, tree_forward,
                   tree_load, tree_row_columns, tree_unload)

# Feasibility slack of a guessed active set, relative to the problem's scale: a guess is
# the LCP's solution when every inequality holds to this (then p is exact to round-off).
GUESS_TOL = 1e-10
# Unknowns (held rows and sliding groups' slip rates) a guess with sliding contacts may
# have; more go to Lemke (two feet of four sliding corners each: 32).
SLIDE_UNKNOWNS = 64
# Primal-dual corrections of the guess before Lemke takes over. A round costs one held
# solve and one product with S; Lemke on the 10-box stack's 120 rows costs 25 of them,
# and with 4 rounds a fifth of its steps went to Lemke (whose basis then kept the next
# guesses failing), with 16 none.
_GUESS_ROUNDS = 16
# A pivot of the guess's Cholesky factor below this times its diagonal entry marks
# redundant rows (four coplanar contacts of a box): they are dropped (impulse 0).
REDUNDANT = 1e-10

# states of a row in a guessed active set; SLIDE_*: a friction row at its group's bound,
# carrying impulse of that sign
ZERO, EQUAL, AT_LO, AT_HI, SLIDE_POS, SLIDE_NEG = 0, 1, 2, 3, 4, 5

# Scratch of ``solve_held`` for up to k rows (``make_held_scratch``).
HeldScratch = namedtuple("HeldScratch", [
    "free",     # (k,) int64 the held rows' positions
    "mat",      # (k, k) their block of S
    "fac",      # (k, k) its Cholesky factor
    "rhs",      # (k,)
    "x",        # (k,)
    "aug",      # (K, K + 1) the unsymmetric system with sliding groups, rhs last; K =
                # min(2k, SLIDE_UNKNOWNS)
    "gkey",     # (k,) int64 each sliding group's first held row (position in sub)
    "gnorm",    # (k,) int64 its normal's position in sub
    "lam",      # (k,) each held row's group's slip rate lambda (0 when not sliding)
])


@njit(cache=True)
def make_held_scratch(k):
    """``HeldScratch`` for up to ``k`` rows (no need to zero)."""
    K = min(2 * k, SLIDE_UNKNOWNS)
    return HeldScratch(np.empty(k, np.int64), np.empty((k, k)), np.empty((k, k)), np.empty(k),
                       np.empty(k), np.empty((K, K + 1)), np.empty(k, np.int64),
                       np.empty(k, np.int64), np.empty(k))


# The vectors of the tree path for one solve (``tree_work``).
TreeWork = namedtuple("TreeWork", [
    "load",     # (2 row capacity,) friction groups' loads (guess_states)
    "p",        # (nn,) impulses of the non-bilateral rows, indexed like oth
    "b",        # (n,) the active rows' rhs - J v
    "g",        # (nb,) b's bilateral part
    "y",        # (nb,) the bilateral rows' unknowns (y = -p)
    "vn",       # (nbody, 6) the bodies' new velocities [linear, angular]
    "state",    # (nn,) int64 each row's guessed state
    "sub",      # (nn,) int64 positions in oth of the rows the guess holds or fixes
])


@njit(cache=True, inline="always")
def tree_work(floats, ints, part, nload, nbody):
    """``TreeWork`` as views of ``floats`` (>= nload + nn + n + 2 nb + 6 nbody,) and ``ints``
    (>= 2 nn,) int64, whatever they hold. Inlined: it returns views, which a ``noalloc``
    caller may only borrow. (Each vector is exactly as long as the table says: the tree
    kernels read y's length.)"""
    nn, n, nb = part.nn, part.n, part.nb
    load, p = floats[:nload], floats[nload:nload + nn]
    o = nload + nn
    b, g, y = floats[o:o + n], floats[o + n:o + n + nb], floats[o + n + nb:o + n + 2 * nb]
    o += n + 2 * nb
    vn = floats[o:o + 6 * nbody].reshape((nbody, 6))
    return TreeWork(load, p, b, g, y, vn, ints[:nn], ints[nn:2 * nn])


# Scratch of ``guess_on_tree``, for up to k held rows (``make_guess_scratch``).
GuessScratch = namedtuple("GuessScratch", [
    "rsel",     # (k,) int64 the held rows
    "alone",    # (nbody,) bool bodies outside the tree
    "dva",      # (k, 12) M^-1 J^T of the rows on bodies outside the tree
    "cols",     # tree.RowColumns of the rows, (k, ...)
    "S",        # (k, k) S of the held rows
    "cvec",     # (k,) their c
    "pt",       # (k,) their impulses
    "held",     # HeldScratch for k rows
    "links",    # (2k,) int64 the sweeps' friction partners and normals (schur_pgs.py)
    "w",        # (k,) the sweeps' residuals
])


@njit(cache=True)
def make_guess_scratch(nheld, nbody, plan):
    """Scratch for ``guess_on_tree`` with up to ``nheld`` held rows on ``plan``."""
    k = max(nheld, 1)
    nz, nnode = plan.z.shape[0], plan.opos.shape[0]
    # no need to zero: guess_on_tree and tree_row_columns clear what they use
    return GuessScratch(np.empty(k, np.int64), np.empty(nbody, np.bool_), np.empty((k, 12)),
                        RowColumns(np.empty((k, nz)), np.empty((k, nnode), np.bool_),
                                   np.empty((k, nnode), np.int64), np.empty(k, np.int64)),
                        np.empty((k, k)), np.empty(k), np.empty(k), make_held_scratch(k),
                        np.empty(2 * k, np.int64), np.empty(k))


@noalloc
def guess_states(rows, part, impulse, state, load, allow_bound=False):
    """Each row's state (nn,) from last step's impulses: a pushing normal or limit holds
    (``EQUAL``), others are zero; a friction row of a pushing contact holds if it
    carried impulse, else stays zero (sticking contacts of one body are redundant in
    their tangents, and Lemke's basis keeps only some of them); a box row inside its
    bounds holds, at a bound it is fixed there. A friction group at its bound (sliding,
    or a redundant contact's friction put there by Lemke's basis): with ``allow_bound``
    its rows that carried impulse slide (``SLIDE_POS``/``SLIDE_NEG`` by their sign),
    else the function returns False (the guess cannot express it). ``load`` (2 nrow,)
    zero on entry (in the slots of the friction rows): scratch for the groups' loads."""
    idx, where, kind, oth, nn = part.idx, part.where, part.kind, part.oth, part.nn
    for a in range(nn):
        i = oth[a]
        r = idx[i]
        k = kind[i]
        if k == KIND_UNILATERAL:
            state[a] = EQUAL if impulse[r] > 0.0 else ZERO
        elif k == KIND_BOX:
            if impulse[r] >= rows.hi[r] * (1.0 - 1e-9) and rows.hi[r] > 0.0:
                state[a] = AT_HI
            elif impulse[r] <= rows.lo[r] * (1.0 - 1e-9) and rows.lo[r] < 0.0:
                state[a] = AT_LO
            else:
                state[a] = EQUAL
        elif k == KIND_FRICTION:
            # |impulse| summed over each friction pyramid (a lone row: its own slot)
            load[load_slot(rows, r, impulse.shape[0])] += abs(impulse[r])
    for a in range(nn):
        i = oth[a]
        if kind[i] != KIND_FRICTION:
            continue
        r = idx[i]
        pn = impulse[rows.parent[r]]
        if pn <= 0.0 or where[rows.parent[r]] < 0:
            state[a] = ZERO
            continue
        if load[load_slot(rows, r, impulse.shape[0])] >= rows.mu[r] * pn * (1.0 - 1e-9):
            if not allow_bound:
                return False
            if impulse[r] > 0.0:
                state[a] = SLIDE_POS
            elif impulse[r] < 0.0:
                state[a] = SLIDE_NEG
            else:
                state[a] = ZERO
            continue
        state[a] = EQUAL if impulse[r] != 0.0 else ZERO
    return True


@njit(cache=True, inline="always")
def is_sliding(st):
    """Whether a row's state is at its group's bound (SLIDE_POS or SLIDE_NEG)."""
    return st == SLIDE_POS or st == SLIDE_NEG


@noalloc
def solve_held(rows, part, sub, ns, state, S, cvec, p, hs):
    """The impulses of the rows ``oth[sub[:ns]]`` in their ``state`` (indexed like
    ``oth``), ``S`` and ``c`` indexed by position in ``sub``: rows at a bound keep it,
    zero rows nothing, and the held rows solve ``S_HH p_H = c_H - S_HB p_B`` (Cholesky);
    with sliding rows (``SLIDE_*``) the system gains each sliding group's slip rate
    ``lambda`` (``hs.lam``, by position in ``sub``) and the group's bound, and is solved
    by Gaussian elimination (``_solve_sliding``). Returns (ok, largest held impulse); ok
    is False for dependent held rows. ``hs``: ``make_held_scratch`` for at least ``ns``
    rows."""
    idx, oth = part.idx, part.oth
    free, mat, fac, rhs, x = hs.free, hs.mat, hs.fac, hs.rhs, hs.x
    nf = np.int64(0)
    slides = False
    for t in range(ns):
        a = sub[t]
        r = idx[oth[a]]
        hs.lam[t] = 0.0
        if state[a] == EQUAL or is_sliding(state[a]):
            slides = slides or is_sliding(state[a])
            free[nf] = t
            nf += 1
            p[a] = 0.0
        elif state[a] == AT_HI:
            p[a] = rows.hi[r]
        elif state[a] == AT_LO:
            p[a] = rows.lo[r]
        else:
            p[a] = 0.0
    for u in range(nf):
        t = free[u]
        acc = cvec[t]
        for v in range(ns):
            if state[sub[v]] == AT_HI or state[sub[v]] == AT_LO:
                acc -= S[t, v] * p[sub[v]]
        rhs[u] = acc
        for v in range(nf):
            mat[u, v] = S[t, free[v]]
    if slides:
        return _solve_sliding(rows, part, sub, ns, state, nf, hs, p)
    # a face's fourth contact depends on the other three: its row is dropped (impulse 0,
    # as in a basic solution of Lemke's) if the equations stay consistent without it
    dropped = cholesky_factor_dropping(mat, nf, fac, REDUNDANT)
    if dropped < 0:
        return False, 0.0
    cholesky_apply(fac, rhs, nf, x)
    if dropped > 0 and not _dropped_rows_hold(mat, rhs, fac, x, nf):
        return False, 0.0
    pmax = 0.0
    for u in range(nf):
        p[sub[free[u]]] = x[u]
        pmax = max(pmax, abs(x[u]))
    return True, pmax


@noalloc
def _dropped_rows_hold(mat, rhs, fac, x, n):
    """Whether the rows ``cholesky_factor_dropping`` dropped (infinite pivot in ``fac``)
    still hold in ``mat[:n, :n] x = rhs`` to 1e-9 of the system's scale."""
    scale = 1e-300
    xmax = dmax = 0.0
    for u in range(n):
        scale = max(scale, abs(rhs[u]))
        xmax = max(xmax, abs(x[u]))
        dmax = max(dmax, abs(mat[u, u]))
    tol = 1e-9 * (scale + dmax * xmax)
    for u in range(n):
        if fac[u, u] != np.inf:
            continue
        s = -rhs[u]
        for v in range(n):
            s += mat[u, v] * x[v]
        if abs(s) > tol:
            return False
    return True


@noalloc
def _solve_sliding(rows, part, sub, ns, state, nf, hs, p):
    """``solve_held``'s system with sliding groups: unknowns the held impulses (``hs.mat``,
    ``hs.rhs`` set for the ``nf`` rows ``hs.free``) and one ``lambda`` per sliding group;
    a sliding row's equation gains ``+ s lambda`` (its velocity is ``-s lambda``: it slips
    against its impulse), and each group adds ``sum s p - mu p_n = 0``. Gaussian
    elimination with partial pivoting; (False, 0) when a pivot is below ``REDUNDANT``
    of its column's scale (dependent rows) or a group's normal is not held."""
    idx, oth = part.idx, part.oth
    free, aug, gkey, gnorm, lam = hs.free, hs.aug, hs.gkey, hs.gnorm, hs.lam
    ng = np.int64(0)
    # the sliding groups: each one's first held row and its normal's position in free
    for u in range(nf):
        a = sub[free[u]]
        if not is_sliding(state[a]):
            continue
        r = idx[oth[a]]
        g = np.int64(-1)
        for h in range(ng):
            if same_group(rows, r, idx[oth[sub[free[gkey[h]]]]]):
                g = h
        if g >= 0:
            continue
        normal = normal_of(rows, part, r)
        gn = np.int64(-1)
        for v in range(nf):
            if sub[free[v]] == normal and state[normal] == EQUAL:
                gn = v
        if gn < 0:
            return False, 0.0
        gkey[ng] = u
        gnorm[ng] = gn
        ng += 1
    dim = nf + ng
    if dim > aug.shape[0]:
        return False, 0.0
    for e in range(dim):
        for c in range(dim + 1):
            aug[e, c] = 0.0
    for u in range(nf):
        for v in range(nf):
            aug[u, v] = hs.mat[u, v]
        aug[u, dim] = hs.rhs[u]
    for h in range(ng):
        rk = idx[oth[sub[free[gkey[h]]]]]
        for u in range(nf):
            a = sub[free[u]]
            if not is_sliding(state[a]) or not same_group(rows, idx[oth[a]], rk):
                continue
            sgn = 1.0 if state[a] == SLIDE_POS else -1.0
            aug[u, nf + h] = sgn
            aug[nf + h, u] = sgn
        aug[nf + h, gnorm[h]] = -rows.mu[rk]
    scale = 1e-300
    for u in range(nf):
        scale = max(scale, abs(aug[u, u]))
    for col in range(dim):
        best = col
        for e in range(col + 1, dim):
            if abs(aug[e, col]) > abs(aug[best, col]):
                best = e
        if abs(aug[best, col]) <= REDUNDANT * scale:
            return False, 0.0
        if best != col:
            for c in range(dim + 1):
                tmp = aug[col, c]
                aug[col, c] = aug[best, c]
                aug[best, c] = tmp
        inv = 1.0 / aug[col, col]
        for e in range(col + 1, dim):
            f = aug[e, col] * inv
            if f != 0.0:
                for c in range(col, dim + 1):
                    aug[e, c] -= f * aug[col, c]
    for e in range(dim - 1, -1, -1):
        acc = aug[e, dim]
        for c in range(e + 1, dim):
            acc -= aug[e, c] * aug[c, dim]
        aug[e, dim] = acc / aug[e, e]
    pmax = 0.0
    for u in range(nf):
        x = aug[u, dim]
        p[sub[free[u]]] = x
        pmax = max(pmax, abs(x))
    for h in range(ng):
        rk = idx[oth[sub[free[gkey[h]]]]]
        for u in range(nf):
            a = sub[free[u]]
            if is_sliding(state[a]) and same_group(rows, idx[oth[a]], rk):
                lam[free[u]] = aug[nf + h, dim]
    return True, pmax


@noalloc
def _group_slip(rows, part, sub, ns, state, lam, r):
    """The slip rate ``lambda`` of friction row ``r``'s group if the group slides among the
    held rows ``oth[sub[:ns]]`` (``lam`` by position in ``sub``), else -1."""
    idx, oth = part.idx, part.oth
    for t in range(ns):
        a = sub[t]
        if is_sliding(state[a]) and same_group(rows, idx[oth[a]], r):
            return lam[t]
    return -1.0


@noalloc
def guessed_active_set(rows, part, S, cvec, state, p, every, hs, w):
    """Solve the rows in ``state`` and check complementarity; on failure correct the
    states (a normal pulling lets go, a row moving into its bound holds) and retry, up
    to ``_GUESS_ROUNDS`` times. True when ``p`` (nn,) solves the mixed LCP of ``S`` (nn,
    nn), ``c`` (nn,), every inequality holding to ``GUESS_TOL`` of the problem's scale.
    ``every`` (nn,) int64 holds 0 .. nn-1; ``hs`` (``make_held_scratch``, nn rows) and
    ``w`` (nn,) are scratch."""
    idx, kind, oth, nn = part.idx, part.kind, part.oth, part.nn
    cmax = 1e-300
    smax = 1e-300
    for a in range(nn):
        cmax = max(cmax, abs(cvec[a]))
        smax = max(smax, abs(S[a, a]))
    for it in range(_GUESS_ROUNDS):
        ok, pmax = solve_held(rows, part, every, nn, state, S, cvec, p, hs)
        if not ok:
            return False
        for a in range(nn):
            if state[a] == EQUAL:
                w[a] = 0.0
                continue
            s = -cvec[a]
            for c in range(nn):
                if p[c] != 0.0:
                    s += S[a, c] * p[c]
            w[a] = s
        tol_w, tol_p = slack(GUESS_TOL, cmax, smax, pmax)
        changed = correct_bounded_rows(rows, part, state, p, w, tol_w, tol_p)
        # friction: rows of a released normal are zero; a zero row of a holding normal
        # must not slip (else it holds too); a group outside its pyramid is sliding,
        # which this method does not do
        for a in range(nn):
            i = oth[a]
            if kind[i] != KIND_FRICTION:
                continue
            r = idx[i]
            normal = normal_of(rows, part, r)
            holding = normal >= 0 and state[normal] == EQUAL
            if not holding:
                if state[a] != ZERO:
                    state[a] = ZERO
                    changed = True
            elif state[a] == ZERO:
                if abs(w[a]) > tol_w:
                    state[a] = EQUAL
                    changed = True
            elif not changed and (group_load(rows, part, r, p)
                                  > rows.mu[r] * max(p[normal], 0.0) + tol_p):
                return False
        if not changed:
            _clamp_round_off(part, p)
            return True
    return False


@noalloc
def correct_bounded_rows(rows, part, state, p, w, tol_w, tol_p):
    """The primal-dual correction of the normals, limits and box rows of a held solve's
    ``p`` and ``w = S p - c`` (nn,): a normal pulling lets go, a zero one moving into its
    surface holds, a box row past a bound keeps it, one at a bound pushed back inside
    leaves it. Returns whether a state changed."""
    idx, kind, oth = part.idx, part.kind, part.oth
    changed = False
    for a in range(part.nn):
        i = oth[a]
        r = idx[i]
        k = kind[i]
        st = state[a]
        if k == KIND_UNILATERAL:
            if st == EQUAL and p[a] < -tol_p:
                state[a] = ZERO
                changed = True
            elif st == ZERO and w[a] < -tol_w:
                state[a] = EQUAL
                changed = True
        elif k == KIND_BOX:
            if st == EQUAL and p[a] > rows.hi[r] + tol_p:
                state[a] = AT_HI
                changed = True
            elif st == EQUAL and p[a] < rows.lo[r] - tol_p:
                state[a] = AT_LO
                changed = True
            elif (st == AT_HI and w[a] > tol_w) or (st == AT_LO and w[a] < -tol_w):
                state[a] = EQUAL
                changed = True
    return changed


@noalloc
def guess_on_tree(rows, part, plan, bodies, tw, ns, gs):
    """Last step's contact state (``tw.state``, ``guess_states``) solved with ``S`` of the
    rows it holds or fixes alone (``oth[tw.sub[:ns]]``), and every other row checked
    against the velocities that follow: ``w = J v_new - rhs`` must not pull on a zero
    normal or limit, nor slip a zero friction row of a holding contact. True when
    ``tw.p``, the new velocities ``tw.vn`` and the bilateral rows' ``tw.y`` solve the
    mixed LCP (``tw.b`` and ``tw.g`` hold the right-hand side); False leaves the full
    complement to decide. ``gs`` (``make_guess_scratch``, room for at least ``ns`` rows)
    is scratch.

    One pass of the tree does it all: ``[0; g]`` is forward substituted, each held row's
    column ``L^-1 J^T`` is made along its path (``tree_row_columns``) and gives its row of
    ``S`` and its ``c`` (``columns_complement``), and once the impulses are known their
    columns are added and one back substitution gives the velocities
    (``columns_velocities``)."""
    idx, kind, oth, nn = part.idx, part.kind, part.oth, part.nn
    sub, state, b, p, vn = tw.sub, tw.state, tw.b, tw.p, tw.vn
    S, cvec = gs.S, gs.cvec
    columns_complement(rows, part, plan, bodies, tw, ns, gs)
    ok, pmax = solve_held(rows, part, sub, ns, state, S, cvec, p, gs.held)
    if not ok:
        return False
    cmax = 1e-300
    smax = 1e-300
    for t in range(ns):
        smax = max(smax, abs(S[t, t]))
        cmax = max(cmax, abs(cvec[t]))
    for a in range(nn):
        cmax = max(cmax, abs(b[oth[a]]))
    tol_w, tol_p = slack(GUESS_TOL, cmax, smax, pmax)
    if not _holding_ok(rows, part, state, p, tol_p):
        return False
    lam = gs.held.lam
    for t in range(ns):
        if is_sliding(state[sub[t]]) and lam[t] < -tol_w:
            return False                        # it would slip along its impulse
    columns_velocities(rows, part, plan, bodies, tw, ns, gs)
    for a in range(nn):
        st = state[a]
        if st == EQUAL or is_sliding(st):         # (held: their velocities as solved)
            continue
        i = oth[a]
        r = idx[i]
        w = rows.cfm[r] * p[a] - rows.rhs[r] + row_dot(rows, r, vn)
        k = kind[i]
        if k == KIND_UNILATERAL and w < -tol_w:
            return False
        if (st == AT_HI and w > tol_w) or (st == AT_LO and w < -tol_w):
            return False
        if k == KIND_FRICTION and abs(w) > tol_w:
            normal = normal_of(rows, part, r)
            if normal >= 0 and state[normal] == EQUAL:
                # a zero row of a holding contact may slip only within its group's rate
                slip = _group_slip(rows, part, sub, ns, state, lam, r)
                if slip < 0.0 or abs(w) > slip + tol_w:
                    return False
    _clamp_round_off(part, p)
    return True


@noalloc
def columns_complement(rows, part, plan, bodies, tw, ns, gs):
    """``gs.S`` (ns, ns) and ``gs.cvec`` (ns,) of the rows ``oth[tw.sub[:ns]]`` from their
    tree columns (``guess_on_tree``): ``[0; tw.g]`` forward substituted, each row's column
    ``L^-1 J^T`` made along its path; bodies outside the tree answer with their own
    inverse mass (``gs.dva``)."""
    idx, oth = part.idx, part.oth
    inv_mass = bodies.inv_mass
    sub, b = tw.sub, tw.b
    nbody = bodies.vel.shape[0]
    rsel, alone, dva, cols, S, cvec = gs.rsel, gs.alone, gs.dva, gs.cols, gs.S, gs.cvec
    H, member = cols.H, cols.member
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
                minv_jt(rows, r, inv_mass, bodies.inv_inertia, dva[t])
    tree_load(plan, nbody, tw.vn, np.bool_(False), tw.g)
    tree_forward(plan, nbody)
    tree_row_columns(plan, nbody, rows, rsel, ns, cols)
    for t in range(ns):
        ra = rsel[t]
        cvec[t] = b[oth[sub[t]]] - tree_column_dot(plan, nbody, cols, t, plan.z, member[t],
                                                   np.bool_(False))
        for tb in range(t + 1):
            rb = rsel[tb]
            acc = tree_column_dot(plan, nbody, cols, t, H[tb], member[tb], np.bool_(True))
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


@noalloc
def columns_velocities(rows, part, plan, bodies, tw, ns, gs):
    """The new velocities ``tw.vn`` and the bilateral rows' ``tw.y`` once the rows
    ``oth[tw.sub[:ns]]`` push with ``tw.p`` (after ``columns_complement``): their columns
    added, one back substitution, the bodies outside the tree by their own inverse mass."""
    sub, p, vn = tw.sub, tw.p, tw.vn
    vel, angvel = bodies.vel, bodies.angvel
    nbody = vel.shape[0]
    pt = gs.pt
    for t in range(ns):
        pt[t] = p[sub[t]]
    tree_add_columns(plan, gs.cols, ns, pt)
    tree_backward(plan, nbody)
    tree_unload(plan, nbody, vn, tw.y)
    for body in range(nbody):
        for k in range(3):
            vn[body, k] += vel[body, k]
            vn[body, 3 + k] += angvel[body, k]
    push(rows, part, sub, ns, p, gs.alone, np.bool_(True), gs.dva, vn)   # the others


@noalloc
def _holding_ok(rows, part, state, p, tol_p):
    """Whether the held rows' impulses keep their bounds: normals and limits push, box
    rows stay inside, every friction group stays inside ``mu p_n``, sliding rows keep
    their signs."""
    idx, kind, oth = part.idx, part.kind, part.oth
    for a in range(part.nn):
        if is_sliding(state[a]):
            # a sliding row keeps its impulse's sign (the group's bound holds as solved)
            if (p[a] if state[a] == SLIDE_POS else -p[a]) < -tol_p:
                return False
            continue
        if state[a] != EQUAL:
            continue
        i = oth[a]
        r = idx[i]
        k = kind[i]
        if k == KIND_UNILATERAL and p[a] < -tol_p:
            return False
        if k == KIND_BOX and (p[a] > rows.hi[r] + tol_p or p[a] < rows.lo[r] - tol_p):
            return False
        if k == KIND_FRICTION:
            normal = normal_of(rows, part, r)
            bound = rows.mu[r] * max(p[normal], 0.0) if normal >= 0 else 0.0
            if group_load(rows, part, r, p) > bound + tol_p:
                return False
    return True


@noalloc
def _clamp_round_off(part, p):
    """Normals and limits a hair below zero (round-off inside the slack) to zero."""
    kind, oth = part.kind, part.oth
    for a in range(part.nn):
        if kind[oth[a]] == KIND_UNILATERAL and p[a] < 0.0:
            p[a] = 0.0
