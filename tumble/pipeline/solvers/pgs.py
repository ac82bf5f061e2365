"""Projected Gauss-Seidel: one row at a time, clamping each impulse to its bounds.

Cheap per iteration and robust; convergence slows on long chains and large mass
ratios, which is what the direct solver is for. Warm-started from the last step's
impulses.
"""
import numpy as np
from numba import njit

from ..._jit import noalloc
from .common import Bodies, apply_impulse, minv_jt, row_active, row_velocity


@njit(cache=True)
def solve_pgs(rows, nrow, inv_mass, inv_inertia, vel, angvel, impulse, iterations, tolerance,
              warm_start):
    """Solve the rows in place; returns the number of sweeps taken.

    impulse (nrow,) holds last step's impulses on entry (used if ``warm_start``) and this
    step's on exit. Sweeps stop when no impulse changes by more than ``tolerance`` (N s).
    """
    dv = np.zeros((nrow, 12))
    diag = np.zeros(nrow)
    return _pgs(rows, nrow, Bodies(inv_mass, inv_inertia, vel, angvel), impulse, iterations,
                tolerance, warm_start, dv, diag)


@noalloc
def _pgs(rows, nrow, bodies, impulse, iterations, tolerance, warm_start, dv, diag):
    """``solve_pgs`` with its work arrays: dv (nrow, 12), diag (nrow,) zeroed."""
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
        diag[r] = a
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
        if rows.parent[r] < 0 or diag[r] <= 0.0:
            continue
        b = rows.mu[r] * max(impulse[rows.parent[r]], 0.0)
        rows.lo[r], rows.hi[r] = -b, b
        p = min(max(impulse[r], -b), b) if warm_start else 0.0
        impulse[r] = p
        apply_impulse(rows, r, dv[r], p, vel, angvel)
    sweeps = 0
    for it in range(iterations):
        sweeps = it + 1
        biggest = 0.0
        for r in range(nrow):
            if diag[r] <= 0.0:
                continue
            if rows.parent[r] >= 0:
                b = rows.mu[r] * max(impulse[rows.parent[r]], 0.0)
                rows.lo[r], rows.hi[r] = -b, b
            residual = rows.rhs[r] - row_velocity(rows, r, vel, angvel) - rows.cfm[r] * impulse[r]
            p = min(max(impulse[r] + residual / diag[r], rows.lo[r]), rows.hi[r])
            delta = p - impulse[r]
            if delta != 0.0:
                impulse[r] = p
                apply_impulse(rows, r, dv[r], delta, vel, angvel)
                biggest = max(biggest, abs(delta))
        if biggest <= tolerance:
            break
    return sweeps
