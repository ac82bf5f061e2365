"""How ``World.step`` enters compiled code: the checks, the step and what surrounds it.

``step_span`` is the whole compiled part of a ``World.step`` for a run of worlds: save
the state, controls and contacts (``save_inputs``, into the scratch memory: no
allocation), check the state and the drive inputs (``checks.py``), hold static bodies
still, feed MJCF position actuators' controls to their joint servos (``prepare_inputs``),
step (``step.step_worlds``), then clear the applied forces -- or, if anything failed,
restore all it saved (``restore_inputs``), so a failed call leaves the world as it was:
every state and control array bit for bit, and each world's live contacts (those below
its contact count; the slots past it are scratch). A serial step calls it once for all
the worlds; ``parallel.step_boxed_parallel`` calls it on each thread for a span of
worlds and gives the verdict, clearing or restoring, itself.

Each array handed from Python to compiled code costs a record of its shape and data and a
reference (for the step's ~210 arrays, 5.6 us of a ``world.step(1)`` call's 25 us, on the
ragdoll). So the arrays cross over in one box (``_jit.ArgBox``, ``box_step_args``),
made once and kept by ``World`` while none of its arrays is replaced, and ``step_span``
is called through its compiled entry point (``_jit.ENTRY_POINTS``). The same compiled
``step_span`` serves the serial and the batched step (a box per span of worlds).
"""
import numpy as np
from numba import njit, typeof, types

from .._jit import ArgBox, assign_arrays, assign_heads, box_args, noalloc
from ..model.types import STATIC
from .checks import DRIVE_OK, STATE_OK, check_drives, check_state
from .step import STEP_OK, StageAddresses, stage_addresses, step_worlds
from .work import make_step_work, work_fits

# What step_span reports in its first field.
CALL_STEPPED, CALL_BAD_STATE, CALL_BAD_DRIVE, CALL_NEW_WORK = 0, 1, 2, 3


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
def clear_applied(c):
    """Applied forces, torques and joint torques last one step call: clear them after it."""
    c.applied_force[:] = 0.0
    c.applied_torque[:] = 0.0
    c.joint_applied[:] = 0.0


@noalloc
def fold_position_actuators(m, c):
    """MJCF position actuators that run as their joint's servo (``act_folded``): the
    control, clamped to its range, over the gear is the servo's target; target rate 0."""
    for a in range(m.act_joint.shape[0]):
        if not m.act_folded[a]:
            continue
        j = m.act_joint[a]
        for w in range(c.ctrl.shape[0]):
            u = min(max(c.ctrl[w, a], m.act_ctrlrange[a, 0]), m.act_ctrlrange[a, 1])
            c.pd_target_q[w, j, 0] = u / m.act_gear[a]
            c.pd_target_qd[w, j, 0] = 0.0


@njit(cache=True, inline="always")
def prepare_inputs(m, s, c, ball):
    """The checks, then the inputs made ready. Returns (stage, code, world, index) with
    stage CALL_STEPPED when the step may go on."""
    code, w, b = check_state(s, c)
    if code != STATE_OK:
        return CALL_BAD_STATE, code, w, b
    code, w, i = check_drives(c, ball)
    if code != DRIVE_OK:
        return CALL_BAD_DRIVE, code, w, i
    hold_static(m, s)
    fold_position_actuators(m, c)
    return CALL_STEPPED, 0, -1, -1


