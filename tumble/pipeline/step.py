"""The step: every stage of the pipeline, in order, ``n`` times, in one compiled call.

Each step of a world runs these stages, in this order (``step_worlds``), one compiled
function each (the ``*_stage`` functions below, named after ``arrays.STAGES``):

    collide_stage               contacts: broad phase, filtering, narrow phase (collide.py);
                                islands at rest put to sleep (sleep.py)
    forces_stage                gravity + applied forces and torques (forces.py), explicit
                                or stable PD servos, joint torques, MJCF actuators
                                (actuators.py), spring-damper contacts (contacts/penalty.py)
    integrate_velocities_stage  Newton-Euler, gyroscopic term explicit or implicit
                                (integrate.py)
    rows_stage                  constraint rows of every joint (joints/rows.py: ERP/CFM,
                                limits, motors, servos), implicit PD rows pulling bodies to
                                targets (actuators.py), contact rows (contacts/rows.py)
    solve_stage                 impulses that satisfy the rows (solve.py, solvers/), the
                                constrained velocities; each joint's force and torque on
                                its child (last step only)
    integrate_positions_stage   positions and orientations with the new velocities
    project_stage               joints projected back together (stabilize.py)
    check_stage                 divergence check (integrate.py)

and after a world's last step ``coordinates_stage`` reads its joint coordinates
(joints/rows.py). State arrays carry a leading world axis (nworld, nbody, ...); each world
is stepped on its own views (``_jit.world_of``). If any world diverges (or a buffer is too
small) the failing world, step and body are returned, and ``call.py`` -- the checks of the
inputs and the calls from Python -- undoes the whole call, every state, control and
contact array restored as it came in.

Why one compiled function per stage, called through its address: Numba re-optimises and
re-emits everything a compiled function calls when it compiles it cold, so a step that
linked its stages in paid for the whole pipeline once more at each level above them
(``step_worlds``, ``call.step_span``: 25 s each of a 324 s cold start). Each stage takes
the step's box (``_jit.ArgBox`` of the model, state, controls, contacts, pairs, ball-joint
marks and scratch; read by ``_jit.box_args`` without counting references), the world, the
step, the step count and the options -- one signature for all of them -- and
``step_worlds`` calls each through the address of its compiled code
(``stage_addresses``, ``_jit.call_address``): every stage compiles once, on its own (in
parallel processes on a cold start: ``tumble._compile``), and the step above them in
seconds. What a stage hands the next within a world's step (the contact count, the row
count, ...) goes through ``work.carry``.

Paths only some worlds take are the stages' *branches* (``BRANCHES``: the general collision
of convex hulls, heightfields and the broad phase; sleeping; penalty contacts; stable PD;
the three solves behind ``solve_fast``: PGS, direct, mixed LCP), each a compiled function
of the same signature that its stage calls through an address ``step_worlds`` hands it in
``work.carry``. A world compiles the branches its model and options call for
(``wanted_branches``) with the stages; one it takes unforeseen (its options changed, say)
returns STEP_MORE_CODE, and ``World`` compiles it and steps again, the call undone as for a
buffer too small. A character on a plane thus never compiles convex-hull collision or
stable PD, a chain of joints no contact solver, and the branches a world does take compile
in parallel processes beside the stages on a cold start.

With ``StepOptions.profile`` the step adds the time of each stage (``arrays.STAGES``) to
``StateArrays.stage_ticks``, in ``_jit.ticks`` units.
"""
from collections import namedtuple

import numpy as np
from numba import njit, typeof, types

from .._compile import compile_all
from .._jit import box_args, call_address, compiled_address, noalloc, ticks, world_of
from .actuators import (PD_EXPLICIT, PD_IMPLICIT, PD_STABLE, actuator_forces, body_servo_rows,
                        stable_servo_forces)
from .arrays import (CONTACT_LCP, CONTACT_PENALTY, CONTACT_PGS, SOLVER_PGS, STAGE_CHECK,
                     STAGE_COLLIDE, STAGE_COORDINATES, STAGE_FORCES, STAGES)
