"""Contact rows for the constraint solvers: a normal row and two friction rows each, and
three spin-friction rows when the model has torsional or rolling friction.

Normal row: ``n . (v_B(p) - v_A(p)) >= target`` with impulse in ``[0, inf)``; the target
pushes out penetration beyond a small slop at the contact ERP, lets a contact still
apart (within the margin) close its gap in one step, and makes the bodies bounce with
their restitution when they hit faster than the bounce threshold. A pair with its own
stiffness k and damping c (``pairs.pair_softness``) is the soft constraint of that
spring-damper instead: ERP = h k / (h k + c), CFM = 1 / (h k + c), no slop (a spring
does not jitter), so it rests at depth ``m g / k``.
Friction rows: along two tangents, bounded by ``-+ mu p_n`` (box friction, Baraff style;
the solvers update the bound from the normal impulse).
Spin-friction rows (``pairs.ROWS_SPIN`` rows per contact, only when some geom of the model
has them; otherwise ``ROWS_SLIDING`` and nothing else changes): the relative angular
velocity about the normal, bounded by ``-+ mu_t p_n`` (torsional), and about the two
tangents, bounded by ``-+ mu_r p_n`` (rolling); ``mu_t``, ``mu_r`` are lengths (m), so the
bounds are angular impulses (N m s). A pair without them gets inactive rows
(``lo == hi == 0``, no parent), which every solver skips.
"""
import math

from numba import njit

from ..joints.common import INF, angular_row, clear_row, linear_row
from .pairs import ROWS_SPIN, pair_softness, pair_spin_friction


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


@njit(cache=True)
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


@njit(cache=True)
def build_contact_rows(m, pos, vel, angvel, con, count, r0, nper, h, erp, cfm, slop,
                       bounce_threshold, rows, impulse):
    """Rows ``r0 + nper c ... r0 + nper c + nper - 1`` for contact c (``nper`` rows per
    contact, ``pairs.rows_per_contact``); warm-start impulses into ``impulse``."""
    for c in range(count):
        a, b = con.body[c, 0], con.body[c, 1]
        ga, gb = con.geom[c, 0], con.geom[c, 1]
        p = con.point[c]
        n = (con.normal[c, 0], con.normal[c, 1], con.normal[c, 2])
        r_a, r_b = lever(pos, a, p), lever(pos, b, p)
        d = con.depth[c]
        k, damp = pair_softness(m, ga, gb)
        if k > 0.0:                        # the pair's own spring-damper (see the docstring)
            s = h * k + max(damp, 0.0)
            row_cfm = 1.0 / (s * h)
            target = k * d / s if d >= 0.0 else d / h
        else:
            row_cfm = cfm / h
            if d > slop:
                target = erp / h * (d - slop)
            elif d < 0.0:
                target = d / h             # still apart: may approach by the gap
            else:
                target = 0.0
        rel = relative_velocity(vel, angvel, a, b, r_a, r_b)
        vn = rel[0] * n[0] + rel[1] * n[1] + rel[2] * n[2]
        if vn < -bounce_threshold and con.restitution[c] > 0.0:
            target = max(target, -con.restitution[c] * vn)
        r = r0 + nper * c
        linear_row(rows, r, a, b, n, r_a, r_b, target, row_cfm, 0.0, INF)
        t1, t2 = tangents(n)
        linear_row(rows, r + 1, a, b, t1, r_a, r_b, 0.0, 0.0, 0.0, 0.0)
        linear_row(rows, r + 2, a, b, t2, r_a, r_b, 0.0, 0.0, 0.0, 0.0)
        for q in range(1, 3):
            rows.parent[r + q] = r
            rows.mu[r + q] = con.friction[c]
            rows.group[r + q] = r + 1
        if nper == ROWS_SPIN:
            mu_t, mu_r = pair_spin_friction(m, ga, gb)
            for q in range(3, 6):
                e = n if q == 3 else (t1 if q == 4 else t2)
                mu = mu_t if q == 3 else mu_r
                if mu > 0.0:
                    angular_row(rows, r + q, a, b, e, 0.0, 0.0, 0.0, 0.0)
                    rows.parent[r + q] = r
                    rows.mu[r + q] = mu
                    rows.group[r + q] = r + 3 if q == 3 else r + 4
                else:
                    clear_row(rows, r + q, a, b)
        for q in range(nper):
            impulse[r + q] = con.impulse[c, q]


@njit(cache=True)
def store_contact_impulses(con, count, r0, nper, impulse):
    """Keep each contact's solved impulses (for reporting and the next warm start)."""
    for c in range(count):
        for q in range(con.impulse.shape[1]):
            con.impulse[c, q] = impulse[r0 + nper * c + q] if q < nper else 0.0
