"""Batched worlds on all cores: ``step_boxed_parallel``, one span of worlds per thread.

A serial step checks, steps and (on a failure) restores the worlds of a batch one after
another (``call.step_span`` over all of them). This entry point cuts the batch into one
run of worlds (a span) per thread (Numba's ``prange``), and each thread runs the same
compiled ``call.step_span`` on its span alone -- views of its slice of every state,
control and contact array: the scratch checked, the span's inputs saved, checked and
prepared, then its worlds stepped one after another. So each world runs exactly the code
of the serial path and its result is bit-identical to it, and nothing of a call but its
verdict runs on one thread.

The threads call ``step_span`` through the address of its compiled code
(``_jit.call_compiled``) instead of linking it in: a function that links the step
re-optimises and re-emits all of it when it compiles cold (the batched step took about
two minutes more than the serial one that way; now seconds), and the serial and the
batched step share one compiled ``step_span``.

The spans share no scratch memory: each has its own ``StepWork`` (``make_spans``,
kept by the World between calls while they fit and the thread count stays: a work holds
its solver's tree plans, which a fresh one would plan again on the first step of every
call), with its inputs' copy, and its own broad-phase buffer. One scratch for a span's
worlds, rather than one per world, stays in the cache from one world to the next, and
each call counts references to a span's ~400 arrays once rather than once per world.

Failures are reported as by the serial path (``first_failure``): scratch that does not
fit first, then the first state check that fails, the first drive check, the first world
that diverged or needs larger buffers -- and every world is restored to its input.
(The serial path stops at that world; here the other spans have run meanwhile and are
rolled back too, which costs time but not results.)

The view helper (``tumble._jit.worlds_view``) works on any namedtuple of arrays whose
leading axis is the world, so state fields added later need no change here -- as long as
the step treats each world on its own, without decisions taken over the whole batch.
"""
import numpy as np
from numba import get_num_threads, njit, prange
from numba.typed import List

from .._jit import ArgBox, call_compiled, compiled_address, worlds_view
from .call import (CALL_BAD_DRIVE, CALL_BAD_STATE, CALL_NEW_WORK, CALL_STEPPED,
                   clear_applied, make_step_box, restore_inputs, step_code, step_span,
                   step_span_signature)
from .checks import DRIVE_ZERO_BODY_QUAT
from .step import STEP_OK

# Columns of each span's outcome in step_boxed_parallel.
_STAGE, _CODE, _WORLD, _INDEX, _STEP, _NEEDED, _SAVED = range(7)


def span_count(nworld):
    """How many spans a batch of ``nworld`` worlds is cut into: one per Numba thread
    (``numba.get_num_threads``), at most one per world."""
    return max(1, min(nworld, get_num_threads()))


@njit(cache=True, inline="always")
def span_bounds(nworld, nspan, j):
    """The worlds (first, end) of span ``j`` of ``nspan``: runs as even as they come."""
    return j * nworld // nspan, (j + 1) * nworld // nspan


@njit(cache=True)
def make_spans(m, s, c, con, pairs, ball, o, nspan):
    """A typed list of one ``call.make_step_box`` per span of the worlds of ``s``
    (``span_bounds``): views of the span's slice of the state, controls and contacts, with
    a pair buffer the size of ``pairs`` and a ``StepWork`` made for the span, both its
    own. (Views of a C-ordered array's leading axis are of the array's own type, so the
    serial step and the spans run one compiled ``call.step_span``.)"""
    spans = List()
    nw = s.body_pos.shape[0]
    for j in range(nspan):
        w0, w1 = span_bounds(nw, nspan, j)
        sv, cv, conv = worlds_view(s, w0, w1), worlds_view(c, w0, w1), worlds_view(con, w0, w1)
        spans.append(make_step_box(m, sv, cv, conv, np.zeros_like(pairs), ball, o))
    return spans


