"""tumble._jit: the noalloc rule is enforced, the namedtuple helpers and the clock work."""
from collections import namedtuple

import numpy as np
import pytest
from numba import njit
from numba.core.errors import TypingError

from tumble._jit import (HAS_TICKS, assign_arrays, copy_arrays, noalloc, tick_seconds, ticks,
                         world_of)

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


@pytest.mark.skipif(not HAS_TICKS, reason="no counter on this machine")
def test_ticks_count_forward_in_seconds_units():
    a = ticks()
    b = ticks()
    assert b >= a
    assert 1e-12 < tick_seconds(0.005) < 1e-6
