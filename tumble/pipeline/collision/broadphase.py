"""Broad phase: pairs of geoms whose axis-aligned bounding boxes overlap.

Two methods, both exact (the same pairs as testing every pair), chosen per world by
``World(..., broadphase=...)``:

* ``"sap"`` (``BROADPHASE_SAP``): sort and sweep along the axis of largest spread.
* ``"grid"`` (``BROADPHASE_GRID``): uniform grid by spatial hashing; the cell size is
  ``GRID_CELL_SCALE`` times the median AABB size; unbounded (planes) and large geoms
  (walls, heightfields, anything bigger than a cell) are kept out of the grid and
  tested against the grid cells they cover.

Both return the pairs ``(i, j)``, ``i < j``, in lexicographic order, which the warm start
of ``collide.collide_world`` relies on. A step on a model with few pairs that may touch
at all uses neither: ``collide.listed_pairs`` lists them once and each step tests their
boxes (``boxes_overlap``).
"""
import numpy as np
from numba import njit

from ...errors import ModelError
from ...model.types import BROADPHASE_GRID, BROADPHASE_SAP, BROADPHASES  # noqa: F401
from .shapes import geom_aabb

#: grid cell edge over the median AABB size (largest side); geoms bigger than a cell are
#: kept out of the grid. Chosen by measurement (bench/bench_collision.py --broadphase).
GRID_CELL_SCALE = 2.0
# Cell coordinates beyond this are not hashed (the geom is treated as large instead), so
# float rounding of ``centre / cell`` stays far below one cell and int64 cannot overflow.
_GRID_MAX_CELL = 2.0 ** 30


@njit(cache=True)
def geom_aabbs(geom_type, geom_pos, geom_quat, geom_size, geom_margin, out_lo, out_hi):
    """AABBs of all geoms into ``out_lo``, ``out_hi`` (G, 3); ``geom_margin`` (G,)."""
    for g in range(geom_type.shape[0]):
        lo, hi = geom_aabb(geom_type[g], geom_pos[g], geom_quat[g], geom_size[g],
                           geom_margin[g])
        for k in range(3):
            out_lo[g, k] = lo[k]
            out_hi[g, k] = hi[k]


@njit(cache=True)
def sweep_axis(aabb_lo, aabb_hi):
    """Axis (0, 1, 2) along which the centres of the bounded AABBs vary most."""
    n = 0
    s = np.zeros(3)
    s2 = np.zeros(3)
    for i in range(aabb_lo.shape[0]):
        ok = True
        for k in range(3):
            if not (np.isfinite(aabb_lo[i, k]) and np.isfinite(aabb_hi[i, k])):
                ok = False
        if not ok:
            continue
        n += 1
        for k in range(3):
            c = 0.5 * (aabb_lo[i, k] + aabb_hi[i, k])
            s[k] += c
            s2[k] += c * c
    if n < 2:
        return 0
    best = 0
    bv = -1.0
    for k in range(3):
        m = s[k] / n
        v = s2[k] / n - m * m
        if v > bv:
            bv = v
            best = k
    return best


@njit(cache=True)
def broadphase_pairs(aabb_lo, aabb_hi, out_pairs, geom_body=None):
    """Pairs of geoms whose (closed) AABBs overlap, by sort and sweep.

    The boxes are sorted by their lower bound along the axis of largest centre
    variance and swept; every candidate is then checked on all three axes, so the
    result is exactly the brute-force set. Unbounded boxes (``+-inf``, as planes get)
    pair with everything they overlap, i.e. everything. With ``geom_body`` (G,) two
    geoms with the same value (same body, or both ``-1`` static world) are not paired.

    Writes pairs ``(i, j)``, ``i < j``, sorted lexicographically, into ``out_pairs``
    (P, 2) int and returns the total number of overlapping pairs. When that exceeds
    P, only P of them (not necessarily the first ones) were written: call again with
    a larger array.
    """
    G = aabb_lo.shape[0]
    cap = out_pairs.shape[0]
    if G < 2:
        return 0
    ax = sweep_axis(aabb_lo, aabb_hi)
    keys = np.empty(G)
    for i in range(G):
        keys[i] = aabb_lo[i, ax]
    order = _stable_order(keys)
    count = 0
    for ii in range(G):
        i = order[ii]
        hi_i = aabb_hi[i, ax]
        for jj in range(ii + 1, G):
            j = order[jj]
            if aabb_lo[j, ax] > hi_i:
                break
            count = _add_pair(aabb_lo, aabb_hi, geom_body, i, j, out_pairs, count)
    sort_pairs(out_pairs, min(count, cap), G)
    return count


