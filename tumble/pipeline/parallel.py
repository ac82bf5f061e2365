"""Batched worlds on all cores: ``step_checked_parallel``, one world per task.

``call.step_checked`` checks, steps and (on a failure) restores the worlds of a batch one
after another; this entry point hands each world to a thread (Numba's ``prange``) as a
batch of one -- views of that world's slice of every state, control and contact array --
and the thread does all of it for its world: the scratch memory checked, the world's
inputs saved, checked and prepared (``call.save_inputs``, ``call.prepare_inputs``), then
``step.step_worlds``. So each world runs exactly the code of the serial path and its
result is bit-identical to it, and nothing of a call but its verdict runs on one thread
(a serial save and check of the whole batch cost 18 us a world of each call: a quarter
of a walking character's step(2) on two threads).

The worlds share no scratch memory: each has its own ``StepWork`` (``make_world_works``,
kept by the World between calls while they fit: a world's work holds its solver's tree
plan, which a fresh one would have to plan again on the first step of every call), with
its inputs' copy, and its own broad-phase buffer.

Failures are reported as by the serial path (``first_failure``): scratch that does not
fit first, then the first state check that fails, the first drive check, the first world
that diverged or needs larger buffers -- and every world is restored to its input.
(The serial path stops at that world; here the others have run meanwhile and are rolled
back too, which costs time but not results.)

The view helper (``tumble._jit.worlds_view``) works on any namedtuple of arrays whose
leading axis is the world, so state fields added later need no change here -- as long as
the step treats each world on its own, without decisions taken over the whole batch.
"""
import numpy as np
from numba import njit, prange
from numba.typed import List

from .._jit import ArgBox, worlds_view
from .call import (CALL_BAD_DRIVE, CALL_BAD_STATE, CALL_NEW_WORK, CALL_STEPPED, clear_applied,
                   prepare_inputs, restore_inputs, save_inputs)
from .checks import DRIVE_ZERO_BODY_QUAT
from .step import STEP_OK, step_worlds
from .work import fits_world, make_step_work

# Columns of each world's outcome in step_checked_parallel.
_STAGE, _CODE, _INDEX, _STEP, _NEEDED, _SAVED = range(6)


@njit(cache=True)
def make_world_works(m, s, c, con, o):
    """A typed list of one ``StepWork`` per world of ``s`` (each made for that world's
    slice of the arrays)."""
    works = List()
    for w in range(s.body_pos.shape[0]):
        works.append(make_step_work(m, worlds_view(s, w, w + 1), worlds_view(c, w, w + 1),
                                    worlds_view(con, w, w + 1), o))
    return works


@njit(cache=True, parallel=True)
def step_checked_parallel(m, s, c, con, pairs, n, o, ball, works):
    """``call.step_checked`` with the worlds spread over Numba's threads.

    Same arguments and result as ``call.step_checked``, but ``works`` holds each world's
    scratch memory (``make_world_works``; CALL_NEW_WORK when one does not fit) and
    ``pairs`` gives the size of each world's broad-phase buffer. The thread count is
    Numba's (``numba.set_num_threads``).
    """
    nw = s.body_pos.shape[0]
    if len(works) != nw:
        return CALL_NEW_WORK, 0, -1, -1, -1, np.int64(0)
    njrow, cap = s.row_impulse.shape[1], con.depth.shape[1]
    out = np.zeros((nw, 6), np.int64)
    for w in prange(nw):
        i = np.int64(w)         # prange's index is unsigned; the typed list takes a signed one
        work = works[i]
        if not fits_world(work, m, njrow, cap, c.body_servo[i:i + 1], o):
            out[i, _STAGE] = CALL_NEW_WORK
        else:
            sw, cw, conw = worlds_view(s, i, i + 1), worlds_view(c, i, i + 1), \
                worlds_view(con, i, i + 1)
            save_inputs(sw, cw, conw, work.saved)
            out[i, _SAVED] = 1
            stage, code, _, index = prepare_inputs(m, sw, cw, ball)
            if stage != CALL_STEPPED:
                out[i, _STAGE], out[i, _CODE], out[i, _INDEX] = stage, code, index
            else:
                status, _, k, b, needed = step_worlds(m, sw, cw, conw, np.empty_like(pairs),
                                                      n, o, work)
                out[i, _STAGE], out[i, _CODE], out[i, _INDEX] = CALL_STEPPED, status, b
                out[i, _STEP], out[i, _NEEDED] = k, needed
    w = first_failure(out)
    if w < 0:
        clear_applied(c)
        return CALL_STEPPED, STEP_OK, -1, -1, -1, np.int64(0)
    for v in range(nw):
        if out[v, _SAVED]:
            restore_inputs(worlds_view(s, v, v + 1), worlds_view(c, v, v + 1),
                           worlds_view(con, v, v + 1), works[v].saved)
    if out[w, _STAGE] == CALL_NEW_WORK:
        return CALL_NEW_WORK, 0, -1, -1, -1, np.int64(0)
    return (out[w, _STAGE], out[w, _CODE], w, out[w, _INDEX], out[w, _STEP],
            out[w, _NEEDED])


@njit(cache=True)
def box_parallel_args(m, s, c, con, pairs, ball, works):
    """The arrays ``step_checked_parallel`` takes, the tuple (m, s, c, con, pairs, ball,
    works), in one ``ArgBox`` for ``step_boxed_parallel`` (``call.box_step_args``: one
    object to hand over instead of ~100 arrays and a list)."""
    return ArgBox((m, s, c, con, pairs, ball, works))


@njit(cache=True)
def step_boxed_parallel(box, n, o):
    """``step_checked_parallel`` on the arrays held by ``box`` (``box_parallel_args``)."""
    m, s, c, con, pairs, ball, works = box.args
    return step_checked_parallel(m, s, c, con, pairs, n, o, ball, works)


@njit(cache=True)
def first_failure(out):
    """The world whose failure the serial path would report, from each world's outcome
    ``out`` (nworld, 6) (stage, code, index, step, needed, saved), or -1 if all stepped.

    The serial path checks the scratch, then every world's state, then every world's
    drives field by field (and, past the fields, world by world), then steps world by
    world; so: any scratch that does not fit, else the first world with a bad state, else
    the bad drive with the least (field, world), else the first world that failed to
    step."""
    nw = out.shape[0]
    for stage in (CALL_NEW_WORK, CALL_BAD_STATE):
        for w in range(nw):
            if out[w, _STAGE] == stage:
                return w
    best, best_key = -1, (0, 0)
    for w in range(nw):
        if out[w, _STAGE] == CALL_BAD_DRIVE:
            key = (min(out[w, _CODE], DRIVE_ZERO_BODY_QUAT), w)
            if best < 0 or key < best_key:
                best, best_key = w, key
    if best >= 0:
        return best
    for w in range(nw):
        if out[w, _CODE] != STEP_OK:
            return w
    return -1
