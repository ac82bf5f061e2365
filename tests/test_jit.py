"""tumble._jit: the noalloc rule is enforced, the namedtuple helpers, the clock, the
argument box (read with and without the runtime), calls through a compiled function's
address, allocating kernels under noalloc callers and loading from the cache work."""
import sys
from collections import namedtuple

import numpy as np
import pytest
from numba import njit, typeof, types
from numba.core.errors import TypingError

from tumble._jit import (ENTRY_POINTS, HAS_TICKS, ArgBox, allocating, assign_arrays,
                         assign_heads, box_args, call_address, call_compiled, caches_to_disk,
                         compiled_address, copy_arrays, load_cached, noalloc, tick_seconds,
                         ticks, world_of)

Pair = namedtuple("Pair", ["a", "count"])


def test_a_noalloc_function_may_not_return_an_array():
    @noalloc
    def hands_back(x):
        x[0] = 1.0
        return x, 1

    @noalloc
    def writes(x):
        x[0] = 2.0
        return x.shape[0]

    x = np.zeros(3)
    with pytest.raises(TypingError, match="noalloc function must not return an array"):
        hands_back(x)
    assert writes(x) == 3 and x[0] == 2.0


def test_world_of_views_one_world_and_keeps_counters_writable():
    @njit
    def bump(t, w):
        v = world_of(t, w)
        v.a[1] += 5.0
        v.count[0] += 1
        return v.a.shape[0]

    t = Pair(np.zeros((3, 2)), np.zeros(3, np.int64))
    assert bump(t, 1) == 2
    assert t.a[1, 1] == 5.0 and t.count.tolist() == [0, 1, 0]


def test_copy_and_assign_restore_every_field():
    @njit
    def scramble_and_restore(t):
        saved = copy_arrays(t)
        t.a[:] = -1.0
        t.count[:] = 7
        assign_arrays(t, saved)

    t = Pair(np.arange(6.0).reshape(3, 2), np.arange(3))
    scramble_and_restore(t)
    assert t.a.tolist() == [[0, 1], [2, 3], [4, 5]] and t.count.tolist() == [0, 1, 2]


def test_assign_arrays_takes_plain_tuples_of_arrays_of_any_rank():
    @noalloc
    def assign(dst, src):
        assign_arrays(dst, src)
        return 0

    src = (np.arange(24.0).reshape(2, 3, 4), np.arange(3), np.ones((2, 2), np.bool_))
    dst = (np.zeros((2, 3, 4)), np.zeros(3, np.int64), np.zeros((2, 2), np.bool_))
    assign(dst, src)
    for a, b in zip(dst, src):
        np.testing.assert_array_equal(a, b)


def test_assign_heads_copies_each_worlds_first_entries_only():
    @noalloc
    def heads(dst, src, counts):
        assign_heads(dst, src, counts)
        return 0

    Two = namedtuple("Two", ["x", "y"])
    src = Two(np.arange(24.0).reshape(3, 4, 2), np.arange(12).reshape(3, 4))
    dst = Two(np.full((3, 4, 2), -1.0), np.full((3, 4), -1))
    heads(dst, src, np.array([0, 2, 4]))
    assert (dst.x[0] == -1).all() and (dst.y[0] == -1).all()
    np.testing.assert_array_equal(dst.x[1, :2], src.x[1, :2])
    assert (dst.x[1, 2:] == -1).all() and (dst.y[1, 2:] == -1).all()
    np.testing.assert_array_equal(dst.x[2], src.x[2])
    np.testing.assert_array_equal(dst.y[2], src.y[2])


@pytest.mark.skipif(not HAS_TICKS, reason="no counter on this machine")
def test_ticks_count_forward_in_seconds_units():
    a = ticks()
    b = ticks()
    assert b >= a
    assert 1e-12 < tick_seconds(0.005) < 1e-6


Two = namedtuple("Two", "a b")


@njit(cache=True)
def _boxed(a, pair):
    return ArgBox((a, pair))


@njit(cache=True)
def _bump_boxed(box, k):
    a, pair = box.args
    a[0] += k
    pair.b[1] = pair.a[0] + a[0]
    return a.shape[0] + pair.b.shape[0]


def test_an_argbox_holds_the_very_arrays_it_was_made_from():
    """Writes through the box reach the caller's arrays and the caller's reach the box's;
    the box keeps them alive after the caller lets go of its names; its entry point is
    found by its type like any argument's."""
    a, pair = np.zeros(3), Two(np.arange(2.0), np.zeros(4))
    box = _boxed(a, pair)
    assert isinstance(box, ArgBox)
    assert _bump_boxed(box, 2.0) == 7
    assert a[0] == 2.0 and pair.b[1] == 2.0
    a[0] = 10.0
    _bump_boxed(box, 1.0)
    assert a[0] == 11.0 and pair.b[1] == 11.0
    ref = a
    del a, pair
    entry = ENTRY_POINTS.get(_bump_boxed, (box, 1.0))
    assert entry is not _bump_boxed           # the compiled entry point, not the dispatcher
    entry(box, 1.0)
    assert ref[0] == 12.0
    other = _boxed(np.zeros(5), Two(np.arange(2.0), np.zeros(4)))
    assert ENTRY_POINTS.get(_bump_boxed, (other, 1.0)) is entry     # same types


