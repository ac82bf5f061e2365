"""The Schur complement of the bilateral rows: the reduced system of the mixed LCP.

With the bilateral rows of a ``RowPartition`` eliminated by a direct solve, the others
see ``S = A_NN - A_NB A_BB^-1 A_BN`` and ``c = b_N - A_NB A_BB^-1 b_B`` (``A = J M^-1 J^T +
C``, ``b = rhs - J v``). When the bilateral rows form a tree (``tree.py``), ``S`` is
``J_N M_B^-1 J_N^T + C_N`` with ``M_B^-1`` the constrained inverse mass, formed from the
6x6 blocks of the few bodies the other rows touch (``complement``), and the bodies'
response to the LCP's impulses is one more tree solve (``respond``). Otherwise (joints in
loops) ``S`` comes from the dense ``A`` (``schur_dense``).
"""
from collections import namedtuple

import numpy as np
from numba import njit

from ..._jit import noalloc
from .common import minv_jt
from .direct import cholesky_apply, cholesky_factor, row_dot
from .tree import tree_body_inverse, tree_solve

# The complement of the rows ``oth[sub[:ns]]`` on the tree (``complement``), and how the
# bodies they touch answer their impulses.
Complement = namedtuple("Complement", [
    "S",        # (ns, ns) J_N M_B^-1 J_N^T + C_N
    "c",        # (ns,) b_N - J_N u0
    "slot",     # (nbody,) int64 each tree body's slot among the blocks of M_B^-1, else -1
    "alone",    # (nbody,) bool bodies the rows touch outside the tree
    "dva",      # (ns, 12) M^-1 J^T of each row, read for the bodies outside the tree
])


@njit(cache=True)
def complement(rows, part, sub, ns, b, plan, bodies, u0):
    """The ``Complement`` of the non-bilateral rows ``oth[sub[:ns]]``: the bodies they
    touch, in the tree or on their own, those bodies' blocks of the constrained inverse
    mass (``tree_body_inverse``), then ``_schur_blocks``. ``b`` (n,) the active rows'
    ``rhs - J v``; ``u0`` (nbody, 6) the bilateral rows' response to ``v``."""
    idx, oth = part.idx, part.oth
    inv_mass = bodies.inv_mass
    nbody = u0.shape[0]
    slot = np.full(nbody, -1, np.int64)
    alone = np.zeros(nbody, np.bool_)
    cb = np.empty(nbody, np.int64)
    nc = np.int64(0)
    for t in range(ns):
        r = idx[oth[sub[t]]]
        for side in range(2):
            body = rows.body_a[r] if side == 0 else rows.body_b[r]
            if body < 0 or inv_mass[body] <= 0.0:
                continue
            if plan.dim[body] == 6:
                if slot[body] < 0:
                    slot[body] = nc
                    cb[nc] = body
                    nc += 1
            else:
                alone[body] = True
    G = np.empty((nc, nc, 6, 6))
    if nc > 0:
        tree_body_inverse(plan, cb, nc, nbody, np.zeros((nc, 6 * nbody + part.nb, 6)),
                          np.zeros((nc, nbody + part.nb), np.bool_), G)
    cpl = Complement(np.empty((ns, ns)), np.empty(ns), slot, alone, np.zeros((ns, 12)))
    _schur_blocks(rows, part, sub, ns, cpl, nc, G, bodies, u0, b, np.zeros((ns, nc + 1, 6)))
    return cpl


