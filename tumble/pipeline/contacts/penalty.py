"""Penalty contacts: springs and dampers at the contact points, added to the forces.

Normal force ``f_n = k d - c v_n`` (d penetration, v_n approach speed positive apart),
never pulling. Friction, by default, is a stick spring of the same stiffness and damping
in the tangent plane (an elastoplastic, Dahl-like model): each contact's elastic force
``s`` is carried from step to step by the matched contact's impulse and grows by
``-k h v_t``; the force is ``s - c v_t``, and beyond ``mu f_n`` the contact slides at
exactly ``mu f_n`` with the spring holding that. So static friction holds (a box below
the friction angle stops within the spring's stretch) and sliding is Coulomb's. With a
``v_slip`` (the ``slip_velocity`` option), friction is instead the lecture's regularised
Coulomb ``f_t = -mu f_n v_t / max(|v_t|, v_slip)``: smooth and memoryless, but bodies
creep at up to ``v_slip`` times the ratio of pull to friction instead of sticking.

Stability rule used for the defaults (``default_penalty``): the lightest body m resting
on four contacts (a box face) feels ``K = 4k`` and ``C = 4c``. Semi-implicit Euler
needs ``w h < 2`` with ``w = sqrt(K/m)`` and ``C h / m_eff < 2`` for the stiffest, least
massive mode; we take ``w h = 0.5``, so ``k = m / (16 h^2)``, and ``c = m / (16 h)``: a
quarter of critical damping for the box bouncing on its face, because the rocking modes
see a corner's effective mass (a cube's is m / 4: ``1 / m + (r x n) . I^-1 (r x n)``)
and a box in a stack is damped from above and below, and critical damping for the bounce
(``c = m / (4 h)``, what tumble used before) is past the explicit limit for those: the
10-box stack at 1/240 s flew apart. A box resting on four contacts sinks
``m g / K = 4 g h^2``: 0.7 mm at 240 Hz; a sphere on one contact four times that; a stack
compresses like springs in series (the 10-box stack by 37 mm at 240 Hz). A pair of geoms
with their own stiffness or damping (``ModelBuilder.add_geom``, combined by
``pairs.pair_softness``) uses those instead; the same rule bounds what is stable:
``k <= m / (16 h^2)`` for a body of mass m on four such contacts.

That rule counts four contacts; a box of the 210-box pyramid rests on eight and carries
eight more, on two neighbours' edges, and explicit springs there are past their limit
(the pyramid flies apart at 1/240 s; a 21-box one jitters apart). So by default
(``penalty_integration='implicit'``) the springs of a body that no joint or body servo
holds are linearly implicit Euler: with D the damping of its contacts plus h times their
stiffness, ``sum G P G^T`` over its contacts (G = [I; [r]x] the lever of each, P = d_n n
n^T in the normal plus d_t in the tangent plane while the friction spring sticks), its
velocity change solves ``(M + h D) dv = h F`` (6x6, Cholesky), F every force on it with
the springs' force taken at the start of the step and ``-h k v_n`` added (the part of
``-h^2 K v`` the friction spring already carries). The neighbours' motion stays explicit
(block Jacobi), which is stable because each body's block holds the whole of every
coupling its contacts make. A resting body's forces are unchanged (v = 0, F = 0), so
loads and compressions are the explicit model's; what changes is that the stiff modes
are damped instead of amplified (about ``h^2 k / m`` more damping, the numerical
dissipation of implicit Euler). Bodies in joints stay explicit: their joint forces come
from the solve after this stage, and a per-body solve that leaves them out would shift a
standing character's equilibrium (its foot would carry the body's weight through M
instead of M + h D). ``penalty_integration='explicit'`` gives the lecture's explicit
springs everywhere.

Spin friction (torsional about the normal, rolling about the tangents; ``mu_t``, ``mu_r``
lengths in m) is the same regularised law on the relative angular velocity:
``tau = -mu f_n w / max(|w|, w_reg)``. The regularisation speed ``w_reg = 4 h mu f_n /
I_eff`` (``1 / I_eff``: the two bodies' inverse inertias about the axis) makes the
torque below saturation a damper that removes at most a quarter of the spin per step,
so up to four contacts of one body stay stable at any step; above ``w_reg`` the torque
is the full ``mu f_n``.
"""
import math

from numba import njit

from ..._jit import noalloc

from ...math.quat import quat_rotate_inv
from ...math.spatial import inertia_world
from ...model.types import DYNAMIC
from .pairs import pair_softness, pair_spin_friction
from .rows import lever, relative_velocity, tangents

