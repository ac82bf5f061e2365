"""``noalloc``: the Numba decorator for compiled helpers that allocate nothing.

Numba counts references to every array a compiled function holds: it increments the
count of each array it receives when the function starts and decrements it when the
function ends, and LLVM's pruning pass removes those pairs only in simple control flow
(a branch with any decrement in it defeats it). The model (``ModelArrays``, 42 arrays),
the constraint rows (``Rows``, 9) and the solver plans are namedtuples of arrays, so a
helper that takes one of them and has a branch paid about a hundred atomic counter
updates per call -- about 0.8 us, far more than its arithmetic (``joint_frames``: 0.94
us a call; 5 ns without counting). A function that allocates nothing does not need the
counts: compiled without Numba's runtime (NRT) it uses its arguments as borrowed
references, which they are.

Rules for a ``noalloc`` function (Numba enforces the first at compile time, with a
typing error on the allocating call):

* it creates no array, list or other object that needs the runtime;
* it returns no array (nor a view, nor a tuple holding one): the caller would release
  a reference it was never given. Helpers that return views (``geom_verts``) are
  inlined instead (``inline="always"``), so their views are borrowed too;
* it calls no compiled function that returns a new array, nor one that allocates at all:
  Numba compiles a callee with its caller's options, so a callee's ``np.empty`` fails
  to type inside a ``noalloc`` caller. An allocating solver therefore gets a
  ``noalloc`` fast path over scratch made in advance (``mlcp.guess_on_tree_fast``),
  called first, with the allocating path after it.

Every array a compiled function with the runtime receives in a namedtuple costs an
increment and a decrement of its count per call (about 14 ns a pair here): passing the
model, the rows and the plan caches to the solver cost 1.6 us a step before
``solve_fast``.
If the running Numba has no ``_nrt`` option, ``noalloc`` is plain ``njit``: correct,
only slower.

Compiled callers pass typed constants (``np.int64(0)``, ``np.bool_(True)``) and start
counters as ``np.int64(0)``, never bare literals: Numba compiles a callee once for a
literal argument (``Literal[int](0)``) and once more for the plain type, which across
the step cost as much compile time as a dozen kernels. For the same reason tests hand
kernels the array types the pipeline does (read-only model arrays, int32 indices).
"""
from numba import njit

try:
    from numba.core.cpu import CPUTargetOptions
    _HAS_NRT_OPTION = hasattr(CPUTargetOptions, "_nrt")
except ImportError:          # pragma: no cover - a Numba that moved its internals
    _HAS_NRT_OPTION = False


def noalloc(fn=None, **options):
    """``njit(cache=True, **options)`` without reference counting (see the module docstring).

    Use as ``@noalloc`` or ``@noalloc(inline="always")``."""
    options.setdefault("cache", True)
    if _HAS_NRT_OPTION:
        options["_nrt"] = False
    if fn is None:
        return lambda f: njit(**options)(f)
    return njit(**options)(fn)