from .collide import (COLLIDE_OK, COLLIDE_PAIRS_FULL, collide_listed, collide_world,
                      listed_pairs, listed_primitives, none_may_collide)
from .contacts.arrays import copy_contact, pair_before
from .contacts.pairs import ROWS_SPIN
from .contacts.penalty import penalty_forces
from .contacts.rows import build_contact_rows, store_contact_impulses
from .forces import accumulate_forces
from .integrate import first_bad_body, integrate_positions, integrate_velocities
from .joints.rows import build_joint_rows, joint_coordinates, joint_reactions
from .joints.servo import JointDrive
from .solve import (SOLVE_DIRECT, SOLVE_LCP, SOLVE_PGS, clear_backoff, solve_direct_rows,
                    solve_fast, solve_lcp, solve_method, solve_pgs_rows)
from .solvers.common import world_inverse_inertia
from .sleep import freeze, sleep_islands
from .solvers.mlcp import FAST_SOLVED
from .stabilize import project_joints

from .work import (BRANCH_COUNT, CARRY_ASLEEP, CARRY_BRANCH, CARRY_EXPLICIT_DRIVES, CARRY_FAST,
                   CARRY_NCON, CARRY_NEEDED, CARRY_NROW, CARRY_STABLE_PD)

STEP_OK, STEP_DIVERGED, STEP_MORE_PAIRS, STEP_MORE_CONTACTS, STEP_MORE_CODE = 0, 1, 2, 3, 4

#: The stages' branches: paths only some worlds take, each a compiled function of the
#: stages' signature called through its address, compiled only for worlds that take it
#: (``wanted_branches``), or on the first step that does (STEP_MORE_CODE).
BRANCHES = ("general_collide", "sleep", "penalty_contact_forces", "stable_pd_forces",
            "pgs_solve", "direct_solve", "lcp_solve")
(BRANCH_GENERAL_COLLIDE, BRANCH_SLEEP, BRANCH_PENALTY, BRANCH_STABLE_PD, BRANCH_PGS_SOLVE,
 BRANCH_DIRECT_SOLVE, BRANCH_LCP_SOLVE) = range(7)
# solve.solve_method's methods run as the branches in the same order (solve_stage adds)
assert (BRANCH_DIRECT_SOLVE - BRANCH_PGS_SOLVE, BRANCH_LCP_SOLVE - BRANCH_PGS_SOLVE) == \
    (SOLVE_DIRECT - SOLVE_PGS, SOLVE_LCP - SOLVE_PGS)
assert len(BRANCHES) == BRANCH_COUNT

# What every stage returns (declared to ``_jit.call_address``).
_RESULT = types.int64


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


@njit(cache=True, inline="always")
def _world(box, w):
    """The model, world ``w``'s views of the state, controls and contacts, the pair buffer
    and the scratch, from the step's box (borrowed: inlined into ``noalloc`` stages)."""
    m, s, c, con, pairs, ball, work = box_args(box)
    return m, world_of(s, w), world_of(c, w), world_of(con, w), pairs, work


@njit(cache=True, inline="always")
def _drive(cw):
    """World ``cw``'s joint drive inputs (``JointDrive``)."""
    return JointDrive(cw.motor_target, cw.pd_kp, cw.pd_kd, cw.pd_max, cw.pd_target_quat,
                      cw.pd_target_q, cw.pd_target_qd, cw.joint_applied)


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


@njit(cache=True, inline="always")
def _branch(work, branch, args):
    """The stages' branch ``branch`` (``BRANCHES``) called with ``args``, through the
    address ``step_worlds`` left in ``work.carry``; STEP_MORE_CODE (the branch in
    CARRY_NEEDED) when this world's call has no code for it: ``World`` compiles it and
    steps again (the call undone, as for a buffer too small)."""
    address = work.carry[CARRY_BRANCH + branch]
    if address == 0:
        work.carry[CARRY_NEEDED] = branch
        return np.int64(STEP_MORE_CODE)
    return call_address(address, _RESULT, args)