@njit(cache=True)
def _scaled_sum(box, k):
    a, pair = box.args
    return k * (a.sum() + pair.b.sum()), a.shape[0]


@njit          # not cached: the test reads its LLVM code, which Numba keeps only when it compiles
def _sums_through_address(address, box, ks):
    out = np.zeros(ks.shape[0])
    for i in range(ks.shape[0]):
        total, n = call_compiled(address, _scaled_sum, (box, ks[i]))
        out[i] = total + n
    return out


def test_call_compiled_runs_the_callee_without_linking_its_code():
    """The caller gets the callee's results through the address of its compiled code, and
    the caller's code holds a call through a pointer, not the callee's body."""
    box = _boxed(np.arange(3.0), Two(np.zeros(2), np.full(4, 0.5)))
    address = compiled_address(_scaled_sum, (typeof(box), types.float64))
    assert address == compiled_address(_scaled_sum, (typeof(box), types.float64))
    out = _sums_through_address(address, box, np.array([1.0, 2.0]))
    np.testing.assert_array_equal(out, [5.0 + 3, 10.0 + 3])
    (ir,) = _sums_through_address.inspect_llvm().values()
    callee = _scaled_sum.overloads[(typeof(box), types.float64)].fndesc.llvm_func_name
    assert f"define i32 @\"{callee}\"" not in ir and f"define i32 @{callee}" not in ir
    assert "inttoptr" in ir


@noalloc
def _sum_borrowed(box):
    a, pair = box_args(box)
    pair.b[0] += 1.0
    return a.sum() + pair.b[0]


@njit
def _sum_counted(box):
    a, pair = box_args(box)
    return a.sum() + pair.b.shape[0]


def test_box_args_reads_the_box_without_the_runtime_and_counts_with_it():
    """``box_args`` in a noalloc function reads the box's own arrays (writes reach them);
    in a function with the runtime it counts the references it takes and gives them back:
    the arrays' reference counts are where they were after many calls of both."""
    a, pair = np.arange(3.0), Two(np.zeros(2), np.zeros(4))
    box = _boxed(a, pair)
    assert _sum_borrowed(box) == 3.0 + 1 and _sum_counted(box) == 3.0 + 4      # compiled
    before = sys.getrefcount(a), sys.getrefcount(pair.b)
    for i in range(1000):
        assert _sum_borrowed(box) == 3.0 + i + 2
        assert _sum_counted(box) == 3.0 + 4
    assert pair.b[0] == 1001.0
    assert (sys.getrefcount(a), sys.getrefcount(pair.b)) == before


def _declared_callee(x, k):
    return np.int64(k * x.shape[0])


@njit          # not cached, as above
def _through_declared(address, x):
    total = np.int64(0)
    for k in range(3):
        total += call_address(address, types.int64, (x, k))
    return total


def test_call_address_compiles_the_caller_without_compiling_the_callee():
    """The caller compiles with the callee's result type declared, before the callee is
    compiled at all; then it runs the callee through its address."""
    callee = noalloc(cache=False)(_declared_callee)
    x = np.zeros(5)
    _through_declared.compile((types.int64, typeof(x)))
    assert not callee.overloads
    address = compiled_address(callee, (typeof(x), types.int64))
    assert _through_declared(address, x) == 0 + 5 + 10


def test_a_noalloc_function_may_call_an_allocating_one():
    """An ``allocating`` kernel keeps the runtime under a noalloc caller (a plain njit one
    fails to type there), and the reference counts stay balanced."""
    @allocating(cache=False)
    def doubled_sum(a):
        b = np.empty(2 * a.shape[0])
        b[:a.shape[0]] = a
        b[a.shape[0]:] = a
        return b.sum()

    @noalloc(cache=False)
    def caller(a):
        return doubled_sum(a[1:]) + 1.0

    a = np.arange(5.0)
    assert caller(a) == 21.0                  # compiled (the compile may keep a reference)
    before = sys.getrefcount(a)
    for _ in range(1000):
        caller(a)
    assert sys.getrefcount(a) == before


def test_load_cached_never_compiles():
    """A dispatcher with no code and nothing cached stays without code; once compiled it
    has code."""
    fresh = njit(cache=False)(lambda x: x + 1)
    assert not load_cached(fresh, (types.int64,))
    assert not fresh.overloads and not caches_to_disk(fresh)
    fresh.compile((types.int64,))
    assert load_cached(fresh, (types.int64,))
