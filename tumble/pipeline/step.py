"""The step: every stage of the pipeline, in order, ``n`` times, in one compiled call.

Each step of a world runs these stages, in this order (``step_worlds``):

    collide.py            contacts: broad phase, filtering, narrow phase
    sleep.py              islands at rest put to sleep (when sleep_time is set)
    forces.py             gravity + applied forces and torques
    actuators.py          explicit (or stable) PD servos, joint torques, MJCF actuators
    contacts/penalty.py   spring-damper contact forces (contact="penalty")
    integrate.py          velocities: Newton-Euler, gyroscopic term explicit or implicit
    joints/rows.py        constraint rows of every joint (ERP/CFM, limits, motors, servos)
    actuators.py          implicit PD rows pulling bodies to targets (hand of god)
    contacts/rows.py      normal, friction (and spin-friction) rows of every contact
    solve.py              impulses that satisfy the rows (solvers/); constrained velocities
    joints/rows.py        each joint's force and torque on its child (last step only)
    integrate.py          positions and orientations with the new velocities
    stabilize.py          joints projected back together (positions only)
    integrate.py          divergence check

``step_worlds`` runs them ``n`` times for each world of a batch, then reads the joint
coordinates (joints/rows.py). State arrays carry a leading world axis (nworld,
nbody, ...); each world is stepped on its own views (``_jit.world_of``). If any world
diverges (or a buffer is too small) the failing world, step and body are returned, and
``call.py`` -- the checks of the inputs and the calls from Python -- undoes the whole call,
every state, control and contact array restored as it came in.

With ``StepOptions.profile`` the step adds the time of each stage (``arrays.STAGES``) to
``StateArrays.stage_ticks``, in ``_jit.ticks`` units.
"""
import numpy as np
from numba import njit

from .._jit import noalloc, ticks, world_of
from .actuators import (PD_EXPLICIT, PD_IMPLICIT, PD_STABLE, actuator_forces, body_servo_rows,
                        stable_servo_forces)
from .arrays import (CONTACT_PENALTY, STAGE_CHECK, STAGE_COLLIDE, STAGE_COORDINATES,
                     STAGE_FORCES, STAGE_INTEGRATE_POSITIONS, STAGE_INTEGRATE_VELOCITIES,
                     STAGE_PROJECT, STAGE_ROWS, STAGE_SOLVE)
from .collide import COLLIDE_OK, COLLIDE_PAIRS_FULL, collide_listed, collide_world
from .contacts.arrays import copy_contact, pair_before
from .contacts.pairs import ROWS_SPIN
from .contacts.penalty import penalty_forces
from .contacts.rows import build_contact_rows, store_contact_impulses
from .forces import accumulate_forces
from .integrate import first_bad_body, integrate_positions, integrate_velocities
from .joints.rows import build_joint_rows, joint_coordinates, joint_reactions
from .joints.servo import JointDrive
from .solve import solve_fast, solve_rows
from .solvers.common import world_inverse_inertia
from .sleep import freeze, sleep_islands
from .solvers.mlcp import FAST_SOLVED
from .stabilize import project_joints

STEP_OK, STEP_DIVERGED, STEP_MORE_PAIRS, STEP_MORE_CONTACTS = 0, 1, 2, 3


@njit(cache=True, inline="always")
def _start(o):
    """The clock at the start of a stage when profiling, else 0."""
    return ticks() if o.profile else np.int64(0)


@njit(cache=True, inline="always")
def _lap(o, stage_ticks, stage, t0):
    """Add the time since ``t0`` to ``stage_ticks[stage]`` when profiling; the clock now."""
    if not o.profile:
        return np.int64(0)
    t1 = ticks()
    stage_ticks[stage] += t1 - t0
    return t1


# The stages below take the namedtuples whole: they allocate nothing, so a call costs no
# reference counting (``_jit.noalloc``). The three stages that may allocate (the general
# broad phase, stable PD's solve, the exact solve) are called from ``step_worlds`` with the
# arrays it unpacked once per world, since an inlined helper taking the namedtuples would
# count a reference to each of their ~120 arrays at every step.

@noalloc
def keep_previous_contacts(s, con, prev, sleeping):
    """Collide, first part: last step's contacts of world ``s`` copied to ``prev`` in pair
    order, which the narrow phase matches for warm starts: geoms, feature ids, points and
    impulses, and with ``sleeping`` on everything (a pair of sleeping bodies takes its
    contacts whole). The sleep stage may have moved the sleeping contacts behind the awake
    ones: two runs in pair order, merged back into one."""
    n = s.contact_count[0]
    split = n
    for c in range(1, n):
        if pair_before(con, c, con, c - 1):
            split = c
            break
    i, j = 0, split
    for q in range(n):
        if j >= n or (i < split and pair_before(con, i, con, j)):
            src = i
            i += 1
        else:
            src = j
            j += 1
        copy_contact(con, src, prev, q, sleeping)


