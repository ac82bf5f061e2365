"""Stage 1 of a step: find the contacts.

    geom world poses -> AABBs -> broad phase (sort and sweep or grid) -> filtering -> narrow phase

Filtering drops pairs on the same body, pairs where neither body can move, pairs whose
collision bits do not match (MuJoCo's contype/conaffinity rule) and excluded body pairs
(bodies joined by a joint, unless the joint asked to collide). Each contact keeps the
impulse of the contact with the same geoms and feature id in the previous step, so the
solvers can warm start.
"""
import numpy as np
from numba import njit

from .._jit import noalloc

from ..math.quat import quat_mul, quat_rotate
from ..model.model import DYNAMIC
from .collision.broadphase import BROADPHASE_SAP, overlapping_pairs
from .collision.dispatch import collide_geoms, collide_pair, geom_aabb_any
from .collision.shapes import CONVEX, PLANE

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


@njit(cache=True)
def collide_world(m, pos, quat, gpos, gquat, aabb_lo, aabb_hi, pairs, con, prev_count, prev,
                  world_margin, broadphase=BROADPHASE_SAP):
    """Contacts of one world, written into ``con`` (a ContactArrays view of this world).

    ``prev`` holds last step's contacts (``prev_count`` of them), to carry impulses over.
    ``world_margin`` (m) is the least margin of every geom: contacts are found that far
    apart, so a fast body meets its contact before it sinks in (speculative contacts).
    ``broadphase`` is ``collision.broadphase.BROADPHASE_SAP`` or ``BROADPHASE_GRID``; both
    give the same pairs in the same order, so the contacts do not depend on it.
    Returns (status, count): status COLLIDE_PAIRS_FULL or COLLIDE_CONTACTS_FULL asks the
    caller for larger buffers (``count`` is then the size needed).
    """
    geom_world_poses(m, pos, quat, gpos, gquat)
    world_aabbs(m, gpos, gquat, world_margin, aabb_lo, aabb_hi)
    npair = overlapping_pairs(broadphase, aabb_lo, aabb_hi, pairs, m.geom_body)
    if npair > pairs.shape[0]:
        return COLLIDE_PAIRS_FULL, npair
    nbody = pos.shape[0]
    cap = con.depth.shape[0]
    # np.int64, not 0: a loop-carried literal would compile every pair routine twice
    count = np.int64(0)
    p = 0                                   # cursor into the previous contacts
    for i in range(npair):
        ga, gb = pairs[i, 0], pairs[i, 1]
        if not may_collide(m, ga, gb, nbody):
            continue
        if count + 4 > cap:
            return COLLIDE_CONTACTS_FULL, 2 * cap + 64
        margin = max(m.geom_margin[ga], m.geom_margin[gb], world_margin)
        ta, tb = np.int64(m.geom_type[ga]), np.int64(m.geom_type[gb])
        if (ta == PLANE) != (tb == PLANE):
            gp, go = (ga, gb) if ta == PLANE else (gb, ga)
            if _above_plane(gpos[gp], gquat[gp], aabb_lo[go], aabb_hi[go], margin):
                continue
        if ta < CONVEX and tb < CONVEX:
            # primitives straight to their pair routine: collide_geoms takes the whole model,
            # whose reference counting would cost more than most pair tests
            n = collide_pair(ta, gpos[ga], gquat[ga], m.geom_size[ga], tb, gpos[gb], gquat[gb],
                             m.geom_size[gb], margin, con.point, con.normal, con.depth,
                             con.feature, count)
        else:
            n = collide_geoms(m, ga, gpos[ga], gquat[ga], gb, gpos[gb], gquat[gb], margin,
                              con.point, con.normal, con.depth, con.feature, count)
        # previous contacts are in the same (ga, gb) order: advance to this pair
        while p < prev_count and (prev.geom[p, 0] < ga or (prev.geom[p, 0] == ga and prev.geom[p, 1] < gb)):
            p += 1
        for c in range(count, count + n):
            con.geom[c, 0] = ga
            con.geom[c, 1] = gb
            con.body[c, 0] = m.geom_body[ga]
            con.body[c, 1] = m.geom_body[gb]
            con.friction[c] = max(m.geom_friction[ga], m.geom_friction[gb])
            con.restitution[c] = max(m.geom_restitution[ga], m.geom_restitution[gb])
            for k in range(con.impulse.shape[1]):
                con.impulse[c, k] = 0.0
            q = p
            while q < prev_count and prev.geom[q, 0] == ga and prev.geom[q, 1] == gb:
                if prev.feature[q] == con.feature[c]:
                    for k in range(con.impulse.shape[1]):
                        con.impulse[c, k] = prev.impulse[q, k]
                    break
                q += 1
        count += n
    return COLLIDE_OK, count
