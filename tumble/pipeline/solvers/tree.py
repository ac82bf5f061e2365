"""Linear-time solve of ``(J M^-1 J^T + C) p = r`` for tree-structured constraints.

The constraints of an articulated character form a tree: bodies joined by joints. Baraff
(1996, "Linear-time dynamics using Lagrange multipliers") solves the augmented system

    K [u; y] = [f; g],      K = [[M, J^T], [J, -C]]

(``M`` the bodies' mass matrix, ``C`` the rows' CFM) over the graph whose nodes are the
bodies and the constraints and whose edges join a constraint to the bodies it acts on.
When that graph is a tree, eliminating the nodes leaves first creates no fill-in, so
``K = L D L^T`` keeps the sparsity of ``K`` and costs O(nodes) small dense blocks. With
``f = 0``, ``y = -p`` solves ``(J M^-1 J^T + C) p = g`` and ``u = M^-1 J^T p`` is the
velocity change the impulses ``p`` cause; with ``f = J_c^T`` and ``g = 0``, ``u`` is the
velocity change of the constrained system per unit impulse on an outside row ``c``
(what the Schur complement of the mixed LCP needs).

Nodes. Rows are grouped by the pair of bodies they act on, counting every body that
cannot move (kinematic, static, the world) as "ground"; each pair is one constraint node
(several joints between the same two bodies share one), each dynamic body one body node.
A connected part of the graph may touch the ground through at most one constraint node,
which becomes its root (a chain hanging from the world); a part that never touches it
(a free-floating ragdoll) is rooted at a body. Any other shape -- a loop of joints, two
ground contacts on one part -- is not a tree: ``tree_plan`` reports it and the caller
solves densely instead.

Blocks. Node i holds ``P_i``, which is positive definite: for a body, its 6x6 mass
matrix (mass, world inertia) plus what its children constraints add; for a constraint,
its CFM plus what its children bodies add. Then ``D_i = P_i`` for bodies and ``-P_i``
for constraints, and since a parent and a child are always of different kinds, the
update of a parent by a child ``D_p -= K_pi D_i^-1 K_ip`` is ``P_p += W^T W`` with
``W = L_i^-1 K_ip`` (``P_i = L_i L_i^T``, Cholesky). Units are those of the rows: the
solution ``p`` is in N s (N m s for angular rows).
"""
from collections import namedtuple

import numpy as np
from numba import njit

from ..._jit import noalloc

# Which rows form which node, and the elimination order (see tree_plan).
TreePlan = namedtuple("TreePlan", [
    "meta",        # (4,) int64: number of pair nodes, nodes in `order`, largest pair size,
                   # 1 when the layout (dim .. row_z) is that of every row in use
    "pair_rows",   # (n,) int64 row positions grouped by pair (in the order of `sel`)
    "pair_start",  # (n + 1,) int64 first entry of each pair in pair_rows
    "pair_body",   # (n, 2) int64 the pair's dynamic bodies, -1 for ground
    "order",       # (nbody + n,) int64 nodes, parents before children; bodies 0..nbody-1,
                   # pair p is node nbody + p
    "opos",        # (nbody + n,) int64 position of each node in `order` (-1: not in it)
    "parent",      # (nbody + n,) int64 parent node, -1 for a root
    "fac_off",     # (nbody + n,) int64 offset of each node's factor in `fac`
    "z_off",       # (nbody + n,) int64 offset of each node's unknowns in the solution vector
    "dim",         # (nbody + n,) int64 size of each node's block in the last factorisation
    "fac",         # (36 nbody + sum of pair sizes^2,) Cholesky factors L, row-major blocks
    "w_off",       # (nbody + n,) int64 offset of each node's W = L^-1 K_node,parent in `wmat`
    "wmat",        # (12 n,) float64 the W blocks, row-major (dim node x dim parent)
    "eparent",     # (nbody + n,) int64 parent in the last factorisation (-1: none)
    "row_z",       # (n,) int64 position of each row's unknown in `z` (-1: not in use)
    "use",         # (n,) int64 1 when a row takes part in the factorisation
    "z",           # (6 nbody + n,) float64 right-hand side, then solution
    "dinv",        # (6 nbody + n,) float64 1 / diagonal of each node's factor, at z_off
])


@njit(cache=True, inline="always")
def _dyn(b, inv_mass):
    """Body ``b`` if it can move, else -1 (ground)."""
    return b if (b >= 0 and inv_mass[b] > 0.0) else -1


