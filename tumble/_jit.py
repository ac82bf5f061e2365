"""Every use of Numba's internals in one module, so that a Numba upgrade touches one file:
``noalloc`` and ``allocating`` (the ``_nrt`` option and a compiler pass), the namedtuple
helpers of compiled code (``world_of``, ``copy_arrays``, ``assign_heads``, ...), a clock
for compiled code (``ticks``), the box that hands many arrays to compiled code as one
object (``ArgBox``, read without the runtime by ``box_args``), the entry points that skip
the dispatcher (``ENTRY_POINTS``), and calls between compiled functions through an
address (``call_compiled``, ``compiled_address``).

``noalloc``: the Numba decorator for compiled helpers that allocate nothing.

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
typing error on the allocating call, and ``noalloc``'s own compiler pass the second):

* it creates no array, list or other object that needs the runtime;
* it returns no array (nor a view, nor a tuple holding one): the caller would release
  a reference it was never given. Helpers that return views (``geom_verts``) are
  inlined instead (``inline="always"``), so their views are borrowed too;
* it calls no compiled function that returns a new array, and calls one that allocates
  only if that one is declared ``allocating``: Numba compiles a callee with its caller's
  options, so a plain callee's ``np.empty`` fails to type inside a ``noalloc`` caller,
  while an ``allocating`` one keeps the runtime (and counts its own references). The
  common case of an allocating solver still gets a ``noalloc`` fast path over scratch
  made in advance (``mlcp.guess_on_tree_fast``), called first.

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
import platform
import time

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils, errors
from numba.core.compiler import CompilerBase, DefaultPassBuilder
from numba.core.compiler_lock import global_compiler_lock
from numba.core.compiler_machinery import FunctionPass, register_pass
from numba.core.typed_passes import NopythonTypeInference
from numba.experimental import structref
from numba.extending import intrinsic, overload

try:
    from numba.core.cpu import CPUTargetOptions
    _HAS_NRT_OPTION = hasattr(CPUTargetOptions, "_nrt")
except ImportError:          # pragma: no cover - a Numba that moved its internals
    _HAS_NRT_OPTION = False


def _holds_array(t):
    """Whether the Numba type ``t`` is an array or a tuple holding one."""
    if isinstance(t, types.Array):
        return True
    if isinstance(t, types.BaseTuple):
        return any(_holds_array(v) for v in t.types)
    return False


@register_pass(mutates_CFG=False, analysis_only=True)
class _NoArrayReturn(FunctionPass):
    """Refuses a ``noalloc`` function that returns an array: without the runtime the caller
    would release a reference it was never given (Numba itself refuses only new arrays)."""
    _name = "tumble_noalloc_returns_no_array"

    def __init__(self):
        FunctionPass.__init__(self)

    def run_pass(self, state):
        if _holds_array(state.return_type):
            raise errors.TypingError(
                f"{state.func_id.func_qualname} is @noalloc and returns "
                f"{state.return_type}: a noalloc function must not return an array "
                f"(tumble._jit; inline it instead)")
        return False


class _NoallocCompiler(CompilerBase):
    """Numba's nopython pipeline with ``_NoArrayReturn`` after type inference."""

    def define_pipelines(self):
        pm = DefaultPassBuilder.define_nopython_pipeline(self.state)
        pm.add_pass_after(_NoArrayReturn, NopythonTypeInference)
        pm.finalize()
        return [pm]


def noalloc(fn=None, **options):
    """``njit(cache=True, **options)`` without reference counting (see the module docstring).

    Use as ``@noalloc`` or ``@noalloc(inline="always")``. Returning an array is a typing
    error (``_NoArrayReturn``), raised when the function compiles."""
    if _HAS_NRT_OPTION:
        options["_nrt"] = False
        options["pipeline_class"] = _NoallocCompiler
    return _cached_njit(fn, options)


