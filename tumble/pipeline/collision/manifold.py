"""Face-against-shape contact manifolds.

A *reference face* is a plane patch (a plane, a box face or a cylinder cap) given by a
point, its outward unit normal ``n`` (pointing from the reference shape towards the
other, *incident*, shape), two unit tangents and a region (rectangle, disc or
unbounded). The incident shape offers a few candidate surface points (box vertices,
capsule end caps, cylinder rim points); the deepest ones below the face and inside the
region become contacts. The contact point is midway between the incident point and
its projection on the face, so it lies midway between the two surfaces.

Candidate numbering (used as feature ids, stable while the contact persists):

* box: vertex index ``i = bx + 2 by + 4 bz`` where ``bk`` is 1 for the +h_k side;
* capsule: 0 for the end at ``-half_length``, 1 for ``+half_length``;
* sphere: 0;
* cylinder: ``cap * 4 + kind`` with ``cap`` 0 for the ``-half_length`` cap and 1 for
  the ``+half_length`` cap, ``kind`` 0 for the rim point deepest along ``-n``, 1 and 2
  for the rim points a quarter turn either side (``+-axis x v``), 3 for the opposite
  rim point. Candidates: the deeper cap's four points and the other cap's kind 0.
"""
import math

import numpy as np
from numba import njit

from ..._jit import noalloc

from ...math.quat import quat_rotate
from ._vec import madd, mid, norm, sub, vcross, vdot, write_contact
from .shapes import BOX, CAPSULE, CYLINDER

# Above this |axis . n| the cylinder counts as standing upright on the face and the
# rim directions come from its local x axis (so they do not spin with noise).
_UPRIGHT = 1e-12


@noalloc
def num_candidates(gtype):
    """Number of candidate points the incident shape offers."""
    if gtype == BOX:
        return 8
    if gtype == CYLINDER:
        return 5
    if gtype == CAPSULE:
        return 2
    return 1


@noalloc
def rim_frame(pos, quat, n):
    """Cylinder axis ``a``, deeper cap sign ``s``, deepest rim direction ``v`` and
    ``u = a x v`` of a cylinder against a face with outward normal ``n``."""
    a = quat_rotate(quat, (0.0, 0.0, 1.0))
    an = vdot(a, n)
    s = -1.0 if an > 0.0 else 1.0
    perp = (n[0] - an * a[0], n[1] - an * a[1], n[2] - an * a[2])
    lp = norm(perp)
    if lp > _UPRIGHT:
        v = (-perp[0] / lp, -perp[1] / lp, -perp[2] / lp)
    else:
        v = quat_rotate(quat, (1.0, 0.0, 0.0))
    u = vcross(a, v)
    return a, s, v, u


@noalloc
def candidate_frame(gtype, pos, quat, n):
    """The rim frame ``(a, s, v, u)`` that ``incident_point`` reads: ``rim_frame`` for a
    cylinder against a face of outward normal ``n``; a placeholder the other shapes
    ignore."""
    if gtype == CYLINDER:
        return rim_frame(pos, quat, n)
    return (0.0, 0.0, 1.0), 1.0, (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)


@noalloc
def incident_point(gtype, pos, quat, size, k, n, rim_a, rim_s, rim_v, rim_u):
    """Candidate ``k`` of the incident shape: ``(valid, world point on its surface, feature)``.

    For round shapes the point is the core point pushed by the radius along ``-n``.
    """
    if gtype == BOX:
        loc = (size[0] if (k & 1) else -size[0],
               size[1] if (k & 2) else -size[1],
               size[2] if (k & 4) else -size[2])
        w = quat_rotate(quat, loc)
        return True, (pos[0] + w[0], pos[1] + w[1], pos[2] + w[2]), k
    if gtype == CYLINDER:
        r = size[0]
        h = size[1]
        if k < 4:
            cs = rim_s
            kind = k
        else:
            cs = -rim_s
            kind = 0
        if kind == 0:
            d = rim_v
        elif kind == 1:
            d = rim_u
        elif kind == 2:
            d = (-rim_u[0], -rim_u[1], -rim_u[2])
        else:
            d = (-rim_v[0], -rim_v[1], -rim_v[2])
        p = (pos[0] + cs * h * rim_a[0] + r * d[0],
             pos[1] + cs * h * rim_a[1] + r * d[1],
             pos[2] + cs * h * rim_a[2] + r * d[2])
        cap = 0 if cs < 0.0 else 1
        return True, p, cap * 4 + kind
    if gtype == CAPSULE:
        r = size[0]
        h = size[1]
        if k == 1 and h <= 0.0:
            return False, (0.0, 0.0, 0.0), k
        a = quat_rotate(quat, (0.0, 0.0, 1.0))
        sh = h if k == 1 else -h
        p = (pos[0] + sh * a[0] - r * n[0], pos[1] + sh * a[1] - r * n[1],
             pos[2] + sh * a[2] - r * n[2])
        return True, p, k
    # SPHERE
    r = size[0]
    return True, (pos[0] - r * n[0], pos[1] - r * n[1], pos[2] - r * n[2]), 0


