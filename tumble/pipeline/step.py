"""The step: every stage of the pipeline, in order, ``n`` times, in one compiled call.

    forces.accumulate_forces        gravity + applied forces and torques
    integrate.integrate_velocities  Newton-Euler, gyroscopic term explicit or implicit
    joints.rows.build_joint_rows    constraint rows of every joint (ERP/CFM, limits, motors)
    solvers.direct / solvers.pgs    impulses that satisfy the rows; constrained velocities
    joints.rows.joint_reactions     each joint's force and torque on its child
    integrate.integrate_positions   positions and orientations with the new velocities
    stabilize.project_joints        joints projected back together (positions only)
    integrate.first_bad_body        divergence check
    joints.rows.joint_coordinates   hinge angles, slider positions, ball rotations

State arrays carry a leading world axis (nworld, nbody, ...) so batches of worlds
step in the same call. If any world diverges the whole call is undone and the
failing world, step and body are returned for the caller to report.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from .forces import accumulate_forces
from .integrate import first_bad_body, integrate_positions, integrate_velocities
from .joints.rows import build_joint_rows, joint_coordinates, joint_reactions
from .solvers.common import make_rows_nb, world_inverse_inertia
from .solvers.direct import solve_direct
from .solvers.pgs import solve_pgs
from .stabilize import project_joints

SOLVER_DIRECT, SOLVER_PGS = 0, 1

# Scalars that configure a step.
StepOptions = namedtuple("StepOptions", [
    "dt", "gyroscopic", "quat_integration", "divergence_limit",
    "erp", "cfm", "solver", "iterations", "tolerance", "warm_start", "projection",
    "projection_tolerance"])

# Everything that changes while stepping, for the compiled step.
StateArrays = namedtuple("StateArrays", [
    "body_pos",        # (nworld, nbody, 3) COM position, m, world frame
    "body_quat",       # (nworld, nbody, 4) principal-frame orientation (x, y, z, w)
    "body_vel",        # (nworld, nbody, 3) COM velocity, m/s, world frame
    "body_angvel",     # (nworld, nbody, 3) angular velocity, rad/s, world frame
    "applied_force",   # (nworld, nbody, 3) N at the COM, world frame, held through the call
    "applied_torque",  # (nworld, nbody, 3) N m, world frame, held through the call
    "row_impulse",     # (nworld, nrow) last step's impulse of every constraint row, N s
    "motor_target",    # (nworld, njoint, 3) motor target velocity of each DoF
    "joint_q",         # (nworld, njoint, 3) joint coordinates (rad or m)
    "joint_qd",        # (nworld, njoint, 3) their rates
    "joint_qrel",      # (nworld, njoint, 4) child joint frame relative to the parent's
    "joint_force",     # (nworld, njoint, 3) force of the joint on its child, N, world
    "joint_torque",    # (nworld, njoint, 3) torque on the child about the anchor, N m, world
])

# What check_state found wrong, by field.
STATE_OK, STATE_NONFINITE_POS, STATE_NONFINITE_QUAT, STATE_ZERO_QUAT, \
    STATE_NONFINITE_VEL, STATE_NONFINITE_ANGVEL, STATE_NONFINITE_FORCE, \
    STATE_NONFINITE_TORQUE = range(8)


@njit(cache=True)
def check_state(s):
    """Validate a state before stepping; normalise its quaternions.

    Returns (code, world, body) with code STATE_OK when all is well; quaternions
    are only normalised once every one has been checked, so a refused state is
    left untouched.
    """
    nw, nb = s.body_pos.shape[0], s.body_pos.shape[1]
    for w in range(nw):
        for b in range(nb):
            for k in range(3):
                if not np.isfinite(s.body_pos[w, b, k]):
                    return STATE_NONFINITE_POS, w, b
                if not np.isfinite(s.body_vel[w, b, k]):
                    return STATE_NONFINITE_VEL, w, b
                if not np.isfinite(s.body_angvel[w, b, k]):
                    return STATE_NONFINITE_ANGVEL, w, b
                if not np.isfinite(s.applied_force[w, b, k]):
                    return STATE_NONFINITE_FORCE, w, b
                if not np.isfinite(s.applied_torque[w, b, k]):
                    return STATE_NONFINITE_TORQUE, w, b
            n2 = 0.0
            for k in range(4):
                if not np.isfinite(s.body_quat[w, b, k]):
                    return STATE_NONFINITE_QUAT, w, b
                n2 += s.body_quat[w, b, k] ** 2
            if n2 < 1e-24:
                return STATE_ZERO_QUAT, w, b
    for w in range(nw):
        for b in range(nb):
            n = np.sqrt(s.body_quat[w, b, 0] ** 2 + s.body_quat[w, b, 1] ** 2
                        + s.body_quat[w, b, 2] ** 2 + s.body_quat[w, b, 3] ** 2)
            for k in range(4):
                s.body_quat[w, b, k] /= n
    return STATE_OK, -1, -1


@njit(cache=True)
def step_worlds(m, s, n, o):
    """Advance every world of state ``s`` by ``n`` steps.

    m : ModelArrays; s : StateArrays (modified in place); o : StepOptions.
    Returns (world, step, body): all -1 on success; otherwise where the state first
    became non-finite or exceeded the divergence limit, after restoring ``s`` to its input.
    """
    nw, nb = s.body_pos.shape[0], s.body_pos.shape[1]
    nrow = s.row_impulse.shape[1]
    h = o.dt
    backup = (s.body_pos.copy(), s.body_quat.copy(), s.body_vel.copy(), s.body_angvel.copy(),
              s.row_impulse.copy())
    force = np.empty((nb, 3))
    torque = np.empty((nb, 3))
    inv_inertia = np.zeros((nb, 3, 3))
    rows = make_rows_nb(nrow)
    for w in range(nw):
        pos, quat = s.body_pos[w], s.body_quat[w]
        vel, angvel = s.body_vel[w], s.body_angvel[w]
        for k in range(n):
            accumulate_forces(m, s.applied_force[w], s.applied_torque[w], force, torque)
            integrate_velocities(m, quat, vel, angvel, force, torque, h, o.gyroscopic)
            if nrow > 0:
                build_joint_rows(m, pos, quat, vel, angvel, s.motor_target[w], h, o.erp, o.cfm,
                                 rows)
                world_inverse_inertia(m, quat, inv_inertia)
                if o.solver == SOLVER_DIRECT:
                    solve_direct(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel,
                                 s.row_impulse[w], o.tolerance)
                else:
                    solve_pgs(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel,
                              s.row_impulse[w], o.iterations, o.tolerance, o.warm_start)
                joint_reactions(m, pos, quat, rows, s.row_impulse[w], h, s.joint_force[w],
                                s.joint_torque[w])
            integrate_positions(m, pos, quat, vel, angvel, h, o.quat_integration)
            if nrow > 0 and o.projection > 0:
                project_joints(m, pos, quat, vel, angvel, s.motor_target[w], rows, inv_inertia,
                               o.projection, o.projection_tolerance)
            bad = first_bad_body(pos, quat, vel, angvel, o.divergence_limit)
            if bad >= 0:
                s.body_pos[:] = backup[0]
                s.body_quat[:] = backup[1]
                s.body_vel[:] = backup[2]
                s.body_angvel[:] = backup[3]
                s.row_impulse[:] = backup[4]
                for w2 in range(nw):
                    joint_coordinates(m, s.body_pos[w2], s.body_quat[w2], s.body_vel[w2],
                                      s.body_angvel[w2], s.joint_q[w2], s.joint_qd[w2],
                                      s.joint_qrel[w2])
                return w, k, bad
        joint_coordinates(m, pos, quat, vel, angvel, s.joint_q[w], s.joint_qd[w], s.joint_qrel[w])
    return -1, -1, -1