def allocating(fn=None, **options):
    """``njit(cache=True, **options)`` for a kernel that allocates and is called from
    ``noalloc`` code (the general broad phase, stable PD, the exact solve): it keeps
    Numba's runtime instead of inheriting its caller's lack of it, and counts references
    to the (borrowed) arrays it is given on the way in and out."""
    if _HAS_NRT_OPTION:
        options["_nrt"] = True
    return _cached_njit(fn, options)


def _cached_njit(fn, options):
    """``njit(cache=True, **options)`` applied to ``fn``, or the decorator that applies it
    when ``fn`` is None (``@noalloc`` and ``@noalloc(...)`` alike)."""
    options.setdefault("cache", True)
    if fn is None:
        return lambda f: njit(**options)(f)
    return njit(**options)(fn)


# ----------------------------------------------------------------------------------------
# Namedtuples of arrays, field by field, in compiled code. The state, control and contact
# tuples carry a leading world axis; these helpers take one world (or a run of worlds) of
# every field at once, so code that handles fields generically needs no change when a
# field is added.

def world_of(t, w):
    """The namedtuple ``t`` of arrays with each array indexed at world ``w`` (compiled).

    A field with a leading world axis only ((nworld,): a per-world counter) becomes the
    1-element view ``[w:w + 1]``, so writes through it still reach ``t``."""
    raise NotImplementedError("world_of is only available in compiled code")


def worlds_view(t, w0, w1):
    """The namedtuple ``t`` of arrays with each array sliced to ``[w0:w1]`` (compiled)."""
    raise NotImplementedError("worlds_view is only available in compiled code")


def copy_arrays(t):
    """The tuple or namedtuple ``t`` with every array copied (compiled)."""
    raise NotImplementedError("copy_arrays is only available in compiled code")


def assign_arrays(dst, src):
    """``dst[i][...] = src[i]`` for every array of the tuples or namedtuples (compiled;
    element by element, so a ``noalloc`` function may call it)."""
    raise NotImplementedError("assign_arrays is only available in compiled code")


def assign_heads(dst, src, counts):
    """``dst[i][w, :counts[w]] = src[i][w, :counts[w]]`` for every array of the namedtuples
    and every world ``w`` (compiled, allocation-free): the first ``counts[w]`` entries
    along the second axis, e.g. a world's live contacts of a buffer that holds more."""
    raise NotImplementedError("assign_heads is only available in compiled code")


def _generated(name, args, body, cls=None):
    """Compile-time source for a function over every field of a namedtuple type."""
    src = f"def {name}({args}):\n" + body
    ns = {"cls": cls}
    exec(src, ns)
    return ns[name]


@overload(world_of)
def _world_of(t, w):
    if isinstance(t, types.BaseNamedTuple):
        fields = ", ".join(f"t[{i}][w:w + 1]" if a.ndim == 1 else f"t[{i}][w]"
                           for i, a in enumerate(t.types))
        return _generated("impl", "t, w", f"    return cls({fields})\n", t.instance_class)
    return None


@overload(worlds_view)
def _worlds_view(t, w0, w1):
    if isinstance(t, types.BaseNamedTuple):
        fields = ", ".join(f"t[{i}][w0:w1]" for i in range(len(t.types)))
        return _generated("impl", "t, w0, w1", f"    return cls({fields})\n", t.instance_class)
    return None


@overload(copy_arrays)
def _copy_arrays(t):
    if not isinstance(t, types.BaseTuple):
        return None
    fields = "".join(f"t[{i}].copy(), " for i in range(len(t.types)))
    if isinstance(t, types.BaseNamedTuple):
        return _generated("impl", "t", f"    return cls({fields})\n", t.instance_class)
    return _generated("impl", "t", f"    return ({fields})\n")


def _copy_loops(i, ndim, bounds):
    """Source of nested loops copying ``src[i]`` into ``dst[i]`` over ``ndim`` axes, axis
    ``k`` running over ``range(bounds[k])`` (a source expression)."""
    idx = ", ".join(f"i{k}" for k in range(ndim))
    lines = [f"    a, b = dst[{i}], src[{i}]\n"]
    for k in range(ndim):
        lines.append("    " * (k + 1) + f"for i{k} in range({bounds[k]}):\n")
    lines.append("    " * (ndim + 1) + f"a[{idx}] = b[{idx}]\n")
    return "".join(lines)