# Below this many items an insertion sort beats NumPy's sorts (no allocation, no set-up):
# a character's dozen or two geoms and their few dozen pairs.
_SMALL = 48


@njit(cache=True, inline="always")
def _insertion_sort(a):
    """Sort ``a`` in place, ascending."""
    for i in range(1, a.shape[0]):
        x = a[i]
        k = i
        while k > 0 and a[k - 1] > x:
            a[k] = a[k - 1]
            k -= 1
        a[k] = x


@njit(cache=True)
def _stable_order(keys):
    """Indices that sort ``keys`` ascending, ties in index order (``argsort``, mergesort)."""
    n = keys.shape[0]
    if n > _SMALL:
        return np.argsort(keys, kind="mergesort")
    order = np.arange(n)
    for i in range(1, n):
        o = order[i]
        x = keys[o]
        k = i
        while k > 0 and keys[order[k - 1]] > x:
            order[k] = order[k - 1]
            k -= 1
        order[k] = o
    return order


@njit(cache=True)
def sort_pairs(out_pairs, m, G):
    """Sort the first ``m`` rows of ``out_pairs`` (each ``i < j < G``) lexicographically."""
    if m > 1:
        pk = np.empty(m, dtype=np.int64)
        for r in range(m):
            pk[r] = np.int64(out_pairs[r, 0]) * G + np.int64(out_pairs[r, 1])
        if m <= _SMALL:
            _insertion_sort(pk)
        else:
            pk.sort()
        for r in range(m):
            out_pairs[r, 0] = pk[r] // G
            out_pairs[r, 1] = pk[r] % G


def find_pairs(aabb_lo, aabb_hi, geom_body=None, method="sap"):
    """Python convenience: all overlapping pairs as an int64 array (K, 2), sorted.

    ``aabb_lo``, ``aabb_hi`` (G, 3) world bounds (m; ``+-inf`` for unbounded geoms);
    ``geom_body`` (G,) optional, geoms with equal values are not paired; ``method`` a key
    of ``BROADPHASES``.
    """
    if not isinstance(method, str) or method not in BROADPHASES:
        raise ModelError(f"broad phase: method must be one of {list(BROADPHASES)}, "
                         f"got {method!r}")
    code = BROADPHASES[method]
    aabb_lo = np.ascontiguousarray(aabb_lo, dtype=np.float64)
    aabb_hi = np.ascontiguousarray(aabb_hi, dtype=np.float64)
    # the kernels get the pipeline's types (int32 pairs, a read-only int32 body per geom;
    # distinct ids filter nothing), so that both share one compilation
    if geom_body is None:
        body = np.arange(aabb_lo.shape[0], dtype=np.int32)
    else:
        body = np.array(geom_body, dtype=np.int32)
    body.flags.writeable = False
    cap = max(16, 4 * aabb_lo.shape[0])
    while True:
        out = np.empty((cap, 2), dtype=np.int32)
        n = overlapping_pairs(code, aabb_lo, aabb_hi, out, body)
        if n <= cap:
            return out[:n].astype(np.int64)
        cap = n


@njit(cache=True)
def overlapping_pairs(method, aabb_lo, aabb_hi, out_pairs, geom_body=None):
    """Broad phase by ``method`` (``BROADPHASE_SAP`` or ``BROADPHASE_GRID``); arguments,
    output and return value as :func:`broadphase_pairs` (the same pairs in the same order)."""
    if method == BROADPHASE_GRID:
        return grid_pairs(aabb_lo, aabb_hi, out_pairs, geom_body, GRID_CELL_SCALE)
    return broadphase_pairs(aabb_lo, aabb_hi, out_pairs, geom_body)


