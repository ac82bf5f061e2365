"""The dense Cholesky kernels of ``solvers/direct.py``, dependent rows included."""
import numpy as np
from hypothesis import assume, given, settings, strategies as st

import tumble
from tumble.apps import benchmarks
from tumble.pipeline.solvers.common import make_rows_nb
from tumble.pipeline.solvers.direct import (assemble, cholesky_apply, cholesky_factor,
                                            cholesky_factor_dropping)
from tumble.pipeline.solvers.guess import REDUNDANT, _dropped_rows_hold

FAST = settings(max_examples=60, deadline=None)


def semidefinite(seed, n, rank):
    """A = J J^T (n, n) of the given rank, J with entries of order 1."""
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(rank, 6)) if rank else np.zeros((0, 6))
    mix = rng.normal(size=(n - rank, rank)) if rank else np.zeros((n - rank, 0))
    rows = np.vstack([J, mix @ J])[rng.permutation(n)]
    return rows @ rows.T + 0.0, rows


def relative_pivots(rows):
    """Each row's exact Cholesky pivot over its diagonal entry: its squared distance from
    the span of the rows before it over its squared length (0: it depends on them)."""
    out = []
    for i, r in enumerate(rows):
        if i == 0:
            rest = r
        else:
            coef = np.linalg.lstsq(rows[:i].T, r, rcond=None)[0]
            rest = r - rows[:i].T @ coef
        out.append(float(rest @ rest) / float(r @ r))
    return np.array(out)


@FAST
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 12), rank=st.integers(1, 6))
def test_dropping_solves_a_consistent_semidefinite_system(seed, n, rank):
    rank = min(rank, n)
    A, rows = semidefinite(seed, n, rank)
    # a row that nearly depends on those before it (pivot 1e-6 of its diagonal) leaves the
    # next dependent row a round-off pivot near the 1e-10 threshold, on either side of it:
    # the count below holds for independent rows that are not that close to dependent
    pivots = relative_pivots(rows)
    assume(np.all((pivots < 1e-20) | (pivots > 1e-4)))
    rng = np.random.default_rng(seed + 1)
    b = A @ rng.normal(size=n)                      # consistent: in A's range
    fac = np.zeros((n, n))
    dropped = cholesky_factor_dropping(A, n, fac, REDUNDANT)
    assert dropped == n - np.linalg.matrix_rank(rows, tol=1e-9)
    x = np.zeros(n)
    cholesky_apply(fac, b, n, x)
    assert np.all(np.isfinite(x))
    assert np.abs(A @ x - b).max() <= 1e-8 * (np.abs(b).max() + 1.0)
    assert np.count_nonzero(x[np.isinf(np.diag(fac))]) == 0      # dropped rows carry 0
    assert _dropped_rows_hold(A, b, fac, x, n)


@FAST
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 12), rank=st.integers(1, 5))
def test_an_inconsistent_dropped_row_is_caught(seed, n, rank):
    rank = min(rank, n - 1)
    A, rows = semidefinite(seed, n, rank)
    # as above: a row within 1e-6 of depending on those before it leaves the dependent
    # rows after it round-off pivots that may fall below zero (seed 10, n 10, rank 5:
    # a relative pivot of 2e-7, then the factorisation reports -1)
    pivots = relative_pivots(rows)
    assume(np.all((pivots < 1e-20) | (pivots > 1e-4)))
    rng = np.random.default_rng(seed + 1)
    fac = np.zeros((n, n))
    assert cholesky_factor_dropping(A, n, fac, REDUNDANT) >= 1
    b = A @ rng.normal(size=n)
    b[np.flatnonzero(np.isinf(np.diag(fac)))[0]] += 1.0           # off A's range
    x = np.zeros(n)
    cholesky_apply(fac, b, n, x)
    assert not _dropped_rows_hold(A, b, fac, x, n)


@FAST
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 10))
def test_dropping_equals_cholesky_on_a_definite_matrix(seed, n):
    rng = np.random.default_rng(seed)
    M = rng.normal(size=(n, n))
    A = M @ M.T + n * np.eye(n)
    fa, fb = np.zeros((n, n)), np.zeros((n, n))
    assert cholesky_factor(A, n, fa) and cholesky_factor_dropping(A, n, fb, REDUNDANT) == 0
    assert np.array_equal(np.tril(fa), np.tril(fb))