@noalloc
def find_listed_contacts(m, s, con, pairs, o, work):
    """Collide, for a model whose geom pairs that may touch are few and all primitives
    (``work.listed_primitive``): their boxes tested, then the narrow phase."""
    return collide_listed(m, s.body_pos, s.body_quat, work.gpos, work.gquat, work.aabb_lo,
                          work.aabb_hi, pairs, con, s.contact_count[0], work.prev,
                          o.contact_margin, work.listed, s.body_rest, o.sleep_time)


@noalloc
def add_forces(m, s, c, con, ncon, drive, o, work, explicit_drives):
    """Forces: gravity and applied loads, explicit actuation (``explicit_drives``) and
    penalty contacts, summed into ``work.force`` and ``work.torque``."""
    force, torque = work.force, work.torque
    accumulate_forces(m, c.applied_force, c.applied_torque, force, torque)
    if explicit_drives:
        actuator_forces(m, s.body_pos, s.body_quat, s.body_vel, s.body_angvel, drive, c.ctrl,
                        o.pd_mode, force, torque)
    if o.contact == CONTACT_PENALTY and ncon > 0:
        penalty_forces(m, s.body_pos, s.body_quat, s.body_vel, s.body_angvel, con, ncon,
                       o.penalty_k, o.penalty_c, o.v_slip, o.dt,
                       work.rows_per_contact == ROWS_SPIN, force, torque)


@noalloc
def build_rows(m, s, c, con, ncon, nrow, drive, o, work):
    """Rows: the joints' (warm-started from last step's impulses), six per servoed body,
    then the contacts', laid out in that order in ``work.rows`` and ``work.imp``; and the
    world inverse inertia the solvers take."""
    njrow = s.row_impulse.shape[0]
    nfix = njrow + 6 * work.servoed.shape[0]
    pos, quat, vel, angvel = s.body_pos, s.body_quat, s.body_vel, s.body_angvel
    rows, imp = work.rows, work.imp
    if njrow > 0:
        build_joint_rows(m, pos, quat, vel, angvel, drive, o.dt, o.erp, o.cfm, rows,
                         o.pd_mode == PD_IMPLICIT)
        for r in range(njrow):
            imp[r] = s.row_impulse[r]
    if nfix > njrow:
        body_servo_rows(pos, quat, work.servoed, c.body_servo, c.body_target_pos,
                        c.body_target_quat, c.body_target_vel, c.body_target_angvel, o.dt,
                        rows, njrow)
        for r in range(njrow, nfix):
            imp[r] = 0.0
    if nrow > nfix:
        build_contact_rows(m, pos, vel, angvel, con, ncon, nfix, work.rows_per_contact, o.dt,
                           o.contact_erp, o.contact_cfm, o.slop, o.bounce_threshold, rows, imp)
    world_inverse_inertia(m, quat, work.inv_inertia)


@noalloc
def keep_impulses(m, s, con, ncon, nrow, o, work, last):
    """Solve, last part: the joints' impulses kept for the next step's warm start, the
    contacts' stored with them, and on the ``last`` step of the call each joint's
    reaction on its child."""
    njrow = s.row_impulse.shape[0]
    nfix = njrow + 6 * work.servoed.shape[0]
    if njrow > 0:
        for r in range(njrow):
            s.row_impulse[r] = work.imp[r]
        if last:            # what users read is the last step's: none before it
            joint_reactions(m, s.body_pos, s.body_quat, work.rows, s.row_impulse, o.dt,
                            s.joint_force, s.joint_torque)
    if nrow > nfix:
        store_contact_impulses(con, ncon, nfix, work.rows_per_contact, work.imp)