@njit(cache=True)
def tree_plan(rows, sel, n, inv_mass, nbody):
    """Group the rows ``sel[:n]`` into nodes and order them for elimination.

    Returns (ok, plan). ``ok`` is False when the body-constraint graph is not a forest
    with at most one ground constraint per part (see the module docstring); the plan is
    then unusable.
    """
    nnode = nbody + n
    key = np.empty(n, np.int64)
    for i in range(n):
        r = sel[i]
        a = _dyn(rows.body_a[r], inv_mass)
        b = _dyn(rows.body_b[r], inv_mass)
        a = nbody if a < 0 else a
        b = nbody if b < 0 else b
        key[i] = min(a, b) * (nbody + 1) + max(a, b)
    perm = np.argsort(key, kind="mergesort")      # stable: rows keep their order in a pair
    pair_rows = np.empty(n, np.int64)
    pair_start = np.zeros(n + 1, np.int64)
    pair_body = np.full((max(n, 1), 2), -1, np.int64)
    npair = 0
    maxdim = 6
    fac_size = 36 * nbody
    last = -1
    size = 0
    for t in range(n):
        i = perm[t]
        pair_rows[t] = i
        if t == 0 or key[i] != last:
            if npair > 0:
                fac_size += size * size
                maxdim = max(maxdim, size)
            pair_start[npair] = t
            lo, hi = key[i] // (nbody + 1), key[i] % (nbody + 1)
            if lo == hi and lo < nbody:
                return False, _empty_plan()       # a row on one body twice: not a tree edge
            pair_body[npair, 0] = lo if lo < nbody else -1
            pair_body[npair, 1] = hi if hi < nbody else -1
            npair += 1
            size = 0
            last = key[i]
        size += 1
    if npair > 0:
        fac_size += size * size
        maxdim = max(maxdim, size)
    pair_start[npair] = n
    # pairs adjacent to each body (CSR)
    adj_start = np.zeros(nbody + 1, np.int64)
    for p in range(npair):
        for s in range(2):
            if pair_body[p, s] >= 0:
                adj_start[pair_body[p, s] + 1] += 1
    for b in range(nbody):
        adj_start[b + 1] += adj_start[b]
    adj = np.empty(adj_start[nbody], np.int64)
    fill = adj_start[:nbody].copy()
    for p in range(npair):
        for s in range(2):
            b = pair_body[p, s]
            if b >= 0:
                adj[fill[b]] = p
                fill[b] += 1
    # breadth-first search from each root; a second path to a node is a loop
    order = np.empty(nnode, np.int64)
    parent = np.full(nnode, -1, np.int64)
    seen = np.zeros(nnode, np.bool_)
    norder = 0
    for phase in range(2):
        for p in range(npair):
            node = nbody + p
            if seen[node]:
                continue
            grounded = pair_body[p, 0] < 0 or pair_body[p, 1] < 0
            if phase == 0 and not grounded:
                continue
            # phase 0: roots at ground pairs; phase 1: free-floating parts, rooted at a body
            root = node if phase == 0 else pair_body[p, 0]
            seen[root] = True
            order[norder] = root
            head = norder
            norder += 1
            while head < norder:
                u = order[head]
                head += 1
                if u >= nbody:                  # a pair node: its one or two bodies
                    q = u - nbody
                    for s in range(2):
                        v = pair_body[q, s]
                        if v < 0 or v == parent[u]:
                            continue
                        if seen[v]:
                            return False, _empty_plan()
                        seen[v] = True
                        parent[v] = u
                        order[norder] = v
                        norder += 1
                else:                           # a body: its pairs
                    for e in range(adj_start[u], adj_start[u + 1]):
                        v = nbody + adj[e]
                        if v == parent[u]:
                            continue
                        if seen[v]:
                            return False, _empty_plan()
                        q = adj[e]
                        if pair_body[q, 0] < 0 or pair_body[q, 1] < 0:
                            return False, _empty_plan()   # a second way to the ground
                        seen[v] = True
                        parent[v] = u
                        order[norder] = v
                        norder += 1
    meta = np.array([npair, norder, maxdim, 0], np.int64)
    opos = np.full(nnode, -1, np.int64)
    for t in range(norder):
        opos[order[t]] = t
    return True, TreePlan(meta, pair_rows, pair_start, pair_body, order, opos, parent,
                          np.zeros(nnode, np.int64), np.zeros(nnode, np.int64),
                          np.zeros(nnode, np.int64), np.zeros(fac_size),
                          np.zeros(nnode, np.int64), np.zeros(12 * max(n, 1)),
                          np.full(nnode, -1, np.int64), np.full(max(n, 1), -1, np.int64),
                          np.ones(max(n, 1), np.int64), np.zeros(6 * nbody + n),
                          np.zeros(6 * nbody + n))


