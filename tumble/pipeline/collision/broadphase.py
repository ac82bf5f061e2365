"""Broad phase: sort and sweep over axis-aligned bounding boxes."""
import numpy as np
from numba import njit

from .shapes import geom_aabb


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
    order = np.argsort(keys, kind="mergesort")
    count = 0
    for ii in range(G):
        i = order[ii]
        hi_i = aabb_hi[i, ax]
        for jj in range(ii + 1, G):
            j = order[jj]
            if aabb_lo[j, ax] > hi_i:
                break
            if (aabb_lo[i, 0] > aabb_hi[j, 0] or aabb_lo[j, 0] > aabb_hi[i, 0]
                    or aabb_lo[i, 1] > aabb_hi[j, 1] or aabb_lo[j, 1] > aabb_hi[i, 1]
                    or aabb_lo[i, 2] > aabb_hi[j, 2] or aabb_lo[j, 2] > aabb_hi[i, 2]):
                continue
            if geom_body is not None:
                if geom_body[i] == geom_body[j]:
                    continue
            if count < cap:
                out_pairs[count, 0] = min(i, j)
                out_pairs[count, 1] = max(i, j)
            count += 1
    m = min(count, cap)
    if m > 1:
        pk = np.empty(m, dtype=np.int64)
        for r in range(m):
            pk[r] = np.int64(out_pairs[r, 0]) * G + np.int64(out_pairs[r, 1])
        pk.sort()
        for r in range(m):
            out_pairs[r, 0] = pk[r] // G
            out_pairs[r, 1] = pk[r] % G
    return count


def find_pairs(aabb_lo, aabb_hi, geom_body=None):
    """Python convenience: all overlapping pairs as an int64 array (K, 2)."""
    aabb_lo = np.ascontiguousarray(aabb_lo, dtype=np.float64)
    aabb_hi = np.ascontiguousarray(aabb_hi, dtype=np.float64)
    cap = max(16, 4 * aabb_lo.shape[0])
    while True:
        out = np.empty((cap, 2), dtype=np.int64)
        if geom_body is None:
            n = broadphase_pairs(aabb_lo, aabb_hi, out)
        else:
            n = broadphase_pairs(aabb_lo, aabb_hi, out,
                                 np.ascontiguousarray(geom_body, dtype=np.int64))
        if n <= cap:
            return out[:n].copy()
        cap = n
