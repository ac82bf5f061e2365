"""Batched worlds on all cores: ``step_worlds_parallel``, one world per task.

``step.step_worlds`` steps the worlds of a batch one after another; this entry point
hands each world to a thread (Numba's ``prange``) as a batch of one -- views of that
world's slice of every state and contact array -- so each world runs exactly the code of
the serial path and its result is bit-identical to it. The worlds do not share any
scratch memory (each world task makes its own ``StepWork`` and broad-phase buffer).

Failures are reported as by the serial path: the lowest-numbered world that failed
(diverged, or needs larger buffers) with its step and body, and every world is restored
to its input. (The serial path stops at that world; here the others have run meanwhile
and are rolled back, which costs time but not results.)

The view, copy and restore helpers work on any namedtuple of arrays whose leading axis is
the world, so state fields added later need no change here -- as long as the step treats
each world on its own, without decisions taken over the whole batch.
"""
import numpy as np
from numba import njit, prange
from numba.core import types
from numba.extending import overload

from .joints.rows import joint_coordinates
from .step import STEP_OK, make_step_work, step_worlds


def world_view(t, w):
    """The namedtuple ``t`` of arrays with each array sliced to ``[w:w + 1]`` (compiled)."""
    raise NotImplementedError("world_view is only available in compiled code")


def copy_arrays(t):
    """The namedtuple ``t`` with every array copied (compiled)."""
    raise NotImplementedError("copy_arrays is only available in compiled code")


def assign_arrays(dst, src):
    """``dst[i][...] = src[i]`` for every array of the namedtuples (compiled)."""
    raise NotImplementedError("assign_arrays is only available in compiled code")


def _generated(name, args, body, cls=None):
    """Compile-time source for a function over every field of a namedtuple type."""
    src = f"def {name}({args}):\n" + body
    ns = {"cls": cls}
    exec(src, ns)
    return ns[name]


@overload(world_view)
def _world_view(t, w):
    if isinstance(t, types.BaseNamedTuple):
        fields = ", ".join(f"t[{i}][w:w + 1]" for i in range(len(t.types)))
        return _generated("impl", "t, w", f"    return cls({fields})\n", t.instance_class)
    return None


@overload(copy_arrays)
def _copy_arrays(t):
    if isinstance(t, types.BaseNamedTuple):
        fields = ", ".join(f"t[{i}].copy()" for i in range(len(t.types)))
        return _generated("impl", "t", f"    return cls({fields})\n", t.instance_class)
    return None


@overload(assign_arrays)
def _assign_arrays(dst, src):
    if isinstance(dst, types.BaseNamedTuple):
        body = "".join(f"    dst[{i}][:] = src[{i}]\n" for i in range(len(dst.types)))
        return _generated("impl", "dst, src", body + "    return 0\n")
    return None


@njit(cache=True, parallel=True)
def step_worlds_parallel(m, s, con, pairs, n, o):
    """``step_worlds`` with the worlds of ``s`` spread over Numba's threads.

    Same arguments and result as ``step.step_worlds``: (status, world, step, body,
    needed). ``pairs`` gives the size of each world's broad-phase buffer. The thread
    count is Numba's (``numba.set_num_threads``).
    """
    nw = s.body_pos.shape[0]
    state0 = copy_arrays(s)
    con0 = copy_arrays(con)
    out = np.zeros((nw, 4), np.int64)
    for w in prange(nw):
        sw, cw = world_view(s, w), world_view(con, w)
        status, _, k, b, needed = step_worlds(m, sw, cw, np.empty_like(pairs), n, o,
                                              make_step_work(m, sw, cw, o))
        out[w, 0] = status
        out[w, 1] = k
        out[w, 2] = b
        out[w, 3] = needed
    for w in range(nw):
        if out[w, 0] != STEP_OK:
            assign_arrays(s, state0)
            assign_arrays(con, con0)
            for w2 in range(nw):
                joint_coordinates(m, s.body_pos[w2], s.body_quat[w2], s.body_vel[w2],
                                  s.body_angvel[w2], s.joint_q[w2], s.joint_qd[w2],
                                  s.joint_qrel[w2])
            return out[w, 0], w, out[w, 1], out[w, 2], out[w, 3]
    return STEP_OK, -1, -1, -1, 0