@njit(cache=True)
def _empty_plan():
    z = np.zeros(1, np.int64)
    return TreePlan(np.zeros(4, np.int64), z, z, np.zeros((1, 2), np.int64), z, z, z, z, z, z,
                    np.zeros(1), z, np.zeros(1), z, z, z, np.zeros(1), np.zeros(1))


# The block kernels below index views (``fac[lo:lo + d * d]``, not ``fac[lo + i * d + k]``):
# an index that is a loop counter is known to be non-negative, so Numba drops its
# negative-index wrap-around, which otherwise costs a compare and a select per access
# (a third of the factorisation's time).

@njit(cache=True, inline="always")
def _chol_block(a, d, dv):
    """In-place Cholesky of the d x d row-major block ``a`` (a view; lower triangle), the
    reciprocals of its diagonal into ``dv`` (multiplying beats dividing in the
    substitutions). False if not positive definite."""
    ok = True
    for i in range(d):
        for k in range(i + 1):
            s = a[i * d + k]
            for t in range(k):
                s -= a[i * d + t] * a[k * d + t]
            if i == k:
                if s <= 1e-300:
                    ok = False
                    s = 1.0
                r = np.sqrt(s)
                a[i * d + i] = r
                dv[i] = 1.0 / r
            else:
                a[i * d + k] = s * dv[k]
    return ok


@njit(cache=True, inline="always")
def _eliminate_block(a, d, dv, w, dp, par):
    """``W = L^-1 K`` in place (``w``, d x dp, K on entry) with the factor ``a``, then
    ``P_parent += W^T W`` (``par``, dp x dp; only its lower triangle, the part the
    Cholesky reads). All arguments are views of the plan's arrays."""
    for i in range(d):
        inv = dv[i]
        for k in range(i):
            el = a[i * d + k]
            for c in range(dp):
                w[i * dp + c] -= el * w[k * dp + c]
        for c in range(dp):
            w[i * dp + c] *= inv
    # each entry of W^T W summed in a register (the compiler cannot tell that ``par`` and
    # ``w`` do not overlap, so a sum kept in ``par`` is stored and reloaded every term)
    for x in range(dp):
        for c in range(x + 1):
            acc = par[x * dp + c]
            for i in range(d):
                acc += w[i * dp + x] * w[i * dp + c]
            par[x * dp + c] = acc


@njit(cache=True, inline="always")
def _forward_node(zu, d, a, dv, w, dp, zp, sign):
    """``z_u <- L_u^-1 z_u``, then ``z_parent -= sign W_u^T z_u`` (dp = 0: no parent); views."""
    for i in range(d):
        s = zu[i]
        for k in range(i):
            s -= a[i * d + k] * zu[k]
        zu[i] = s * dv[i]
    for i in range(d):
        x = sign * zu[i]
        for c in range(dp):
            zp[c] -= w[i * dp + c] * x


@njit(cache=True, inline="always")
def _backward_node(zu, d, a, dv, w, dp, zp):
    """``z_u <- L_u^-T (z_u - W_u z_parent)`` (dp = 0: no parent); views."""
    for i in range(d):
        s = 0.0
        for c in range(dp):
            s += w[i * dp + c] * zp[c]
        zu[i] -= s
    for i in range(d - 1, -1, -1):
        s = zu[i]
        for k in range(i + 1, d):
            s -= a[k * d + i] * zu[k]
        zu[i] = s * dv[i]


@njit(cache=True, inline="always")
def _inv3(a):
    """Inverse of a symmetric positive definite 3x3 matrix, row-major flat tuple."""
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
    inv = 1.0 / det
    return (c00 * inv, (a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]) * inv,
            (a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]) * inv,
            c01 * inv, (a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]) * inv,
            (a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]) * inv,
            c02 * inv, (a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]) * inv,
            (a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]) * inv)