# Floor of the spin regularisation speed (rad/s), for bodies that cannot turn.
_W_FLOOR = 1e-9


def default_penalty(lightest_mass, h):
    """(k, c) for the lightest colliding body at step ``h`` (see the module docstring)."""
    return lightest_mass / (16.0 * h * h), lightest_mass / (16.0 * h)


@njit(cache=True, inline="always")
def _inv_inertia_about(m, quat, b, e):
    """``e . I^-1 e`` of body ``b`` about the world unit direction ``e`` (0 for the world
    and bodies that are not dynamic)."""
    if b < 0:
        return 0.0
    eb = quat_rotate_inv(quat[b], e)
    inv = m.body_inv_inertia[b]
    return eb[0] * eb[0] * inv[0] + eb[1] * eb[1] * inv[1] + eb[2] * eb[2] * inv[2]


@noalloc
def _spin_torque(m, quat, a, b, e, w, mu, fn, h):
    """Regularised spin-friction torque (N m, on b, along the unit direction ``e``) of a
    relative spin rate ``w`` (rad/s) about ``e``."""
    inv = _inv_inertia_about(m, quat, a, e) + _inv_inertia_about(m, quat, b, e)
    w_reg = max(4.0 * h * mu * fn * inv, _W_FLOOR)
    return -mu * fn * w / max(abs(w), w_reg)


