"""General convex contacts (GJK + MPR) and the cylinder pairs built on them.

:func:`convex_contact` gives the single deepest (or nearest) contact of any two convex
shapes (sphere, capsule, box, cylinder): GJK on the cores when they are apart (exact
distance, then the radii are subtracted), MPR on the whole shapes when the cores
overlap.

The cylinder pair routines add a small manifold for resting contacts: when the contact
normal is within about 1.8 degrees of a box face or cylinder cap normal, that face is
taken as the reference face and the other shape's candidate points below it and
inside it (``manifold.face_manifold``) become the contacts; the GJK/MPR point is added
if it is deeper than all of them.

Feature ids for these pairs: 0 for the GJK/MPR point; ``1 + 8 * ref + c`` for a face
contact, with ``ref = 6 * (0 if the face is on A else 1) + face`` (box face
``2 * axis + (sign > 0)``, cylinder cap 0 for ``-half_length``, 1 for
``+half_length``) and ``c`` the candidate number of ``manifold`` (0..7).
"""
import math

import numpy as np
from numba import njit

from ...math.quat import quat_rotate
from ._vec import any_perp, frame_axes, madd, norm, normalize_or, q4, sub, v3, vcross, vdot
from .gjk import gjk_distance, mpr_penetration
from .manifold import add_single_contact, face_manifold
from .shapes import BOX, CAPSULE, CYLINDER, core_radius, shape_scale, support_core

# Type codes and flags are passed as int(...)/bool(...): Numba specialises a callee on
# every literal argument value, which multiplied the compile time of these kernels.

# |cos| between the contact normal and a face normal above which the face is used.
COS_FACE = 0.9995
# Rounds of shift-out GJK refinement of the MPR penetration direction.
REFINE_ITER = 32


@njit(cache=True)
def convex_contact(ta, pa, qa, sa, tb, pb, qb, sb, va=None, vb=None):
    """Deepest/nearest contact of two convex shapes.

    Returns ``(depth, normal A->B, point_a, point_b)``: ``depth`` > 0 is penetration,
    < 0 the distance; ``point_a`` is on A's surface, ``point_b`` on B's, and
    ``point_a - point_b`` is ``depth * normal`` (up to the tolerances below).

    Apart cores: GJK, exact. Overlapping cores: MPR (on shapes inflated by a hair so
    that touching counts) gives a first normal ``n``; then B is moved out along ``n``
    past its support-plane penetration, GJK on the now separated shapes gives the
    closest points and their normal ``n'``, and the penetration along ``n'`` of the
    unmoved shapes follows exactly from the support planes. Repeating with ``n'``
    converges to a direction whose shift-out normal is itself, a local minimum of the
    penetration depth (in one round for flat contacts; ``REFINE_ITER`` rounds at most).
    Accuracy: depth to about 1e-7 of the shape size; normal and points to about 1e-3
    for curved contacts (the depth is flat around the best direction). For very deep
    overlaps (cores crossing near their centres) the local minimum found can depend on
    rounding. ``va``, ``vb``: hull vertices of ``CONVEX`` shapes.
    """
    ra = core_radius(ta, sa)
    rb = core_radius(tb, sb)
    sc = shape_scale(ta, sa, va) + shape_scale(tb, sb, vb)
    dist, ca, cb, overlap = gjk_distance(ta, pa, qa, sa, tb, pb, qb, sb, va, vb)
    if not overlap and dist > 1e-9 * sc:
        n = normalize_or(sub(cb, ca), (0.0, 0.0, 1.0))
        return ra + rb - dist, n, madd(ca, n, ra), madd(cb, n, -rb)
    # inflate both shapes a little so that touching shapes overlap for MPR
    delta = 1e-7 * sc
    hit, n, depth, xa, xb = mpr_penetration(ta, pa, qa, sa, ra + delta, tb, pb, qb, sb,
                                            rb + delta, 1e-12 * sc, va, vb)
    if hit:
        depth = depth - 2.0 * delta
        xa = madd(xa, n, -delta)
        xb = madd(xb, n, delta)
    else:
        # cannot happen for shapes of non-zero thickness: start from the centres
        n = normalize_or(sub(pb, pa), (0.0, 0.0, 1.0))
        depth = ra + rb
    return _refine_penetration(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, sc, n, depth, xa, xb,
                               va, vb)


@njit(cache=True)
def _support_gap(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, n, va, vb):
    """Penetration of A and B along unit ``n``: ``max_A n.x - min_B n.x``."""
    a = madd(support_core(ta, pa, qa, sa, n, va), n, ra)
    b = madd(support_core(tb, pb, qb, sb, (-n[0], -n[1], -n[2]), vb), n, -rb)
    return vdot(n, sub(a, b))


