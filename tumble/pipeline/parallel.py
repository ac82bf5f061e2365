"""Batched worlds on all cores: ``step_worlds_parallel``, one world per task.

``step.step_worlds`` steps the worlds of a batch one after another; this entry point
hands each world to a thread (Numba's ``prange``) as a batch of one -- views of that
world's slice of every state and contact array -- so each world runs exactly the code of
the serial path and its result is bit-identical to it. The worlds do not share any
scratch memory: each world has its own ``StepWork`` (``make_world_works``, kept by the
World between calls while they fit, ``world_works_fit``: a world's work holds its solver's
tree plan, which a fresh one would have to plan again on the first step of every call)
and broad-phase buffer.

Failures are reported as by the serial path: the lowest-numbered world that failed
(diverged, or needs larger buffers) with its step and body; the caller (``call.py``)
restores every world to its input. (The serial path stops at that world; here the others
have run meanwhile and are rolled back too, which costs time but not results.)

The view helper (``tumble._jit.worlds_view``) works on any namedtuple of arrays whose
leading axis is the world, so state fields added later need no change here -- as long as
the step treats each world on its own, without decisions taken over the whole batch.
"""
import numpy as np
from numba import njit, prange
from numba.typed import List

from .._jit import worlds_view
from .step import STEP_OK, step_worlds
from .work import fits_world, make_step_work


@njit(cache=True)
def make_world_works(m, s, c, con, o):
    """A typed list of one ``StepWork`` per world of ``s`` (each made for that world's
    slice of the arrays)."""
    works = List()
    for w in range(s.body_pos.shape[0]):
        works.append(make_step_work(m, worlds_view(s, w, w + 1), worlds_view(c, w, w + 1),
                                    worlds_view(con, w, w + 1), o))
    return works


@njit(cache=True)
def world_works_fit(works, m, s, c, con, o):
    """Whether ``works`` (make_world_works) still fit every world (``work.work_fits``;
    from the few arrays it reads: views of every array of each world cost 8 us a world
    on each call)."""
    if len(works) != s.body_pos.shape[0]:
        return False
    njrow, cap = s.row_impulse.shape[1], con.depth.shape[1]
    for w in range(s.body_pos.shape[0]):
        if not fits_world(works[w], m, njrow, cap, c.body_servo[w:w + 1], o):
            return False
    return True


@njit(cache=True, parallel=True)
def step_worlds_parallel(m, s, c, con, pairs, n, o, works):
    """``step_worlds`` with the worlds of ``s`` spread over Numba's threads.

    Same arguments and result as ``step.step_worlds``: (status, world, step, body,
    needed). ``pairs`` gives the size of each world's broad-phase buffer; ``works`` each
    world's scratch (``make_world_works``, fitting: ``world_works_fit``). The thread
    count is Numba's (``numba.set_num_threads``).
    """
    nw = s.body_pos.shape[0]
    out = np.zeros((nw, 4), np.int64)
    for w in prange(nw):
        sw, cw, conw = worlds_view(s, w, w + 1), worlds_view(c, w, w + 1), \
            worlds_view(con, w, w + 1)
        # (prange's index is unsigned; the typed list takes a signed one)
        status, _, k, b, needed = step_worlds(m, sw, cw, conw, np.empty_like(pairs), n, o,
                                              works[np.int64(w)])
        out[w, 0] = status
        out[w, 1] = k
        out[w, 2] = b
        out[w, 3] = needed
    for w in range(nw):
        if out[w, 0] != STEP_OK:
            return out[w, 0], w, out[w, 1], out[w, 2], out[w, 3]
    return STEP_OK, -1, -1, -1, np.int64(0)