@noalloc
def penalty_forces(m, pos, quat, vel, angvel, con, count, k, c, v_slip, h, spin_model, force,
                   torque, lhs, free):
    """Add the contact forces (N) and their torques about each COM to ``force``/``torque``;
    each contact's ``impulse`` becomes its force times ``h`` (normal, tangent 1, tangent 2)
    and its spin-friction torque times ``h`` (about the normal, tangent 1, tangent 2).

    k, c : the world's stiffness (N/m) and damping (N s/m), for pairs without their own.
    spin_model : whether any geom has spin friction (``pairs.rows_per_contact``); if not,
    the spin impulses stay the zeros the collision stage wrote.
    lhs : (nbody, 6, 6) scratch, or 0 rows for explicit springs everywhere.
    free : (nbody,) bool the bodies whose springs may be implicit (no joint, no servo).
    With implicit springs, ``force``/``torque`` of a free body in contact end as ``M dv /
    h`` of its implicit velocity change, and its contacts' impulses are their forces at
    the end of the step (``_end_of_step_impulses``).
    """
    implicit = lhs.shape[0] > 0
    if implicit:
        for b in range(lhs.shape[0]):
            if free[b]:
                for r in range(6):
                    for q in range(r + 1):
                        lhs[b, r, q] = 0.0
    for i in range(count):
        d = con.depth[i]
        if d <= 0.0:
            for q in range(con.impulse.shape[1]):
                con.impulse[i, q] = 0.0
            continue
        a, b = con.body[i, 0], con.body[i, 1]
        kp, cp, n, r_a, r_b, rel = _contact_state(m, pos, vel, angvel, con, i, k, c)
        vn = rel[0] * n[0] + rel[1] * n[1] + rel[2] * n[2]
        # implicit: both sides free or unmoving; the spring then also sees this step's
        # closing h vn (linearly implicit Euler's -h K v), the rest in the bodies' solve
        imp = implicit and _free_side(m, free, a) and _free_side(m, free, b)
        fn = max(kp * d - (cp + h * kp if imp else cp) * vn, 0.0)
        t1, t2 = tangents(n)
        v1 = rel[0] * t1[0] + rel[1] * t1[1] + rel[2] * t1[2]
        v2 = rel[0] * t2[0] + rel[1] * t2[1] + rel[2] * t2[2]
        cap = con.friction[i] * fn
        d_t = 0.0                      # the friction's damping d f_t / d v_t, N s/m
        if v_slip > 0.0:
            # regularised Coulomb: a damper up to v_slip, mu f_n beyond
            speed = math.sqrt(v1 * v1 + v2 * v2)
            f1, f2 = -cap * v1 / max(speed, v_slip), -cap * v2 / max(speed, v_slip)
            s1, s2 = f1, f2
            if speed < v_slip:
                d_t = cap / v_slip
        else:
            # stick spring: last step's elastic force (carried by the matched contact's
            # impulse; 0 for a new contact) stretched by this step's slip, plus damping;
            # beyond mu f_n it slides and the spring holds only what is transmitted
            s1, s2, f1, f2, sliding = _stick_spring(con.impulse[i, 1] / h,
                                                    con.impulse[i, 2] / h, v1, v2, v1, v2,
                                                    kp, cp, h, cap)
            d_t = 0.0 if sliding else cp + h * kp
        if imp and fn > 0.0:
            d_n = cp + h * kp
            _add_damping(lhs, free, a, r_a, n, h * d_n, h * d_t)
            _add_damping(lhs, free, b, r_b, n, h * d_n, h * d_t)
        f = (fn * n[0] + f1 * t1[0] + f2 * t2[0], fn * n[1] + f1 * t1[1] + f2 * t2[1],
             fn * n[2] + f1 * t1[2] + f2 * t2[2])
        con.impulse[i, 0] = fn * h
        con.impulse[i, 1] = h * s1
        con.impulse[i, 2] = h * s2
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
        if not spin_model:
            continue
        # spin friction: torque on b about the contact, -torque on a
        spin = (0.0, 0.0, 0.0)
        mu_t, mu_r = pair_spin_friction(m, con.geom[i, 0], con.geom[i, 1])
        if (mu_t > 0.0 or mu_r > 0.0) and fn > 0.0:
            wb = (angvel[b, 0], angvel[b, 1], angvel[b, 2]) if b >= 0 else (0.0, 0.0, 0.0)
            wa = (angvel[a, 0], angvel[a, 1], angvel[a, 2]) if a >= 0 else (0.0, 0.0, 0.0)
            wr = (wb[0] - wa[0], wb[1] - wa[1], wb[2] - wa[2])
            wn = wr[0] * n[0] + wr[1] * n[1] + wr[2] * n[2]
            tn = _spin_torque(m, quat, a, b, n, wn, mu_t, fn, h) if mu_t > 0.0 else 0.0
            wt = (wr[0] - wn * n[0], wr[1] - wn * n[1], wr[2] - wn * n[2])
            roll = math.sqrt(wt[0] * wt[0] + wt[1] * wt[1] + wt[2] * wt[2])
            tr = 0.0
            if mu_r > 0.0 and roll > 0.0:
                e = (wt[0] / roll, wt[1] / roll, wt[2] / roll)
                tr = _spin_torque(m, quat, a, b, e, roll, mu_r, fn, h) / roll
            spin = (tn * n[0] + tr * wt[0], tn * n[1] + tr * wt[1], tn * n[2] + tr * wt[2])
        con.impulse[i, 3] = h * (spin[0] * n[0] + spin[1] * n[1] + spin[2] * n[2])
        con.impulse[i, 4] = h * (spin[0] * t1[0] + spin[1] * t1[1] + spin[2] * t1[2])
        con.impulse[i, 5] = h * (spin[0] * t2[0] + spin[1] * t2[1] + spin[2] * t2[2])
        for kk in range(3):
            if b >= 0:
                torque[b, kk] += spin[kk]
            if a >= 0:
                torque[a, kk] -= spin[kk]
    if implicit:
        _solve_implicit(m, quat, lhs, free, force, torque)
        _end_of_step_impulses(m, pos, vel, angvel, con, count, k, c, v_slip, h, force,
                              torque, free)
        _implicit_forces(m, quat, lhs, free, force, torque)


@njit(cache=True, inline="always")
def _contact_state(m, pos, vel, angvel, con, i, k, c):
    """Contact ``i``'s spring and damper (its pair's own, else the world's ``k``, ``c``),
    normal, levers from each body's COM, and the relative velocity of b's point to a's
    (start of the step)."""
    a, b = con.body[i, 0], con.body[i, 1]
    kp, cp = pair_softness(m, con.geom[i, 0], con.geom[i, 1])
    if kp <= 0.0:
        kp = k
    if cp < 0.0:
        cp = c
    p = con.point[i]
    n = (con.normal[i, 0], con.normal[i, 1], con.normal[i, 2])
    r_a, r_b = lever(pos, a, p), lever(pos, b, p)
    return kp, cp, n, r_a, r_b, relative_velocity(vel, angvel, a, b, r_a, r_b)


