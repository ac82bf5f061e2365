"""Penalty contacts: springs and dampers at the contact points, added to the forces.

Normal force ``f_n = k d - c v_n`` (d penetration, v_n approach speed positive apart),
never pulling; Coulomb friction regularised as ``f_t = -mu f_n v_t / max(|v_t|, v_slip)``
so it is capped by ``mu f_n`` and smooth near rest (bodies creep at up to ``v_slip``
times the ratio of pull to friction instead of sticking exactly).

Stability rule used for the defaults (``default_penalty``): the lightest body m resting
on four contacts (a box face) feels ``K = 4k`` and ``C = 4c``. Semi-implicit Euler
needs ``w h < 2`` with ``w = sqrt(K/m)`` and ``C h / m < 2``; we take ``w h = 0.5``
and critical damping ``C = 2 sqrt(K m)`` (so ``C h / m = 1``): ``k = m / (16 h^2)``,
``c = m / (4 h)``. A box resting on four contacts sinks ``m g / K = 4 g h^2``: 0.7 mm at
240 Hz; a sphere on one contact four times that.
"""
import math


from ..._jit import noalloc
from .rows import lever, relative_velocity, tangents


def default_penalty(lightest_mass, h):
    """(k, c) for the lightest colliding body at step ``h`` (see the module docstring)."""
    return lightest_mass / (16.0 * h * h), lightest_mass / (4.0 * h)


@noalloc
def penalty_forces(pos, vel, angvel, con, count, k, c, v_slip, h, force, torque):
    """Add the contact forces (N) and their torques about each COM to ``force``/``torque``;
    each contact's ``impulse`` becomes its force times ``h`` (normal, tangent 1, tangent 2)."""
    for i in range(count):
        d = con.depth[i]
        if d <= 0.0:
            con.impulse[i, 0] = con.impulse[i, 1] = con.impulse[i, 2] = 0.0
            continue
        a, b = con.body[i, 0], con.body[i, 1]
        p = con.point[i]
        n = (con.normal[i, 0], con.normal[i, 1], con.normal[i, 2])
        r_a, r_b = lever(pos, a, p), lever(pos, b, p)
        rel = relative_velocity(vel, angvel, a, b, r_a, r_b)
        vn = rel[0] * n[0] + rel[1] * n[1] + rel[2] * n[2]
        fn = max(k * d - c * vn, 0.0)
        vt = (rel[0] - vn * n[0], rel[1] - vn * n[1], rel[2] - vn * n[2])
        speed = math.sqrt(vt[0] * vt[0] + vt[1] * vt[1] + vt[2] * vt[2])
        ft = con.friction[i] * fn / max(speed, v_slip)
        f = (fn * n[0] - ft * vt[0], fn * n[1] - ft * vt[1], fn * n[2] - ft * vt[2])
        t1, t2 = tangents(n)
        con.impulse[i, 0] = fn * h
        con.impulse[i, 1] = h * (f[0] * t1[0] + f[1] * t1[1] + f[2] * t1[2])
        con.impulse[i, 2] = h * (f[0] * t2[0] + f[1] * t2[1] + f[2] * t2[2])
        for side in range(2):
            body = b if side == 0 else a
            if body < 0:
                continue
            s = 1.0 if side == 0 else -1.0
            r = r_b if side == 0 else r_a
            for kk in range(3):
                force[body, kk] += s * f[kk]
            torque[body, 0] += s * (r[1] * f[2] - r[2] * f[1])
            torque[body, 1] += s * (r[2] * f[0] - r[0] * f[2])
            torque[body, 2] += s * (r[0] * f[1] - r[1] * f[0])
