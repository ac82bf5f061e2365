"""The rows of a mixed LCP sorted by kind, once per solve (``RowPartition``).

Rows (see ``joints/common.py``) fall into four kinds:

* bilateral (unbounded: joint rows, dampers), eliminated by a direct solve;
* unilateral (``[0, inf)``: contact normals, joint limits);
* friction rows of a contact (bounds ``-+ mu p_n``, ``rows.parent`` the normal);
* symmetric box rows (``[-F, F]``: motors, dry joint friction).

Inactive rows (``lo == hi == 0``, not friction) take no part. The solvers index the
active rows by their position among them (``idx``), and the non-bilateral ones, which
make the LCP, by their position in ``oth``.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from ..._jit import noalloc
from ..joints.common import INF

KIND_BILATERAL, KIND_UNILATERAL, KIND_FRICTION, KIND_BOX = 0, 1, 2, 3
_BIG = 0.5 * INF

# The active rows of one solve by kind (``partition_rows``). Arrays are int64 views of one
# scratch block, (nrow,) each; only their first n, nb or nn entries are set.
RowPartition = namedtuple("RowPartition", [
    "idx",      # the active rows (row numbers), n of them
    "where",    # (nrow,) each row's position in idx, -1 when inactive
    "kind",     # KIND_* of each active row, by position in idx
    "bil",      # positions in idx of the bilateral rows, nb of them
    "oth",      # positions in idx of the others (the LCP's rows), nn of them
    "bsel",     # the bilateral rows themselves (row numbers), nb of them
    "nrow",     # rows in use (active or not)
    "n",        # active rows
    "nb",       # bilateral rows
    "nn",       # other active rows: n - nb
])


@njit(cache=True, inline="always")
def partition_rows(rows, nrow, ints):
    """The ``RowPartition`` of the rows ``0 .. nrow-1`` in the scratch ``ints`` (>= 6 nrow,)
    int64. Inlined: it returns views, which a ``noalloc`` caller may only borrow."""
    idx, where, kind = ints[:nrow], ints[nrow:2 * nrow], ints[2 * nrow:3 * nrow]
    bil, oth, bsel = ints[3 * nrow:4 * nrow], ints[4 * nrow:5 * nrow], ints[5 * nrow:6 * nrow]
    n, nb = _sort_rows(rows, nrow, idx, where, kind, bil, oth, bsel)
    return RowPartition(idx, where, kind, bil, oth, bsel, nrow, n, nb, n - nb)


@noalloc
def _sort_rows(rows, nrow, idx, where, kind, bil, oth, bsel):
    """One pass over the rows filling the arrays of ``RowPartition`` (the active rows
    are ``solvers.common.row_active``'s). Returns (active rows, bilateral rows)."""
    n = np.int64(0)
    nb = np.int64(0)
    no = np.int64(0)
    for r in range(nrow):
        lo, hi = rows.lo[r], rows.hi[r]
        if rows.parent[r] >= 0:
            k = KIND_FRICTION
        elif lo == 0.0 and hi == 0.0:
            where[r] = -1
            continue
        elif lo <= -_BIG and hi >= _BIG:
            k = KIND_BILATERAL
        elif lo == 0.0 and hi >= _BIG:
            k = KIND_UNILATERAL
        else:
            k = KIND_BOX
        idx[n] = r
        where[r] = n
        kind[n] = k
        if k == KIND_BILATERAL:
            bil[nb] = n
            bsel[nb] = r
            nb += 1
        else:
            oth[no] = n
            no += 1
        n += 1
    return n, nb


@noalloc
def normal_of(rows, part, r):
    """Position in ``part.oth`` of friction row ``r``'s normal row (-1 if it is not there)."""
    pa = part.where[rows.parent[r]]
    oth = part.oth
    for c in range(part.nn):
        if oth[c] == pa:
            return c
    return -1


@noalloc
def group_load(rows, part, r, p):
    """Sum of |p| (nn,) over the friction rows sharing friction row ``r``'s pyramid."""
    idx, oth, kind = part.idx, part.oth, part.kind
    load = 0.0
    for c in range(part.nn):
        if kind[oth[c]] == KIND_FRICTION and same_group(rows, r, idx[oth[c]]):
            load += abs(p[c])
    return load


@njit(cache=True, inline="always")
def same_group(rows, r, q):
    """Whether friction rows ``r`` and ``q`` share a pyramid (a row shares its own)."""
    return r == q or (rows.group[r] >= 0 and rows.group[q] == rows.group[r])


@njit(cache=True, inline="always")
def load_slot(rows, r, nrow):
    """Friction row ``r``'s slot in a groups' load array (2 nrow,): its group's, or its
    own past ``nrow`` when it has none."""
    return rows.group[r] if rows.group[r] >= 0 else nrow + r