@njit(cache=True, inline="always")
def _collided(work, code, ncon):
    """Collide's status for ``collide_listed``'s or ``collide_world``'s (code, count): the
    count into CARRY_NCON, or the buffer size needed into CARRY_NEEDED."""
    if code == COLLIDE_OK:
        work.carry[CARRY_NCON] = ncon
        return np.int64(STEP_OK)
    work.carry[CARRY_NEEDED] = ncon
    return np.int64(STEP_MORE_PAIRS if code == COLLIDE_PAIRS_FULL else STEP_MORE_CONTACTS)


# The stages. Each takes (box, w, k, n, o): the step's box, the world, the step (of n) and
# the options; returns STEP_OK or what stops the step, as an int64 (``step_worlds`` calls
# them declared so: ``stage_addresses`` checks). They allocate nothing (``noalloc``);
# the kernels that may (the general broad phase, stable PD, the exact solve) are
# ``_jit.allocating`` and count their own references.

@noalloc
def collide_stage(box, w, k, n, o):
    """Contacts of world ``w`` (``work.carry[CARRY_NCON]`` of them to treat), and islands
    at rest put to sleep. STEP_MORE_PAIRS or STEP_MORE_CONTACTS when a buffer is too small
    (the size needed in ``work.carry[CARRY_NEEDED]``)."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    ncon = np.int64(0)
    if m.geom_type.shape[0] > 1:
        keep_previous_contacts(sw, conw, work.prev, o.sleep_time > 0.0)
        if work.listed_primitive:
            code, ncon = collide_listed(m, sw.body_pos, sw.body_quat, work.gpos, work.gquat,
                                        work.aabb_lo, work.aabb_hi, pairs, conw,
                                        sw.contact_count[0], work.prev, o.contact_margin,
                                        work.listed, sw.body_rest, o.sleep_time)
            status = _collided(work, code, ncon)
        else:
            status = _branch(work, BRANCH_GENERAL_COLLIDE, (box, w, k, n, o))
        if status != STEP_OK:
            return status
        ncon = work.carry[CARRY_NCON]
        sw.contact_count[0] = ncon
    work.carry[CARRY_NCON] = ncon
    work.carry[CARRY_ASLEEP] = 0
    if o.sleep_time > 0.0:
        return _branch(work, BRANCH_SLEEP, (box, w, k, n, o))
    return np.int64(STEP_OK)


@noalloc
def forces_stage(box, w, k, n, o):
    """Forces on world ``w``: gravity and applied loads, explicit actuation and penalty
    contacts summed into ``work.force`` and ``work.torque``; stable PD's servo forces."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    accumulate_forces(m, cw.applied_force, cw.applied_torque, work.force, work.torque)
    if work.carry[CARRY_EXPLICIT_DRIVES] != 0:
        _explicit_forces(box, w, o)
    status = np.int64(STEP_OK)
    if o.contact == CONTACT_PENALTY and work.carry[CARRY_NCON] > 0:
        status = _branch(work, BRANCH_PENALTY, (box, w, k, n, o))
    if work.carry[CARRY_STABLE_PD] != 0 and status == STEP_OK:
        status = _branch(work, BRANCH_STABLE_PD, (box, w, k, n, o))
    return status


