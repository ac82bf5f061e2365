"""Projected block Gauss-Seidel on the contact LCP's Schur complement, then polished exact.

When last step's contact state is not this step's answer (a foot that starts or stops
sliding, a corner that touches down or lifts), Lemke's path takes 10-30 pivots over the
pyramid LCP's three variables a row (``pyramid.py``). Most of those steps change only a few
rows' states, which a few cheap sweeps over the small dense ``S`` (nn, nn) find:

1. Sweeps of projected Gauss-Seidel from last step's impulses, a friction group's rows
   together: each group's impulse is the exact minimiser of the LCP's quadratic over its
   pyramid ``|p_1| + |p_2| <= mu p_n`` in the metric of its 2x2 block of ``S`` (a
   Euclidean projection would converge to impulses that do not dissipate the most).
2. The state each row's impulse suggests (``states_of``): a pushing normal holds, a
   friction group at its bound slides against its impulse, a box row at a bound keeps it.
3. That state's held system solved exactly (``guess.solve_held``; with a pyramid sliding,
   held normals that depend on the others let go first) and checked against the whole LCP
   (``pyramid.complementary``, Lemke's own verification), then corrected by the rows that
   break it and solved again, a few times (``_corrected``). Only a state that passes is
   kept: the answer is the LCP's to round-off, as Lemke's would be; otherwise Lemke runs
   as before.
"""
import numpy as np

from ..._jit import noalloc
from .direct import cholesky_factor_dropping
from .guess import (AT_HI, AT_LO, EQUAL, GUESS_TOL, REDUNDANT, SLIDE_NEG, SLIDE_POS, ZERO,
                    columns_complement, columns_velocities, correct_bounded_rows,
                    is_sliding, solve_held)
from .lemke import VERIFY_TOL
from .partition import KIND_BOX, KIND_FRICTION, KIND_UNILATERAL, normal_of, same_group
from .pyramid import complementary, problem_scale, slack

# The state is read after this many sweeps in all (0: last step's impulses as they are),
# until one solves the LCP; the sweeps stop early once no impulse moves by more than
# SWEEP_TOL of the largest.
SWEEP_READS = (0, 4, 12, 40)
SWEEP_TOL = 1e-6
# Most LCP rows ``sweep_on_tree`` takes: its complement costs O(rows^2) column products,
# which past a few contacts the 6x6 blocks of ``schur.complement`` beat.
SWEEP_ROWS = 48
# Corrections of the state each read of the sweeps gets before more sweeps.
CORRECTIONS = 4
# An impulse group within this fraction of its pyramid's bound counts as sliding.
_AT_BOUND = 1e-9


@noalloc
def friction_links(rows, part, partner, normal):
    """Each LCP row's friction partner and normal, by position in ``part.oth``:
    ``partner[a]`` the other row of ``a``'s pyramid (-1: alone or not friction),
    ``normal[a]`` its normal row (-1: none or not friction). False if a pyramid has
    more than two rows (then the sweeps do not apply)."""
    idx, kind, oth, nn = part.idx, part.kind, part.oth, part.nn
    for a in range(nn):
        partner[a] = -1
        normal[a] = -1
    for a in range(nn):
        if kind[oth[a]] != KIND_FRICTION:
            continue
        r = idx[oth[a]]
        normal[a] = normal_of(rows, part, r)
        for c in range(nn):
            if c != a and kind[oth[c]] == KIND_FRICTION and same_group(rows, r, idx[oth[c]]):
                if partner[a] >= 0:
                    return False
                partner[a] = c
    return True


@noalloc
def _energy(gaa, gab, gbb, va, vb, pa, pb):
    return 0.5 * (gaa * pa * pa + 2.0 * gab * pa * pb + gbb * pb * pb) + va * pa + vb * pb


