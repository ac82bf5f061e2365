"""Stage 1 of a step: find the contacts.

    geom world poses -> AABBs -> broad phase (sort and sweep or grid) -> filtering -> narrow phase
    geom world poses -> AABBs -> listed pairs' boxes -> narrow phase       (small scenes)

A model with at most ``LISTED_PAIRS_MAX`` geom pairs that pass the filters (they depend
on the model alone) lists them once (``listed_pairs``); each step then tests only their
boxes, in the order the broad phase would give them. When every listed pair is of
primitive shapes, ``collide_listed`` runs the whole stage without allocating.

Filtering drops pairs on the same body, pairs where neither body can move, pairs whose
collision bits do not match (MuJoCo's contype/conaffinity rule) and excluded body pairs
(bodies joined by a joint, unless the joint asked to collide). Each contact keeps the
impulse of the contact with the same geoms and feature id in the previous step, so the
solvers can warm start. With sleeping on, a pair whose bodies are both asleep (or static)
is not tested: neither has moved since the last step, whose contacts of the pair it takes
as they were (``sleep.py``).
"""
import numpy as np
from numba import njit

from .._jit import allocating, noalloc

from ..math.quat import quat_mul, quat_rotate
from ..model.types import CONVEX, DYNAMIC, PLANE, STATIC
from .collision.broadphase import boxes_overlap, overlapping_pairs
from .collision.dispatch import collide_geoms, collide_pair, geom_aabb_any
from .collision.shapes import MAX_CONTACTS_PER_PAIR
from .contacts.arrays import copy_contact

# What collide_world reports besides the contact count.
COLLIDE_OK, COLLIDE_PAIRS_FULL, COLLIDE_CONTACTS_FULL = 0, 1, 2


@noalloc
def geom_world_poses(m, pos, quat, gpos, gquat):
    """World position (ngeom, 3) and orientation (ngeom, 4) of every geom."""
    for g in range(m.geom_type.shape[0]):
        b = m.geom_body[g]
        if b < 0:
            for k in range(3):
                gpos[g, k] = m.geom_pos[g, k]
            for k in range(4):
                gquat[g, k] = m.geom_quat[g, k]
            continue
        r = quat_rotate(quat[b], m.geom_pos[g])
        q = quat_mul(quat[b], m.geom_quat[g])
        for k in range(3):
            gpos[g, k] = pos[b, k] + r[k]
        for k in range(4):
            gquat[g, k] = q[k]


@noalloc
def world_aabbs(m, gpos, gquat, world_margin, aabb_lo, aabb_hi):
    """World AABB (ngeom, 3) lower and upper corners of every geom, grown by its margin or
    ``world_margin``, whichever is larger."""
    for g in range(m.geom_type.shape[0]):
        lo, hi = geom_aabb_any(m, g, gpos[g], gquat[g], max(m.geom_margin[g], world_margin))
        for k in range(3):
            aabb_lo[g, k] = lo[k]
            aabb_hi[g, k] = hi[k]


@noalloc
def _above_plane(plane_pos, plane_quat, lo, hi, margin):
    """Whether the box ``lo``..``hi`` lies entirely more than ``margin`` above the plane
    (the side its +z normal points to): then nothing inside it can touch the plane, and
    the pair test is skipped. Infinite boxes (planes, heightfields) never are."""
    n = quat_rotate(plane_quat, (0.0, 0.0, 1.0))
    lowest = 0.0
    for k in range(3):
        c = 0.5 * (lo[k] + hi[k])
        e = 0.5 * (hi[k] - lo[k])
        lowest += n[k] * (c - plane_pos[k]) - abs(n[k]) * e
    return lowest > margin