@njit(cache=True)
def _refine_penetration(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, sc, n, depth, xa, xb, va,
                        vb):
    """Shift-out refinement of a penetration direction (see :func:`convex_contact`).

    The map ``n -> n'`` (move B out along ``n`` just past its support-plane
    penetration, take GJK's closest-point normal) has the locally least penetration
    direction as a fixed point. It is iterated; when successive steps line up it is
    extrapolated (Aitken when contracting, which is slow for deep penetrations, and
    doubling steps when drifting away from a ridge).
    Returns the last evaluated ``(depth, n', point_a, point_b)``.
    """
    eps = 1e-4 * sc
    prev_step = (0.0, 0.0, 0.0)
    gain = 1.0
    out_depth = math.inf
    out_n = n
    out_xa = xa
    out_xb = xb
    for _ in range(REFINE_ITER):
        # shift B out along n past its support-plane penetration: apart by >= eps
        s = max(_support_gap(ta, pa, qa, sa, ra, tb, pb, qb, sb, rb, n, va, vb), 0.0) + eps
        dist, ca, cb, overlap = gjk_distance(ta, pa, qa, sa, tb, madd(pb, n, s), qb, sb, va, vb)
        if overlap:
            break
        n2 = normalize_or(sub(cb, ca), n)
        out_depth = s * vdot(n, n2) - (dist - ra - rb)   # exact penetration along n2
        out_n = n2
        out_xa = madd(ca, n2, ra)                         # A's support along n2
        out_xb = madd(madd(cb, n2, -rb), n, -s)           # B's support along -n2
        step = sub(n2, n)
        change = norm(step)
        if change <= 1e-10:
            break
        nxt = n2
        lp = norm(prev_step)
        if lp > 0.0 and vdot(step, prev_step) > 0.99 * change * lp:
            rho = change / lp
            if rho < 0.9:
                # contracting towards a fixed point: Aitken extrapolation
                nxt = normalize_or(madd(n2, step, rho / (1.0 - rho)), n2)
                gain = 1.0
            else:
                # drifting steadily (leaving a ridge): take growing steps, at most
                # 0.3 rad; an overshoot is corrected by the following plain steps
                gain = min(2.0 * gain, 0.3 / change)
                nxt = normalize_or(madd(n2, step, gain), n2)
        else:
            gain = 1.0
        prev_step = step
        n = nxt
    if out_depth == math.inf:
        return depth, n, xa, xb
    return out_depth, out_n, out_xa, out_xb


@njit(cache=True)
def _face_feature(on_b, face):
    return 1 + 8 * (6 * on_b + face)


@njit(cache=True)
def _cap(pos, quat, h, n, towards):
    """Cap of a cylinder whose outward normal has sign ``towards`` along ``n``:
    ``(|axis . n|, centre, outward normal, cap code)``."""
    a = quat_rotate(quat, (0.0, 0.0, 1.0))
    an = vdot(a, n)
    s = 1.0 if an * towards >= 0.0 else -1.0
    c = (s * a[0], s * a[1], s * a[2])
    return abs(an), madd(pos, c, h), c, (1 if s > 0.0 else 0)


@njit(cache=True)
def collide_capsule_cylinder(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                             out_normal, out_depth, out_feature, start):
    """Capsule A, cylinder B (GJK/MPR; end caps against B's cap when resting on it)."""
    pa, qa, sa = v3(pos_a), q4(quat_a), v3(size_a)
    pb, qb, sb = v3(pos_b), q4(quat_b), v3(size_b)
    depth0, n, xa, xb = convex_contact(np.int64(CAPSULE), pa, qa, sa, np.int64(CYLINDER), pb, qb,
                                       sb)
    if depth0 <= -margin:
        return 0
    cnt = np.int64(0)
    dmax = -math.inf
    al, cc, c, code = _cap(pb, qb, sb[1], n, -1.0)
    if al >= COS_FACE:
        t1 = any_perp(c)
        t2 = vcross(c, t1)
        cnt, dmax = face_manifold(np.int64(CAPSULE), pa, qa, sa, cc, c, t1, t2, sb[0], sb[0],
                                  bool(True), margin, bool(True), _face_feature(np.int64(1), code),
                                  out_point, out_normal,
                                  out_depth, out_feature, start)
    tol = 1e-6 * (shape_scale(np.int64(CAPSULE), sa) + shape_scale(np.int64(CYLINDER), sb))
    return add_single_contact(cnt, dmax, depth0, n, xa, xb, tol, out_point, out_normal,
                              out_depth, out_feature, start)