@noalloc
def pyramid_minimiser(gaa, gab, gbb, va, vb, bound):
    """``argmin 1/2 p.G p + v.p`` over ``|p_a| + |p_b| <= bound`` for the symmetric
    positive (semi)definite 2x2 ``G``: the unconstrained minimiser when inside, else the
    best point of the four edges. Returns (p_a, p_b)."""
    if bound <= 0.0:
        return 0.0, 0.0
    det = gaa * gbb - gab * gab
    if det > 1e-14 * (gaa * gbb) and det > 0.0:
        pa = (gab * vb - gbb * va) / det
        pb = (gab * va - gaa * vb) / det
        if abs(pa) + abs(pb) <= bound:
            return pa, pb
    best_a = 0.0
    best_b = 0.0
    best = np.inf
    for sa in (-1.0, 1.0):
        for sb in (-1.0, 1.0):
            # the edge p = (sa t, sb (bound - t)), t in [0, bound]
            da, db = sa, -sb
            ea, eb = 0.0, sb * bound
            curv = gaa * da * da + 2.0 * gab * da * db + gbb * db * db
            slope = (gaa * ea + gab * eb) * da + (gab * ea + gbb * eb) * db + va * da + vb * db
            t = -slope / curv if curv > 0.0 else (0.0 if slope > 0.0 else bound)
            t = min(max(t, 0.0), bound)
            pa = ea + t * da
            pb = eb + t * db
            f = _energy(gaa, gab, gbb, va, vb, pa, pb)
            if f < best:
                best, best_a, best_b = f, pa, pb
    return best_a, best_b


@noalloc
def _row_residual(S, cvec, p, a, nn):
    """``(S p - c)_a``."""
    acc = -cvec[a]
    for c in range(nn):
        acc += S[a, c] * p[c]
    return acc


@noalloc
def block_gauss_seidel(rows, part, S, cvec, p, partner, normal, sweeps):
    """Sweeps of projected block Gauss-Seidel on ``w = S p - c`` (module docstring),
    updating ``p`` (nn,) in place from its values on entry. Returns the sweeps done."""
    idx, kind, oth, nn = part.idx, part.kind, part.oth, part.nn
    for sweep in range(sweeps):
        change = 0.0
        pmax = 1e-300
        for a in range(nn):
            k = kind[oth[a]]
            r = idx[oth[a]]
            d = S[a, a]
            if d <= 0.0:
                continue
            if k == KIND_UNILATERAL or k == KIND_BOX:
                new = p[a] - _row_residual(S, cvec, p, a, nn) / d
                if k == KIND_UNILATERAL:
                    new = max(new, 0.0)
                else:
                    new = min(max(new, rows.lo[r]), rows.hi[r])
                change = max(change, abs(new - p[a]))
                p[a] = new
            elif partner[a] < 0 or partner[a] > a:
                # a friction pyramid, once (at its first row)
                n = normal[a]
                bound = rows.mu[r] * max(p[n], 0.0) if n >= 0 else 0.0
                b = partner[a]
                va = _row_residual(S, cvec, p, a, nn) - d * p[a]
                if b < 0:
                    new = min(max(-va / d, -bound), bound)
                    change = max(change, abs(new - p[a]))
                    p[a] = new
                else:
                    gab = 0.5 * (S[a, b] + S[b, a])
                    va -= gab * p[b]
                    vb = _row_residual(S, cvec, p, b, nn) - S[b, b] * p[b] - gab * p[a]
                    na, nb_ = pyramid_minimiser(d, gab, S[b, b], va, vb, bound)
                    change = max(change, abs(na - p[a]), abs(nb_ - p[b]))
                    p[a] = na
                    p[b] = nb_
            pmax = max(pmax, abs(p[a]))
        if change <= SWEEP_TOL * pmax:
            return sweep + 1
    return sweeps