@noalloc
def integrate_velocities_stage(box, w, k, n, o):
    """World ``w``'s velocities under the forces (sleeping bodies kept still)."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    integrate_velocities(m, sw.body_quat, sw.body_vel, sw.body_angvel, work.force,
                         work.torque, o.dt, o.gyroscopic)
    if work.carry[CARRY_ASLEEP] > 0:
        freeze(sw.body_vel, sw.body_angvel, work.awake, m)
    return np.int64(STEP_OK)


@noalloc
def rows_stage(box, w, k, n, o):
    """Rows of world ``w`` (``work.carry[CARRY_NROW]`` of them): the joints' (warm-started
    from last step's impulses), six per servoed body, then the contacts', laid out in that
    order in ``work.rows`` and ``work.imp``; and the world inverse inertia the solvers
    take."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    ncon = work.carry[CARRY_NCON]
    njrow = sw.row_impulse.shape[0]
    nfix = njrow + 6 * work.servoed.shape[0]
    nrow = nfix + (work.rows_per_contact * ncon if o.contact != CONTACT_PENALTY else 0)
    work.carry[CARRY_NROW] = nrow
    if nrow == 0:
        return np.int64(STEP_OK)
    pos, quat, vel, angvel = sw.body_pos, sw.body_quat, sw.body_vel, sw.body_angvel
    rows, imp = work.rows, work.imp
    if njrow > 0:
        build_joint_rows(m, pos, quat, vel, angvel, _drive(cw), o.dt, o.erp, o.cfm, rows,
                         o.pd_mode == PD_IMPLICIT)
        for r in range(njrow):
            imp[r] = sw.row_impulse[r]
    if nfix > njrow:
        _body_servo_rows(box, w, o, njrow, nfix)
    if nrow > nfix:
        build_contact_rows(m, pos, vel, angvel, conw, ncon, nfix, work.rows_per_contact, o.dt,
                           o.contact_erp, o.contact_cfm, o.slop, o.bounce_threshold, rows, imp)
    world_inverse_inertia(m, quat, work.inv_inertia)
    return np.int64(STEP_OK)


@noalloc
def solve_stage(box, w, k, n, o):
    """Impulses for world ``w``'s rows and the velocities they make; the joints' impulses
    kept for the next step's warm start, the contacts' stored with them, and on the last
    step of the call (``k == n - 1``) each joint's reaction on its child."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    nrow, ncon = work.carry[CARRY_NROW], work.carry[CARRY_NCON]
    if nrow == 0:
        return np.int64(STEP_OK)
    vel, angvel = sw.body_vel, sw.body_angvel
    rows, imp, inv_inertia, caches = work.rows, work.imp, work.inv_inertia, work.caches
    fast = solve_fast(m, rows, nrow, ncon, inv_inertia, vel, angvel, imp, o, caches,
                      work.fast, sw.lcp_backoff)
    if fast == FAST_SOLVED:
        clear_backoff(sw.lcp_backoff)   # solved exactly: no back-off from Lemke
    else:
        work.carry[CARRY_FAST] = fast
        status = _branch(work, BRANCH_PGS_SOLVE + solve_method(o, ncon) - SOLVE_PGS,
                         (box, w, k, n, o))
        if status != STEP_OK:
            return status
    njrow = sw.row_impulse.shape[0]
    nfix = njrow + 6 * work.servoed.shape[0]
    if njrow > 0:
        for r in range(njrow):
            sw.row_impulse[r] = imp[r]
        if k == n - 1:            # what users read is the last step's: none before it
            joint_reactions(m, sw.body_pos, sw.body_quat, rows, sw.row_impulse, o.dt,
                            sw.joint_force, sw.joint_torque)
    if nrow > nfix:
        store_contact_impulses(conw, ncon, nfix, work.rows_per_contact, imp)
    if work.carry[CARRY_ASLEEP] > 0:
        freeze(vel, angvel, work.awake, m)
    return np.int64(STEP_OK)


@noalloc
def integrate_positions_stage(box, w, k, n, o):
    """World ``w``'s positions and orientations with its new velocities."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    integrate_positions(m, sw.body_pos, sw.body_quat, sw.body_vel, sw.body_angvel, o.dt,
                        o.quat_integration)
    return np.int64(STEP_OK)