@noalloc
def _layout(plan, nbody):
    """Block sizes and offsets of the nodes for the rows in use (``plan.use``); a pair with
    no row in use drops out and its children become roots."""
    norder = plan.meta[1]
    dim, foff, zoff = plan.dim, plan.fac_off, plan.z_off
    fo = 0
    zo = 0
    for t in range(norder):
        u = plan.order[t]
        if u < nbody:
            d = 6
        else:
            p = u - nbody
            d = 0
            for e in range(plan.pair_start[p], plan.pair_start[p + 1]):
                i = plan.pair_rows[e]
                if plan.use[i]:
                    plan.row_z[i] = zo + d
                    d += 1
                else:
                    plan.row_z[i] = -1
        dim[u] = d
        foff[u] = fo
        zoff[u] = zo
        fo += d * d
        zo += d
    wo = 0
    for t in range(norder):
        u = plan.order[t]
        pa = plan.parent[u]
        if pa >= 0 and dim[pa] == 0:
            pa = -1
        plan.eparent[u] = pa
        plan.w_off[u] = wo
        if pa >= 0:
            wo += dim[u] * dim[pa]


@noalloc
def tree_factor(plan, rows, sel, cfm, inv_mass, inv_inertia, nbody):
    """Factorise ``K`` for the rows of ``plan`` with ``plan.use[i] == 1``.

    cfm (n,) : the diagonal ``C`` of each row position (velocity per impulse).
    inv_mass (nbody,), inv_inertia (nbody, 3, 3) world frame. Returns False if a block
    is not positive definite (redundant rows without CFM)."""
    norder = plan.meta[1]
    fac, dim, foff, zoff = plan.fac, plan.dim, plan.fac_off, plan.z_off
    all_used = True
    for i in range(plan.pair_start[plan.meta[0]]):
        if plan.use[i] == 0:
            all_used = False
    if not (all_used and plan.meta[3] == 1):
        _layout(plan, nbody)
        plan.meta[3] = 1 if all_used else 0
    # initial blocks: mass matrices and CFM
    for t in range(norder):
        u = plan.order[t]
        d = dim[u]
        a = fac[foff[u]:foff[u] + d * d]
        for k in range(d * d):
            a[k] = 0.0
        if u < nbody:
            m = 1.0 / inv_mass[u]
            for k in range(3):
                a[k * 6 + k] = m
            iw = _inv3(inv_inertia[u])
            for i in range(3):
                for k in range(3):
                    a[(3 + i) * 6 + 3 + k] = iw[i * 3 + k]
        else:
            p = u - nbody
            k = 0
            for e in range(plan.pair_start[p], plan.pair_start[p + 1]):
                i = plan.pair_rows[e]
                if plan.use[i]:
                    a[k * d + k] = cfm[i]
                    k += 1
    # eliminate children first: P_u = L L^T, W = L^-1 K_u,parent, P_parent += W^T W
    # (blocks of six, a body's and most joints', get kernels compiled for that size)
    wm, dinv = plan.wmat, plan.dinv
    for t in range(norder - 1, -1, -1):
        u = plan.order[t]
        d = dim[u]
        if d == 0:
            continue
        a = fac[foff[u]:foff[u] + d * d]
        dv = dinv[zoff[u]:zoff[u] + d]
        ok = _chol_block(a, 6, dv) if d == 6 else _chol_block(a, d, dv)
        if not ok:
            return False
        pa = plan.eparent[u]
        if pa < 0:
            continue
        dp = dim[pa]
        wo = plan.w_off[u]
        w = wm[wo:wo + d * dp]
        _coupling(plan, rows, sel, u, pa, nbody, w, dp)
        par = fac[foff[pa]:foff[pa] + dp * dp]
        if d == 6 and dp == 6:
            _eliminate_block(a, 6, dv, w, 6, par)
        else:
            _eliminate_block(a, d, dv, w, dp, par)
    return True


@noalloc
def _coupling(plan, rows, sel, u, pa, nbody, w, dp):
    """w = K_{u, pa} (a view, dim u x dp, row-major): a pair's Jacobian block on its parent
    body, or a body's (6 x m) transposed block of its parent pair."""
    # the same Jacobian entries either way: a pair's row k on the body is row k of the
    # block (u pair, pa body) or column k of it (u body, pa pair: K = J_pa,u^T)
    if u >= nbody:
        p, body, row_step, col_step = u - nbody, pa, dp, 1
    else:
        p, body, row_step, col_step = pa - nbody, u, 1, dp
    k = 0
    for e in range(plan.pair_start[p], plan.pair_start[p + 1]):
        i = plan.pair_rows[e]
        if plan.use[i]:
            r = sel[i]
            jac = rows.J[r, 6:] if rows.body_a[r] != body else rows.J[r, :6]
            for c in range(6):
                w[k * row_step + c * col_step] = jac[c]
            k += 1


