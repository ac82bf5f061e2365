"""How ``World.step`` enters compiled code: the checks, the step and what surrounds it.

``step_checked`` is the whole compiled part of a serial ``World.step``: save the state,
controls and contacts, check the state and the drive inputs (``checks.py``), hold static
bodies still, feed MJCF position actuators' controls to their joint servos, step
(``step.step_worlds``), then clear the applied forces -- or, if the step failed, restore
all it saved, so a failed call leaves the world bit for bit as it was.
``step_checked_parallel`` is the same around ``parallel.step_worlds_parallel``.

Each array handed from Python to compiled code costs a record of its shape and data and a
reference (for the step's ~210 arrays, 5.6 us of a ``world.step(1)`` call's 25 us, on the
ragdoll). So the serial path hands over one box holding them all (``_jit.ArgBox``)
(``box_step_args``), made once and kept by ``World`` while none of its arrays is replaced,
and calls ``step_boxed`` through its compiled entry point (``_jit.ENTRY_POINTS``).
"""
import numpy as np
from numba import njit

from .._jit import ArgBox, assign_arrays, copy_arrays, noalloc
from ..model.types import STATIC
from .checks import DRIVE_OK, STATE_OK, check_drives, check_state
from .parallel import step_worlds_parallel, world_works_fit
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
def _prepare(m, s, c, ball):
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
    every state, control and contact array restored as it came in.

    Returns (stage, code, world, index, step, needed): stage CALL_BAD_STATE or
    CALL_BAD_DRIVE with the check's (code, world, body or joint) and nothing changed;
    CALL_NEW_WORK when ``work`` does not fit (make it anew and call again); CALL_STEPPED
    with step_worlds' (status, world, body in index, step, needed).
    """
    if not work_fits(work, m, s, c, con, o):
        return CALL_NEW_WORK, 0, -1, -1, -1, np.int64(0)
    saved = _save(s, c, con)
    stage, code, w, i = _prepare(m, s, c, ball)
    if stage != CALL_STEPPED:
        return stage, code, w, i, -1, np.int64(0)
    status, fw, fk, fb, needed = step_worlds(m, s, c, con, pairs, n, o, work)
    _finish(s, c, con, saved, status)
    return CALL_STEPPED, status, fw, fb, fk, needed


@njit(cache=True)
def step_checked_parallel(m, s, c, con, pairs, n, o, ball, works):
    """``step_checked`` with the worlds spread over Numba's threads, each world with its
    scratch memory in ``works`` (``parallel.make_world_works``; CALL_NEW_WORK when they
    do not fit)."""
    if not world_works_fit(works, m, s, c, con, o):
        return CALL_NEW_WORK, 0, -1, -1, -1, np.int64(0)
    saved = _save(s, c, con)
    stage, code, w, i = _prepare(m, s, c, ball)
    if stage != CALL_STEPPED:
        return stage, code, w, i, -1, np.int64(0)
    status, fw, fk, fb, needed = step_worlds_parallel(m, s, c, con, pairs, n, o, works)
    _finish(s, c, con, saved, status)
    return CALL_STEPPED, status, fw, fb, fk, needed


@njit(cache=True, inline="always")
def _save(s, c, con):
    """Copies of what a call may change: the state, the contacts, and the four control
    arrays the preparation writes (target quaternions normalised, position actuators'
    targets); the step itself writes no control."""
    return (copy_arrays(s), copy_arrays(con), c.pd_target_quat.copy(),
            c.body_target_quat.copy(), c.pd_target_q.copy(), c.pd_target_qd.copy())


@njit(cache=True, inline="always")
def _finish(s, c, con, saved, status):
    """After the step: the applied loads cleared if it stepped, else everything restored
    from ``saved`` (``_save``, taken before the checks normalised anything)."""
    if status == STEP_OK:
        clear_applied(c)
    else:
        assign_arrays(s, saved[0])
        assign_arrays(con, saved[1])
        c.pd_target_quat[:] = saved[2]
        c.body_target_quat[:] = saved[3]
        c.pd_target_q[:] = saved[4]
        c.pd_target_qd[:] = saved[5]


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
