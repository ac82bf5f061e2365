"""The step: every stage of the pipeline, in order, ``n`` times, in one compiled call.

    collide.collide_world           contacts: broad phase, filtering, narrow phase
    forces.accumulate_forces        gravity + applied forces and torques
    actuators.actuator_forces       explicit PD servos, joint torques, MJCF actuators
    contacts.penalty                spring-damper contact forces (contact="penalty")
    integrate.integrate_velocities  Newton-Euler, gyroscopic term explicit or implicit
    joints.rows.build_joint_rows    constraint rows of every joint (ERP/CFM, limits, motors)
    actuators.body_servo_rows       implicit PD rows pulling bodies to targets (hand of god)
    contacts.rows                   normal, friction (and spin-friction) rows of every contact
    solvers.direct / solvers.pgs    impulses that satisfy the rows; constrained velocities
    joints.rows.joint_reactions     each joint's force and torque on its child (last step)
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
from numba.typed import List

from .._jit import noalloc
from ..model.model import STATIC
from .collide import (COLLIDE_OK, COLLIDE_PAIRS_FULL, collide_listed, collide_world,
                      listed_pairs, listed_primitives)
from .contacts.arrays import ContactArrays, make_contacts_nb
from .contacts.pairs import ROWS_SPIN, rows_per_contact
from .contacts.penalty import penalty_forces
from .contacts.rows import build_contact_rows, store_contact_impulses
from .actuators import (PD_EXPLICIT, PD_IMPLICIT, PD_STABLE, actuator_forces, body_servo_rows,
                        servo_on, servoed_bodies, stable_servo_forces)
from .forces import accumulate_forces
from .integrate import first_bad_body, integrate_positions, integrate_velocities
from .joints.rows import build_joint_rows, joint_coordinates, joint_reactions
from .joints.servo import JointDrive
from .solvers.common import make_rows_nb, world_inverse_inertia
from .solvers.direct import solve_direct
from .solvers.mlcp import FAST_SOLVED, guess_on_tree_fast, make_fast_scratch, solve_mlcp
from .solvers.pgs import solve_pgs
from .solvers.tree import make_plan_cache, plan_capacity
from .stabilize import project_joints, projection_setup

SOLVER_DIRECT, SOLVER_PGS = 0, 1
CONTACT_LCP, CONTACT_PGS, CONTACT_PENALTY = 0, 1, 2
STEP_OK, STEP_DIVERGED, STEP_MORE_PAIRS, STEP_MORE_CONTACTS = 0, 1, 2, 3

# Scalars that configure a step.
StepOptions = namedtuple("StepOptions", [
    "dt", "gyroscopic", "quat_integration", "divergence_limit",
    "erp", "cfm", "solver", "iterations", "tolerance", "warm_start", "projection",
    "projection_tolerance", "contact", "contact_erp", "contact_cfm", "slop",
    "bounce_threshold", "penalty_k", "penalty_c", "v_slip", "contact_margin", "pd_mode",
    "broadphase"])

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
    "pd_kp",           # (nworld, njoint) PD servo stiffness (N m/rad, N/m); 0 and kd 0: off
    "pd_kd",           # (nworld, njoint) PD servo damping (N m s/rad, N s/m)
    "pd_max",          # (nworld, njoint) bound on each DoF's servo torque (N m or N)
    "pd_target_quat",  # (nworld, njoint, 4) ball targets, child joint frame in the parent's
    "pd_target_q",     # (nworld, njoint, 3) hinge/universal/slider target coordinates
    "pd_target_qd",    # (nworld, njoint, 3) target rates along the DoF axes
    "joint_applied",   # (nworld, njoint, 3) torque (force) per DoF, held through the call
    "ctrl",            # (nworld, nactuator) MJCF actuator controls
    "body_servo",      # (nworld, nbody, 4) body servo gains kp N/m, kd N s/m, kp_rot N m/rad,
                       # kd_rot N m s/rad (all 0: off); the implicit hand of god
    "body_target_pos",     # (nworld, nbody, 3) its target COM position, m, world
    "body_target_quat",    # (nworld, nbody, 4) target orientation (as body_quat)
    "body_target_vel",     # (nworld, nbody, 3) target COM velocity, m/s
    "body_target_angvel",  # (nworld, nbody, 3) target angular velocity, rad/s
    "joint_q",         # (nworld, njoint, 3) joint coordinates (rad or m)
    "joint_qd",        # (nworld, njoint, 3) their rates
    "joint_qrel",      # (nworld, njoint, 4) child joint frame relative to the parent's
    "joint_force",     # (nworld, njoint, 3) force of the joint on its child, N, world
    "joint_torque",    # (nworld, njoint, 3) torque on the child about the anchor, N m, world
    "contact_count",   # (nworld,) int64 contacts found in the last step
    "lcp_fallbacks",   # (nworld,) int64 steps where Lemke failed and PGS stood in
])

# What check_state found wrong, by field.
STATE_OK, STATE_NONFINITE_POS, STATE_NONFINITE_QUAT, STATE_ZERO_QUAT, \
    STATE_NONFINITE_VEL, STATE_NONFINITE_ANGVEL, STATE_NONFINITE_FORCE, \
    STATE_NONFINITE_TORQUE = range(8)


@noalloc
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


# What check_drives reports: the field at fault (DRIVE_FIELDS order), or one of these.
DRIVE_OK = -1
DRIVE_FIELDS = ("motor_target", "pd_target_quat", "pd_target_q", "pd_target_qd",
                "joint_applied", "ctrl", "pd_kp", "pd_kd", "body_servo", "body_target_pos",
                "body_target_quat", "body_target_vel", "body_target_angvel")
DRIVE_ZERO_BODY_QUAT, DRIVE_BAD_MAX, DRIVE_ZERO_JOINT_QUAT = 100, 101, 102


@noalloc
def _first_bad_2d(a, nonneg):
    """(w, i) of the first non-finite (or, with ``nonneg``, negative) entry of the
    (nworld, n) array ``a``; (-1, -1) if none."""
    for w in range(a.shape[0]):
        for i in range(a.shape[1]):
            if not np.isfinite(a[w, i]) or (nonneg and a[w, i] < 0.0):
                return w, i
    return -1, -1


@noalloc
def _first_bad_3d(a, nonneg):
    """``_first_bad_2d`` for an (nworld, n, k) array: (w, i) of the first bad row."""
    for w in range(a.shape[0]):
        for i in range(a.shape[1]):
            for k in range(a.shape[2]):
                if not np.isfinite(a[w, i, k]) or (nonneg and a[w, i, k] < 0.0):
                    return w, i
    return -1, -1


@noalloc
def _normalise_rows(q):
    """Divide each non-zero 4-vector of the (nworld, n, 4) array ``q`` by its length."""
    for w in range(q.shape[0]):
        for i in range(q.shape[1]):
            n = np.sqrt(q[w, i, 0] ** 2 + q[w, i, 1] ** 2 + q[w, i, 2] ** 2 + q[w, i, 3] ** 2)
            if n > 0.0:
                for k in range(4):
                    q[w, i, k] /= n


@noalloc
def check_drives(s, ball):
    """Validate the drive inputs of state ``s`` (targets, gains, torques, controls, body
    servos) before stepping, then normalise the target quaternions.

    ``ball`` (njoint,) bool marks ball joints, whose ``pd_target_quat`` must not be zero.
    Returns (code, world, index): code DRIVE_OK, an index into DRIVE_FIELDS for a
    non-finite (or, for gains, negative) entry of that field, DRIVE_ZERO_BODY_QUAT for a
    zero target orientation of a servoed body, DRIVE_BAD_MAX for a servo torque bound
    that is not > 0, DRIVE_ZERO_JOINT_QUAT for a zero ball target; index is the joint,
    actuator or body. Nothing is changed when a check fails.
    """
    fields3 = (s.motor_target, s.pd_target_quat, s.pd_target_q, s.pd_target_qd,
               s.joint_applied)
    for f in range(5):
        w, i = _first_bad_3d(fields3[f], np.bool_(False))
        if w >= 0:
            return f, w, i
    w, i = _first_bad_2d(s.ctrl, np.bool_(False))
    if w >= 0:
        return 5, w, i
    w, i = _first_bad_2d(s.pd_kp, np.bool_(True))
    if w >= 0:
        return 6, w, i
    w, i = _first_bad_2d(s.pd_kd, np.bool_(True))
    if w >= 0:
        return 7, w, i
    w, i = _first_bad_3d(s.body_servo, np.bool_(True))
    if w >= 0:
        return 8, w, i
    targets = (s.body_target_pos, s.body_target_quat, s.body_target_vel, s.body_target_angvel)
    for f in range(4):
        w, i = _first_bad_3d(targets[f], np.bool_(False))
        if w >= 0:
            return 9 + f, w, i
    nw = s.body_pos.shape[0]
    for w in range(nw):
        for b in range(s.body_servo.shape[1]):
            if s.body_servo[w, b, 2] > 0.0 or s.body_servo[w, b, 3] > 0.0:
                n2 = 0.0
                for k in range(4):
                    n2 += s.body_target_quat[w, b, k] ** 2
                if n2 < 1e-24:
                    return DRIVE_ZERO_BODY_QUAT, w, b
        for j in range(s.pd_max.shape[1]):
            if not s.pd_max[w, j] > 0.0:
                return DRIVE_BAD_MAX, w, j
            if ball[j]:
                n2 = 0.0
                for k in range(4):
                    n2 += s.pd_target_quat[w, j, k] ** 2
                if n2 < 1e-24:
                    return DRIVE_ZERO_JOINT_QUAT, w, j
    _normalise_rows(s.body_target_quat)
    _normalise_rows(s.pd_target_quat)
    return DRIVE_OK, -1, -1


@njit(cache=True)
def solve_rows(m, rows, nrow, njrow, ncon, inv_inertia, vel, angvel, imp, o, caches):
    """Solve joint and contact rows together with the solver the options pick.

    caches : (direct, mlcp) tree-plan caches (``make_solver_caches``).
    Returns 1 when the exact (Lemke) solve failed and PGS stood in, else 0."""
    if o.contact == CONTACT_PGS or (o.solver == SOLVER_PGS and ncon == 0):
        solve_pgs(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel, imp, o.iterations,
                  o.tolerance, o.warm_start)
        return 0
    if ncon == 0 or o.contact == CONTACT_PENALTY:
        solve_direct(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel, imp, o.tolerance,
                     caches[0])
        return 0
    # exact: the mixed LCP by Lemke; if Lemke reports failure, PGS from the warm start
    status = solve_mlcp(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel, imp, np.int64(0),
                        caches[1])
    if status != 0:
        solve_pgs(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel, imp, o.iterations,
                  o.tolerance, o.warm_start)
        return 1
    return 0


@noalloc
def solve_fast(m, rows, nrow, ncon, inv_inertia, vel, angvel, imp, o, caches, fast):
    """``solve_rows``'s most common case, a character standing or walking on an exact (LCP)
    contact model, without allocating or reference counting (``mlcp.guess_on_tree_fast``).
    True when it solved the rows; False leaves everything to ``solve_rows``."""
    if o.contact != CONTACT_LCP or ncon == 0:
        return False
    return guess_on_tree_fast(rows, nrow, m.body_inv_mass, inv_inertia, vel, angvel, imp,
                              caches[1], fast) == FAST_SOLVED


@njit(cache=True)
def make_solver_caches(m, servoed, nbody):
    """Tree-plan caches of the direct solver and of the mixed LCP for one ``step`` call:
    the joints' (and body servos') rows keep their plan from step to step."""
    nrow, nfac = plan_capacity(m.joint_parent, m.joint_child, m.joint_row_count, servoed,
                               m.body_inv_mass, nbody)
    return (make_plan_cache(nrow, nbody, nfac), make_plan_cache(nrow, nbody, nfac))


# Scratch memory of one world's steps, kept by the World between step calls (made by
# make_step_work; step_worlds checks it still fits with work_fits).
StepWork = namedtuple("StepWork", [
    "key",          # (5,) int64: contact capacity, rows, projection on, spin rows,
                    # 1 when the listed pairs are all primitives (collide_listed)
    "force",        # (nbody, 3) accumulated force, N
    "torque",       # (nbody, 3) accumulated torque, N m
    "inv_inertia",  # (nbody, 3, 3) world inverse inertia
    "rows",         # Rows for joints, body servos and contacts
    "imp",          # (rows,) impulses handed to the solvers
    "gpos", "gquat", "aabb_lo", "aabb_hi",   # (ngeom, 3|4) geom poses and boxes
    "prev",         # ContactArrays: last step's contacts (warm start)
    "vel_pred", "angvel_pred",               # (nbody, 3) stable PD's prediction
    "servoed",      # (ns,) int64 bodies with a body servo (6 rows each after the joints')
    "projection",   # stabilize.projection_setup
    "caches",       # (direct, mlcp) tree-plan caches (make_solver_caches)
    "fast",         # mlcp.FastScratch: the mixed LCP's common case without allocating
    "listed",       # (K, 2) int32 the geom pairs that may touch (collide.listed_pairs)
])


@njit(cache=True)
def make_step_work(m, s, con, o):
    """Scratch memory for stepping the worlds of ``s`` with options ``o``."""
    nb = s.body_pos.shape[1]
    ng = m.geom_type.shape[0]
    njrow = s.row_impulse.shape[1]
    cap = con.depth.shape[1]
    servoed = servoed_bodies(s.body_servo)
    nper = rows_per_contact(m)               # rows per contact: 3, or 6 with spin friction
    ncap = _row_capacity(njrow, servoed.shape[0], nper, cap, o)
    rows = make_rows_nb(ncap)
    project = njrow > 0 and o.projection > 0
    listed = listed_pairs(m, nb)
    key = np.array([cap, ncap, 1 if project else 0, nper,
                    1 if listed_primitives(m, listed) else 0], np.int64)
    caches = make_solver_caches(m, servoed, nb)
    return StepWork(key, np.empty((nb, 3)), np.empty((nb, 3)), np.zeros((nb, 3, 3)), rows,
                    np.zeros(ncap), np.zeros((ng, 3)), np.zeros((ng, 4)), np.zeros((ng, 3)),
                    np.zeros((ng, 3)), make_contacts_nb(cap), np.empty((nb, 3)),
                    np.empty((nb, 3)), servoed, projection_setup(m, rows, nb, project),
                    caches, make_fast_scratch(ncap, nb, caches[1]), listed)


@njit(cache=True, inline="always")
def _row_capacity(njrow, nservoed, nper, cap, o):
    """Rows a step lays out: the joints', six per servoed body, then ``nper`` for each of
    ``cap`` contacts unless contacts are penalty springs."""
    return njrow + 6 * nservoed + (nper * cap if o.contact != CONTACT_PENALTY else 0)


@noalloc
def work_fits(work, m, s, con, o):
    """Whether ``work`` (make_step_work) still fits the state, contacts and options."""
    njrow = s.row_impulse.shape[1]
    cap = con.depth.shape[1]
    # the bodies with a servo, in order, must be those the rows were laid out for
    k = 0
    ns = work.servoed.shape[0]
    for b in range(s.body_servo.shape[1]):
        if servo_on(s.body_servo, b):
            if k >= ns or work.servoed[k] != b:
                return False
            k += 1
    if k != ns:
        return False
    ncap = _row_capacity(njrow, ns, work.key[3], cap, o)
    project = njrow > 0 and o.projection > 0
    return (work.key[0] == cap and work.key[1] == ncap and work.key[2] == (1 if project else 0)
            and work.rows.rhs.shape[0] == ncap and work.gpos.shape[0] == m.geom_type.shape[0])


# What step_checked reports in its first field.
CALL_STEPPED, CALL_BAD_STATE, CALL_BAD_DRIVE, CALL_NEW_WORK = 0, 1, 2, 3


@njit(cache=True, inline="always")
def step_checked(m, s, con, pairs, n, o, ball, work):
    """The whole of ``World.step`` that runs compiled, in one call: check the state
    (``check_state``) and the drive inputs (``check_drives``; ``ball`` (njoint,) bool marks
    ball joints), hold static bodies still, feed MJCF position actuators' controls to
    their joint servos, then ``step_worlds`` with the scratch memory ``work``, and clear
    the applied forces, torques and joint torques once it has stepped.

    Returns (stage, code, world, index, step, needed): stage CALL_BAD_STATE or
    CALL_BAD_DRIVE with the check's (code, world, body or joint) and nothing changed;
    CALL_NEW_WORK when ``work`` does not fit (make it anew and call again); CALL_STEPPED
    with step_worlds' (status, world, body in index, step, needed).
    """
    code, w, b = check_state(s)
    if code != STATE_OK:
        return CALL_BAD_STATE, code, w, b, -1, 0
    code, w, i = check_drives(s, ball)
    if code != DRIVE_OK:
        return CALL_BAD_DRIVE, code, w, i, -1, 0
    if not work_fits(work, m, s, con, o):
        return CALL_NEW_WORK, 0, -1, -1, -1, 0
    hold_static(m, s)
    fold_position_actuators(m, s)
    status, fw, fk, fb, needed = step_worlds(m, s, con, pairs, n, o, work)
    if status == STEP_OK:
        clear_applied(s)
    return CALL_STEPPED, status, fw, fb, fk, needed


@njit(cache=True)
def box_step_args(m, s, con, pairs, ball, work):
    """The arrays ``step_checked`` takes, held in one Numba typed list (one item, the
    tuple (m, s, con, pairs, ball, work)) for ``step_boxed``.

    Each array handed from Python to compiled code gets a record of its shape and data
    and a reference made for it: for the step's ~210 arrays that was 5.6 us of a
    ``world.step(1)`` call's 25 us of overhead (the ragdoll, measured). A typed list
    crosses over as one object and holds the very same arrays (writes on either side
    are seen by the other), so it is made once and kept while none of them is replaced
    (``World`` drops it when it replaces one)."""
    box = List()
    box.append((m, s, con, pairs, ball, work))
    return box


@njit(cache=True)
def step_boxed(box, n, o):
    """``step_checked`` on the arrays held by ``box`` (``box_step_args``). ``step_checked``
    is inlined here (Numba IR): a call would count a reference to each of its ~210
    arrays on the way in and out (5 us). ``step_worlds`` is not: inlined, its loop ran
    1.5 us a step slower."""
    m, s, con, pairs, ball, work = box[0]
    return step_checked(m, s, con, pairs, n, o, ball, work)


@noalloc
def hold_static(m, s):
    """Zero the velocities of static bodies in every world (a user may have written them)."""
    for b in range(m.body_kind.shape[0]):
        if m.body_kind[b] == STATIC:
            for w in range(s.body_vel.shape[0]):
                for k in range(3):
                    s.body_vel[w, b, k] = 0.0
                    s.body_angvel[w, b, k] = 0.0


@noalloc
def clear_applied(s):
    """Applied forces, torques and joint torques last one step call: clear them after it."""
    s.applied_force[:] = 0.0
    s.applied_torque[:] = 0.0
    s.joint_applied[:] = 0.0


@noalloc
def fold_position_actuators(m, s):
    """MJCF position actuators that run as their joint's servo (``act_folded``): the
    control, clamped to its range, over the gear is the servo's target; target rate 0."""
    for a in range(m.act_joint.shape[0]):
        if not m.act_folded[a]:
            continue
        j = m.act_joint[a]
        for w in range(s.ctrl.shape[0]):
            c = min(max(s.ctrl[w, a], m.act_ctrlrange[a, 0]), m.act_ctrlrange[a, 1])
            s.pd_target_q[w, j, 0] = c / m.act_gear[a]
            s.pd_target_qd[w, j, 0] = 0.0


