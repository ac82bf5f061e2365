"""The step: every stage of the pipeline, in order, ``n`` times, in one compiled call.

    forces.accumulate_forces        gravity + applied forces and torques
    integrate.integrate_velocities  Newton-Euler, gyroscopic term explicit or implicit
    integrate.integrate_positions   positions and orientations with the new velocities
    integrate.first_bad_body        divergence check

State arrays carry a leading world axis (nworld, nbody, ...) so batches of worlds
step in the same call. If any world diverges the whole call is undone and the
failing world, step and body are returned for the caller to report.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from .forces import accumulate_forces
from .integrate import first_bad_body, integrate_positions, integrate_velocities

# Everything that changes while stepping, for the compiled step.
StateArrays = namedtuple("StateArrays", [
    "body_pos",        # (nworld, nbody, 3) COM position, m, world frame
    "body_quat",       # (nworld, nbody, 4) principal-frame orientation (x, y, z, w)
    "body_vel",        # (nworld, nbody, 3) COM velocity, m/s, world frame
    "body_angvel",     # (nworld, nbody, 3) angular velocity, rad/s, world frame
    "applied_force",   # (nworld, nbody, 3) N at the COM, world frame, held through the call
    "applied_torque",  # (nworld, nbody, 3) N m, world frame, held through the call
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
def step_worlds(m, s, n, h, gyro_mode, quat_mode, limit):
    """Advance every world of state ``s`` by ``n`` steps of ``h`` seconds.

    m : ModelArrays; s : StateArrays (modified in place).
    Returns (world, step, body): all -1 on success; otherwise where the state first
    became non-finite or exceeded ``limit``, after restoring ``s`` to its input.
    """
    nw, nb = s.body_pos.shape[0], s.body_pos.shape[1]
    pos0 = s.body_pos.copy()
    quat0 = s.body_quat.copy()
    vel0 = s.body_vel.copy()
    angvel0 = s.body_angvel.copy()
    force = np.empty((nb, 3))
    torque = np.empty((nb, 3))
    for w in range(nw):
        pos, quat = s.body_pos[w], s.body_quat[w]
        vel, angvel = s.body_vel[w], s.body_angvel[w]
        for k in range(n):
            accumulate_forces(m, s.applied_force[w], s.applied_torque[w], force, torque)
            integrate_velocities(m, quat, vel, angvel, force, torque, h, gyro_mode)
            integrate_positions(m, pos, quat, vel, angvel, h, quat_mode)
            bad = first_bad_body(pos, quat, vel, angvel, limit)
            if bad >= 0:
                s.body_pos[:] = pos0
                s.body_quat[:] = quat0
                s.body_vel[:] = vel0
                s.body_angvel[:] = angvel0
                return w, k, bad
    return -1, -1, -1