@noalloc
def _excluded(m, a, b, nbody):
    """Binary search of the body pair among the model's excluded pairs."""
    a = nbody if a < 0 else a
    b = nbody if b < 0 else b
    key = min(a, b) * (nbody + 1) + max(a, b)
    keys = m.exclude_keys
    lo, hi = 0, keys.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if keys[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    return lo < keys.shape[0] and keys[lo] == key


@noalloc
def may_collide(m, ga, gb, nbody):
    """Whether geoms ``ga`` and ``gb`` are allowed to touch (before any geometry test)."""
    a, b = m.geom_body[ga], m.geom_body[gb]
    if a == b:
        return False
    moving_a = a >= 0 and m.body_kind[a] == DYNAMIC
    moving_b = b >= 0 and m.body_kind[b] == DYNAMIC
    if not (moving_a or moving_b):
        return False
    if (m.geom_contype[ga] & m.geom_conaffinity[gb]) == 0 and \
            (m.geom_contype[gb] & m.geom_conaffinity[ga]) == 0:
        return False
    return not _excluded(m, a, b, nbody)


# Scenes with at most this many geom pairs that may touch (``may_collide``) list them once
# and test their boxes every step instead of sorting (``listed_pairs``): a character's
# hundred pairs take 0.3 us that way, the sort and sweep 1.7 us (allocating).
LISTED_PAIRS_MAX = 512


@njit(cache=True)
def listed_pairs(m, nbody):
    """The geom pairs ``(i, j)``, ``i < j``, lexicographic, that ``may_collide`` (K, 2) int32
    when there are at most ``LISTED_PAIRS_MAX``, else an empty (0, 2) array (the broad
    phase finds the pairs). Depends on the model alone, which cannot change."""
    ng = m.geom_type.shape[0]
    out = np.empty((LISTED_PAIRS_MAX, 2), np.int32)
    k = 0
    for i in range(ng):
        for j in range(i + 1, ng):
            if may_collide(m, i, j, nbody):
                if k == LISTED_PAIRS_MAX:
                    return np.empty((0, 2), np.int32)
                out[k, 0] = i
                out[k, 1] = j
                k += 1
    return out[:k].copy()


@noalloc
def listed_primitives(m, listed):
    """Whether every pair of ``listed`` (``listed_pairs``) is of two primitive geoms: then
    ``collide_listed`` does the whole collision stage. An empty list is too many pairs to
    list, unless no pair may collide at all (a chain whose links touch nothing): then the
    listed stage finds nothing, and the general collision need not be compiled."""
    if listed.shape[0] == 0:
        return none_may_collide(m)
    for c in range(listed.shape[0]):
        if m.geom_type[listed[c, 0]] >= CONVEX or m.geom_type[listed[c, 1]] >= CONVEX:
            return False
    return True


@noalloc
def none_may_collide(m):
    """Whether no pair of the model's geoms ``may_collide``."""
    ng, nbody = m.geom_type.shape[0], m.body_kind.shape[0]
    for i in range(ng):
        for j in range(i + 1, ng):
            if may_collide(m, i, j, nbody):
                return False
    return True


@noalloc
def _listed_overlaps(listed, aabb_lo, aabb_hi, pairs):
    """The pairs of ``listed`` whose boxes overlap into ``pairs`` (in order); returns their
    number (only the first ``pairs.shape[0]`` are written)."""
    npair = 0
    for c in range(listed.shape[0]):
        i, j = listed[c, 0], listed[c, 1]
        if boxes_overlap(aabb_lo, aabb_hi, i, j):
            if npair < pairs.shape[0]:
                pairs[npair, 0] = i
                pairs[npair, 1] = j
            npair += 1
    return npair


# What _narrow_phase reports.
_NARROW_DONE, _NARROW_FULL, _NARROW_GENERAL = 0, 1, 2


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@noalloc(inline="always")
def _narrow_phase(m, pairs, i, npair, filtered, gpos, gquat, aabb_lo, aabb_hi, con, count,
                  prev_count, prev, p, world_margin, rest, sleep_time):
    """Contacts of the candidate pairs ``pairs[i:npair]`` into ``con`` from ``count`` on,
    skipping pairs that may not touch (unless already ``filtered``) and shapes clear of a
    plane, and taking a still pair's from last step (``_still``, ``_keep_contacts``);
    ``p`` is the cursor into last step's contacts (``_record_contacts``).
    Returns (status, i, count, p, margin): _NARROW_DONE; _NARROW_FULL when ``con`` has
    no room left; _NARROW_GENERAL at a pair ``i`` of non-primitive geoms, for the caller's
    general routine (then ``margin`` is that pair's)."""
    nbody = m.body_kind.shape[0]
    cap = con.depth.shape[0]
    while i < npair:
        ga, gb = pairs[i, 0], pairs[i, 1]
        if not (filtered or may_collide(m, ga, gb, nbody)):
            i += 1
            continue
        if count + MAX_CONTACTS_PER_PAIR > cap:
            return _NARROW_FULL, i, count, p, 0.0
        if sleep_time > 0.0 and _still(m, ga, rest, sleep_time) and \
                _still(m, gb, rest, sleep_time):
            count, p = _keep_contacts(ga, gb, con, count, prev_count, prev, p)
            i += 1
            continue
        margin = max(m.geom_margin[ga], m.geom_margin[gb], world_margin)
        ta, tb = np.int64(m.geom_type[ga]), np.int64(m.geom_type[gb])
        if (ta == PLANE) != (tb == PLANE):
            gp, go = (ga, gb) if ta == PLANE else (gb, ga)
            if _above_plane(gpos[gp], gquat[gp], aabb_lo[go], aabb_hi[go], margin):
                i += 1
                continue
        if ta >= CONVEX or tb >= CONVEX:
            return _NARROW_GENERAL, i, count, p, margin
        n = collide_pair(ta, gpos[ga], gquat[ga], m.geom_size[ga], tb, gpos[gb], gquat[gb],
                         m.geom_size[gb], margin, con.point, con.normal, con.depth,
                         con.feature, count)
        p = _record_contacts(m, ga, gb, con, count, n, prev_count, prev, p, margin)
        count += n
        i += 1
    return _NARROW_DONE, i, count, p, 0.0


@njit(cache=True, inline="always")
def _still(m, g, rest, sleep_time):
    """Whether geom ``g`` has not moved since the last step: its body is the world, static,
    or dynamic and asleep in the last step (``rest`` (nbody,) s at rest >= ``sleep_time``,
    so its velocities were zero when its pose was last advanced)."""
    b = m.geom_body[g]
    if b < 0 or m.body_kind[b] == STATIC:
        return True
    return m.body_kind[b] == DYNAMIC and rest[b] >= sleep_time


@njit(cache=True, inline="always")
def _pair_run(prev, prev_count, p, ga, gb):
    """Where last step's contacts (in pair order) of pair (ga, gb) lie: ``prev[start:end]``,
    found from the cursor ``p`` on (empty, at the place they would be, if none)."""
    while p < prev_count and (prev.geom[p, 0] < ga
                              or (prev.geom[p, 0] == ga and prev.geom[p, 1] < gb)):
        p += 1
    end = p
    while end < prev_count and prev.geom[end, 0] == ga and prev.geom[end, 1] == gb:
        end += 1
    return p, end


@noalloc
def _keep_contacts(ga, gb, con, count, prev_count, prev, p):
    """Last step's contacts of the pair (ga, gb) (``prev``, in pair order; ``p`` the
    cursor into them) copied whole into ``con`` from ``count`` on: the pair has not moved,
    so the narrow phase would find them again. Returns (count, p) advanced."""
    p, end = _pair_run(prev, prev_count, p, ga, gb)
    for q in range(p, end):
        copy_contact(prev, q, con, count + q - p)
    return count + end - p, end


@noalloc
def _record_contacts(m, ga, gb, con, count, n, prev_count, prev, p, reach):
    """Fill in the geoms, bodies and materials of the ``n`` contacts of pair (ga, gb) at
    ``con[count:]``, each with the impulse of last step's contact of the same pair
    (``prev``, ``prev_count`` of them, in pair order like this step's; ``p`` the cursor
    into them, returned advanced to this pair): the one with the same feature id, else
    the nearest within ``reach`` (m) whose feature no contact of the pair has now.

    The second rule keeps a warm start when a manifold's points stay but their ids
    change: two boxes face to face pick either box's face as the reference as rounding
    tips the tie (4-6% of the 210-box pyramid's contacts lost their impulses each step)."""
    p, end = _pair_run(prev, prev_count, p, ga, gb)
    for c in range(count, count + n):
        con.geom[c, 0] = ga
        con.geom[c, 1] = gb
        con.body[c, 0] = m.geom_body[ga]
        con.body[c, 1] = m.geom_body[gb]
        con.friction[c] = max(m.geom_friction[ga], m.geom_friction[gb])
        con.restitution[c] = max(m.geom_restitution[ga], m.geom_restitution[gb])
        # mostly the manifold is last step's, in the same order
        q0 = p + c - count
        if q0 < end and prev.feature[q0] == con.feature[c]:
            for k in range(con.impulse.shape[1]):
                con.impulse[c, k] = prev.impulse[q0, k]
            continue
        match = -1
        nearest = reach * reach
        for q in range(p, end):
            if prev.feature[q] == con.feature[c]:
                match = q
                break
            if _feature_taken(con, count, n, prev.feature[q]):
                continue
            d2 = 0.0
            for k in range(3):
                d2 += (prev.point[q, k] - con.point[c, k]) ** 2
            if d2 < nearest:
                match, nearest = q, d2
        for k in range(con.impulse.shape[1]):
            con.impulse[c, k] = prev.impulse[match, k] if match >= 0 else 0.0
    return p


@njit(cache=True, inline="always")
def _feature_taken(con, count, n, feature):
    """Whether one of this pair's contacts ``con[count:count + n]`` has ``feature``."""
    for c in range(count, count + n):
        if con.feature[c] == feature:
            return True
    return False


@allocating
def collide_world(m, pos, quat, gpos, gquat, aabb_lo, aabb_hi, pairs, con, prev_count, prev,
                  world_margin, broadphase, listed, rest, sleep_time):
    """Contacts of one world, written into ``con`` (a ContactArrays view of this world).

    ``prev`` holds last step's contacts (``prev_count`` of them), to carry impulses over.
    ``world_margin`` (m) is the least margin of every geom: contacts are found that far
    apart, so a fast body meets its contact before it sinks in (speculative contacts).
    ``listed`` (``listed_pairs``): the pairs that may touch, tested box against box; when
    empty, the broad phase ``broadphase`` (``collision.broadphase.BROADPHASE_SAP`` or
    ``BROADPHASE_GRID``) finds the candidates. All three give the same pairs in the same
    order, so the contacts do not depend on the route.
    ``rest`` (nbody,) s each body's time at rest and ``sleep_time`` (> 0 when sleeping is
    on): a pair of bodies that slept in the last step, or static, takes ``prev``'s
    contacts of the pair instead of being tested (pass 0.0 to test every pair).
    Returns (status, count): status COLLIDE_PAIRS_FULL or COLLIDE_CONTACTS_FULL asks the
    caller for larger buffers (``count`` is then the size needed).
    """
    geom_world_poses(m, pos, quat, gpos, gquat)
    world_aabbs(m, gpos, gquat, world_margin, aabb_lo, aabb_hi)
    filtered = listed.shape[0] > 0
    if filtered:
        npair = _listed_overlaps(listed, aabb_lo, aabb_hi, pairs)
    else:
        npair = overlapping_pairs(broadphase, aabb_lo, aabb_hi, pairs, m.geom_body)
    if npair > pairs.shape[0]:
        return COLLIDE_PAIRS_FULL, npair
    # np.int64, not 0: a loop-carried literal would compile every pair routine twice
    count = np.int64(0)
    p = np.int64(0)
    i = np.int64(0)
    while True:
        status, i, count, p, margin = _narrow_phase(m, pairs, i, npair, filtered, gpos, gquat,
                                                    aabb_lo, aabb_hi, con, count, prev_count,
                                                    prev, p, world_margin, rest, sleep_time)
        if status == _NARROW_DONE:
            return COLLIDE_OK, count
        if status == _NARROW_FULL:
            return COLLIDE_CONTACTS_FULL, 2 * con.depth.shape[0] + 64
        ga, gb = pairs[i, 0], pairs[i, 1]
        n = collide_geoms(m, ga, gpos[ga], gquat[ga], gb, gpos[gb], gquat[gb], margin,
                          con.point, con.normal, con.depth, con.feature, count)
        p = _record_contacts(m, ga, gb, con, count, n, prev_count, prev, p, margin)
        count += n
        i += 1


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@noalloc(inline="always")
def collide_listed(m, pos, quat, gpos, gquat, aabb_lo, aabb_hi, pairs, con, prev_count, prev,
                   world_margin, listed, rest, sleep_time):
    """``collide_world`` for a scene whose ``listed`` pairs are all of primitives
    (``listed_primitives``), without allocating or counting references (the model's
    arrays alone cost 1.4 us a call that way). Same arguments and results."""
    geom_world_poses(m, pos, quat, gpos, gquat)
    world_aabbs(m, gpos, gquat, world_margin, aabb_lo, aabb_hi)
    npair = _listed_overlaps(listed, aabb_lo, aabb_hi, pairs)
    if npair > pairs.shape[0]:
        return COLLIDE_PAIRS_FULL, npair
    status, i, count, p, margin = _narrow_phase(m, pairs, np.int64(0), npair, np.bool_(True),
                                                gpos, gquat, aabb_lo, aabb_hi, con,
                                                np.int64(0), prev_count, prev, np.int64(0),
                                                world_margin, rest, sleep_time)
    if status == _NARROW_FULL:
        return COLLIDE_CONTACTS_FULL, 2 * con.depth.shape[0] + 64
    return COLLIDE_OK, count