@noalloc
def states_of(rows, part, p, partner, normal, state):
    """The active-set state (``guess.ZERO`` ...) each row's impulse ``p`` (nn,) suggests:
    a pushing normal or limit holds, a box row at a bound keeps it, a friction pyramid at
    its bound slides against its impulse (its zero rows stay zero), inside it sticks."""
    idx, kind, oth, nn = part.idx, part.kind, part.oth, part.nn
    for a in range(nn):
        k = kind[oth[a]]
        r = idx[oth[a]]
        if k == KIND_UNILATERAL:
            state[a] = EQUAL if p[a] > 0.0 else ZERO
        elif k == KIND_BOX:
            if rows.hi[r] > 0.0 and p[a] >= rows.hi[r] * (1.0 - _AT_BOUND):
                state[a] = AT_HI
            elif rows.lo[r] < 0.0 and p[a] <= rows.lo[r] * (1.0 - _AT_BOUND):
                state[a] = AT_LO
            else:
                state[a] = EQUAL
    for a in range(nn):
        if kind[oth[a]] != KIND_FRICTION:
            continue
        n = normal[a]
        if n < 0 or state[n] != EQUAL:
            state[a] = ZERO
            continue
        bound = rows.mu[idx[oth[a]]] * p[n]
        load = abs(p[a]) + (abs(p[partner[a]]) if partner[a] >= 0 else 0.0)
        if load >= bound * (1.0 - _AT_BOUND):
            state[a] = SLIDE_POS if p[a] > 0.0 else (SLIDE_NEG if p[a] < 0.0 else ZERO)
        else:
            state[a] = EQUAL


@noalloc
def _corrected(rows, part, S, cvec, p, lam, state, partner, normal, w):
    """One primal-dual correction of ``state`` after its held solve gave ``p`` (and each
    sliding row's group slip ``lam``), by the rows that break the LCP: a normal pulling
    lets go, a zero normal moving into its surface holds, a box row past a bound keeps it
    (or leaves it), a sticking pyramid past its bound slides, a sliding one whose slip
    runs along its impulse sticks, a sliding row whose impulse changed sign lets go and a
    zero row slipping faster than its group slides. ``w`` (nn,) holds ``S p - c``, as
    ``pyramid.complementary`` leaves it. Returns whether a state changed."""
    idx, kind, oth, nn = part.idx, part.kind, part.oth, part.nn
    cmax, smax, pmax = problem_scale(S, cvec, p, nn)
    tol_w, tol_p = slack(GUESS_TOL, cmax, smax, pmax)
    changed = correct_bounded_rows(rows, part, state, p, w, tol_w, tol_p)
    for a in range(nn):
        if kind[oth[a]] != KIND_FRICTION or (partner[a] >= 0 and partner[a] < a):
            continue
        b = partner[a]
        nrm = normal[a]
        if nrm < 0 or state[nrm] != EQUAL:
            for c in (a, b):
                if c >= 0 and state[c] != ZERO:
                    state[c] = ZERO
                    changed = True
            continue
        bound = rows.mu[idx[oth[a]]] * max(p[nrm], 0.0)
        load = abs(p[a]) + (abs(p[b]) if b >= 0 else 0.0)
        sliding = is_sliding(state[a]) or (b >= 0 and is_sliding(state[b]))
        if not sliding:
            if load > bound + tol_p:
                for c in (a, b):
                    if c >= 0:
                        state[c] = SLIDE_POS if p[c] > 0.0 else (SLIDE_NEG if p[c] < 0.0
                                                                else ZERO)
                changed = True
                continue
            for c in (a, b):
                if c >= 0 and state[c] == ZERO and abs(w[c]) > tol_w:
                    state[c] = EQUAL
                    changed = True
            continue
        slip = lam[a] if is_sliding(state[a]) else lam[b]
        if slip < -tol_w:
            for c in (a, b):
                if c >= 0:
                    state[c] = EQUAL
            changed = True
            continue
        for c in (a, b):
            if c < 0:
                continue
            if is_sliding(state[c]):
                if (p[c] if state[c] == SLIDE_POS else -p[c]) < -tol_p:
                    state[c] = ZERO
                    changed = True
            elif abs(w[c]) > slip + tol_w:
                state[c] = SLIDE_NEG if w[c] > 0.0 else SLIDE_POS
                changed = True
    return changed