@njit(cache=True)
def step_worlds(m, s, con, pairs, n, o, work):
    """Advance every world of state ``s`` (contacts ``con``) by ``n`` steps.

    m : ModelArrays; s : StateArrays and con : ContactArrays (modified in place);
    pairs : (P, 2) broad-phase buffer; o : StepOptions; work : StepWork that fits
    (``make_step_work``, ``work_fits``).
    Returns (status, world, step, body, needed): status STEP_OK; STEP_DIVERGED with where
    the state first became non-finite or ran away; or STEP_MORE_PAIRS / STEP_MORE_CONTACTS
    with the buffer size needed. On any failure ``s`` is restored to its input.
    """
    nw = s.body_pos.shape[0]
    ng = m.geom_type.shape[0]
    njrow = s.row_impulse.shape[1]
    h = o.dt
    backup = (s.body_pos.copy(), s.body_quat.copy(), s.body_vel.copy(), s.body_angvel.copy(),
              s.row_impulse.copy(), s.contact_count.copy())
    con_backup = ContactArrays(con.geom.copy(), con.body.copy(), con.point.copy(),
                               con.normal.copy(), con.depth.copy(), con.feature.copy(),
                               con.friction.copy(), con.restitution.copy(), con.impulse.copy())
    force, torque, inv_inertia, rows, imp = (work.force, work.torque, work.inv_inertia,
                                             work.rows, work.imp)
    gpos, gquat, aabb_lo, aabb_hi, prev = (work.gpos, work.gquat, work.aabb_lo, work.aabb_hi,
                                           work.prev)
    vel_pred, angvel_pred, servoed = work.vel_pred, work.angvel_pred, work.servoed
    projection, caches = work.projection, work.caches
    nfix = njrow + 6 * servoed.shape[0]      # joint rows, then body servo rows, then contacts
    nper = work.key[3]                       # rows per contact: 3, or 6 with spin friction
    status, fail_w, fail_k, fail_b, needed = STEP_OK, -1, -1, -1, 0
    # explicit actuator work only when something could push: a servo off the implicit
    # path, an applied joint torque or an MJCF actuator
    has_servo = np.any(s.pd_kp > 0.0) or np.any(s.pd_kd > 0.0)
    has_drives = m.act_joint.shape[0] > 0 or np.any(s.joint_applied != 0.0) or (
        o.pd_mode == PD_EXPLICIT and has_servo)
    for w in range(nw):
        pos, quat = s.body_pos[w], s.body_quat[w]
        vel, angvel = s.body_vel[w], s.body_angvel[w]
        cw = ContactArrays(con.geom[w], con.body[w], con.point[w], con.normal[w], con.depth[w],
                           con.feature[w], con.friction[w], con.restitution[w], con.impulse[w])
        drive = JointDrive(s.motor_target[w], s.pd_kp[w], s.pd_kd[w], s.pd_max[w],
                           s.pd_target_quat[w], s.pd_target_q[w], s.pd_target_qd[w],
                           s.joint_applied[w])
        for k in range(n):
            ncon = np.int64(0)
            if ng > 1:
                nprev = s.contact_count[w]
                for c in range(nprev):
                    prev.geom[c, 0], prev.geom[c, 1] = cw.geom[c, 0], cw.geom[c, 1]
                    prev.feature[c] = cw.feature[c]
                    for q in range(cw.impulse.shape[1]):
                        prev.impulse[c, q] = cw.impulse[c, q]
                if work.key[4] == 1:
                    code, ncon = collide_listed(m, pos, quat, gpos, gquat, aabb_lo, aabb_hi,
                                                pairs, cw, nprev, prev, o.contact_margin,
                                                work.listed)
                else:
                    code, ncon = collide_world(m, pos, quat, gpos, gquat, aabb_lo, aabb_hi,
                                               pairs, cw, nprev, prev, o.contact_margin,
                                               o.broadphase, work.listed)
                if code != COLLIDE_OK:
                    status = STEP_MORE_PAIRS if code == COLLIDE_PAIRS_FULL else STEP_MORE_CONTACTS
                    fail_w, fail_k, needed = w, k, ncon
                    break
                s.contact_count[w] = ncon
            accumulate_forces(m, s.applied_force[w], s.applied_torque[w], force, torque)
            if has_drives:
                actuator_forces(m, pos, quat, vel, angvel, drive, s.ctrl[w], o.pd_mode,
                                force, torque)
            if has_servo and o.pd_mode == PD_STABLE:
                world_inverse_inertia(m, quat, inv_inertia)
                stable_servo_forces(m, pos, quat, vel, angvel, drive, h, o.erp, o.cfm,
                                    o.gyroscopic, o.tolerance, rows, imp, vel_pred,
                                    angvel_pred, inv_inertia, force, torque, caches[0])
            if o.contact == CONTACT_PENALTY and ncon > 0:
                penalty_forces(m, pos, quat, vel, angvel, cw, ncon, o.penalty_k, o.penalty_c,
                               o.v_slip, h, nper == ROWS_SPIN, force, torque)
            integrate_velocities(m, quat, vel, angvel, force, torque, h, o.gyroscopic)
            nrow = nfix + (nper * ncon if o.contact != CONTACT_PENALTY else 0)
            if nrow > 0:
                if njrow > 0:
                    build_joint_rows(m, pos, quat, vel, angvel, drive, h, o.erp, o.cfm, rows,
                                     o.pd_mode == PD_IMPLICIT)
                    imp[:njrow] = s.row_impulse[w]
                if nfix > njrow:
                    body_servo_rows(pos, quat, servoed, s.body_servo[w], s.body_target_pos[w],
                                    s.body_target_quat[w], s.body_target_vel[w],
                                    s.body_target_angvel[w], h, rows, njrow)
                    imp[njrow:nfix] = 0.0
                if nrow > nfix:
                    build_contact_rows(m, pos, vel, angvel, cw, ncon, nfix, nper, h,
                                       o.contact_erp, o.contact_cfm, o.slop,
                                       o.bounce_threshold, rows, imp)
                world_inverse_inertia(m, quat, inv_inertia)
                if not solve_fast(m, rows, nrow, ncon, inv_inertia, vel, angvel, imp, o,
                                  caches, work.fast):
                    s.lcp_fallbacks[w] += solve_rows(m, rows, nrow, nfix, ncon, inv_inertia, vel,
                                                     angvel, imp, o, caches)
                if njrow > 0:
                    s.row_impulse[w] = imp[:njrow]
                    if k == n - 1:       # what users read is the last step's: none before it
                        joint_reactions(m, pos, quat, rows, s.row_impulse[w], h,
                                        s.joint_force[w], s.joint_torque[w])
                if nrow > nfix:
                    store_contact_impulses(cw, ncon, nfix, nper, imp)
            integrate_positions(m, pos, quat, vel, angvel, h, o.quat_integration)
            if njrow > 0 and o.projection > 0:
                project_joints(m, pos, quat, rows, inv_inertia, o.projection,
                               o.projection_tolerance, projection)
            bad = first_bad_body(pos, quat, vel, angvel, o.divergence_limit)
            if bad >= 0:
                status, fail_w, fail_k, fail_b = STEP_DIVERGED, w, k, bad
                break
        if status != STEP_OK:
            break
        joint_coordinates(m, pos, quat, vel, angvel, s.joint_q[w], s.joint_qd[w], s.joint_qrel[w])
    if status != STEP_OK:
        s.body_pos[:] = backup[0]
        s.body_quat[:] = backup[1]
        s.body_vel[:] = backup[2]
        s.body_angvel[:] = backup[3]
        s.row_impulse[:] = backup[4]
        s.contact_count[:] = backup[5]
        con.geom[:] = con_backup.geom
        con.body[:] = con_backup.body
        con.point[:] = con_backup.point
        con.normal[:] = con_backup.normal
        con.depth[:] = con_backup.depth
        con.feature[:] = con_backup.feature
        con.friction[:] = con_backup.friction
        con.restitution[:] = con_backup.restitution
        con.impulse[:] = con_backup.impulse
        for w2 in range(nw):
            joint_coordinates(m, s.body_pos[w2], s.body_quat[w2], s.body_vel[w2],
                              s.body_angvel[w2], s.joint_q[w2], s.joint_qd[w2], s.joint_qrel[w2])
    return status, fail_w, fail_k, fail_b, needed
