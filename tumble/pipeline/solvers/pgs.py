"""Projected Gauss-Seidel: one row at a time, clamping each impulse to its bounds.

Cheap per iteration and robust; convergence slows on long chains and large mass
ratios, which is what the direct solver is for. Warm-started from the last step's
impulses.
"""
import numpy as np
from numba import njit

from ..._jit import noalloc
from .common import Bodies, apply_impulse, minv_jt, row_active


@njit(cache=True)
def solve_pgs(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, iterations, tolerance,
              velocity_tolerance, warm_start):
    """Solve the rows in place; returns the number of sweeps taken.

    impulse (nrow,) holds last step's impulses on entry (used if ``warm_start``) and this
    step's on exit. Sweeps stop when no impulse changes by more than ``tolerance`` (N s),
    or no row's velocity by more than ``velocity_tolerance`` (m/s or rad/s: the change
    of the row's impulse times its ``J M^-1 J^T + cfm``).
    """
    dv = np.zeros((nrow, 12))
    inv_diag = np.zeros(nrow)
    return _pgs(rows, nrow, Bodies(inv_mass, inv_inertia, vel, angvel), impulse, iterations,
                tolerance, velocity_tolerance, warm_start, dv, inv_diag)


@noalloc
def _pgs(rows, nrow, bodies, impulse, iterations, tolerance, velocity_tolerance, warm_start,
         dv, inv_diag):
    """``solve_pgs`` with its work arrays: dv (nrow, 12) and inv_diag (nrow,), which
    receive each row's ``M^-1 J^T`` and ``1 / (J M^-1 J^T + cfm)`` (0 for a row that moves
    nothing)."""
    inv_mass, inv_inertia = bodies.inv_mass, bodies.inv_inertia
    vel, angvel = bodies.vel, bodies.angvel
    for r in range(nrow):
        if not row_active(rows, r):
            impulse[r] = 0.0
            continue
        minv_jt(rows, r, inv_mass, inv_inertia, dv[r])
        a = rows.cfm[r]
        for k in range(12):
            a += rows.J[r, k] * dv[r, k]
        inv_diag[r] = 1.0 / a if a > 0.0 else 0.0
        if rows.parent[r] >= 0:
            continue                                   # friction: warm-started below
        if warm_start:
            p = min(max(impulse[r], rows.lo[r]), rows.hi[r])
            impulse[r] = p
            apply_impulse(rows, r, dv[r], p, vel, angvel)
        else:
            impulse[r] = 0.0
    # friction rows after their normals, whose impulses set their bounds
    for r in range(nrow):
        if rows.parent[r] < 0 or inv_diag[r] <= 0.0:
            continue
        b = _friction_bounds(rows, impulse, r)
        p = min(max(impulse[r], -b), b) if warm_start else 0.0
        impulse[r] = p
        apply_impulse(rows, r, dv[r], p, vel, angvel)
    sweeps = 0
    for it in range(iterations):
        sweeps = it + 1
        biggest, unsettled = _sweep(rows, nrow, impulse, dv, inv_diag, vel, angvel,
                                    velocity_tolerance)
        if biggest <= tolerance or not unsettled:
            break
    return sweeps


@njit(cache=True, inline="always")
def _friction_bounds(rows, impulse, r):
    """Friction row ``r``'s bounds ``-+ mu p_n`` from its normal's impulse, written into
    ``rows.lo``, ``rows.hi``; returns ``mu p_n``."""
    bound = rows.mu[r] * max(impulse[rows.parent[r]], 0.0)
    rows.lo[r], rows.hi[r] = -bound, bound
    return bound


@noalloc
def _sweep(rows, nrow, impulse, dv, inv_diag, vel, angvel, velocity_tolerance):
    """One Gauss-Seidel sweep over the rows; returns the largest impulse change, and
    whether some row's velocity changed by more than ``velocity_tolerance`` (its impulse
    change over ``inv_diag``).

    Consecutive rows on the same two bodies (a contact's normal and friction rows, a
    joint's rows, a body servo's) are swept with the bodies' velocities held in locals and
    stored once: a contact's three rows load and store them once. (No row joins a body to
    itself: the builder refuses such joints and collision filters such pairs.)"""
    biggest = 0.0
    unsettled = False
    r = 0
    while r < nrow:
        a, b = rows.body_a[r], rows.body_b[r]
        end = r + 1
        while end < nrow and rows.body_a[end] == a and rows.body_b[end] == b:
            end += 1
        va = wa = vb = wb = (0.0, 0.0, 0.0)
        if a >= 0:
            va = (vel[a, 0], vel[a, 1], vel[a, 2])
            wa = (angvel[a, 0], angvel[a, 1], angvel[a, 2])
        if b >= 0:
            vb = (vel[b, 0], vel[b, 1], vel[b, 2])
            wb = (angvel[b, 0], angvel[b, 1], angvel[b, 2])
        for q in range(r, end):
            if inv_diag[q] <= 0.0:
                continue
            if rows.parent[q] >= 0:
                _friction_bounds(rows, impulse, q)
            j = rows.J[q]
            # summed as a tree: the sweep is bound by this chain's latency, row after row
            sa = sb = 0.0
            if a >= 0:
                sa = ((j[0] * va[0] + j[1] * va[1]) + j[2] * va[2]) + \
                    ((j[3] * wa[0] + j[4] * wa[1]) + j[5] * wa[2])
            if b >= 0:
                sb = ((j[6] * vb[0] + j[7] * vb[1]) + j[8] * vb[2]) + \
                    ((j[9] * wb[0] + j[10] * wb[1]) + j[11] * wb[2])
            residual = rows.rhs[q] - (sa + sb) - rows.cfm[q] * impulse[q]
            p = min(max(impulse[q] + residual * inv_diag[q], rows.lo[q]), rows.hi[q])
            delta = p - impulse[q]
            if delta != 0.0:
                impulse[q] = p
                d = dv[q]
                if a >= 0:
                    va = (va[0] + d[0] * delta, va[1] + d[1] * delta, va[2] + d[2] * delta)
                    wa = (wa[0] + d[3] * delta, wa[1] + d[4] * delta, wa[2] + d[5] * delta)
                if b >= 0:
                    vb = (vb[0] + d[6] * delta, vb[1] + d[7] * delta, vb[2] + d[8] * delta)
                    wb = (wb[0] + d[9] * delta, wb[1] + d[10] * delta, wb[2] + d[11] * delta)
                biggest = max(biggest, abs(delta))
                unsettled = unsettled or abs(delta) > velocity_tolerance * inv_diag[q]
        if a >= 0:
            for k in range(3):
                vel[a, k] = va[k]
                angvel[a, k] = wa[k]
        if b >= 0:
            for k in range(3):
                vel[b, k] = vb[k]
                angvel[b, k] = wb[k]
        r = end
    return biggest, unsettled