@noalloc
def _drop_dependent_normals(part, S, state, normal, hs):
    """With a pyramid sliding, the held system is solved by elimination, which cannot
    drop rows: the normals held (``state`` EQUAL) that depend on the others (a face's
    fourth corner) let go here instead, with their friction rows (their impulse is then
    0, as in a basic solution of Lemke's; the check decides whether that holds)."""
    kind, oth, nn = part.kind, part.oth, part.nn
    sliding = False
    for a in range(nn):
        sliding = sliding or is_sliding(state[a])
    if not sliding:
        return
    free, mat, fac = hs.free, hs.mat, hs.fac
    nf = np.int64(0)
    for a in range(nn):
        if kind[oth[a]] == KIND_UNILATERAL and state[a] == EQUAL:
            free[nf] = a
            nf += 1
    for u in range(nf):
        for v in range(nf):
            mat[u, v] = S[free[u], free[v]]
    if cholesky_factor_dropping(mat, nf, fac, REDUNDANT) <= 0:
        return
    for u in range(nf):
        if fac[u, u] == np.inf:
            state[free[u]] = ZERO
    for a in range(nn):
        if normal[a] >= 0 and state[normal[a]] == ZERO:
            state[a] = ZERO


@noalloc
def schur_pgs_exact(rows, part, S, cvec, impulse, p, state, partner, normal, every, hs, w):
    """The LCP of ``S``, ``c`` (``pyramid.py``) by the sweeps, the state they suggest and
    its exact held solve (module docstring), starting from last step's ``impulse`` (by
    row); the state is read after 0, 4, 12 and 40 sweeps and corrected up to
    ``CORRECTIONS`` times (``_corrected``). True with ``p`` (nn,) the verified answer;
    False when no state found solves the LCP (then ``p`` holds anything). ``state``,
    ``partner``, ``normal``, ``every`` (nn,) int64 (``every`` holding 0 .. nn-1), ``hs``
    (``make_held_scratch``, nn rows) and ``w`` (nn,) are scratch."""
    idx, kind, oth, nn = part.idx, part.kind, part.oth, part.nn
    if not friction_links(rows, part, partner, normal):
        return False
    for a in range(nn):
        r = idx[oth[a]]
        v = impulse[r]
        if kind[oth[a]] == KIND_UNILATERAL:
            v = max(v, 0.0)
        elif kind[oth[a]] == KIND_BOX:
            v = min(max(v, rows.lo[r]), rows.hi[r])
        w[a] = v
    done = np.int64(0)
    for target in SWEEP_READS:
        done += block_gauss_seidel(rows, part, S, cvec, w, partner, normal, target - done)
        states_of(rows, part, w, partner, normal, state)
        for rnd in range(CORRECTIONS + 1):
            _drop_dependent_normals(part, S, state, normal, hs)
            ok, _ = solve_held(rows, part, every, nn, state, S, cvec, p, hs)
            if not ok:
                break
            if complementary(rows, part, S, cvec, p, VERIFY_TOL, hs.x):
                return True
            if rnd == CORRECTIONS or not _corrected(rows, part, S, cvec, p, hs.lam, state,
                                                    partner, normal, hs.x):
                break
        if done < target:               # converged: more sweeps find nothing new
            break
    return False


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@noalloc(inline="always")
def sweep_on_tree(rows, part, plan, bodies, tw, gs, impulse):
    """``schur_pgs_exact`` on the complement of every LCP row from their tree columns
    (``guess.columns_complement``), the new velocities applied to ``tw.vn``, ``tw.y``
    (``guess.columns_velocities``), for a caller whose guess on the tree failed (the
    tree factorised, ``tw.b`` and ``tw.g`` set). True when solved (``tw.p`` the impulses);
    False when the rows are more than ``gs`` has room for or the sweeps' state does not
    solve the LCP."""
    nn = part.nn
    if nn > gs.rsel.shape[0] or nn > SWEEP_ROWS:
        return False
    sub = tw.sub
    for a in range(nn):
        sub[a] = a
    columns_complement(rows, part, plan, bodies, tw, nn, gs)
    if not schur_pgs_exact(rows, part, gs.S, gs.cvec, impulse, tw.p, tw.state,
                           gs.links[:nn], gs.links[nn:2 * nn], sub, gs.held, gs.w):
        return False
    columns_velocities(rows, part, plan, bodies, tw, nn, gs)
    return True