@noalloc
def project_stage(box, w, k, n, o):
    """World ``w``'s joints projected back together (positions only), if asked for."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    if sw.row_impulse.shape[0] > 0 and o.projection > 0:
        project_joints(m, sw.body_pos, sw.body_quat, work.rows, work.inv_inertia,
                       o.projection, o.projection_tolerance, work.projection)
    return np.int64(STEP_OK)


@noalloc
def check_stage(box, w, k, n, o):
    """The first body of world ``w`` whose state is not finite or ran away, or -1."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    return np.int64(first_bad_body(sw.body_pos, sw.body_quat, sw.body_vel, sw.body_angvel,
                                   o.divergence_limit))


@noalloc
def coordinates_stage(box, w, k, n, o):
    """World ``w``'s joint coordinates from its bodies (after its last step)."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    joint_coordinates(m, sw.body_pos, sw.body_quat, sw.body_vel, sw.body_angvel, sw.joint_q,
                      sw.joint_qd, sw.joint_qrel)
    return np.int64(STEP_OK)


# The stages' less common paths, each reading the box itself: what a branch passes is then
# read from the box only when the branch runs. (Read once at a stage's start, the ~700
# values stable PD's call takes were loaded on every step of a world without it: 2% of
# the PD ragdoll's step.)

@noalloc
def _explicit_forces(box, w, o):
    """Forces: explicit PD servos, joint torques and MJCF actuators of world ``w``."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    actuator_forces(m, sw.body_pos, sw.body_quat, sw.body_vel, sw.body_angvel, _drive(cw),
                    cw.ctrl, o.pd_mode, work.force, work.torque)
    return 0


@noalloc
def _body_servo_rows(box, w, o, njrow, nfix):
    """Rows: six per servoed body of world ``w``, rows ``[njrow, nfix)``, impulses zero."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    body_servo_rows(sw.body_pos, sw.body_quat, work.servoed, cw.body_servo,
                    cw.body_target_pos, cw.body_target_quat, cw.body_target_vel,
                    cw.body_target_angvel, o.dt, work.rows, njrow)
    for r in range(njrow, nfix):
        work.imp[r] = 0.0
    return 0


# The branches (``BRANCHES``), in that order: the stages' paths some worlds never take,
# each called through its address (``_branch``) so that it compiles on its own, and only
# for a world that takes it. (Linked into their stages, the general collision and stable
# PD were 30% of ragdoll600's cold compile, 2026-12-07, which never runs either.)

@noalloc
def general_collide(box, w, k, n, o):
    """Collide, a scene that is not all listed primitive pairs: the broad phase, convex
    hulls and heightfields (``collide.collide_world``); what ``_collided`` says."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    code, ncon = collide_world(m, sw.body_pos, sw.body_quat, work.gpos, work.gquat,
                               work.aabb_lo, work.aabb_hi, pairs, conw, sw.contact_count[0],
                               work.prev, o.contact_margin, o.broadphase, work.listed,
                               sw.body_rest, o.sleep_time)
    return _collided(work, code, ncon)


@noalloc
def sleep(box, w, k, n, o):
    """Collide, last part: islands of world ``w`` at rest put to sleep, their contacts
    moved behind the awake ones; the awake contacts (those the step treats) into
    CARRY_NCON, the sleeping bodies into CARRY_ASLEEP."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    ncon, asleep = sleep_islands(m, sw.body_vel, sw.body_angvel, sw.body_rest, cw, conw,
                                 work.carry[CARRY_NCON], o, work.island, work.island_rest,
                                 work.awake, work.prev)
    work.carry[CARRY_NCON] = ncon
    work.carry[CARRY_ASLEEP] = asleep
    return np.int64(STEP_OK)


@noalloc
def penalty_contact_forces(box, w, k, n, o):
    """Forces: spring-damper contacts of world ``w`` (its first ``CARRY_NCON``)."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    penalty_forces(m, sw.body_pos, sw.body_quat, sw.body_vel, sw.body_angvel, conw,
                   work.carry[CARRY_NCON], o.penalty_k, o.penalty_c, o.v_slip, o.dt,
                   work.rows_per_contact == ROWS_SPIN, work.force, work.torque,
                   work.penalty_lhs, work.penalty_free)
    return np.int64(STEP_OK)