@njit(cache=True, inline="always")
def _node_views(plan, u, d, z, fac, dinv, wm):
    """Views of node ``u`` (dim ``d``): its unknowns, factor, reciprocal diagonal, W block,
    its parent's dim and unknowns (dim 0 and an empty view without a parent)."""
    pa = plan.eparent[u]
    dp = plan.dim[pa] if pa >= 0 else 0
    op = plan.z_off[pa] if pa >= 0 else 0
    o, lo, wo = plan.z_off[u], plan.fac_off[u], plan.w_off[u]
    return (z[o:o + d], fac[lo:lo + d * d], dinv[o:o + d], wm[wo:wo + d * dp], dp,
            z[op:op + dp])


@noalloc
def tree_solve(plan, nbody, f, g, u_out, y_out):
    """Solve ``K [u; y] = [f; g]`` with the factorisation of ``tree_factor``.

    f (nbody, 6) : right-hand side of the body nodes (force-like: [linear, angular]).
    g (n,) : right-hand side of the rows (only rows in use are read).
    u_out (nbody, 6) : the bodies' unknowns (zero for bodies outside the system).
    y_out (n,) : the rows' unknowns (zero for rows not in use). ``y = -p``.
    """
    tree_load(plan, nbody, f, np.bool_(True), g)
    tree_forward(plan, nbody)
    tree_backward(plan, nbody)
    tree_unload(plan, nbody, u_out, y_out)


@noalloc
def tree_load(plan, nbody, f, with_f, g):
    """``z = [f; g]`` (``f`` read only ``with_f``, else zero): the right-hand side of
    ``tree_solve``, which runs these four phases; callers that add columns to the
    forward-substituted ``z`` (``tree_row_columns``) run them one by one."""
    z, zoff = plan.z, plan.z_off
    for t in range(plan.meta[1]):
        u = plan.order[t]
        if u < nbody:
            zu = z[zoff[u]:zoff[u] + 6]
            for k in range(6):
                zu[k] = f[u, k] if with_f else 0.0
    for i in range(g.shape[0]):
        if plan.row_z[i] >= 0:
            z[plan.row_z[i]] = g[i]


@noalloc
def tree_forward(plan, nbody):
    """Forward substitution, children first: ``z_u <- L_u^-1 z_u``,
    ``z_parent -= s_u W_u^T z_u``."""
    for t in range(plan.meta[1] - 1, -1, -1):
        u = plan.order[t]
        if plan.dim[u] > 0:
            _forward_at(plan, u, nbody, plan.z)


@njit(cache=True, inline="always")
def _forward_at(plan, u, nbody, z):
    """``_forward_node`` at node ``u`` (dim > 0) on ``z``: the plan's vector or a column."""
    d = plan.dim[u]
    zu, a, dv, w, dp, zp = _node_views(plan, u, d, z, plan.fac, plan.dinv, plan.wmat)
    sign = 1.0 if u < nbody else -1.0
    if d == 6 and dp == 6:
        _forward_node(zu, 6, a, dv, w, 6, zp, sign)
    else:
        _forward_node(zu, d, a, dv, w, dp, zp, sign)


@noalloc
def tree_backward(plan, nbody):
    """Back substitution, parents first: ``x_u = s_u L_u^-T (z_u - W_u x_parent)``."""
    z, fac, dim, wm, dinv = plan.z, plan.fac, plan.dim, plan.wmat, plan.dinv
    for t in range(plan.meta[1]):
        u = plan.order[t]
        d = dim[u]
        if d == 0:
            continue
        zu, a, dv, w, dp, zp = _node_views(plan, u, d, z, fac, dinv, wm)
        if d == 6 and dp == 6:
            _backward_node(zu, 6, a, dv, w, 6, zp)
        else:
            _backward_node(zu, d, a, dv, w, dp, zp)
        if u >= nbody:
            for i in range(d):
                zu[i] = -zu[i]


@noalloc
def tree_unload(plan, nbody, u_out, y_out):
    """The solution in ``z`` into ``u_out`` (nbody, 6) and ``y_out`` (n,) (see tree_solve)."""
    z, zoff = plan.z, plan.z_off
    for b in range(nbody):
        for k in range(6):
            u_out[b, k] = 0.0
    for t in range(plan.meta[1]):
        u = plan.order[t]
        if u < nbody:
            zu = z[zoff[u]:zoff[u] + 6]
            for k in range(6):
                u_out[u, k] = zu[k]
    for i in range(y_out.shape[0]):
        y_out[i] = z[plan.row_z[i]] if plan.row_z[i] >= 0 else 0.0