@overload(assign_arrays)
def _assign_arrays(dst, src):
    if isinstance(dst, types.BaseTuple):
        body = "".join(_copy_loops(i, a.ndim, [f"a.shape[{k}]" for k in range(a.ndim)])
                       for i, a in enumerate(dst.types))
        return _generated("impl", "dst, src", body + "    return 0\n")
    return None


@overload(assign_heads)
def _assign_heads(dst, src, counts):
    if isinstance(dst, types.BaseNamedTuple):
        body = "".join(_copy_loops(i, a.ndim, ["a.shape[0]", "counts[i0]"]
                                   + [f"a.shape[{k}]" for k in range(2, a.ndim)])
                       for i, a in enumerate(dst.types))
        return _generated("impl", "dst, src, counts", body + "    return 0\n")
    return None


# ----------------------------------------------------------------------------------------
# A clock compiled code can read. Numba has none, and a ctypes call would keep every
# function that reads it out of the cache (its address is baked in); an LLVM intrinsic is
# cached like any other code.

_MACHINE = platform.machine().lower()
#: Whether ``ticks`` counts time on this machine (x86-64: the time-stamp counter;
#: AArch64: the virtual counter). Elsewhere it returns 0 and stage times stay 0.
HAS_TICKS = _MACHINE in ("x86_64", "amd64", "aarch64", "arm64")


@intrinsic
def _read_ticks(typingctx):
    def codegen(context, builder, signature, args):
        i64 = ir.IntType(64)
        if _MACHINE in ("x86_64", "amd64"):
            fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(i64, []),
                                                "llvm.readcyclecounter")
            return builder.call(fn, [])
        if _MACHINE in ("aarch64", "arm64"):
            asm = ir.InlineAsm(ir.FunctionType(i64, []), "mrs $0, cntvct_el0", "=r",
                               side_effect=True)
            return builder.call(asm, [])
        return ir.Constant(i64, 0)
    return types.int64(), codegen


@njit(cache=True, inline="always")
def ticks():
    """A monotonic counter (int64) in machine-dependent units (``tick_seconds``)."""
    return _read_ticks()


def tick_seconds(calibrate_s=0.02):
    """Seconds per ``ticks`` unit, measured against ``time.perf_counter`` over
    ``calibrate_s`` seconds (0.0 when the machine has no counter)."""
    if not HAS_TICKS:
        return 0.0
    ticks()                                   # compile outside the measurement
    t0, c0 = time.perf_counter(), ticks()
    while time.perf_counter() - t0 < calibrate_s:
        pass
    t1, c1 = time.perf_counter(), ticks()
    return (t1 - t0) / max(c1 - c0, 1)


# ----------------------------------------------------------------------------------------
# Many arrays handed to compiled code as one object.