@noalloc
def stable_pd_forces(box, w, k, n, o):
    """Forces: stable PD's servo forces of world ``w`` (a solve of its joints ahead)."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    world_inverse_inertia(m, sw.body_quat, work.inv_inertia)
    stable_servo_forces(m, sw.body_pos, sw.body_quat, sw.body_vel, sw.body_angvel,
                        _drive(cw), o.dt, o.erp, o.cfm, o.gyroscopic, o.tolerance, work.rows,
                        work.imp, work.vel_pred, work.angvel_pred, work.inv_inertia,
                        work.force, work.torque, work.caches[0])
    return np.int64(STEP_OK)


# The three solves of ``solve.solve_method``, for the rows ``solve_fast`` did not solve.

@noalloc
def pgs_solve(box, w, k, n, o):
    """Solve: world ``w``'s rows by projected Gauss-Seidel (``solve.solve_pgs_rows``)."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    solve_pgs_rows(m, work.rows, work.carry[CARRY_NROW], work.inv_inertia, sw.body_vel,
                   sw.body_angvel, work.imp, o)
    return np.int64(STEP_OK)


@noalloc
def direct_solve(box, w, k, n, o):
    """Solve: world ``w``'s rows, none of them exact contacts, by the direct solver
    (``solve.solve_direct_rows``)."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    solve_direct_rows(m, work.rows, work.carry[CARRY_NROW], work.inv_inertia, sw.body_vel,
                      sw.body_angvel, work.imp, o, work.caches[0])
    return np.int64(STEP_OK)


@noalloc
def lcp_solve(box, w, k, n, o):
    """Solve: world ``w``'s rows with exact contacts by the mixed LCP (``solve.solve_lcp``;
    ``solve_fast``'s status in CARRY_FAST); PGS standing in for Lemke counted."""
    m, sw, cw, conw, pairs, work = _world(box, w)
    sw.lcp_fallbacks[0] += solve_lcp(m, work.rows, work.carry[CARRY_NROW],
                                     work.carry[CARRY_NCON], work.inv_inertia, sw.body_vel,
                                     sw.body_angvel, work.imp, o, work.caches[1],
                                     sw.lcp_backoff, work.carry[CARRY_FAST])
    return np.int64(STEP_OK)


#: The stage functions in the order of ``arrays.STAGES``.
STAGE_FUNCTIONS = (collide_stage, forces_stage, integrate_velocities_stage, rows_stage,
                   solve_stage, integrate_positions_stage, project_stage, check_stage,
                   coordinates_stage)

#: The branch functions in the order of ``BRANCHES``.
BRANCH_FUNCTIONS = (general_collide, sleep, penalty_contact_forces, stable_pd_forces,
                    pgs_solve, direct_solve, lcp_solve)

# Roughly what each stage and branch costs to compile cold, in seconds of one process
# (``bench/profile_compile.py`` on ragdoll600, 2026-12-07 on a quick machine; the stages,
# the direct and mixed-LCP solves and step_span re-measured in its ninth session on one
# about as fast): how ``_compile.compile_all`` shares them among processes.
_COMPILE_COST = (29.0, 5.0, 3.0, 16.0, 30.0, 2.0, 8.0, 1.0, 1.0)
_BRANCH_COST = (40.0, 6.0, 3.0, 30.0, 3.0, 15.0, 41.0)
# Stages and branches that share most of their callees, compiled in one process so that
# their shared code is compiled once: the collision's; the contact solvers' (the fast
# path and the mixed LCP: partition, tree factor, guesses); the direct solver's (also
# stable PD's). The two solver groups share only the tree's plan and factor, and apart
# they balance the two processes of a 2-core machine.
_COMPILE_GROUPS = ({collide_stage, general_collide, sleep},
                   {solve_stage, lcp_solve, pgs_solve}, {direct_solve, stable_pd_forces})