@noalloc
def _candidate_depth(gtype, pos, quat, size, k, face_pt, n, t1, t2, e1, e2, is_disc,
                     rim_a, rim_s, rim_v, rim_u):
    """``(ok, depth, point, feature)`` of candidate ``k``; ok is False outside the region."""
    valid, p, f = incident_point(gtype, pos, quat, size, k, n, rim_a, rim_s, rim_v, rim_u)
    if not valid:
        return False, 0.0, p, f
    rel = sub(p, face_pt)
    x = vdot(rel, t1)
    y = vdot(rel, t2)
    if is_disc:
        lim = e1 * (1.0 + 1e-9) + 1e-12
        if x * x + y * y > lim * lim:
            return False, 0.0, p, f
    else:
        if abs(x) > e1 * (1.0 + 1e-9) + 1e-12 or abs(y) > e2 * (1.0 + 1e-9) + 1e-12:
            return False, 0.0, p, f
    return True, -vdot(rel, n), p, f


@noalloc
def face_manifold(gtype, pos, quat, size, face_pt, n, t1, t2, e1, e2, is_disc, margin,
                  flip, feature_base, out_point, out_normal, out_depth, out_feature, start):
    """Up to 4 deepest candidates of the incident shape below the face, inside its region.

    The region is ``|x| <= e1, |y| <= e2`` in the tangent coordinates ``(t1, t2)``, or
    the disc ``x^2 + y^2 <= e1^2`` when ``is_disc``; pass ``math.inf`` for unbounded.
    The written normal is ``n`` (reference is shape A) or ``-n`` when ``flip`` (reference
    is shape B). Feature = ``feature_base + candidate feature``.
    Returns ``(count, depth of the deepest written contact or -inf)``.
    """
    rim_a, rim_s, rim_v, rim_u = candidate_frame(gtype, pos, quat, n)
    ncand = num_candidates(gtype)
    sgn = -1.0 if flip else 1.0
    normal = (sgn * n[0], sgn * n[1], sgn * n[2])
    # one pass keeping the four deepest, deepest first; a later candidate goes ahead of
    # a kept one only if deeper by more than 1e-12, so near ties keep the lower index
    d0 = d1 = d2 = d3 = -math.inf
    p0 = p1 = p2 = p3 = (0.0, 0.0, 0.0)
    f0 = f1 = f2 = f3 = np.int64(0)
    for k in range(ncand):
        ok, depth, p, f = _candidate_depth(gtype, pos, quat, size, k, face_pt, n, t1, t2,
                                           e1, e2, is_disc, rim_a, rim_s, rim_v, rim_u)
        if not ok or depth <= -margin or depth <= d3 + 1e-12:
            continue
        if depth > d0 + 1e-12:
            d0, d1, d2, d3 = depth, d0, d1, d2
            p0, p1, p2, p3 = p, p0, p1, p2
            f0, f1, f2, f3 = f, f0, f1, f2
        elif depth > d1 + 1e-12:
            d1, d2, d3 = depth, d1, d2
            p1, p2, p3 = p, p1, p2
            f1, f2, f3 = f, f1, f2
        elif depth > d2 + 1e-12:
            d2, d3 = depth, d2
            p2, p3 = p, p2
            f2, f3 = f, f2
        else:
            d3, p3, f3 = depth, p, f
    count = 0
    for slot in range(4):
        if slot == 0:
            d, p, f = d0, p0, f0
        elif slot == 1:
            d, p, f = d1, p1, f1
        elif slot == 2:
            d, p, f = d2, p2, f2
        else:
            d, p, f = d3, p3, f3
        if d == -math.inf:
            break
        write_contact(out_point, out_normal, out_depth, out_feature, start + count,
                      madd(p, n, 0.5 * d), normal, d, feature_base + f)
        count += 1
    deepest = d0
    return count, deepest


@njit(cache=True)
def add_single_contact(cnt, dmax, depth0, n, xa, xb, tol, out_point, out_normal, out_depth,
                       out_feature, start):
    """Append the GJK/MPR contact (depth ``depth0``, normal ``n``, witness points ``xa``,
    ``xb``, feature 0) to the ``cnt`` face contacts written from ``start`` unless their
    deepest, ``dmax``, is within ``tol`` of it; with 4 already, it replaces the
    shallowest. Returns the new count."""
    if cnt > 0 and depth0 <= dmax + tol:
        return cnt
    row = start + cnt
    if cnt == 4:
        row = start
        for i in range(1, 4):
            if out_depth[start + i] < out_depth[row]:
                row = start + i
        cnt = 3
    write_contact(out_point, out_normal, out_depth, out_feature, row, mid(xa, xb), n, depth0,
                  np.int64(0))
    return cnt + 1
