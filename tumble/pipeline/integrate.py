"""Stages of a step that advance the state: velocities, then positions (semi-implicit Euler).

Velocities are updated first, from the forces of ``forces.py``; positions then move
with the *new* velocities. Orientation uses either the lecture's first-order update
``q + h/2 (w, 0) q`` (normalised) or the exact exponential map for a constant ``w``.

The gyroscopic term ``w x I w`` can be treated three ways (``GYRO_*``):

* explicit: ``I dw = h (tau - w x I w)`` with the old ``w``; adds energy every step,
  so a fast-spinning asymmetric body speeds up and eventually diverges.
* implicit (default): the implicit midpoint rule on Euler's equations in the body
  frame, ``I (w1 - w0) + h wm x I wm = h tau`` with ``wm = (w0 + w1)/2``, solved by
  Newton's method. Torque-free, it keeps the kinetic energy and ``|L|`` exactly, so
  a spinning body neither speeds up nor slows down at any step size; the world
  direction of ``L`` then wanders by O(h |w|) (bounded, no drift) because the
  orientation moves with the end-of-step velocity. Default because it is correct
  for free bodies and never adds energy that constraint solvers must fight.
* variational: the Lie-group variational integrator of Lee, Leok and McClamroch (2005)
  for the free rotation: the velocity a step rotated with fixes the discrete momentum it
  left, and the next rotation is the one that carries that momentum (plus the torque's
  impulse) on. Torque-free, the spatial angular momentum is kept to round-off in any
  direction (the implicit rule keeps only its size) and the energy error stays bounded
  (the scheme is symplectic). It needs the exponential orientation update; a few Newton
  steps more than the implicit rule per body.
* none: drop the term (what some game engines do); wrong for any asymmetric body.
"""
import math

from numba import njit

from .._jit import noalloc
from ..math.quat import quat_integrate_exp, quat_integrate_linear, quat_rotate, quat_rotate_inv
from ..model.types import DYNAMIC, STATIC

GYRO_NONE, GYRO_EXPLICIT, GYRO_IMPLICIT, GYRO_VARIATIONAL = 0, 1, 2, 3
QUAT_EXP, QUAT_LINEAR = 0, 1

_NEWTON_ITERS = 8
_NEWTON_TOL = 1e-13


@njit(cache=True, inline="always")
def _solve3(a, r):
    """Solve the 3x3 system ``a x = r`` (a as a nested tuple) by Cramer's rule."""
    c00 = a[1][1] * a[2][2] - a[1][2] * a[2][1]
    c01 = a[1][2] * a[2][0] - a[1][0] * a[2][2]
    c02 = a[1][0] * a[2][1] - a[1][1] * a[2][0]
    det = a[0][0] * c00 + a[0][1] * c01 + a[0][2] * c02
    inv = 1.0 / det
    c10 = a[0][2] * a[2][1] - a[0][1] * a[2][2]
    c11 = a[0][0] * a[2][2] - a[0][2] * a[2][0]
    c12 = a[0][1] * a[2][0] - a[0][0] * a[2][1]
    c20 = a[0][1] * a[1][2] - a[0][2] * a[1][1]
    c21 = a[0][2] * a[1][0] - a[0][0] * a[1][2]
    c22 = a[0][0] * a[1][1] - a[0][1] * a[1][0]
    return ((c00 * r[0] + c10 * r[1] + c20 * r[2]) * inv,
            (c01 * r[0] + c11 * r[1] + c21 * r[2]) * inv,
            (c02 * r[0] + c12 * r[1] + c22 * r[2]) * inv)


@noalloc
def implicit_gyroscopic(inertia, w0, tau, h):
    """Body-frame angular velocity after one implicit-midpoint step of Euler's equations.

    Solves ``I (w - w0) + h wm x (I wm) - h tau = 0`` with ``wm = (w0 + w) / 2`` (all
    body frame; ``inertia`` the principal moments (3,)) by Newton's method from the
    explicit guess. Without torque it keeps ``|I w|`` and ``w . I w`` exactly: the
    midpoint rule preserves quadratic invariants.
    """
    i0, i1, i2 = inertia[0], inertia[1], inertia[2]
    w = (w0[0] + h * tau[0] / i0, w0[1] + h * tau[1] / i1, w0[2] + h * tau[2] / i2)
    k = 0.5 * h
    for _ in range(_NEWTON_ITERS):
        m = (0.5 * (w0[0] + w[0]), 0.5 * (w0[1] + w[1]), 0.5 * (w0[2] + w[2]))
        lm = (i0 * m[0], i1 * m[1], i2 * m[2])
        f = (i0 * (w[0] - w0[0]) + h * (m[1] * lm[2] - m[2] * lm[1]) - h * tau[0],
             i1 * (w[1] - w0[1]) + h * (m[2] * lm[0] - m[0] * lm[2]) - h * tau[1],
             i2 * (w[2] - w0[2]) + h * (m[0] * lm[1] - m[1] * lm[0]) - h * tau[2])
        # d/dw [m x I m] = ([m]x I - [I m]x) / 2
        jac = ((i0, k * (-m[2] * i1 + lm[2]), k * (m[1] * i2 - lm[1])),
               (k * (m[2] * i0 - lm[2]), i1, k * (-m[0] * i2 + lm[0])),
               (k * (-m[1] * i0 + lm[1]), k * (m[0] * i1 - lm[0]), i2))
        d = _solve3(jac, f)
        w = (w[0] - d[0], w[1] - d[1], w[2] - d[2])
        if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= _NEWTON_TOL * _NEWTON_TOL * (
                w[0] * w[0] + w[1] * w[1] + w[2] * w[2] + 1e-300):
            break
    return w


