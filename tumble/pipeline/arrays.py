"""The arrays a step reads and writes, and the scalars that configure it.

Three namedtuples cross from ``World`` into compiled code, each array with a leading
world axis (``nworld``) so that a batch of worlds steps in one call:

* ``StateArrays``: what the step advances (poses, velocities, solver memory) and what it
  reports (joint coordinates and reactions, counters, stage times);
* ``ControlArrays``: what the user writes between steps (applied forces, joint servo
  gains and targets, actuator controls, body servos); the step reads it and clears only
  the applied forces and torques after a successful call;
* ``StepOptions``: scalars (``World.options`` converted by ``tumble.world.options``).

Contacts travel in their own ``contacts.arrays.ContactArrays``.
"""
from collections import namedtuple

import numpy as np

SOLVER_DIRECT, SOLVER_PGS = 0, 1
CONTACT_LCP, CONTACT_PGS, CONTACT_PENALTY = 0, 1, 2

# The stages a step times when ``StepOptions.profile`` is on (``StateArrays.stage_ticks``).
STAGES = ("collide", "forces", "integrate_velocities", "rows", "solve",
          "integrate_positions", "project_joints", "divergence_check", "joint_coordinates")
(STAGE_COLLIDE, STAGE_FORCES, STAGE_INTEGRATE_VELOCITIES, STAGE_ROWS, STAGE_SOLVE,
 STAGE_INTEGRATE_POSITIONS, STAGE_PROJECT, STAGE_CHECK, STAGE_COORDINATES) = range(len(STAGES))

StepOptions = namedtuple("StepOptions", [
    "dt", "gyroscopic", "quat_integration", "divergence_limit",
    "erp", "cfm", "solver", "iterations", "tolerance", "velocity_tolerance",
    "warm_start", "projection",
    "projection_tolerance", "contact", "contact_erp", "contact_cfm", "slop",
    "bounce_threshold", "penalty_k", "penalty_c", "v_slip", "penalty_implicit",
    "contact_margin", "pd_mode",
    "broadphase", "profile", "sleep_time", "sleep_speed", "sleep_spin"])

StateArrays = namedtuple("StateArrays", [
    "body_pos",        # (nworld, nbody, 3) COM position, m, world frame
    "body_quat",       # (nworld, nbody, 4) principal-frame orientation (x, y, z, w)
    "body_vel",        # (nworld, nbody, 3) COM velocity, m/s, world frame
    "body_angvel",     # (nworld, nbody, 3) angular velocity, rad/s, world frame
    "row_impulse",     # (nworld, nrow) last step's impulse of every joint row, N s
    "joint_q",         # (nworld, njoint, 3) joint coordinates (rad or m)
    "joint_qd",        # (nworld, njoint, 3) their rates
    "joint_qrel",      # (nworld, njoint, 4) child joint frame relative to the parent's
    "joint_force",     # (nworld, njoint, 3) force of the joint on its child, N, world
    "joint_torque",    # (nworld, njoint, 3) torque on the child about the anchor, N m, world
    "contact_count",   # (nworld,) int64 contacts found in the last step
    "lcp_fallbacks",   # (nworld,) int64 steps where PGS stood in for Lemke
    "lcp_backoff",     # (nworld, 3) int64 steps left that skip Lemke, the skip window, and
                       # the fewest contacts of a failure since the last exact solve
    "stage_ticks",     # (nworld, len(STAGES)) int64 time in each stage (_jit.ticks units)
    "body_rest",       # (nworld, nbody) s each body has been at rest (sleep.py)
])

ControlArrays = namedtuple("ControlArrays", [
    "applied_force",   # (nworld, nbody, 3) N at the COM, world frame, held through the call
    "applied_torque",  # (nworld, nbody, 3) N m, world frame, held through the call
    "joint_applied",   # (nworld, njoint, 3) torque (force) per DoF, held through the call
    "motor_target",    # (nworld, njoint, 3) motor target velocity of each DoF
    "pd_kp",           # (nworld, njoint) PD servo stiffness (N m/rad, N/m); 0 and kd 0: off
    "pd_kd",           # (nworld, njoint) PD servo damping (N m s/rad, N s/m)
    "pd_max",          # (nworld, njoint) bound on each DoF's servo torque (N m or N)
    "pd_target_quat",  # (nworld, njoint, 4) ball targets, child joint frame in the parent's
    "pd_target_q",     # (nworld, njoint, 3) hinge/universal/slider target coordinates
    "pd_target_qd",    # (nworld, njoint, 3) target rates along the DoF axes
    "ctrl",            # (nworld, nactuator) MJCF actuator controls
    "body_servo",      # (nworld, nbody, 4) body servo gains kp N/m, kd N s/m, kp_rot N m/rad,
                       # kd_rot N m s/rad (all 0: off); the implicit hand of god
    "body_target_pos",     # (nworld, nbody, 3) its target COM position, m, world
    "body_target_quat",    # (nworld, nbody, 4) target orientation (as body_quat)
    "body_target_vel",     # (nworld, nbody, 3) target COM velocity, m/s
    "body_target_angvel",  # (nworld, nbody, 3) target angular velocity, rad/s
])


def make_state_arrays(nworld, nbody, njoint, nrow):
    """Zeroed ``StateArrays`` for ``nworld`` copies of a model."""
    nw, nb, nj = nworld, nbody, njoint
    return StateArrays(
        body_pos=np.zeros((nw, nb, 3)), body_quat=np.zeros((nw, nb, 4)),
        body_vel=np.zeros((nw, nb, 3)), body_angvel=np.zeros((nw, nb, 3)),
        row_impulse=np.zeros((nw, nrow)), joint_q=np.zeros((nw, nj, 3)),
        joint_qd=np.zeros((nw, nj, 3)), joint_qrel=np.zeros((nw, nj, 4)),
        joint_force=np.zeros((nw, nj, 3)), joint_torque=np.zeros((nw, nj, 3)),
        contact_count=np.zeros(nw, np.int64), lcp_fallbacks=np.zeros(nw, np.int64),
        lcp_backoff=np.zeros((nw, 3), np.int64),
        stage_ticks=np.zeros((nw, len(STAGES)), np.int64), body_rest=np.zeros((nw, nb)))


def make_control_arrays(nworld, nbody, njoint, nactuator):
    """Zeroed ``ControlArrays`` for ``nworld`` copies of a model."""
    nw, nb, nj = nworld, nbody, njoint
    return ControlArrays(
        applied_force=np.zeros((nw, nb, 3)), applied_torque=np.zeros((nw, nb, 3)),
        joint_applied=np.zeros((nw, nj, 3)), motor_target=np.zeros((nw, nj, 3)),
        pd_kp=np.zeros((nw, nj)), pd_kd=np.zeros((nw, nj)), pd_max=np.zeros((nw, nj)),
        pd_target_quat=np.zeros((nw, nj, 4)), pd_target_q=np.zeros((nw, nj, 3)),
        pd_target_qd=np.zeros((nw, nj, 3)), ctrl=np.zeros((nw, nactuator)),
        body_servo=np.zeros((nw, nb, 4)), body_target_pos=np.zeros((nw, nb, 3)),
        body_target_quat=np.zeros((nw, nb, 4)), body_target_vel=np.zeros((nw, nb, 3)),
        body_target_angvel=np.zeros((nw, nb, 3)))