@njit(cache=True, inline="always")
def _stick_spring(s1, s2, slip1, slip2, u1, u2, kp, cp, h, cap):
    """The friction spring: its elastic force ``s`` (N, along the two tangents) stretched
    by ``-kp h slip``, its force ``s - cp u`` (u the tangential velocity); beyond ``cap``
    it slides, force and spring at ``cap`` along the force. Returns (s1, s2, f1, f2,
    sliding)."""
    s1 = s1 - kp * h * slip1
    s2 = s2 - kp * h * slip2
    f1, f2 = s1 - cp * u1, s2 - cp * u2
    mag = math.sqrt(f1 * f1 + f2 * f2)
    if mag > cap:
        f1, f2 = f1 * cap / mag, f2 * cap / mag
        return f1, f2, f1, f2, True
    return s1, s2, f1, f2, False


@njit(cache=True, inline="always")
def _free_side(m, free, b):
    """Whether contact side ``b`` lets its springs be implicit: the world, a body that
    does not move under forces, or a free one."""
    return b < 0 or m.body_kind[b] != DYNAMIC or free[b]


@noalloc
def _add_damping(lhs, free, b, r, n, d_n, d_t):
    """Add ``G P G^T`` to the lower triangle of body ``b``'s 6x6 block (if free): G = [I;
    [r]x] maps a point force at lever ``r`` to the wrench about the COM, P = d_t I +
    (d_n - d_t) n n^T the contact's damping (with h K folded in) in the normal and tangent
    directions. Blocks: P, [r]x P below it, and [r]x P [r]x^T."""
    if b < 0 or not free[b]:
        return
    e = d_n - d_t
    # P (symmetric)
    p00, p11, p22 = d_t + e * n[0] * n[0], d_t + e * n[1] * n[1], d_t + e * n[2] * n[2]
    p01, p02, p12 = e * n[0] * n[1], e * n[0] * n[2], e * n[1] * n[2]
    # C = [r]x P: C[i][j] = (r x column j of P)[i]
    c00 = r[1] * p02 - r[2] * p01
    c01 = r[1] * p12 - r[2] * p11
    c02 = r[1] * p22 - r[2] * p12
    c10 = r[2] * p00 - r[0] * p02
    c11 = r[2] * p01 - r[0] * p12
    c12 = r[2] * p02 - r[0] * p22
    c20 = r[0] * p01 - r[1] * p00
    c21 = r[0] * p11 - r[1] * p01
    c22 = r[0] * p12 - r[1] * p02
    L = lhs[b]
    L[0, 0] += p00
    L[1, 0] += p01
    L[1, 1] += p11
    L[2, 0] += p02
    L[2, 1] += p12
    L[2, 2] += p22
    L[3, 0] += c00
    L[3, 1] += c01
    L[3, 2] += c02
    L[4, 0] += c10
    L[4, 1] += c11
    L[4, 2] += c12
    L[5, 0] += c20
    L[5, 1] += c21
    L[5, 2] += c22
    # C [r]x^T: entry (i, j) = (r x row i of C), component j
    L[3, 3] += r[1] * c02 - r[2] * c01
    L[4, 3] += r[1] * c12 - r[2] * c11
    L[4, 4] += r[2] * c10 - r[0] * c12
    L[5, 3] += r[1] * c22 - r[2] * c21
    L[5, 4] += r[2] * c20 - r[0] * c22
    L[5, 5] += r[0] * c21 - r[1] * c20


@noalloc
def _solve_implicit(m, quat, lhs, free, force, torque):
    """Each free body with springs: ``x = (M + h D)^-1 (force, torque)`` in place of its
    force and torque (``x h`` its velocity change), the factor left in ``lhs``. On entry
    ``lhs[b]``'s lower triangle holds ``h D``."""
    for b in range(lhs.shape[0]):
        if not free[b] or lhs[b, 0, 0] + lhs[b, 1, 1] + lhs[b, 2, 2] <= 0.0:
            continue
        a = lhs[b]
        mass = 1.0 / m.body_inv_mass[b]
        iw = inertia_world(quat[b], m.body_inertia[b])
        for r in range(3):
            a[r, r] += mass
            for q in range(r + 1):
                a[3 + r, 3 + q] += iw[r][q]
        # Cholesky in place (lower), then the two triangular solves on the wrench
        for j in range(6):
            t = a[j, j]
            for q in range(j):
                t -= a[j, q] * a[j, q]
            a[j, j] = math.sqrt(t)
            for r in range(j + 1, 6):
                t = a[r, j]
                for q in range(j):
                    t -= a[r, q] * a[j, q]
                a[r, j] = t / a[j, j]
        for r in range(6):
            t = _get6(force, torque, b, r)
            for q in range(r):
                t -= a[r, q] * _get6(force, torque, b, q)
            _set6(force, torque, b, r, t / a[r, r])
        for r in range(5, -1, -1):
            t = _get6(force, torque, b, r)
            for q in range(r + 1, 6):
                t -= a[q, r] * _get6(force, torque, b, q)
            _set6(force, torque, b, r, t / a[r, r])