def dense_cholesky(A):
    """The textbook factor, every product taken (the kernel skips leading zeros)."""
    n = A.shape[0]
    L = np.zeros_like(A)
    for i in range(n):
        for k in range(i + 1):
            s = A[i, k]
            for t in range(k):
                s -= L[i, t] * L[k, t]
            L[i, k] = np.sqrt(s) if i == k else s / L[k, k]
    return L


@FAST
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 14), band=st.integers(0, 5))
def test_a_banded_factor_is_the_dense_one_to_the_bit(seed, n, band):
    """Rows with leading zeros (contacts sorted by body pair make a band) factor to the bit
    as the dense loops do, and solve the system."""
    rng = np.random.default_rng(seed)
    M = rng.normal(size=(n, n))
    A = M @ M.T + n * np.eye(n)
    A[np.abs(np.subtract.outer(np.arange(n), np.arange(n))) > band] = 0.0
    A += n * np.eye(n)                              # still positive definite
    fac = np.full((n, n), np.nan)                   # stale scratch must not leak in
    assert cholesky_factor(A, n, fac)
    ref = dense_cholesky(A)
    assert np.array_equal(np.tril(fac), ref)
    b = rng.normal(size=n)
    x = np.zeros(n)
    cholesky_apply(fac, b, n, x)
    np.testing.assert_allclose(A @ x, b, atol=1e-10 * (1.0 + np.abs(b).max()))


@FAST
@given(seed=st.integers(0, 2**32 - 1), runs=st.lists(
    st.tuples(st.integers(-1, 3), st.integers(-1, 3), st.integers(1, 4)), min_size=1,
    max_size=6))
def test_assembly_by_runs_of_rows_equals_J_Minv_JT(seed, runs):
    """Rows in runs on the same two bodies (either way round, the world as -1) assemble to
    ``J M^-1 J^T + CFM`` and ``rhs - J v`` as NumPy computes them from the whole Jacobian."""
    rng = np.random.default_rng(seed)
    nbody = 4
    pairs = [(a, b) for a, b, k in runs if a != b for _ in range(k)]
    assume(pairs)
    n = len(pairs)
    rows = make_rows_nb(n)
    inv_mass = rng.uniform(0.5, 2.0, nbody)
    inv_mass[3] = 0.0                               # a static body
    B = rng.normal(size=(nbody, 3, 3))
    inv_inertia = np.einsum("bij,bkj->bik", B, B) + np.eye(3)
    inv_inertia[3] = 0.0
    vel, angvel = rng.normal(size=(nbody, 3)), rng.normal(size=(nbody, 3))
    Jfull = np.zeros((n, 6 * nbody))
    Minv = np.zeros((6 * nbody, 6 * nbody))
    for body in range(nbody):
        Minv[6 * body:6 * body + 3, 6 * body:6 * body + 3] = inv_mass[body] * np.eye(3)
        Minv[6 * body + 3:6 * body + 6, 6 * body + 3:6 * body + 6] = inv_inertia[body]
    for r, (a, b) in enumerate(pairs):
        rows.body_a[r], rows.body_b[r] = a, b
        rows.J[r] = rng.normal(size=12)
        rows.rhs[r] = rng.normal()
        rows.cfm[r] = rng.uniform(0.0, 1e-3)
        for side, body in enumerate((a, b)):
            if body >= 0:
                Jfull[r, 6 * body:6 * body + 6] = rows.J[r, 6 * side:6 * side + 6]
    idx = np.arange(n)
    dv, A, b = np.zeros((n, 12)), np.full((n, n), np.nan), np.zeros(n)
    assemble(rows, idx, n, inv_mass, inv_inertia, vel, angvel, dv, A, b)
    ref = Jfull @ Minv @ Jfull.T + np.diag(rows.cfm[:n])
    np.testing.assert_allclose(A, ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(b, rows.rhs[:n] - Jfull @ np.hstack([vel, angvel]).ravel(),
                               rtol=1e-12, atol=1e-12)


def test_an_indefinite_matrix_is_refused():
    A = np.array([[1.0, 2.0], [2.0, 1.0]])
    assert cholesky_factor_dropping(A, 2, np.zeros((2, 2)), REDUNDANT) == -1


def test_the_ten_box_stack_stays_exact_with_dependent_rows_dropped():
    """Each box face has four contacts, one of whose rows depends on the others: dropped,
    the stack's last contact state solves its steps; it stays exact and never falls back."""
    w = tumble.World(benchmarks.build("stack"), contact="lcp")
    top0 = w.body_pos[-1].copy()
    w.step(benchmarks.STACK["steps"])
    assert w.lcp_fallbacks == 0
    assert np.linalg.norm(w.body_pos[-1] - top0) < 1e-6
