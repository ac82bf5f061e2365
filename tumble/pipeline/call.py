"""How ``World.step`` enters compiled code: the checks, the step and what surrounds it.

``step_checked`` is the whole compiled part of a serial ``World.step``: save the state,
controls and contacts (``save_inputs``, into the scratch memory: no allocation), check
the state and the drive inputs (``checks.py``), hold static bodies still, feed MJCF
position actuators' controls to their joint servos (``prepare_inputs``), step
(``step.step_worlds``), then clear the applied forces -- or, if anything failed, restore
all it saved (``restore_inputs``), so a failed call leaves the world as it was: every
state and control array bit for bit, and each world's live contacts (those below its
contact count; the slots past it are scratch). ``parallel.step_checked_parallel`` does
the same with each world's saving, checks and step on a thread.

Each array handed from Python to compiled code costs a record of its shape and data and a
reference (for the step's ~210 arrays, 5.6 us of a ``world.step(1)`` call's 25 us, on the
ragdoll). So the serial path hands over one box holding them all (``_jit.ArgBox``)
(``box_step_args``), made once and kept by ``World`` while none of its arrays is replaced,
and calls ``step_boxed`` through its compiled entry point (``_jit.ENTRY_POINTS``).
"""
import numpy as np
from numba import njit

from .._jit import ArgBox, assign_arrays, assign_heads, noalloc
from ..model.types import STATIC
from .checks import DRIVE_OK, STATE_OK, check_drives, check_state
from .step import STEP_OK, step_worlds
from .work import work_fits

# What step_checked reports in its first field.
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


@njit(cache=True, inline="always")
def step_checked(m, s, c, con, pairs, n, o, ball, work):
    """The whole of a serial ``World.step`` that runs compiled: checks (``ball``
    (njoint,) bool marks ball joints, whose targets must not be zero), the step with the
    scratch memory ``work``, the applied loads cleared once it has stepped; on a failure
    every state and control array and the live contacts restored as they came in.

    Returns (stage, code, world, index, step, needed): stage CALL_BAD_STATE or
    CALL_BAD_DRIVE with the check's (code, world, body or joint) and nothing changed;
    CALL_NEW_WORK when ``work`` does not fit (make it anew and call again); CALL_STEPPED
    with step_worlds' (status, world, body in index, step, needed).
    """
    if not work_fits(work, m, s, c, con, o):
        return CALL_NEW_WORK, 0, -1, -1, -1, np.int64(0)
    save_inputs(s, c, con, work.saved)
    stage, code, w, i = prepare_inputs(m, s, c, ball)
    if stage != CALL_STEPPED:
        restore_inputs(s, c, con, work.saved)
        return stage, code, w, i, -1, np.int64(0)
    status, fw, fk, fb, needed = step_worlds(m, s, c, con, pairs, n, o, work)
    if status == STEP_OK:
        clear_applied(c)
    else:
        restore_inputs(s, c, con, work.saved)
    return CALL_STEPPED, status, fw, fb, fk, needed


@noalloc
def save_inputs(s, c, con, saved):
    """Copy what a call may change into ``saved`` (``work.Saved``, the same worlds): the
    state, each world's live contacts, and the four control arrays the preparation writes
    (target quaternions normalised, position actuators' targets); the step itself writes
    no control."""
    assign_arrays(saved.state, s)
    assign_heads(saved.contacts, con, s.contact_count)
    _copy_controls(saved, c)


@noalloc
def restore_inputs(s, c, con, saved):
    """Undo a failed call: everything ``save_inputs`` copied, put back."""
    assign_arrays(s, saved.state)
    assign_heads(con, saved.contacts, s.contact_count)
    _copy_controls(c, saved)


@njit(cache=True, inline="always")
def _copy_controls(dst, src):
    """The four control arrays a call writes, from ``src`` into ``dst`` (namedtuples
    holding them under the controls' names)."""
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
def box_step_args(m, s, c, con, pairs, ball, work):
    """The arrays ``step_checked`` takes, the tuple (m, s, c, con, pairs, ball, work), in
    one ``ArgBox`` for ``step_boxed``: it crosses over as one object and holds the very
    same arrays (writes on either side are seen by the other)."""
    return ArgBox((m, s, c, con, pairs, ball, work))


@njit(cache=True)
def step_boxed(box, n, o):
    """``step_checked`` on the arrays held by ``box`` (``box_step_args``). ``step_checked``
    is inlined here (Numba IR): a call would count a reference to each of its ~210 arrays
    on the way in and out (5 us). ``step_worlds`` is not: inlined, its loop ran 1.5 us a
    step slower."""
    m, s, c, con, pairs, ball, work = box.args
    return step_checked(m, s, c, con, pairs, n, o, ball, work)