# Columns ``h_t = L^-1 f_t`` of rows outside the tree (``tree_row_columns``), for up to k
# rows; each is kept only on the nodes of its path.
RowColumns = namedtuple("RowColumns", [
    "H",        # (k, 6 nbody + rows) the columns, set only on each column's nodes
    "member",   # (k, nbody + rows) bool the nodes of each column
    "path",     # (k, nbody + rows) int64 those nodes, children first
    "plen",     # (k,) int64 their number
])


@noalloc
def tree_row_columns(plan, nbody, rows, rsel, ns, cols):
    """``h_t = L^-1 f_t`` for the outside rows ``rsel[:ns]``, ``f_t`` the row's Jacobian
    on its bodies in the tree (force-like): the column ``tree_forward`` would make of a
    unit impulse on the row. ``h_t`` is nonzero only on the paths from those bodies to
    their root, so each row costs its path.

    With them ``J_t M_B^-1 J_s^T = sum_u s_u h_t,u . h_s,u`` (``tree_column_dot``), the
    velocity ``J_t u`` of the solution of ``[0; g]`` is that sum against the forward
    substituted ``z``, and impulses ``p`` on the rows add ``sum_t p_t h_t`` to it
    (``tree_add_columns``) before ``tree_backward``.
    cols : ``RowColumns`` with room for ``ns`` rows, ``member`` False on entry; the
    others are written here."""
    dim, zoff, opos = plan.dim, plan.z_off, plan.opos
    H, member, path, plen = cols.H, cols.member, cols.path, cols.plen
    for t in range(ns):
        r = rsel[t]
        n = np.int64(0)
        for side in range(2):
            body = rows.body_b[r] if side else rows.body_a[r]
            if body < 0 or dim[body] != 6:
                continue
            u = body
            while u >= 0 and not member[t, u]:
                member[t, u] = True
                for k in range(zoff[u], zoff[u] + dim[u]):
                    H[t, k] = 0.0
                # insertion by elimination position, children (later in `order`) first
                q = n
                while q > 0 and opos[path[t, q - 1]] < opos[u]:
                    path[t, q] = path[t, q - 1]
                    q -= 1
                path[t, q] = u
                n += 1
                u = plan.eparent[u]
            hb = H[t, zoff[body]:zoff[body] + 6]
            for k in range(6):
                hb[k] += rows.J[r, 6 * side + k]
        plen[t] = n
        for q in range(n):
            _forward_at(plan, path[t, q], nbody, H[t])


@noalloc
def tree_column_dot(plan, nbody, cols, t, x, xm, restrict):
    """``sum_u s_u h_t,u . x_u`` over the nodes of column ``t`` of ``cols``: with
    ``restrict``, only those in ``xm`` (the nodes of another column ``x``, a row of
    ``member``); without, ``x`` covers every node (the forward substituted ``z``)."""
    dim, zoff = plan.dim, plan.z_off
    H, path, plen = cols.H, cols.path, cols.plen
    acc = 0.0
    for q in range(plen[t]):
        u = path[t, q]
        if restrict and not xm[u]:
            continue
        o = zoff[u]
        s = 0.0
        for e in range(dim[u]):
            s += H[t, o + e] * x[o + e]
        acc += s if u < nbody else -s
    return acc


@noalloc
def tree_add_columns(plan, cols, ns, p):
    """``z += sum_t p_t h_t`` over the nodes of the columns ``cols`` (p (ns,))."""
    z, dim, zoff = plan.z, plan.dim, plan.z_off
    H, path, plen = cols.H, cols.path, cols.plen
    for t in range(ns):
        if p[t] == 0.0:
            continue
        for q in range(plen[t]):
            u = path[t, q]
            o = zoff[u]
            for e in range(dim[u]):
                z[o + e] += p[t] * H[t, o + e]


# ------------------------------------------------------------------ plans kept across steps

# A plan made once and reused while the same rows are factorised step after step (the
# joints of a character): ``plan`` has room for ``capacity`` rows; ``key`` (3, capacity)
# holds the planned rows and their two bodies; ``meta`` [rows planned (-1: none), the
# plan's ok flag].
PlanCache = namedtuple("PlanCache", ["plan", "key", "meta"])


