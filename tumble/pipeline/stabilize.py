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

from .._jit import noalloc
from ..math.quat import quat_exp, quat_mul, quat_normalize
from .joints.rows import build_core_rows, core_error
from .solvers.common import world_inverse_inertia
from .solvers.direct import assemble, cholesky_apply, cholesky_factor, row_responses
from .solvers.tree import tree_factor, tree_plan, tree_solve

# Relative regularisation of the projection system: keeps redundant rows (loops) solvable.
_REGULARISATION = 1e-10


@njit(cache=True, inline="always")
def _rigid(m, j):
    """Whether joint ``j`` is rigid: no spring, no own CFM (soft joints are meant to give)."""
    return not (m.joint_stiffness[j] != 0.0 or m.joint_soft_damping[j] != 0.0
                or m.joint_cfm[j] > 0.0)


@noalloc
def _rigid_core_rows(m, rows, idx):
    """Count (and, if ``idx`` has room, list) the core rows of rigid joints: soft joints (a
    spring, or their own CFM) are meant to give, so they are never projected. Their bodies
    are written into ``rows`` as build_joint_rows writes them."""
    n = 0
    for j in range(m.joint_type.shape[0]):
        if not _rigid(m, j):
            continue
        for r in range(m.joint_row_start[j], m.joint_row_start[j] + m.joint_core_rows[j]):
            if n < idx.shape[0]:
                idx[n] = r
                rows.body_a[r] = m.joint_parent[j]
                rows.body_b[r] = m.joint_child[j]
            n += 1
    return n


@njit(cache=True)
def projection_setup(m, rows, nbody, enabled):
    """What ``project_joints`` needs for model ``m``, made once per ``step`` call: the rigid
    joints' core rows, whether they form a tree and its plan (``solvers/tree.py``), and
    the work arrays. Writes the rows' bodies into ``rows``. With ``enabled`` False (no
    projection asked for) it selects no rows, and ``project_joints`` does nothing."""
    n = _rigid_core_rows(m, rows, np.empty(0, np.int64)) if enabled else 0
    idx = np.empty(n, np.int64)
    _rigid_core_rows(m, rows, idx)
    tree, plan = tree_plan(rows, idx, n, m.body_inv_mass, nbody)
    nd = 0 if tree else n
    return (idx, tree, plan, np.zeros((n, 12)), np.zeros(n), np.zeros((nd, nd)),
            np.zeros((nd, nd)), np.zeros(n), np.zeros(n), np.zeros((nbody, 6)),
            np.zeros((nbody, 6)), np.zeros((nbody, 3)))


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@noalloc(inline="always")
def project_joints(m, pos, quat, rows, inv_inertia, iterations, tolerance, setup):
    """Move bodies so every rigid joint's core rows hold at the position level, once some
    row's error exceeds ``tolerance`` (m or rad); below it ERP alone corrects the drift.
    ``setup`` comes from ``projection_setup``.

    Each Gauss-Newton step solves ``(J M^-1 J^T + R) y = -C`` (R: the relative
    regularisation) in linear time over the joints' tree (``solvers/tree.py``), or densely
    when the joints form loops."""
    idx, tree, plan, dv, b, A, work, reg, y, u, fzero, zero = setup
    n = idx.shape[0]
    if n == 0 or _largest_core_error(m, pos, quat, rows) < tolerance:
        return
    _project(m, pos, quat, rows, inv_inertia, iterations, tolerance, idx, n,
             tree, plan, dv, b, A, work, reg, y, u, fzero, zero)


@noalloc
def _largest_core_error(m, pos, quat, rows):
    """Largest position error (m or rad) of the rigid joints' core rows (``core_error``),
    the first thing ``_project`` would measure."""
    biggest = 0.0
    for j in range(m.joint_type.shape[0]):
        if _rigid(m, j):
            biggest = max(biggest, core_error(m, pos, quat, rows, j))
    return biggest


# inlined: compiled on its own, it would emit again all it calls (a cold start's cost)
@noalloc(inline="always")
def _project(m, pos, quat, rows, inv_inertia, iterations, tolerance, idx, n, tree,
             plan, dv, b, A, work, reg, y, u, fzero, zero):
    """The Gauss-Newton iterations of ``project_joints`` on its work arrays."""
    nb = pos.shape[0]
    # Gauss-Newton converges quadratically: once the error is a tenth of the tolerance
    # (what ERP then corrects), a further iteration would cost a factorisation for
    # nothing visible
    done = max(0.1 * tolerance, 1e-12)
    for it in range(iterations):
        # with h = 1 and ERP = 1 each core row's rhs is minus its position error
        build_core_rows(m, pos, quat, rows)
        world_inverse_inertia(m, quat, inv_inertia)
        for i in range(n):
            rows.cfm[idx[i]] = 0.0
        if tree:
            row_responses(rows, idx, n, m.body_inv_mass, inv_inertia, zero, zero, dv, b)
            for i in range(n):
                a = 0.0
                for c in range(12):
                    a += rows.J[idx[i], c] * dv[i, c]
                reg[i] = _REGULARISATION * a + 1e-300
        else:
            assemble(rows, idx, n, m.body_inv_mass, inv_inertia, zero, zero, dv, A, b)
            for i in range(n):
                A[i, i] += _REGULARISATION * A[i, i] + 1e-300
        biggest = 0.0
        for i in range(n):
            biggest = max(biggest, abs(b[i]))
        if biggest < (tolerance if it == 0 else done):
            return
        if tree:
            # K [u; -y] = [0; b]: u = M^-1 J^T y, each body's displacement and rotation
            if not tree_factor(plan, rows, idx, reg, m.body_inv_mass, inv_inertia, nb):
                return
            tree_solve(plan, nb, fzero, b, u, y)
        else:
            if not cholesky_factor(A, n, work):
                return
            cholesky_apply(work, b, n, y)
            u[:] = 0.0
            for i in range(n):
                r = idx[i]
                for side in range(2):
                    body = rows.body_a[r] if side == 0 else rows.body_b[r]
                    if body < 0:
                        continue
                    for c in range(6):
                        u[body, c] += dv[i, 6 * side + c] * y[i]
        for body in range(nb):
            for c in range(3):
                pos[body, c] += u[body, c]
            if u[body, 3] != 0.0 or u[body, 4] != 0.0 or u[body, 5] != 0.0:
                q = quat_normalize(quat_mul(quat_exp((u[body, 3], u[body, 4], u[body, 5])),
                                            quat[body]))
                for c in range(4):
                    quat[body, c] = q[c]