@njit(cache=True, inline="always")
def boxes_overlap(lo, hi, i, j):
    """Closed AABBs ``i`` and ``j`` overlap on all three axes."""
    return not (lo[i, 0] > hi[j, 0] or lo[j, 0] > hi[i, 0]
                or lo[i, 1] > hi[j, 1] or lo[j, 1] > hi[i, 1]
                or lo[i, 2] > hi[j, 2] or lo[j, 2] > hi[i, 2])


@njit(cache=True, inline="always")
def _add_pair(aabb_lo, aabb_hi, geom_body, i, j, out_pairs, count):
    """Count the candidate pair (i, j) if its boxes overlap and (with ``geom_body``) its
    geoms are on different bodies, recording it as (min, max) while ``out_pairs`` has
    room; returns the new count (the caller asks for a larger buffer when it overflows)."""
    if not boxes_overlap(aabb_lo, aabb_hi, i, j):
        return count
    if geom_body is not None:
        if geom_body[i] == geom_body[j]:
            return count
    if count < out_pairs.shape[0]:
        out_pairs[count, 0] = min(i, j)
        out_pairs[count, 1] = max(i, j)
    return count + 1


@njit(cache=True, inline="always")
def _cell_hash(x, y, z, mask):
    """Bucket of cell (x, y, z) in a table of ``mask + 1`` (a power of two) buckets."""
    h = (x * 73856093) ^ (y * 19349663) ^ (z * 83492791)
    return h & mask