@njit(cache=True, inline="always")
def _cayley_of_increment(w_b, h):
    """Cayley vector ``f`` of the rotation ``exp(h w_b)``: ``tan(h |w_b| / 2)`` along ``w_b``."""
    n = math.sqrt(w_b[0] * w_b[0] + w_b[1] * w_b[1] + w_b[2] * w_b[2])
    if n * h < 1e-8:
        s = 0.5 * h
    else:
        s = math.tan(0.5 * h * n) / n
    return (s * w_b[0], s * w_b[1], s * w_b[2])


@noalloc
def variational_momentum(inertia, w_b, h):
    """Discrete body momentum (3,) at the end of a step that rotated by ``exp(h w_b)``.

    The Lie-group variational integrator (Lee, Leok and McClamroch 2005) ties a step's
    rotation ``F = cay(f)`` to the momentum at its start by
    ``h P + h P x f + f (f . h P) = 2 I f``; at its end the momentum is ``F^T P``.
    ``inertia``: principal moments (3,); ``w_b``: body frame, rad/s; kg m^2/s.
    """
    f = _cayley_of_increment(w_b, h)
    i0, i1, i2 = inertia[0], inertia[1], inertia[2]
    # (1 - [f]x + f f^T) hP = 2 I f
    a = ((1.0 + f[0] * f[0], f[2] + f[0] * f[1], -f[1] + f[0] * f[2]),
         (-f[2] + f[1] * f[0], 1.0 + f[1] * f[1], f[0] + f[1] * f[2]),
         (f[1] + f[2] * f[0], -f[0] + f[2] * f[1], 1.0 + f[2] * f[2]))
    hp = _solve3(a, (2.0 * i0 * f[0], 2.0 * i1 * f[1], 2.0 * i2 * f[2]))
    # F^T = cay(-f) applied to hP: x - 2/(1+|f|^2) (f x x - f x (f x x))
    c = 2.0 / (1.0 + f[0] * f[0] + f[1] * f[1] + f[2] * f[2])
    fx = (f[1] * hp[2] - f[2] * hp[1], f[2] * hp[0] - f[0] * hp[2], f[0] * hp[1] - f[1] * hp[0])
    ffx = (f[1] * fx[2] - f[2] * fx[1], f[2] * fx[0] - f[0] * fx[2], f[0] * fx[1] - f[1] * fx[0])
    return ((hp[0] + c * (-fx[0] + ffx[0])) / h, (hp[1] + c * (-fx[1] + ffx[1])) / h,
            (hp[2] + c * (-fx[2] + ffx[2])) / h)


@noalloc
def variational_gyroscopic(inertia, w0, tau, h):
    """Body-frame angular velocity of the next step by the Lie-group variational integrator.

    ``w0`` (body frame) is the velocity the last step rotated with (``exp(h w0)``); the
    momentum it leaves, plus ``h tau``, fixes the next rotation ``F = cay(f)`` through
    ``h P + h P x f + f (f . h P) = 2 I f``, solved by Newton's method (quadratic; the
    implicit-midpoint answer starts it). Returns ``w`` with ``exp(h w) = F``. Torque-free,
    the spatial angular momentum ``R P`` is kept to round-off and the energy error stays
    bounded (the scheme is symplectic). Orientations must move by the exponential map.
    """
    p = variational_momentum(inertia, w0, h)
    hp = (h * (p[0] + h * tau[0]), h * (p[1] + h * tau[1]), h * (p[2] + h * tau[2]))
    i0, i1, i2 = inertia[0], inertia[1], inertia[2]
    f = (0.5 * hp[0] / i0, 0.5 * hp[1] / i1, 0.5 * hp[2] / i2)
    for _ in range(2 * _NEWTON_ITERS):
        fp = f[0] * hp[0] + f[1] * hp[1] + f[2] * hp[2]
        g = (hp[0] + (hp[1] * f[2] - hp[2] * f[1]) + f[0] * fp - 2.0 * i0 * f[0],
             hp[1] + (hp[2] * f[0] - hp[0] * f[2]) + f[1] * fp - 2.0 * i1 * f[1],
             hp[2] + (hp[0] * f[1] - hp[1] * f[0]) + f[2] * fp - 2.0 * i2 * f[2])
        # dG/df = [hP]x + (f . hP) 1 + f hP^T - 2 I
        jac = ((fp + f[0] * hp[0] - 2.0 * i0, -hp[2] + f[0] * hp[1], hp[1] + f[0] * hp[2]),
               (hp[2] + f[1] * hp[0], fp + f[1] * hp[1] - 2.0 * i1, -hp[0] + f[1] * hp[2]),
               (-hp[1] + f[2] * hp[0], hp[0] + f[2] * hp[1], fp + f[2] * hp[2] - 2.0 * i2))
        d = _solve3(jac, g)
        f = (f[0] - d[0], f[1] - d[1], f[2] - d[2])
        if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= _NEWTON_TOL * _NEWTON_TOL * (
                f[0] * f[0] + f[1] * f[1] + f[2] * f[2] + 1e-300):
            break
    n = math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2])
    s = 2.0 / h if n < 1e-8 else 2.0 * math.atan(n) / (n * h)
    return (s * f[0], s * f[1], s * f[2])