@njit(cache=True)
def make_plan_cache(capacity, nbody, fac_capacity):
    """An empty cache for plans of up to ``capacity`` rows over ``nbody`` bodies whose
    factors take up to ``fac_capacity`` numbers (``plan_capacity``). With capacity 0 it
    never holds a plan: ``cached_tree_plan`` then plans afresh every call."""
    cap = max(capacity, 1)
    nnode = nbody + cap
    plan = TreePlan(np.zeros(4, np.int64), np.zeros(cap, np.int64), np.zeros(cap + 1, np.int64),
                    np.full((cap, 2), -1, np.int64), np.zeros(nnode, np.int64),
                    np.full(nnode, -1, np.int64), np.full(nnode, -1, np.int64),
                    np.zeros(nnode, np.int64), np.zeros(nnode, np.int64),
                    np.zeros(nnode, np.int64), np.zeros(max(fac_capacity, 1)),
                    np.zeros(nnode, np.int64), np.zeros(12 * cap), np.full(nnode, -1, np.int64),
                    np.full(cap, -1, np.int64), np.ones(cap, np.int64),
                    np.zeros(6 * nbody + cap), np.zeros(6 * nbody + cap))
    meta = np.array([-1, 0, capacity, fac_capacity], np.int64)
    return PlanCache(plan, np.full((3, cap), -1, np.int64), meta)


@njit(cache=True)
def plan_capacity(joint_parent, joint_child, joint_row_count, servoed, inv_mass, nbody):
    """Room a plan needs for any subset of the rows of these joints and of six-row body
    servos on the bodies ``servoed``: (rows, factor entries). Rows between the same two
    bodies share one block, so the factor needs ``36 nbody + sum of block sizes^2``."""
    nj = joint_parent.shape[0]
    keys = np.empty(nj + servoed.shape[0], np.int64)
    sizes = np.empty(nj + servoed.shape[0], np.int64)
    nkey = 0
    nrow = 0
    for k in range(nj + servoed.shape[0]):
        if k < nj:
            a, b, count = _dyn(joint_parent[k], inv_mass), _dyn(joint_child[k], inv_mass), joint_row_count[k]
        else:
            a, b, count = _dyn(servoed[k - nj], inv_mass), -1, 6
        a = nbody if a < 0 else a
        b = nbody if b < 0 else b
        key = min(a, b) * (nbody + 1) + max(a, b)
        nrow += count
        found = False
        for t in range(nkey):
            if keys[t] == key:
                sizes[t] += count
                found = True
                break
        if not found:
            keys[nkey] = key
            sizes[nkey] = count
            nkey += 1
    fac = 36 * nbody
    for t in range(nkey):
        fac += sizes[t] * sizes[t]
    return nrow, fac


@noalloc
def _same_rows(cache, rows, sel, n):
    """Whether ``cache`` was planned for the rows ``sel[:n]`` on the same bodies."""
    key, meta = cache.key, cache.meta
    if meta[0] != n or n > key.shape[1]:
        return False
    for i in range(n):
        r = sel[i]
        if key[0, i] != r or key[1, i] != rows.body_a[r] or key[2, i] != rows.body_b[r]:
            return False
    return True


@noalloc
def plan_kept(cache, rows, sel, n):
    """Whether ``cache`` holds a good plan for the rows ``sel[:n]`` already (then
    ``cache.plan`` is the one ``cached_tree_plan`` would return)."""
    return _same_rows(cache, rows, sel, n) and cache.meta[1] == 1


@njit(cache=True)
def cached_tree_plan(cache, rows, sel, n, inv_mass, nbody):
    """``tree_plan`` for the rows ``sel[:n]``, remembered in ``cache``: while the same rows
    (with the same bodies) come back, the plan is reused as it is. Returns (ok, plan): the
    cache's plan, or a fresh one when the rows do not fit in it."""
    key, meta, plan = cache.key, cache.meta, cache.plan
    if _same_rows(cache, rows, sel, n):
        return meta[1] == 1, plan
    ok, fresh = tree_plan(rows, sel, n, inv_mass, nbody)
    if n > meta[2] or fresh.fac.shape[0] > plan.fac.shape[0] or fresh.z.shape[0] > plan.z.shape[0]:
        return ok, fresh
    for i in range(4):
        plan.meta[i] = fresh.meta[i]
    _copy_into(fresh.pair_rows, plan.pair_rows)
    _copy_into(fresh.pair_start, plan.pair_start)
    for i in range(fresh.pair_body.shape[0]):
        plan.pair_body[i, 0], plan.pair_body[i, 1] = fresh.pair_body[i, 0], fresh.pair_body[i, 1]
    _copy_into(fresh.order, plan.order)
    _copy_into(fresh.opos, plan.opos)
    _copy_into(fresh.parent, plan.parent)
    _copy_into(fresh.dim, plan.dim)
    _copy_into(fresh.eparent, plan.eparent)
    _copy_into(fresh.use, plan.use)
    for i in range(n):
        r = sel[i]
        key[0, i], key[1, i], key[2, i] = r, rows.body_a[r], rows.body_b[r]
    meta[0] = n
    meta[1] = 1 if ok else 0
    return ok, plan