@njit(cache=True)
def collide_box_cylinder(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                         out_normal, out_depth, out_feature, start):
    """Box A, cylinder B (GJK/MPR; a box face or a cap as reference face when resting)."""
    pa, qa, sa = v3(pos_a), q4(quat_a), v3(size_a)
    pb, qb, sb = v3(pos_b), q4(quat_b), v3(size_b)
    depth0, n, xa, xb = convex_contact(np.int64(BOX), pa, qa, sa, np.int64(CYLINDER), pb, qb, sb)
    if depth0 <= -margin:
        return 0
    A = frame_axes(qa)
    k = 0
    best = -1.0
    for i in range(3):
        c = abs(vdot(A[i], n))
        if c > best:
            best = c
            k = i
    s = 1.0 if vdot(A[k], n) >= 0.0 else -1.0
    f = (s * A[k][0], s * A[k][1], s * A[k][2])
    box_ok = best >= COS_FACE
    al, cc, c, code = _cap(pb, qb, sb[1], n, -1.0)
    cap_ok = al >= COS_FACE
    e1 = sa[(k + 1) % 3]
    e2 = sa[(k + 2) % 3]
    r = sb[0]
    use_box = box_ok and (not cap_ok or 4.0 * e1 * e2 >= math.pi * r * r)
    cnt = np.int64(0)
    dmax = -math.inf
    for attempt in range(2):
        if cnt > 0:
            break
        if (attempt == 0) == use_box:
            if box_ok:
                cnt, dmax = face_manifold(np.int64(CYLINDER), pb, qb, sb, madd(pa, f, sa[k]), f,
                                          A[(k + 1) % 3], A[(k + 2) % 3], e1, e2, bool(False),
                                          margin, bool(False),
                                          _face_feature(np.int64(0), 2 * k + (1 if s > 0.0 else 0)),
                                          out_point, out_normal, out_depth, out_feature, start)
        elif cap_ok:
            t1 = any_perp(c)
            t2 = vcross(c, t1)
            cnt, dmax = face_manifold(np.int64(BOX), pa, qa, sa, cc, c, t1, t2, r, r, bool(True),
                                      margin, bool(True),
                                      _face_feature(np.int64(1), code), out_point, out_normal,
                                      out_depth, out_feature, start)
    tol = 1e-6 * (shape_scale(np.int64(BOX), sa) + shape_scale(np.int64(CYLINDER), sb))
    return add_single_contact(cnt, dmax, depth0, n, xa, xb, tol, out_point, out_normal,
                              out_depth, out_feature, start)


@njit(cache=True)
def collide_cylinder_cylinder(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin, out_point,
                              out_normal, out_depth, out_feature, start):
    """Cylinder A, cylinder B (GJK/MPR; the larger facing cap as reference when resting)."""
    pa, qa, sa = v3(pos_a), q4(quat_a), v3(size_a)
    pb, qb, sb = v3(pos_b), q4(quat_b), v3(size_b)
    depth0, n, xa, xb = convex_contact(np.int64(CYLINDER), pa, qa, sa, np.int64(CYLINDER), pb,
                                       qb, sb)
    if depth0 <= -margin:
        return 0
    ala, cca, ca, codea = _cap(pa, qa, sa[1], n, 1.0)
    alb, ccb, cb, codeb = _cap(pb, qb, sb[1], n, -1.0)
    oka = ala >= COS_FACE
    okb = alb >= COS_FACE
    use_a = oka and (not okb or sa[0] >= sb[0])
    cnt = np.int64(0)
    dmax = -math.inf
    for attempt in range(2):
        if cnt > 0:
            break
        if (attempt == 0) == use_a:
            if oka:
                t1 = any_perp(ca)
                t2 = vcross(ca, t1)
                cnt, dmax = face_manifold(np.int64(CYLINDER), pb, qb, sb, cca, ca, t1, t2, sa[0],
                                          sa[0],
                                          bool(True), margin, bool(False),
                                          _face_feature(np.int64(0), codea), out_point,
                                          out_normal, out_depth, out_feature, start)
        elif okb:
            t1 = any_perp(cb)
            t2 = vcross(cb, t1)
            cnt, dmax = face_manifold(np.int64(CYLINDER), pa, qa, sa, ccb, cb, t1, t2, sb[0], sb[0],
                                      bool(True),
                                      margin, bool(True), _face_feature(np.int64(1), codeb),
                                      out_point, out_normal, out_depth, out_feature, start)
    tol = 1e-6 * (shape_scale(np.int64(CYLINDER), sa) + shape_scale(np.int64(CYLINDER), sb))
    return add_single_contact(cnt, dmax, depth0, n, xa, xb, tol, out_point, out_normal,
                              out_depth, out_feature, start)