@noalloc
def step_span(box, stages, n, o, alone):
    """Check and step the worlds of the arrays in ``box`` (``box_step_args``: the model,
    state, controls and contacts -- of a whole batch, or views of a span of its worlds --
    a pair buffer, the ball-joint marks and scratch made for those worlds) ``n`` times;
    ``stages``: the step's stages' compiled code (``step.stage_addresses``).
    ``alone``: the box is the whole call (the serial step: it clears the applied loads
    once stepped, or restores everything on a failure); otherwise a thread's span of a
    batch (the caller gives the verdict, clears and restores).

    Returns (stage, code, world, index, step, needed), worlds numbered in the box: stage
    CALL_BAD_STATE or CALL_BAD_DRIVE with the check's (code, world, body or joint) and
    nothing changed; CALL_NEW_WORK when the scratch does not fit (make it anew and call
    again); CALL_STEPPED with step_worlds' (status, world, body in index, step, needed).

    It reads the box without counting references (``_jit.box_args``: a call with the
    runtime would count one for each of its ~210 arrays on the way in and out, 5 us).
    """
    m, s, c, con, pairs, ball, work = box_args(box)
    if not work_fits(work, m, s, c, con, o):
        return CALL_NEW_WORK, np.int64(0), np.int64(-1), np.int64(-1), np.int64(-1), np.int64(0)
    save_inputs(s, c, con, work.saved)
    stage, code, w, i = prepare_inputs(m, s, c, ball)
    if stage != CALL_STEPPED:
        if alone:
            restore_inputs(s, c, con, work.saved)
        return stage, code, w, i, np.int64(-1), np.int64(0)
    status, fw, fk, fb, needed = step_worlds(box, stages, n, o)
    if alone:
        if status == STEP_OK:
            clear_applied(c)
        else:
            restore_inputs(s, c, con, work.saved)
    return CALL_STEPPED, status, fw, fb, fk, needed


def step_span_signature(box, o):
    """The Numba argument types of ``step_span`` for the box ``box`` and options ``o``."""
    return (box._numba_type_, typeof(StageAddresses(*[0] * len(StageAddresses._fields))),
            types.int64, typeof(o), types.boolean)


def step_code(box, o, branches):
    """The stages' compiled code for the box ``box`` and options ``o``, with the branches
    named in ``branches`` (``step.stage_addresses``), and ``step_span`` compiled for them
    meanwhile (or loaded: in this process while worker processes compile the stages on a
    cold start)."""
    return stage_addresses(box, o, branches,
                           meanwhile=[(step_span, step_span_signature(box, o))])


@noalloc(inline="always")
def save_inputs(s, c, con, saved):
    """Copy what a call may change into ``saved`` (``work.Saved``, the same worlds): the
    state, each world's live contacts, and the four control arrays the preparation writes
    (target quaternions normalised, position actuators' targets); the step itself writes
    no control."""
    assign_arrays(saved.state, s)
    assign_heads(saved.contacts, con, s.contact_count)
    _copy_controls(saved, c)


@noalloc(inline="always")
def restore_inputs(s, c, con, saved):
    """Undo a failed call: everything ``save_inputs`` copied, put back."""
    assign_arrays(s, saved.state)
    assign_heads(con, saved.contacts, s.contact_count)
    _copy_controls(c, saved)


@njit(cache=True, inline="always")
def _copy_controls(dst, src):
    """The four control arrays a call writes, from ``src`` into ``dst`` (namedtuples
    holding them under the controls' names). Written out: the four kept as a tuple in
    ``Saved`` and copied by ``_jit.assign_arrays`` measured 2 us slower a call (of 14.5
    us for the ragdoll's ``step(0)``)."""
    for a, b in ((dst.pd_target_quat, src.pd_target_quat),
                 (dst.body_target_quat, src.body_target_quat)):
        for w in range(a.shape[0]):
            for i in range(a.shape[1]):
                for k in range(4):
                    a[w, i, k] = b[w, i, k]
    for a, b in ((dst.pd_target_q, src.pd_target_q), (dst.pd_target_qd, src.pd_target_qd)):
        for w in range(a.shape[0]):
            for i in range(a.shape[1]):
                for k in range(a.shape[2]):
                    a[w, i, k] = b[w, i, k]


@njit(cache=True)
def make_step_box(m, s, c, con, pairs, ball, o):
    """``box_step_args`` with a new scratch for these arrays and options ``o``
    (``work.make_step_work``): made in one call, so the scratch never crosses into Python
    (each crossing compiles code for every one of its arrays), and with both inlined
    (a call passing the namedtuples compiles for seconds, for their ~1,200 fields)."""
    return box_step_args(m, s, c, con, pairs, ball, make_step_work(m, s, c, con, o))


@njit(cache=True, inline="always")
def box_step_args(m, s, c, con, pairs, ball, work):
    """What ``step_span`` takes, the tuple (m, s, c, con, pairs, ball, work), in one
    ``ArgBox``: it crosses over as one object and holds the very same arrays (writes on
    either side are seen by the other)."""
    return ArgBox((m, s, c, con, pairs, ball, work))