@noalloc
def _schur_blocks(rows, part, sub, ns, cpl, nc, G, bodies, u0, b, resp):
    """``cpl.S`` and ``cpl.c`` for the rows ``oth[sub[:ns]]`` from the bodies' blocks ``G``
    (nc, nc, 6, 6). ``resp[t, s]`` is the velocity change of contact body slot ``s`` per
    unit impulse of row ``t`` (zero on entry); rows on a body outside the tree use that
    body's own inverse mass (``cpl.dva``, filled here)."""
    idx, oth = part.idx, part.oth
    inv_mass = bodies.inv_mass
    slot, alone, dva, S, cvec = cpl.slot, cpl.alone, cpl.dva, cpl.S, cpl.c
    for t in range(ns):
        r = idx[oth[sub[t]]]
        for side in range(2):
            body = rows.body_a[r] if side == 0 else rows.body_b[r]
            if body < 0 or inv_mass[body] <= 0.0:
                continue
            if alone[body]:
                minv_jt(rows, r, inv_mass, bodies.inv_inertia, dva[t])
                continue
            sp = slot[body]
            o = 6 * side
            for q in range(nc):
                for i in range(6):
                    acc = 0.0
                    for k in range(6):
                        acc += G[q, sp, i, k] * rows.J[r, o + k]
                    resp[t, q, i] += acc
    for t in range(ns):
        ra = idx[oth[sub[t]]]
        for tb in range(t + 1):
            rb = idx[oth[sub[tb]]]
            acc = 0.0
            for side in range(2):
                body = rows.body_b[rb] if side else rows.body_a[rb]
                if body < 0 or inv_mass[body] <= 0.0:
                    continue
                o = 6 * side
                if alone[body]:
                    for sa in range(2):
                        other = rows.body_b[ra] if sa else rows.body_a[ra]
                        if other == body:
                            for k in range(6):
                                acc += rows.J[rb, o + k] * dva[t, 6 * sa + k]
                else:
                    q = slot[body]
                    for k in range(6):
                        acc += rows.J[rb, o + k] * resp[t, q, k]
            S[t, tb] = acc
            S[tb, t] = acc
        S[t, t] += rows.cfm[ra]
        cvec[t] = b[oth[sub[t]]] - row_dot(rows, ra, u0)


@noalloc
def respond(rows, part, sub, ns, p, plan, cpl, bodies, u0, vn, y1):
    """The second tree solve: the bodies' velocities ``vn`` (nbody, 6) [linear, angular]
    once the rows ``oth[sub[:ns]]`` push with ``p`` (indexed like ``oth``) and the
    bilateral rows answer (their part in ``y1`` (nb,), ``y = -p``); ``u0`` is the
    bilateral response to the velocities before."""
    vel, angvel = bodies.vel, bodies.angvel
    nbody = vel.shape[0]
    for body in range(nbody):
        for k in range(6):
            vn[body, k] = 0.0
    push(rows, part, sub, ns, p, cpl.alone, np.bool_(False), rows.J, vn)   # J^T p, the tree
    for u in range(part.nb):
        y1[u] = 0.0
    tree_solve(plan, nbody, vn, y1, vn, y1)
    for body in range(nbody):
        for k in range(3):
            vn[body, k] += vel[body, k] + u0[body, k]
            vn[body, 3 + k] += angvel[body, k] + u0[body, 3 + k]
    push(rows, part, sub, ns, p, cpl.alone, np.bool_(True), cpl.dva, vn)   # M^-1 J^T p, the others


@noalloc
def push(rows, part, sub, ns, p, alone, on_alone, per_row, out):
    """``out[body] += per_row[.., side] p`` for the rows ``oth[sub[:ns]]`` on the bodies that
    are (``on_alone``) or are not outside the tree; ``per_row`` is indexed by row (J) for
    the tree, by position in ``sub`` (dva) for the others."""
    idx, oth = part.idx, part.oth
    for t in range(ns):
        a = sub[t]
        pa = p[a]
        if pa == 0.0:
            continue
        r = idx[oth[a]]
        q = t if on_alone else r
        for side in range(2):
            body = rows.body_b[r] if side else rows.body_a[r]
            if body >= 0 and alone[body] == on_alone:
                for k in range(6):
                    out[body, k] += per_row[q, 6 * side + k] * pa


@njit(cache=True)
def schur_dense(A, b, part, X, S, cvec):
    """The Schur complement of ``A``'s bilateral block into ``S`` (nn, nn) and ``cvec``
    (nn,): one Cholesky factorisation of ``A_BB``, then a solve per column into ``X``
    (nb, nn + 1) = ``A_BB^-1 [A_BN | b_B]``. False if ``A_BB`` is not positive definite."""
    bil, nb, oth, nn = part.bil, part.nb, part.oth, part.nn
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