@njit(cache=True)
def grid_pairs(aabb_lo, aabb_hi, out_pairs, geom_body=None, cell_scale=GRID_CELL_SCALE):
    """Pairs of geoms whose (closed) AABBs overlap, by a hashed uniform grid.

    The cell edge ``h`` is ``cell_scale`` times the median largest side of the bounded
    AABBs (m). A geom whose AABB fits in a cell (every side <= h) is filed under the one
    cell holding its centre; two such geoms can only overlap when their cells are
    neighbours, so each looks at its own cell and 13 of the 26 around it (each neighbour
    pair once). The other geoms (unbounded planes, walls, heightfields, anything larger)
    are tested against the grid cells their AABB covers (or against every small geom,
    when that is fewer tests) and against each other by sort and sweep.

    Arguments, output (sorted, ``i < j``), overflow rule and return value as
    :func:`broadphase_pairs`; the pair set is exactly the brute-force one.
    """
    G = aabb_lo.shape[0]
    cap = out_pairs.shape[0]
    if G < 2:
        return 0
    # largest side of each box; inf for unbounded ones
    ext = np.empty(G)
    nb = 0
    for i in range(G):
        e = 0.0
        for k in range(3):
            d = aabb_hi[i, k] - aabb_lo[i, k]
            if not np.isfinite(d):
                e = np.inf
                break
            e = max(e, d)
        ext[i] = e
        if e < np.inf:
            nb += 1
    h = 0.0
    if nb > 0:
        fin = np.empty(nb)
        r = 0
        for i in range(G):
            if ext[i] < np.inf:
                fin[r] = ext[i]
                r += 1
        fin.sort()
        h = cell_scale * fin[nb // 2]
    if not (h > 0.0 and np.isfinite(h)):
        h = 1.0                               # points only: any cell size is exact
    # slightly larger cells than the admission size, so rounding of centre / cell can
    # never put two overlapping small geoms more than one cell apart
    inv = 1.0 / (h * (1.0 + 1e-4))
    cx = np.empty(G, dtype=np.int64)
    cy = np.empty(G, dtype=np.int64)
    cz = np.empty(G, dtype=np.int64)
    small = np.empty(G, dtype=np.int64)
    large = np.empty(G, dtype=np.int64)
    ns = 0
    nl = 0
    for i in range(G):
        ok = ext[i] <= h
        if ok:
            fx = np.floor(0.5 * (aabb_lo[i, 0] + aabb_hi[i, 0]) * inv)
            fy = np.floor(0.5 * (aabb_lo[i, 1] + aabb_hi[i, 1]) * inv)
            fz = np.floor(0.5 * (aabb_lo[i, 2] + aabb_hi[i, 2]) * inv)
            ok = (abs(fx) < _GRID_MAX_CELL and abs(fy) < _GRID_MAX_CELL
                  and abs(fz) < _GRID_MAX_CELL)
        if ok:
            cx[i] = np.int64(fx)
            cy[i] = np.int64(fy)
            cz[i] = np.int64(fz)
            small[ns] = i
            ns += 1
        else:
            large[nl] = i
            nl += 1
    # hash table: bucket b holds items[start[b]:start[b + 1]] (counting sort)
    nbucket = 16
    while nbucket < 2 * ns:
        nbucket *= 2
    mask = nbucket - 1
    start = np.zeros(nbucket + 1, dtype=np.int64)
    bucket = np.empty(G, dtype=np.int64)
    for a in range(ns):
        i = small[a]
        b = _cell_hash(cx[i], cy[i], cz[i], mask)
        bucket[i] = b
        start[b + 1] += 1
    for b in range(nbucket):
        start[b + 1] += start[b]
    fill = start[:nbucket].copy()
    items = np.empty(max(ns, 1), dtype=np.int64)
    for a in range(ns):
        i = small[a]
        b = bucket[i]
        items[fill[b]] = i
        fill[b] += 1
    count = 0
    # small against small: own cell (higher index only) and the 13 neighbours after it
    for a in range(ns):
        i = small[a]
        xi, yi, zi = cx[i], cy[i], cz[i]
        for d in range(13, 27):
            dx = d // 9 - 1
            dy = (d // 3) % 3 - 1
            dz = d % 3 - 1
            x, y, z = xi + dx, yi + dy, zi + dz
            b = bucket[i] if d == 13 else _cell_hash(x, y, z, mask)
            for t in range(start[b], start[b + 1]):
                j = items[t]
                if cx[j] != x or cy[j] != y or cz[j] != z:
                    continue
                if d == 13 and j <= i:
                    continue
                count = _add_pair(aabb_lo, aabb_hi, geom_body, i, j, out_pairs, count)
    # large against small: scan the cells whose small geoms could reach the box (a small
    # centre lies within h / 2 of it), or every small geom when that is cheaper
    for a in range(nl):
        i = large[a]
        scan_cells = ext[i] < np.inf
        ncell = 1.0
        if scan_cells:
            for k in range(3):
                ncell *= (np.floor((aabb_hi[i, k] + 0.5 * h) * inv)
                          - np.floor((aabb_lo[i, k] - 0.5 * h) * inv) + 3.0)
            scan_cells = ncell < ns and np.isfinite(ncell)
        if scan_cells:
            x0 = np.int64(np.floor((aabb_lo[i, 0] - 0.5 * h) * inv)) - 1
            x1 = np.int64(np.floor((aabb_hi[i, 0] + 0.5 * h) * inv)) + 1
            y0 = np.int64(np.floor((aabb_lo[i, 1] - 0.5 * h) * inv)) - 1
            y1 = np.int64(np.floor((aabb_hi[i, 1] + 0.5 * h) * inv)) + 1
            z0 = np.int64(np.floor((aabb_lo[i, 2] - 0.5 * h) * inv)) - 1
            z1 = np.int64(np.floor((aabb_hi[i, 2] + 0.5 * h) * inv)) + 1
            for x in range(x0, x1 + 1):
                for y in range(y0, y1 + 1):
                    for z in range(z0, z1 + 1):
                        b = _cell_hash(x, y, z, mask)
                        for t in range(start[b], start[b + 1]):
                            j = items[t]
                            if cx[j] != x or cy[j] != y or cz[j] != z:
                                continue
                            count = _add_pair(aabb_lo, aabb_hi, geom_body, i, j, out_pairs, count)
        else:
            for c in range(ns):
                j = small[c]
                count = _add_pair(aabb_lo, aabb_hi, geom_body, i, j, out_pairs, count)
    # large against large: sort and sweep along x (unbounded ones sort first and meet all)
    if nl > 1:
        keys = np.empty(nl)
        for a in range(nl):
            keys[a] = aabb_lo[large[a], 0]
        order = np.argsort(keys, kind="mergesort")
        for aa in range(nl):
            i = large[order[aa]]
            for bb in range(aa + 1, nl):
                j = large[order[bb]]
                if aabb_lo[j, 0] > aabb_hi[i, 0]:
                    break
                count = _add_pair(aabb_lo, aabb_hi, geom_body, i, j, out_pairs, count)
    sort_pairs(out_pairs, min(count, cap), G)
    return count
