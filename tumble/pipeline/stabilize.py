"""Stage after the position update: project the joints back together (post-stabilisation).

Velocity-level constraints keep joints together only to first order; a fast-whipping
chain drifts apart by O(h^2 w^2 r) a step. ERP pulls the drift back over a few steps
through the velocities, which also changes the energy. This stage instead moves the
positions alone (Cline and Pai 2003): Gauss-Newton steps on ``C(x) = 0`` with the
mass-weighted correction ``dx = M^-1 J^T y``, ``J M^-1 J^T y = -C``. Velocities are
untouched, so no energy is added; only the core rows of rigid joints are projected.
Projection is not free either: velocities tangent to the old configuration are then
re-projected by the next solve, which dissipates, so it only runs once the drift
exceeds a tolerance and ERP keeps small errors in check.
"""
import numpy as np
from numba import njit

from ..math.quat import quat_exp, quat_mul, quat_normalize
from .joints.rows import build_joint_rows
from .solvers.common import world_inverse_inertia
from .solvers.direct import assemble, cholesky_solve

# Relative regularisation of the projection system: keeps redundant rows (loops) solvable.
_REGULARISATION = 1e-10


@njit(cache=True, inline="always")
def _rigid(m, j):
    """Soft joints (a spring, or their own CFM) are meant to give: never projected."""
    return m.joint_stiffness[j] == 0.0 and m.joint_soft_damping[j] == 0.0 and m.joint_cfm[j] <= 0.0


@njit(cache=True)
def project_joints(m, pos, quat, vel, angvel, drive, rows, inv_inertia, iterations,
                   tolerance):
    """Move bodies so every rigid joint's core rows hold at the position level, once some
    row's error exceeds ``tolerance`` (m or rad); below it ERP alone corrects the drift."""
    nj = m.joint_type.shape[0]
    n = 0
    for j in range(nj):
        if _rigid(m, j):
            n += m.joint_core_rows[j]
    if n == 0:
        return
    idx = np.empty(n, np.int64)
    dv = np.zeros((n, 12))
    A = np.zeros((n, n))
    b = np.zeros(n)
    work = np.zeros((n, n))
    zero = np.zeros_like(vel)
    nb = pos.shape[0]
    drot = np.zeros((nb, 3))
    for it in range(iterations):
        # with h = 1 and ERP = 1 each core row's rhs is minus its position error
        build_joint_rows(m, pos, quat, zero, zero, drive, 1.0, 1.0, 0.0, rows, False)
        world_inverse_inertia(m, quat, inv_inertia)
        k = 0
        for j in range(nj):
            if not _rigid(m, j):
                continue
            for r in range(m.joint_row_start[j], m.joint_row_start[j] + m.joint_core_rows[j]):
                idx[k] = r
                rows.cfm[r] = 0.0
                k += 1
        assemble(rows, idx, n, m.body_inv_mass, inv_inertia, zero, zero, dv, A, b)
        biggest = 0.0
        for i in range(n):
            biggest = max(biggest, abs(b[i]))
            A[i, i] += _REGULARISATION * A[i, i] + 1e-300
        if biggest < (tolerance if it == 0 else 1e-12):
            return
        y, ok = cholesky_solve(A, b, n, work)
        if not ok:
            return
        drot[:] = 0.0
        for i in range(n):
            r = idx[i]
            for side in range(2):
                body = rows.body_a[r] if side == 0 else rows.body_b[r]
                if body < 0:
                    continue
                o = 6 * side
                for c in range(3):
                    pos[body, c] += dv[i, o + c] * y[i]
                    drot[body, c] += dv[i, o + 3 + c] * y[i]
        for body in range(nb):
            if drot[body, 0] != 0.0 or drot[body, 1] != 0.0 or drot[body, 2] != 0.0:
                q = quat_normalize(quat_mul(quat_exp(drot[body]), quat[body]))
                for c in range(4):
                    quat[body, c] = q[c]