@noalloc
def _implicit_forces(m, quat, lhs, free, force, torque):
    """The solved bodies' ``x`` back to the force and torque the integrator takes, ``M x``
    (so that it changes their velocities by ``h x``)."""
    for b in range(lhs.shape[0]):
        if not free[b] or lhs[b, 0, 0] == 0.0:
            continue
        mass = 1.0 / m.body_inv_mass[b]
        iw = inertia_world(quat[b], m.body_inertia[b])
        for kk in range(3):
            force[b, kk] *= mass
        w0, w1, w2 = torque[b, 0], torque[b, 1], torque[b, 2]
        for kk in range(3):
            torque[b, kk] = iw[kk][0] * w0 + iw[kk][1] * w1 + iw[kk][2] * w2


@njit(cache=True, inline="always")
def _get6(force, torque, b, r):
    return force[b, r] if r < 3 else torque[b, r - 3]


@njit(cache=True, inline="always")
def _set6(force, torque, b, r, value):
    if r < 3:
        force[b, r] = value
    else:
        torque[b, r - 3] = value


@noalloc
def _end_of_step_impulses(m, pos, vel, angvel, con, count, k, c, v_slip, h, x_lin, x_ang,
                          free):
    """The impulses of the implicit contacts at the end of the step: each contact's force
    less its damping of the step's change of the relative velocity ``du`` (from the free
    bodies' solved ``x``: ``h (x_lin + x_ang x r)``; linearly implicit Euler's ``F - D
    du``), and the friction spring stretched by the end velocity (``s - k h du_t``), both
    within the cone."""
    for i in range(count):
        a, b = con.body[i, 0], con.body[i, 1]
        fn = con.impulse[i, 0] / h
        if fn <= 0.0 or not (_free_side(m, free, a) and _free_side(m, free, b)):
            continue
        kp, cp, n, r_a, r_b, rel = _contact_state(m, pos, vel, angvel, con, i, k, c)
        du_b = _velocity_change(free, b, r_b, h, x_lin, x_ang)
        du_a = _velocity_change(free, a, r_a, h, x_lin, x_ang)
        du = (du_b[0] - du_a[0], du_b[1] - du_a[1], du_b[2] - du_a[2])
        fn = max(fn - (cp + h * kp) * (du[0] * n[0] + du[1] * n[1] + du[2] * n[2]), 0.0)
        t1, t2 = tangents(n)
        d1 = du[0] * t1[0] + du[1] * t1[1] + du[2] * t1[2]
        d2 = du[0] * t2[0] + du[1] * t2[1] + du[2] * t2[2]
        u1 = rel[0] * t1[0] + rel[1] * t1[1] + rel[2] * t1[2] + d1
        u2 = rel[0] * t2[0] + rel[1] * t2[1] + rel[2] * t2[2] + d2
        cap = con.friction[i] * fn
        if v_slip > 0.0:
            speed = math.sqrt(u1 * u1 + u2 * u2)
            s1, s2 = -cap * u1 / max(speed, v_slip), -cap * u2 / max(speed, v_slip)
        else:
            s1, s2, _, _, _ = _stick_spring(con.impulse[i, 1] / h, con.impulse[i, 2] / h,
                                            d1, d2, u1, u2, kp, cp, h, cap)
        con.impulse[i, 0] = h * fn
        con.impulse[i, 1] = h * s1
        con.impulse[i, 2] = h * s2


@njit(cache=True, inline="always")
def _velocity_change(free, b, r, h, x_lin, x_ang):
    """This step's velocity change (3,) of body ``b``'s point at lever ``r``, ``h (x_lin +
    x_ang x r)`` from its implicit solve; zero for bodies that are not free."""
    if b < 0 or not free[b]:
        return (0.0, 0.0, 0.0)
    w0, w1, w2 = x_ang[b, 0], x_ang[b, 1], x_ang[b, 2]
    return (h * (x_lin[b, 0] + w1 * r[2] - w2 * r[1]),
            h * (x_lin[b, 1] + w2 * r[0] - w0 * r[2]),
            h * (x_lin[b, 2] + w0 * r[1] - w1 * r[0]))