@njit(cache=True)
def step_worlds(m, s, c, con, pairs, n, o, work):
    """Advance every world of state ``s`` by ``n`` steps.

    m : ModelArrays; s : StateArrays, c : ControlArrays and con : ContactArrays (``s`` and
    ``con`` modified in place); pairs : (P, 2) broad-phase buffer; o : StepOptions; work :
    StepWork that fits (``work.make_step_work``, ``work.work_fits``).
    Returns (status, world, step, body, needed): status STEP_OK; STEP_DIVERGED with where
    the state first became non-finite or ran away; or STEP_MORE_PAIRS / STEP_MORE_CONTACTS
    with the buffer size needed. On a failure it returns at once, the failing world
    mid-step: the caller restores what it saved (``call.py``).

    Each step of a world (a substep) runs the stages in order: collide, sleep, forces,
    integrate velocities, rows, solve, integrate positions, project joints, divergence
    check; after the last, the joint coordinates.
    """
    ng = m.geom_type.shape[0]
    njrow = s.row_impulse.shape[1]
    rows, imp, inv_inertia, caches = work.rows, work.imp, work.inv_inertia, work.caches
    # explicit actuator work only when something could push: a servo off the implicit
    # path, an applied joint torque or an MJCF actuator
    servoed_joints = np.any(c.pd_kp > 0.0) or np.any(c.pd_kd > 0.0)
    explicit_drives = m.act_joint.shape[0] > 0 or np.any(c.joint_applied != 0.0) or (
        o.pd_mode == PD_EXPLICIT and servoed_joints)
    stable_pd = servoed_joints and o.pd_mode == PD_STABLE
    for w in range(s.body_pos.shape[0]):
        sw, cw, conw = world_of(s, w), world_of(c, w), world_of(con, w)
        pos, quat, vel, angvel = sw.body_pos, sw.body_quat, sw.body_vel, sw.body_angvel
        drive = JointDrive(cw.motor_target, cw.pd_kp, cw.pd_kd, cw.pd_max, cw.pd_target_quat,
                           cw.pd_target_q, cw.pd_target_qd, cw.joint_applied)
        for k in range(n):
            t = _start(o)
            # collide
            ncon = np.int64(0)
            if ng > 1:
                keep_previous_contacts(sw, conw, work.prev, o.sleep_time > 0.0)
                if work.listed_primitive:
                    code, ncon = find_listed_contacts(m, sw, conw, pairs, o, work)
                else:
                    code, ncon = collide_world(m, pos, quat, work.gpos, work.gquat,
                                               work.aabb_lo, work.aabb_hi, pairs, conw,
                                               sw.contact_count[0], work.prev,
                                               o.contact_margin, o.broadphase, work.listed,
                                               sw.body_rest, o.sleep_time)
                if code != COLLIDE_OK:
                    return (STEP_MORE_PAIRS if code == COLLIDE_PAIRS_FULL
                            else STEP_MORE_CONTACTS), w, k, -1, ncon
                sw.contact_count[0] = ncon
            # sleep: contacts with an awake body first, the ncon of them the step treats
            asleep = 0
            if o.sleep_time > 0.0:
                ncon, asleep = sleep_islands(m, vel, angvel, sw.body_rest, cw, conw, ncon, o,
                                             work.island, work.island_rest, work.awake,
                                             work.prev)
            t = _lap(o, sw.stage_ticks, STAGE_COLLIDE, t)
            # forces
            add_forces(m, sw, cw, conw, ncon, drive, o, work, explicit_drives)
            if stable_pd:
                world_inverse_inertia(m, quat, inv_inertia)
                stable_servo_forces(m, pos, quat, vel, angvel, drive, o.dt, o.erp, o.cfm,
                                    o.gyroscopic, o.tolerance, rows, imp, work.vel_pred,
                                    work.angvel_pred, inv_inertia, work.force, work.torque,
                                    caches[0])
            t = _lap(o, sw.stage_ticks, STAGE_FORCES, t)
            integrate_velocities(m, quat, vel, angvel, work.force, work.torque, o.dt,
                                 o.gyroscopic)
            if asleep > 0:
                freeze(vel, angvel, work.awake, m)
            t = _lap(o, sw.stage_ticks, STAGE_INTEGRATE_VELOCITIES, t)
            nrow = njrow + 6 * work.servoed.shape[0] + (
                work.rows_per_contact * ncon if o.contact != CONTACT_PENALTY else 0)
            if nrow > 0:
                build_rows(m, sw, cw, conw, ncon, nrow, drive, o, work)
                t = _lap(o, sw.stage_ticks, STAGE_ROWS, t)
                # solve
                fast = solve_fast(m, rows, nrow, ncon, inv_inertia, vel, angvel, imp, o,
                                  caches, work.fast)
                if fast == FAST_SOLVED:
                    sw.lcp_backoff[0] = 0           # solved exactly: no back-off from Lemke
                    sw.lcp_backoff[1] = 0
                else:
                    sw.lcp_fallbacks[0] += solve_rows(m, rows, nrow, ncon, inv_inertia, vel,
                                                      angvel, imp, o, caches,
                                                      sw.lcp_backoff, fast)
                keep_impulses(m, sw, conw, ncon, nrow, o, work, k == n - 1)
                if asleep > 0:
                    freeze(vel, angvel, work.awake, m)
                t = _lap(o, sw.stage_ticks, STAGE_SOLVE, t)
            integrate_positions(m, pos, quat, vel, angvel, o.dt, o.quat_integration)
            t = _lap(o, sw.stage_ticks, STAGE_INTEGRATE_POSITIONS, t)
            if njrow > 0 and o.projection > 0:
                project_joints(m, pos, quat, rows, inv_inertia, o.projection,
                               o.projection_tolerance, work.projection)
            t = _lap(o, sw.stage_ticks, STAGE_PROJECT, t)
            bad = first_bad_body(pos, quat, vel, angvel, o.divergence_limit)
            _lap(o, sw.stage_ticks, STAGE_CHECK, t)
            if bad >= 0:
                return STEP_DIVERGED, w, k, bad, np.int64(0)
        t = _start(o)
        joint_coordinates(m, pos, quat, vel, angvel, sw.joint_q, sw.joint_qd, sw.joint_qrel)
        _lap(o, sw.stage_ticks, STAGE_COORDINATES, t)
    return STEP_OK, -1, -1, -1, np.int64(0)