@njit(cache=True)
def box_parallel_args(s, c, con, spans):
    """What ``step_boxed_parallel`` takes, the batch's state, controls and contacts and
    its spans (``make_spans``), in one ``ArgBox``."""
    return ArgBox((s, c, con, spans))


def span_addresses(spans, o, branches):
    """The compiled code ``step_boxed_parallel`` calls on each thread for the spans
    ``spans`` (``make_spans``) and options ``o``, compiled now if it is not yet: the
    address of ``call.step_span``'s and the stages' with the branches named in
    ``branches`` (``step.stage_addresses``)."""
    stages = step_code(spans[0], o, branches)
    return compiled_address(step_span, step_span_signature(spans[0], o)), stages


@njit(cache=True, parallel=True)
def step_boxed_parallel(box, n, o, span, stages):
    """``call.step_span`` for the whole batch with its spans of worlds spread over Numba's
    threads, on what ``box`` holds (``box_parallel_args``); ``span`` is the address of
    ``call.step_span``'s compiled code for a span and ``stages`` the step's stages'
    (``span_addresses``), called through it rather than linked in: this function then
    compiles in seconds instead of emitting the whole step once more.

    Same result as ``call.step_span`` over all the worlds (``first_failure``), and
    CALL_NEW_WORK when a span's scratch does not fit.
    """
    s, c, con, spans = box.args
    nw, nspan = s.body_pos.shape[0], len(spans)
    out = np.zeros((nspan, 7), np.int64)
    for j in prange(nspan):
        i = np.int64(j)         # prange's index is unsigned; the typed list takes a signed one
        w0 = span_bounds(nw, nspan, i)[0]
        stage, code, w, index, k, needed = call_compiled(
            span, step_span, (spans[i], stages, n, o, np.bool_(False)))
        if w >= 0:
            w += w0
        out[i, _STAGE], out[i, _CODE], out[i, _WORLD], out[i, _INDEX] = stage, code, w, index
        out[i, _STEP], out[i, _NEEDED] = k, needed
        out[i, _SAVED] = stage != CALL_NEW_WORK
    f = first_failure(out)
    if f < 0:
        clear_applied(c)
        return CALL_STEPPED, STEP_OK, -1, -1, -1, np.int64(0)
    for v in range(nspan):
        if out[v, _SAVED]:
            span_args = spans[v].args
            restore_inputs(span_args[1], span_args[2], span_args[3], span_args[6].saved)
    if out[f, _STAGE] == CALL_NEW_WORK:
        return CALL_NEW_WORK, 0, -1, -1, -1, np.int64(0)
    return (out[f, _STAGE], out[f, _CODE], out[f, _WORLD], out[f, _INDEX], out[f, _STEP],
            out[f, _NEEDED])


@njit(cache=True)
def first_failure(out):
    """The span whose failure the serial path would report, from each span's outcome
    ``out`` (nspan, 7) (stage, code, world, index, step, needed, saved), or -1 if all
    stepped. Each span reports as the serial path would for its worlds.

    The serial path checks the scratch, then every world's state, then every world's
    drives field by field (and, past the fields, world by world), then steps world by
    world; so: any scratch that does not fit, else the first span with a bad state, else
    the bad drive with the least (field, world), else the first span that failed to
    step."""
    nspan = out.shape[0]
    for stage in (CALL_NEW_WORK, CALL_BAD_STATE):
        for j in range(nspan):
            if out[j, _STAGE] == stage:
                return j
    best, best_key = -1, (0, 0)
    for j in range(nspan):
        if out[j, _STAGE] == CALL_BAD_DRIVE:
            key = (min(out[j, _CODE], DRIVE_ZERO_BODY_QUAT), out[j, _WORLD])
            if best < 0 or key < best_key:
                best, best_key = j, key
    if best >= 0:
        return best
    for j in range(nspan):
        if out[j, _CODE] != STEP_OK:
            return j
    return -1
