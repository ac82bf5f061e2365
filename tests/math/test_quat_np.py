"""The vectorised NumPy quaternion helpers against scipy's Rotation."""
import numpy as np
from hypothesis import given, settings, strategies as st
from scipy.spatial.transform import Rotation, Slerp

from tumble.math import quat_np as Q

FAST = settings(max_examples=50, deadline=None)


def rotations(seed, n):
    return Rotation.random(n, random_state=seed)


@FAST
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 6))
def test_product_rotation_and_rotation_vector_match_scipy(seed, n):
    a, b = rotations(seed, n), rotations(seed + 1, n)
    v = np.random.default_rng(seed).normal(size=(n, 3))
    np.testing.assert_allclose((a * b).apply(v), Q.qrot(Q.qmul(a.as_quat(), b.as_quat()), v),
                               atol=1e-12)
    np.testing.assert_allclose(a.apply(v), Q.qrot(a.as_quat(), v), atol=1e-12)
    np.testing.assert_allclose(Q.qrot(Q.qmul(Q.qconj(a.as_quat()), a.as_quat()), v), v,
                               atol=1e-12)
    rv = Q.qrotvec(a.as_quat())
    np.testing.assert_allclose(Rotation.from_rotvec(rv).as_matrix(), a.as_matrix(), atol=1e-12)
    assert np.all(np.linalg.norm(rv, axis=-1) <= np.pi + 1e-12)
    np.testing.assert_allclose(Q.qangle(a.as_quat()), np.linalg.norm(rv, axis=-1), atol=1e-12)


@FAST
@given(seed=st.integers(0, 2**31 - 1), alpha=st.floats(0.0, 1.0))
def test_slerp_matches_scipy_and_keeps_its_ends(seed, alpha):
    r = rotations(seed, 2)
    q0, q1 = r.as_quat()
    expected = Slerp([0.0, 1.0], r)([alpha])
    got = Q.qslerp(q0, q1, alpha)
    np.testing.assert_allclose(Rotation.from_quat(got).as_matrix(), expected.as_matrix()[0],
                               atol=1e-10)
    assert np.array_equal(Q.qslerp(q0, q1, 0.0), q0)


@FAST
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 6))
def test_matrix_matches_scipy_and_single_quaternion_helpers_match_vectorised(seed, n):
    r = rotations(seed, n)
    q = r.as_quat()
    np.testing.assert_allclose(Q.qmatrix(q), r.as_matrix(), atol=1e-12)
    assert Q.qmatrix(q[0]).shape == (3, 3)
    v = np.random.default_rng(seed).normal(size=3)
    a, b = q[0], q[-1]
    np.testing.assert_allclose(Q.qmul_one(a, b), Q.qmul(a, b), atol=1e-15)
    np.testing.assert_allclose(Q.qconj_one(a), Q.qconj(a), atol=0.0)
    np.testing.assert_allclose(Q.qrot_one(a, v), Q.qrot(a, v), atol=1e-12)
    axis = v / np.linalg.norm(v)
    np.testing.assert_allclose(Q.qaxis_angle_one(axis, 0.7),
                               Rotation.from_rotvec(0.7 * axis).as_quat(), atol=1e-12)