# What the process that hands out the stages compiles meanwhile (``call.step_span``).
_MEANWHILE_COST = 11.0

#: The addresses of the stages' compiled code (int), one field per ``arrays.STAGES``, then
#: of their branches' (``BRANCHES``; 0 for a branch not compiled for this call).
StageAddresses = namedtuple("StageAddresses", STAGES + BRANCHES)


def stage_signature(box, o):
    """The Numba argument types every stage takes for the box ``box`` and options ``o``."""
    return (box._numba_type_, types.int64, types.int64, types.int64, typeof(o))


def takes_general_collision(m):
    """Whether a world of the model arrays ``m`` collides by ``collide.collide_world``
    (the general collision branch): not every pair that may touch is of two primitives,
    or there are too many to list (as ``work.make_step_work`` decides)."""
    return m.geom_type.shape[0] > 1 and not listed_primitives(
        m, listed_pairs(m, m.body_kind.shape[0]))


def wanted_branches(m, o, general_collision):
    """The names of the branches (``BRANCHES``) a world of the model arrays ``m`` stepped
    with options ``o`` will take, to compile with the stages: the general collision when
    ``general_collision`` (``takes_general_collision(m)``, which a caller keeps: the model
    cannot change); sleeping, penalty contacts and stable PD when the options ask for
    them; and the solves ``solve.solve_method`` can pick: PGS when the options use it, the
    direct solve for joints or penalty contacts, the mixed LCP for exact contacts (none of
    the contact branches when no pair of geoms may touch). A
    branch missed here (body servos on a model without joints, say) compiles on the first
    step that takes it."""
    wanted = []
    # contacts are possible at all (a chain whose links touch nothing needs no contact
    # solve; a model that takes the general collision has pairs to collide)
    contacts = m.geom_type.shape[0] > 1 and (general_collision or not none_may_collide(m))
    if general_collision:
        wanted.append("general_collide")
    if o.sleep_time > 0.0:
        wanted.append("sleep")
    penalty = contacts and o.contact == CONTACT_PENALTY
    if penalty:
        wanted.append("penalty_contact_forces")
    if o.pd_mode == PD_STABLE:
        wanted.append("stable_pd_forces")
    if o.contact == CONTACT_PGS or o.solver == SOLVER_PGS:
        wanted.append("pgs_solve")
    if o.contact != CONTACT_PGS and (m.joint_row_count.sum() > 0 or penalty):
        wanted.append("direct_solve")
    if contacts and o.contact == CONTACT_LCP:
        wanted.append("lcp_solve")
    return tuple(wanted)


def stage_addresses(box, o, branches=(), compiled_only=False, meanwhile=()):
    """The stages' compiled code for the box ``box`` (``call.box_step_args``) and options
    ``o``, with the branches named in ``branches`` (``BRANCHES``) and any other branch
    this process has already compiled for them: a ``StageAddresses`` for ``step_worlds``.
    What this process has no code for yet is loaded from Numba's cache or compiled now,
    in parallel processes (``_compile.compile_all``), and ``meanwhile`` -- (dispatcher,
    argtypes) pairs, e.g. the step around the stages -- is compiled here while they are;
    with ``compiled_only``, None instead of compiling. Valid while the process lives."""
    unknown = set(branches) - set(BRANCHES)
    if unknown:
        raise ValueError(f"no such branch of the step: {sorted(unknown)}; "
                         f"the branches are {BRANCHES}")
    sig = stage_signature(box, o)
    wanted = [f for name, f in zip(BRANCHES, BRANCH_FUNCTIONS) if name in branches]
    functions = STAGE_FUNCTIONS + tuple(wanted)
    if compiled_only and any(sig not in f.overloads for f in functions):
        return None
    costs = dict(zip(STAGE_FUNCTIONS + BRANCH_FUNCTIONS, _COMPILE_COST + _BRANCH_COST))
    compile_all([(f, sig, costs[f]) for f in functions],
                [(d, argtypes, _MEANWHILE_COST) for d, argtypes in meanwhile],
                _COMPILE_GROUPS)
    for f in functions:             # step_worlds calls them as returning _RESULT
        if f.overloads[sig].signature.return_type != _RESULT:
            raise TypeError(f"{f.__name__} returns {f.overloads[sig].signature.return_type}, "
                            f"not {_RESULT}")
    return StageAddresses(*(compiled_address(f, sig) for f in STAGE_FUNCTIONS),
                          *(compiled_address(f, sig) if sig in f.overloads else 0
                            for f in BRANCH_FUNCTIONS))


