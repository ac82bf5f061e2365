"""What both solvers need: rows, effective masses, applying an impulse."""
from collections import namedtuple

import numpy as np
from numba import njit

from ..._jit import noalloc
from ...math.spatial import inertia_world_inv
from ...model.model import DYNAMIC

# parent >= 0 marks a friction row whose bounds are -+ mu * impulse[parent]; friction rows
# with the same group (>= 0) share one friction pyramid in the exact (Lemke) solver, e.g.
# a contact's two tangent rows, or its two rolling rows.
Rows = namedtuple("Rows", ["body_a", "body_b", "J", "rhs", "cfm", "lo", "hi", "parent", "mu",
                           "group"])

# The bodies the rows act on, as the solvers' kernels pass them along.
Bodies = namedtuple("Bodies", [
    "inv_mass",     # (nbody,) 1/kg, zero for bodies that cannot move
    "inv_inertia",  # (nbody, 3, 3) world frame
    "vel",          # (nbody, 3) m/s, updated in place
    "angvel",       # (nbody, 3) rad/s world frame, updated in place
])


@njit(cache=True)
def make_rows_nb(nrow):
    """Empty row arrays for ``nrow`` rows (see joints/common.py for their meaning)."""
    return Rows(np.full(nrow, -1, np.int32), np.full(nrow, -1, np.int32), np.zeros((nrow, 12)),
                np.zeros(nrow), np.zeros(nrow), np.zeros(nrow), np.zeros(nrow),
                np.full(nrow, -1, np.int32), np.zeros(nrow), np.full(nrow, -1, np.int32))


@noalloc
def world_inverse_inertia(m, quat, out):
    """(nbody, 3, 3) inverse world inertia of each dynamic body; zero for the others."""
    for b in range(quat.shape[0]):
        if m.body_kind[b] != DYNAMIC:
            out[b] = 0.0
            continue
        a = inertia_world_inv(quat[b], m.body_inv_inertia[b])
        for i in range(3):
            for k in range(3):
                out[b, i, k] = a[i][k]


@njit(cache=True, inline="always")
def row_active(rows, r):
    return rows.parent[r] >= 0 or not (rows.lo[r] == 0.0 and rows.hi[r] == 0.0)


@noalloc
def minv_jt(rows, r, inv_mass, inv_inertia, out):
    """``M^-1 J_r^T`` (12,) for row r: the velocity change per unit impulse."""
    for side in range(2):
        b = rows.body_a[r] if side == 0 else rows.body_b[r]
        o = 6 * side
        if b < 0:
            for k in range(6):
                out[o + k] = 0.0
            continue
        im = inv_mass[b]
        jr, ii = rows.J[r], inv_inertia[b]      # views: no negative-index wrap-around
        for k in range(3):
            out[o + k] = im * jr[o + k]
        for i in range(3):
            s = 0.0
            for k in range(3):
                s += ii[i, k] * jr[o + 3 + k]
            out[o + 3 + i] = s


@njit(cache=True, inline="always")
def row_velocity(rows, r, vel, angvel):
    """``J_r v``: the row's current velocity."""
    s = 0.0
    jr = rows.J[r]
    for side in range(2):
        b = rows.body_a[r] if side == 0 else rows.body_b[r]
        if b < 0:
            continue
        o = 6 * side
        vb, wb = vel[b], angvel[b]
        for k in range(3):
            s += jr[o + k] * vb[k] + jr[o + 3 + k] * wb[k]
    return s


@njit(cache=True, inline="always")
def apply_impulse(rows, r, dv, p, vel, angvel):
    """Add ``p`` times the row's velocity change ``dv`` (12,) to both bodies."""
    for side in range(2):
        b = rows.body_a[r] if side == 0 else rows.body_b[r]
        if b < 0:
            continue
        o = 6 * side
        vb, wb = vel[b], angvel[b]
        for k in range(3):
            vb[k] += dv[o + k] * p
            wb[k] += dv[o + 3 + k] * p


@noalloc
def active_rows(rows, nrow, idx, where, impulse):
    """Indices of the rows that take part (``row_active``) into ``idx`` (nrow,); their
    position among them into ``where`` (nrow,), -1 and a zero ``impulse`` for the others.
    Returns their number. (Inactive rows are the unreached limits and unused motor,
    damper and friction slots, written as ``lo == hi == 0``: no solver sees them.)"""
    n = 0
    for r in range(nrow):
        if row_active(rows, r):
            idx[n] = r
            where[r] = n
            n += 1
        else:
            where[r] = -1
            impulse[r] = 0.0
    return n


@noalloc
def apply_impulses(rows, idx, n, dv, p, vel, angvel):
    """``apply_impulse`` for the rows ``idx[:n]`` with impulses ``p[:n]``, responses ``dv``."""
    for i in range(n):
        apply_impulse(rows, idx[i], dv[i], p[i], vel, angvel)