@structref.register
class ArgBoxType(types.StructRef):
    """Numba's type of an :class:`ArgBox`: one field, ``args``, a tuple (of namedtuples of
    arrays)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(t)) for name, t in fields)


class ArgBox(structref.StructRefProxy):
    """A tuple of arrays held in one object, made in compiled code (``ArgBox(args)``) and
    read there as ``box.args``: the very same arrays, not copies.

    Handing compiled code ~200 arrays one by one costs a type check and a reference per
    array at every call (5.6 us for the step's); the box crosses as one pointer. Why not a
    Numba typed list (what this replaced): its item getter wraps the item in an optional
    value, and LLVM took 30 s to compile that for the step's arguments; a struct field
    compiles in a fraction of a second."""


structref.define_proxy(ArgBox, ArgBoxType, ["args"])

# Numba's own ``box.args`` needs the runtime (it finds the payload through an NRT call) and
# counts a reference to each of the tuple's ~200 arrays; the payload pointer is the fourth
# field of Numba's MemInfo struct (``NRT_MemInfo``: refct, dtor, dtor_info, data, size).
_MEMINFO = ir.LiteralStructType([cgutils.intp_t, cgutils.voidptr_t, cgutils.voidptr_t,
                                 cgutils.voidptr_t, cgutils.intp_t])


@intrinsic
def box_args(typingctx, box):
    """``box.args`` (an :class:`ArgBox`'s tuple) without Numba's runtime: in a ``noalloc``
    function a borrowed tuple, the box's own arrays, with no reference counted, so reading
    it costs a few loads and compiles in a fraction of a second. With the runtime on, the
    tuple is counted as a new reference, as Numba's own read does."""
    if not isinstance(box, ArgBoxType):
        return None
    argty = box.field_dict["args"]

    def codegen(context, builder, signature, llargs):
        ref = cgutils.create_struct_proxy(box)(context, builder, value=llargs[0])
        meminfo = builder.bitcast(ref.meminfo, _MEMINFO.as_pointer())
        payload = builder.load(cgutils.gep(builder, meminfo, 0, 3))
        layout = context.data_model_manager[box.get_data_type()].get_value_type()
        field = cgutils.gep_inbounds(builder, builder.bitcast(payload, layout.as_pointer()),
                                     0, 0)                   # the payload's one field, args
        value = _load_by_leaf(builder, field, argty)
        if context.enable_nrt:
            context.nrt.incref(builder, argty, value)
        return value
    return argty(box), codegen


def _load_by_leaf(builder, ptr, ty):
    """The value of Numba type ``ty`` at ``ptr``, its tuples assembled from a load of each
    array or scalar, so that LLVM keeps only the loads a function uses. (Measured no faster
    on the PD ragdoll than one load of the whole ~12 KB tuple, which LLVM narrowed itself;
    kept as the form that cannot copy it.)"""
    if isinstance(ty, types.BaseTuple) and len(ty) > 0:
        value = ir.Constant(ptr.type.pointee, ir.Undefined)
        for i, t in enumerate(ty.types):
            item = _load_by_leaf(builder, cgutils.gep_inbounds(builder, ptr, 0, i), t)
            value = builder.insert_value(value, item, i)
        return value
    return builder.load(ptr)


# ----------------------------------------------------------------------------------------
# Calling compiled code from Python without the dispatcher's type matching.

def _type_key(x):
    """What Numba's type of ``x`` depends on, cheaply: for arrays dtype, rank, layout and
    writability; namedtuples field by field; other values their Python type."""
    if isinstance(x, np.ndarray):
        return (x.dtype.str, x.ndim, x.flags.c_contiguous, x.flags.writeable)
    if isinstance(x, tuple):
        return (type(x),) + tuple(_type_key(v) for v in x)
    if isinstance(x, ArgBox):
        return x._numba_type_
    return type(x)


class EntryPoints:
    """Compiled entry points of Numba dispatchers, found once per argument types.

    Calling an entry point skips the dispatcher's type matching, which costs more than a
    small world's step; matching once costs 2 ms, so the entry point is remembered for
    every later call whose arguments have the same types (``_type_key``)."""

    def __init__(self):
        self._found = {}

    def get(self, dispatcher, args, compiled_only=False):
        """The entry point of ``dispatcher`` for arguments typed as ``args`` (the dispatcher
        itself if this Numba does not expose it). With ``compiled_only``, None when
        nothing is compiled for these types yet (the caller then goes through the
        dispatcher, which compiles)."""
        key = (dispatcher, _type_key(args))
        entry = self._found.get(key)
        if entry is None:
            try:
                sig = tuple(dispatcher.typeof_pyval(a) for a in args)
                entry = dispatcher.overloads[sig].entry_point
            except KeyError:
                if compiled_only:
                    return None
                entry = dispatcher
            except (AttributeError, TypeError):
                entry = dispatcher
            self._found[key] = entry
        return entry


def compiled_any(dispatcher):
    """Whether ``dispatcher`` has compiled code for some argument types in this process."""
    return bool(dispatcher.overloads)


#: The process's entry points (a memo: it changes how fast a call starts, never a result).
ENTRY_POINTS = EntryPoints()


# ----------------------------------------------------------------------------------------
# Compiled code calling compiled code through an address.
#
# A compiled function links in the LLVM code of every compiled function it calls and
# optimises and emits the lot again: each level of callers above the step pays for the
# whole step once more when it compiles cold (the batched step's loop over threads cost
# about two minutes that way). ``call_compiled`` calls instead through an address handed
# over at run time, so the caller's code holds only the call, and caches like any other
# code (an address baked in would not survive the process).

@intrinsic
def call_compiled(typingctx, address, fn, args):
    """``fn(*args)`` (``fn`` a Numba dispatcher, ``args`` a tuple) through ``address``, the
    entry of ``fn``'s code for these argument types (``compiled_address``), without linking
    that code into the caller. Literal arguments count as their plain types, as
    ``compiled_address`` sees them."""
    if not isinstance(address, types.Integer) or not isinstance(fn, types.Dispatcher):
        return None
    argtys = tuple(types.unliteral(t) for t in args.types)
    restype = typingctx.resolve_function_type(fn, argtys, {}).return_type
    return restype(address, fn, args), _call_through(args, argtys, restype)


def _call_through(args, argtys, restype):
    """Codegen of a call through the address in the first argument with the tuple in the
    third, as a compiled function of ``argtys`` returning ``restype`` is called (Numba's
    calling convention; an exception raised in the callee propagates)."""
    def codegen(context, builder, signature, llargs):
        values = cgutils.unpack_tuple(builder, llargs[2], len(argtys))
        values = [context.cast(builder, v, t, u)
                  for v, t, u in zip(values, args.types, argtys)]
        fnty = context.call_conv.get_function_type(restype, argtys)
        callee = builder.inttoptr(llargs[0], fnty.as_pointer())
        status, out = context.call_conv.call_function(builder, callee, restype, argtys,
                                                      values)
        with cgutils.if_unlikely(builder, status.is_error):
            context.call_conv.return_status_propagate(builder, status)
        return out
    return codegen


@intrinsic
def call_address(typingctx, address, restype, args):
    """The function at ``address`` (``compiled_address``) called with the tuple ``args``,
    its result declared as ``restype`` (a Numba type, e.g. ``types.int64``): as
    ``call_compiled`` but without typing the callee, so the caller compiles without
    compiling it (what lets the step and its stages compile in separate processes). The
    callee must have been compiled for exactly these argument types and return
    ``restype``."""
    if not isinstance(address, types.Integer):
        return None
    if isinstance(restype, (types.NumberClass, types.TypeRef)):
        result = restype.instance_type
    else:
        return None
    argtys = tuple(types.unliteral(t) for t in args.types)
    return result(address, restype, args), _call_through(args, argtys, result)


def load_cached(dispatcher, argtypes):
    """Whether ``dispatcher`` has code for the Numba types ``argtypes`` in this process,
    loading it from Numba's on-disk cache if it is there; never compiles (Numba's own
    ``compile`` does this first, then compiles)."""
    sig = tuple(argtypes)
    if sig in dispatcher.overloads:
        return True
    try:
        with global_compiler_lock:
            cres = dispatcher._cache.load_overload(sig, dispatcher.targetctx)
            if cres is None:
                return False
            dispatcher.targetctx.insert_user_function(cres.entry_point, cres.fndesc,
                                                      [cres.library])
            dispatcher.add_overload(cres)
    except AttributeError:            # pragma: no cover - a Numba that moved its internals
        return False
    return True


def caches_to_disk(dispatcher):
    """Whether ``dispatcher`` keeps what it compiles in Numba's on-disk cache (so another
    process can compile it for this one)."""
    cache = getattr(dispatcher, "_cache", None)
    return cache is not None and type(cache).__name__ != "NullCache"


def compiled_address(dispatcher, argtypes):
    """The address of ``dispatcher``'s compiled code for the Numba types ``argtypes``
    (compiled now if it is not yet): what ``call_compiled`` takes. Valid while the
    process lives."""
    sig = tuple(argtypes)
    if sig not in dispatcher.overloads:
        dispatcher.compile(sig)
    cres = dispatcher.overloads[sig]
    return cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)