@njit(cache=True, inline="always")
def _any_nonzero(a):
    """Whether any entry of the array ``a`` is nonzero (gains are never negative: checked
    on the way in), without the temporary array ``np.any(a != 0)`` would make."""
    for v in a.reshape(a.size):
        if v != 0.0:
            return True
    return False


@noalloc
def step_worlds(box, stages, n, o):
    """Advance every world of the box ``box`` (``call.box_step_args``: the model, state,
    controls, contacts, pairs, ball-joint marks and a scratch ``StepWork`` that fits) by
    ``n`` steps, the state and contacts modified in place; ``stages`` : the stages'
    compiled code (``stage_addresses``); o : StepOptions.

    Returns (status, world, step, body, needed): status STEP_OK; STEP_DIVERGED with where
    the state first became non-finite or ran away; or STEP_MORE_PAIRS / STEP_MORE_CONTACTS
    with the buffer size needed. On a failure it returns at once, the failing world
    mid-step: the caller restores what it saved (``call.py``).
    """
    m, s, c, con, pairs, ball, work = box_args(box)
    # explicit actuator work only when something could push: a servo off the implicit
    # path, an applied joint torque or an MJCF actuator
    servoed_joints = _any_nonzero(c.pd_kp) or _any_nonzero(c.pd_kd)
    work.carry[CARRY_EXPLICIT_DRIVES] = m.act_joint.shape[0] > 0 or _any_nonzero(
        c.joint_applied) or (o.pd_mode == PD_EXPLICIT and servoed_joints)
    work.carry[CARRY_STABLE_PD] = servoed_joints and o.pd_mode == PD_STABLE
    for b in range(BRANCH_COUNT):
        work.carry[CARRY_BRANCH + b] = stages[STAGE_COORDINATES + 1 + b]
    for w in range(s.body_pos.shape[0]):
        stage_ticks = s.stage_ticks[w]
        for k in range(n):
            args = (box, w, k, n, o)
            t = _start(o)
            status = call_address(stages[STAGE_COLLIDE], _RESULT, args)
            if status != STEP_OK:
                return status, w, k, np.int64(-1), work.carry[CARRY_NEEDED]
            t = _lap(o, stage_ticks, STAGE_COLLIDE, t)
            # forces, velocities, rows, solve, positions, projection: in arrays.STAGES order
            for stage in range(STAGE_FORCES, STAGE_CHECK):
                status = call_address(stages[stage], _RESULT, args)
                if status != STEP_OK:
                    return status, w, k, np.int64(-1), work.carry[CARRY_NEEDED]
                t = _lap(o, stage_ticks, stage, t)
            bad = call_address(stages[STAGE_CHECK], _RESULT, args)
            _lap(o, stage_ticks, STAGE_CHECK, t)
            if bad >= 0:
                return STEP_DIVERGED, w, k, bad, np.int64(0)
        t = _start(o)
        call_address(stages[STAGE_COORDINATES], _RESULT, (box, w, n - 1, n, o))
        _lap(o, stage_ticks, STAGE_COORDINATES, t)
    return STEP_OK, np.int64(-1), np.int64(-1), np.int64(-1), np.int64(0)
