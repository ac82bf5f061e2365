"""Contact rows for the constraint solvers: one normal row and two friction rows each.

Normal row: ``n . (v_B(p) - v_A(p)) >= target`` with impulse in ``[0, inf)``; the target
pushes out penetration beyond a small slop at the contact ERP, lets a contact still
apart (within the margin) close its gap in one step, and makes the bodies bounce with
their restitution when they hit faster than the bounce threshold.
Friction rows: along two tangents, bounded by ``-+ mu p_n`` (box friction, Baraff style;
the solvers update the bound from the normal impulse).
"""
import math

from numba import njit

from ..._jit import noalloc
from ..joints.common import INF, linear_row


@njit(cache=True, inline="always")
def tangents(n):
    """Two unit tangents completing the unit normal ``n`` to a right-handed frame,
    chosen from ``n`` alone so a resting contact keeps the same ones every step."""
    if abs(n[0]) < 0.57735:
        a = (0.0, n[2], -n[1])            # n x (1, 0, 0)
    else:
        a = (-n[2], 0.0, n[0])            # n x (0, 1, 0)
    s = 1.0 / math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    t1 = (a[0] * s, a[1] * s, a[2] * s)
    t2 = (n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2], n[0] * t1[1] - n[1] * t1[0])
    return t1, t2


@njit(cache=True, inline="always")
def lever(pos, b, p):
    """Lever arm (world) from body ``b``'s COM to the point; the world's origin for -1."""
    if b < 0:
        return (p[0], p[1], p[2])
    return (p[0] - pos[b, 0], p[1] - pos[b, 1], p[2] - pos[b, 2])


@noalloc
def relative_velocity(vel, angvel, a, b, r_a, r_b):
    """Velocity of B's material point minus A's at the contact, world frame."""
    x = y = z = 0.0
    for side in range(2):
        body = b if side == 0 else a
        if body < 0:
            continue
        r = r_b if side == 0 else r_a
        s = 1.0 if side == 0 else -1.0
        w0, w1, w2 = angvel[body, 0], angvel[body, 1], angvel[body, 2]
        x += s * (vel[body, 0] + w1 * r[2] - w2 * r[1])
        y += s * (vel[body, 1] + w2 * r[0] - w0 * r[2])
        z += s * (vel[body, 2] + w0 * r[1] - w1 * r[0])
    return (x, y, z)


@noalloc
def build_contact_rows(pos, vel, angvel, con, count, r0, h, erp, cfm, slop, bounce_threshold,
                       rows, impulse):
    """Rows ``r0 + 3c .. r0 + 3c + 2`` for contact c; warm-start impulses into ``impulse``."""
    for c in range(count):
        a, b = con.body[c, 0], con.body[c, 1]
        p = con.point[c]
        n = (con.normal[c, 0], con.normal[c, 1], con.normal[c, 2])
        r_a, r_b = lever(pos, a, p), lever(pos, b, p)
        d = con.depth[c]
        if d > slop:
            target = erp / h * (d - slop)
        elif d < 0.0:
            target = d / h                 # still apart: may approach by the gap
        else:
            target = 0.0
        rel = relative_velocity(vel, angvel, a, b, r_a, r_b)
        vn = rel[0] * n[0] + rel[1] * n[1] + rel[2] * n[2]
        if vn < -bounce_threshold and con.restitution[c] > 0.0:
            target = max(target, -con.restitution[c] * vn)
        r = r0 + 3 * c
        linear_row(rows, r, a, b, n, r_a, r_b, target, cfm / h, 0.0, INF)
        t1, t2 = tangents(n)
        linear_row(rows, r + 1, a, b, t1, r_a, r_b, 0.0, 0.0, 0.0, 0.0)
        linear_row(rows, r + 2, a, b, t2, r_a, r_b, 0.0, 0.0, 0.0, 0.0)
        for k in range(1, 3):
            rows.parent[r + k] = r
            rows.mu[r + k] = con.friction[c]
        for k in range(3):
            impulse[r + k] = con.impulse[c, k]


@noalloc
def store_contact_impulses(con, count, r0, impulse):
    """Keep each contact's solved impulses (for reporting and the next warm start)."""
    for c in range(count):
        for k in range(3):
            con.impulse[c, k] = impulse[r0 + 3 * c + k]
