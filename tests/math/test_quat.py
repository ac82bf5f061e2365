"""Quaternion kernels against scipy's Rotation (x, y, z, w) and closed forms."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tumble.math import (quat_conj, quat_exp, quat_from_axis_angle, quat_from_mat,
                         quat_integrate_exp, quat_integrate_linear, quat_log, quat_mul,
                         quat_normalize, quat_rotate, quat_rotate_inv, quat_to_mat)
from tumble.math.spatial import apply_inertia, cross, inertia_world, point_velocity, skew

finite = st.floats(-1.0, 1.0, allow_nan=False)
quats = st.tuples(finite, finite, finite, finite).filter(
    lambda q: np.linalg.norm(q) > 1e-3).map(lambda q: np.array(q) / np.linalg.norm(q))
vecs = st.tuples(*(st.floats(-10.0, 10.0, allow_nan=False),) * 3).map(np.array)
SET = settings(max_examples=200, deadline=None)


def same_rotation(a, b, tol=1e-12):
    return min(np.abs(np.asarray(a) - b).max(), np.abs(np.asarray(a) + b).max()) < tol


@SET
@given(quats, quats)
def test_composition_matches_scipy(a, b):
    expected = (Rotation.from_quat(a) * Rotation.from_quat(b)).as_quat()
    assert same_rotation(quat_mul(a, b), expected)


@SET
@given(quats, vecs)
def test_rotate_and_inverse(q, v):
    r = Rotation.from_quat(q)
    np.testing.assert_allclose(quat_rotate(q, v), r.apply(v), atol=1e-12)
    np.testing.assert_allclose(quat_rotate_inv(q, v), r.inv().apply(v), atol=1e-12)
    np.testing.assert_allclose(quat_rotate_inv(q, quat_rotate(q, v)), v, atol=1e-12)
    assert same_rotation(quat_mul(q, quat_conj(q)), np.array([0, 0, 0, 1.0]))


@SET
@given(quats)
def test_matrix_round_trip(q):
    m = np.asarray(quat_to_mat(q))
    np.testing.assert_allclose(m, Rotation.from_quat(q).as_matrix(), atol=1e-12)
    assert same_rotation(quat_from_mat(m), q, tol=1e-10)
    assert quat_from_mat(m)[3] >= 0.0


@SET
@given(quats)
def test_log_exp_round_trip(q):
    r = np.asarray(quat_log(q))
    assert np.linalg.norm(r) <= np.pi + 1e-12
    assert same_rotation(quat_exp(r), q, tol=1e-10)
    expected = Rotation.from_quat(q).as_rotvec()
    if np.linalg.norm(expected) < np.pi - 1e-6:       # at pi, r and -r are both right
        np.testing.assert_allclose(r, expected, atol=1e-10)


def test_small_angles_have_no_cancellation():
    r = np.array([1e-12, -2e-12, 3e-12])
    np.testing.assert_allclose(quat_log(quat_exp(r)), r, rtol=1e-9)
    np.testing.assert_allclose(quat_exp(np.zeros(3)), [0, 0, 0, 1])


def test_axis_angle_and_normalize():
    q = np.asarray(quat_from_axis_angle(np.array([0.0, 0.0, 2.0]), np.pi / 2))
    np.testing.assert_allclose(quat_rotate(q, np.array([1.0, 0, 0])), [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(quat_normalize(np.array([1.0, 2, 3, 4]))), 1.0)


@pytest.mark.parametrize("steps", [1, 10, 240])
def test_exp_integration_is_exact_for_constant_angular_velocity(steps):
    w = np.array([0.3, -2.0, 5.0])
    h = 1.0 / 240.0
    q = np.array([0.1, 0.2, 0.3, 0.9])
    q = q / np.linalg.norm(q)
    out = q
    for _ in range(steps):
        out = np.asarray(quat_integrate_exp(out, w, h))
    exact = (Rotation.from_rotvec(w * h * steps) * Rotation.from_quat(q)).as_quat()
    assert same_rotation(out, exact, tol=1e-12)


def test_linear_integration_is_first_order_and_unit():
    """q + h/2 (w,0) q, normalised: the angle per step falls short by O((|w| h)^3)."""
    w = np.array([0.0, 0.0, 6.0])
    for h in (1e-2, 5e-3):
        q = np.asarray(quat_integrate_linear(np.array([0.0, 0, 0, 1]), w, h))
        assert abs(np.linalg.norm(q) - 1.0) < 1e-15
        angle = 2.0 * np.arctan2(q[2], q[3])
        exact = 6.0 * h
        # tan(a/2) = |w| h / 2 exactly, so a = 2 atan(|w| h / 2)
        np.testing.assert_allclose(angle, 2.0 * np.arctan(exact / 2.0), rtol=1e-12)
        assert exact - angle < (exact ** 3) / 10.0


@SET
@given(vecs, vecs)
def test_cross_and_skew(a, b):
    np.testing.assert_allclose(cross(a, b), np.cross(a, b), atol=1e-12)
    np.testing.assert_allclose(np.asarray(skew(a)) @ b, np.cross(a, b), atol=1e-12)


@SET
@given(quats, vecs)
def test_world_inertia(q, w):
    moments = np.array([0.3, 0.5, 0.7])
    r = Rotation.from_quat(q).as_matrix()
    expected = r @ np.diag(moments) @ r.T
    np.testing.assert_allclose(inertia_world(q, moments), expected, atol=1e-12)
    np.testing.assert_allclose(apply_inertia(q, moments, w), expected @ w, atol=1e-10)


def test_point_velocity():
    v = point_velocity(np.array([1.0, 0, 0]), np.array([0, 0, 2.0]), np.zeros(3),
                       np.array([0.0, 1.0, 0.0]))
    np.testing.assert_allclose(v, [1.0 - 2.0, 0, 0])