@noalloc
def integrate_velocities(m, quat, vel, angvel, force, torque, h, gyro_mode):
    """``v += h f / m``; ``w`` from Euler's equations with the chosen gyroscopic form.

    m : ModelArrays.  quat (nbody, 4); vel, angvel, force, torque (nbody, 3), world
    frame, COM. Only dynamic bodies change; kinematic ones keep the velocity set for them.
    """
    for b in range(vel.shape[0]):
        if m.body_kind[b] != DYNAMIC:
            continue
        inv_m = m.body_inv_mass[b]
        for k in range(3):
            vel[b, k] += h * inv_m * force[b, k]
        q = quat[b]
        inertia = m.body_inertia[b]
        w_b = quat_rotate_inv(q, angvel[b])
        tau_b = quat_rotate_inv(q, torque[b])
        if gyro_mode == GYRO_IMPLICIT:
            w_b = implicit_gyroscopic(inertia, w_b, tau_b, h)
        elif gyro_mode == GYRO_VARIATIONAL:
            w_b = variational_gyroscopic(inertia, w_b, tau_b, h)
        else:
            if gyro_mode == GYRO_EXPLICIT:
                l_b = (inertia[0] * w_b[0], inertia[1] * w_b[1], inertia[2] * w_b[2])
                tau_b = (tau_b[0] - (w_b[1] * l_b[2] - w_b[2] * l_b[1]),
                         tau_b[1] - (w_b[2] * l_b[0] - w_b[0] * l_b[2]),
                         tau_b[2] - (w_b[0] * l_b[1] - w_b[1] * l_b[0]))
            inv_i = m.body_inv_inertia[b]
            w_b = (w_b[0] + h * inv_i[0] * tau_b[0], w_b[1] + h * inv_i[1] * tau_b[1],
                   w_b[2] + h * inv_i[2] * tau_b[2])
        w = quat_rotate(q, w_b)
        angvel[b, 0], angvel[b, 1], angvel[b, 2] = w[0], w[1], w[2]


@noalloc
def integrate_positions(m, pos, quat, vel, angvel, h, quat_mode):
    """``x += h v`` and the orientation update with the new velocities; static bodies stay."""
    for b in range(pos.shape[0]):
        if m.body_kind[b] == STATIC:
            continue
        for k in range(3):
            pos[b, k] += h * vel[b, k]
        if quat_mode == QUAT_LINEAR:
            q = quat_integrate_linear(quat[b], angvel[b], h)
        else:
            q = quat_integrate_exp(quat[b], angvel[b], h)
        quat[b, 0], quat[b, 1], quat[b, 2], quat[b, 3] = q[0], q[1], q[2], q[3]


@noalloc
def first_bad_body(pos, quat, vel, angvel, limit):
    """Index of the first body whose state is non-finite or beyond ``limit``, else -1.

    ``limit`` bounds |position| (m) and |velocity| (m/s, rad/s) componentwise: past it
    a simulation has run away even if the numbers are still finite.
    """
    for b in range(pos.shape[0]):
        for k in range(3):
            if not (abs(pos[b, k]) <= limit and abs(vel[b, k]) <= limit
                    and abs(angvel[b, k]) <= limit):
                return b
        for k in range(4):
            if not math.isfinite(quat[b, k]):
                return b
    return -1


@njit(cache=True)
def variational_spin_momenta(inertia, quat, angvel, h, out):
    """Spin angular momenta (nworld, nbody, 3), world, kg m^2/s, into ``out``: the discrete
    momenta that the variational gyroscopic mode keeps (``variational_momentum`` of each
    body's last rotation). inertia (nbody, 3) principal moments; quat (nworld, nbody, 4);
    angvel (nworld, nbody, 3) world rad/s; h the step (s)."""
    for w in range(quat.shape[0]):
        for b in range(quat.shape[1]):
            q = quat[w, b]
            p = variational_momentum(inertia[b], quat_rotate_inv(q, angvel[w, b]), h)
            s = quat_rotate(q, p)
            out[w, b, 0], out[w, b, 1], out[w, b, 2] = s[0], s[1], s[2]