@noalloc
def _copy_into(src, dst):
    """dst[:len(src)] = src (the cache's arrays are at least as long)."""
    for i in range(src.shape[0]):
        dst[i] = src[i]


# ----------------------------------------------- inverse mass of a few bodies of the tree

@njit(cache=True, inline="always")
def _forward_columns(hu, d, a, dv, w, dp, hp, sign):
    """``_forward_node`` on six columns: ``hu`` (d, 6) and ``hp`` (dp, 6) are views of the
    node's and its parent's rows of ``h``."""
    for i in range(d):
        inv = dv[i]
        for k in range(i):
            el = a[i * d + k]
            for c in range(6):
                hu[i, c] -= el * hu[k, c]
        for c in range(6):
            hu[i, c] *= inv
    for i in range(d):
        for e in range(dp):
            x = sign * w[i * dp + e]
            for c in range(6):
                hp[e, c] -= x * hu[i, c]


@noalloc
def tree_body_inverse(plan, bodies, nc, nbody, H, member, G):
    """6x6 blocks ``G[c, d]`` of ``M_B^-1`` (the constrained inverse mass, top-left block of
    ``K^-1``) between the bodies ``bodies[:nc]``, all in the tree: the velocity change
    [linear, angular] of body ``bodies[c]`` per unit impulse [force, torque] on body
    ``bodies[d]`` with every factorised row holding.

    With ``K = L D L^T`` (D = +1 on body blocks, -1 on row blocks),
    ``f_a^T K^-1 f_b = sum_u s_u h_a,u . h_b,u`` with ``h = L^-1 f``. The columns here are
    the six unit impulses on each body: ``h`` is nonzero only on the body's path to its
    root, so each body costs its path and each pair of bodies the path they share.
    Work arrays: H (nc, 6 nbody + rows, 6) float64 zero on entry and left zero;
    member (nc, nbody + rows) bool, False on entry and left False. G (nc, nc, 6, 6) out.
    """
    dim, zoff, foff, fac, wm, dinv = plan.dim, plan.z_off, plan.fac_off, plan.fac, plan.wmat, plan.dinv
    for a in range(nc):
        b = bodies[a]
        o = zoff[b]
        for k in range(6):
            H[a, o + k, k] = 1.0
        u = b
        while u >= 0:
            member[a, u] = True
            d = dim[u]
            pa = plan.eparent[u]
            dp = dim[pa] if pa >= 0 else 0
            op = zoff[pa] if pa >= 0 else 0
            o, lo, wo = zoff[u], foff[u], plan.w_off[u]
            hu, hp = H[a, o:o + d], H[a, op:op + dp]
            fa, dv, w = fac[lo:lo + d * d], dinv[o:o + d], wm[wo:wo + d * dp]
            sign = 1.0 if u < nbody else -1.0
            if d == 6 and dp == 6:
                _forward_columns(hu, 6, fa, dv, w, 6, hp, sign)
            else:
                _forward_columns(hu, d, fa, dv, w, dp, hp, sign)
            u = pa
    for a in range(nc):
        for bb in range(a + 1):
            for i in range(6):
                for k in range(6):
                    G[a, bb, i, k] = 0.0
            u = bodies[a]
            while u >= 0:
                if member[bb, u]:
                    o = zoff[u]
                    ha, hb, g = H[a, o:o + dim[u]], H[bb, o:o + dim[u]], G[a, bb]
                    sign = 1.0 if u < nbody else -1.0
                    for e in range(dim[u]):
                        for i in range(6):
                            x = sign * ha[e, i]
                            for k in range(6):
                                g[i, k] += x * hb[e, k]
                u = plan.eparent[u]
            if bb != a:
                for i in range(6):
                    for k in range(6):
                        G[bb, a, k, i] = G[a, bb, i, k]
    for a in range(nc):
        u = bodies[a]
        while u >= 0:
            member[a, u] = False
            o = zoff[u]
            for e in range(dim[u]):
                for c in range(6):
                    H[a, o + e, c] = 0.0
            u = plan.eparent[u]
