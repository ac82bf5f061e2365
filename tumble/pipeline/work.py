"""Scratch memory of a step call: what the stages write between them, made once and kept
by ``World`` between calls (``make_step_work``) while it still fits (``work_fits``)."""
from collections import namedtuple

import numpy as np
from numba import njit

from .._jit import copy_arrays, noalloc
from ..model.types import DYNAMIC
from .actuators import servo_on, servoed_bodies
from .arrays import CONTACT_PENALTY
from .collide import listed_pairs, listed_primitives
from .contacts.arrays import make_contacts_nb
from .contacts.pairs import rows_per_contact
from .solve import make_solver_caches
from .solvers.common import make_rows_nb
from .solvers.mlcp import make_fast_scratch
from .stabilize import projection_setup

# Slots of ``StepWork.carry``: what one stage of the step hands the next within a world's
# step (``step.py``), and what ``step_worlds`` works out once per call for the forces.
(CARRY_NCON, CARRY_ASLEEP, CARRY_NROW, CARRY_NEEDED, CARRY_EXPLICIT_DRIVES,
 CARRY_STABLE_PD, CARRY_FAST) = range(7)
# From here on, the address of each of the stages' branches' code (``step.BRANCHES``),
# written by ``step_worlds`` at every call: addresses live only as long as the process.
CARRY_BRANCH = 7
BRANCH_COUNT = 7
CARRY_SLOTS = CARRY_BRANCH + BRANCH_COUNT

StepWork = namedtuple("StepWork", [
    "contact_capacity",   # int: contacts per world the contact arrays hold
    "row_capacity",       # int: rows laid out (joints, 6 per servoed body, contacts)
    "projecting",         # bool: joints are projected after the position update
    "rows_per_contact",   # int: 3, or 6 with spin friction
    "listed_primitive",   # bool: the listed pairs are all primitives (collide_listed)
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
    "caches",       # (direct, mlcp) tree-plan caches (solve.make_solver_caches)
    "fast",         # mlcp.FastScratch: the mixed LCP's common case without allocating
    "listed",       # (K, 2) int32 the geom pairs that may touch (collide.listed_pairs)
    "island",       # (nbody,) int64 each body's island (sleep.py)
    "island_rest",  # (nbody,) s the least time at rest in each island
    "awake",        # (nbody,) bool the dynamic bodies of awake islands
    "saved",        # Saved: the call's inputs, restored if it fails (call.save_inputs)
    "carry",        # (CARRY_SLOTS,) int64 what a stage hands the next (step.py)
    "penalty_lhs",  # (nbody, 6, 6) a free body's implicit penalty system (0 rows unless
                    # contacts are implicit penalty springs; contacts/penalty.py)
    "penalty_free", # (nbody,) bool dynamic bodies in no joint and without a body servo
])

# What a step call may change, copied before it (the worlds' leading axis kept): the
# state, the contacts (those below each world's count are the ones restored) and the four
# control arrays the checks and the position actuators write.
Saved = namedtuple("Saved", ["state", "contacts", "pd_target_quat", "body_target_quat",
                             "pd_target_q", "pd_target_qd"])


@njit(cache=True, inline="always")
def make_step_work(m, s, c, con, o):
    """Scratch memory for stepping the worlds of state ``s`` with controls ``c``, contacts
    ``con`` and options ``o`` (the arrays of every world of a serial step, or views of
    one world's slice for the threads' step)."""
    nb = s.body_pos.shape[1]
    ng = m.geom_type.shape[0]
    njrow = s.row_impulse.shape[1]
    cap = con.depth.shape[1]
    servoed = servoed_bodies(c.body_servo)
    nper = rows_per_contact(m)
    ncap = _row_capacity(njrow, servoed.shape[0], nper, cap, o)
    rows = make_rows_nb(ncap)
    project = njrow > 0 and o.projection > 0
    listed = listed_pairs(m, nb)
    caches = make_solver_caches(m, servoed, nb)
    return StepWork(np.int64(cap), np.int64(ncap), project, np.int64(nper),
                    listed_primitives(m, listed), np.empty((nb, 3)), np.empty((nb, 3)),
                    np.zeros((nb, 3, 3)), rows, np.zeros(ncap), np.zeros((ng, 3)),
                    np.zeros((ng, 4)), np.zeros((ng, 3)), np.zeros((ng, 3)),
                    make_contacts_nb(cap), np.empty((nb, 3)), np.empty((nb, 3)), servoed,
                    projection_setup(m, rows, nb, project), caches,
                    make_fast_scratch(ncap, nb, caches[1]), listed, np.zeros(nb, np.int64),
                    np.zeros(nb), np.ones(nb, np.bool_),
                    Saved(copy_arrays(s), copy_arrays(con), c.pd_target_quat.copy(),
                          c.body_target_quat.copy(), c.pd_target_q.copy(),
                          c.pd_target_qd.copy()),
                    np.zeros(CARRY_SLOTS, np.int64),
                    np.zeros((nb if _implicit_penalty(o) else 0, 6, 6)),
                    _unconstrained(m, servoed, nb))


@njit(cache=True, inline="always")
def _implicit_penalty(o):
    """Whether options ``o`` make free bodies' penalty springs implicit."""
    return o.contact == CONTACT_PENALTY and o.penalty_implicit


@njit(cache=True, inline="always")
def _unconstrained(m, servoed, nb):
    """(nb,) bool: the dynamic bodies that no joint and no body servo holds (their
    forces are final before the solve, so penalty springs can be implicit on them)."""
    free = np.zeros(nb, np.bool_)
    for b in range(nb):
        free[b] = m.body_kind[b] == DYNAMIC
    for j in range(m.joint_child.shape[0]):
        free[m.joint_child[j]] = False
        if m.joint_parent[j] >= 0:
            free[m.joint_parent[j]] = False
    for b in servoed:
        free[b] = False
    return free


@njit(cache=True, inline="always")
def _row_capacity(njrow, nservoed, nper, cap, o):
    """Rows a step lays out: the joints', six per servoed body, then ``nper`` for each of
    ``cap`` contacts unless contacts are penalty springs."""
    return njrow + 6 * nservoed + (nper * cap if o.contact != CONTACT_PENALTY else 0)


@noalloc(inline="always")
def work_fits(work, m, s, c, con, o):
    """Whether ``work`` (make_step_work) still fits the state, controls, contacts and
    options. (Inlined: a call passing the namedtuples compiled for 4 s, for their ~1,200
    fields.)"""
    if work.saved.state.body_pos.shape[0] != s.body_pos.shape[0]:
        return False
    njrow, cap, body_servo = s.row_impulse.shape[1], con.depth.shape[1], c.body_servo
    # the bodies with a servo, in order, must be those the rows were laid out for
    k = 0
    ns = work.servoed.shape[0]
    for b in range(body_servo.shape[1]):
        if servo_on(body_servo, b):
            if k >= ns or work.servoed[k] != b:
                return False
            k += 1
    if k != ns:
        return False
    ncap = _row_capacity(njrow, ns, work.rows_per_contact, cap, o)
    project = njrow > 0 and o.projection > 0
    return (work.contact_capacity == cap and work.row_capacity == ncap
            and work.projecting == project and work.rows.rhs.shape[0] == ncap
            and work.gpos.shape[0] == m.geom_type.shape[0]
            and (work.penalty_lhs.shape[0] > 0) == _implicit_penalty(o))
