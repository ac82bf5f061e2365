"""Mass properties of primitives and composites against closed forms and sampling."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import tumble
from tumble.model import mass


def sampled_mass_properties(inside, half_box, density, n=400_000, seed=0):
    """Monte Carlo mass, COM and inertia of the solid {x: inside(x)} within a bounding box."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, (n, 3)) * half_box
    x = x[inside(x)]
    vol = 8.0 * np.prod(half_box) * len(x) / n
    m = density * vol
    com = x.mean(0)
    d = x - com
    inertia = m * (np.eye(3) * (d * d).sum(1).mean() - d.T @ d / len(d))
    return m, com, inertia


def test_sphere_and_box_closed_forms():
    m, i = mass.sphere_mass(0.5, 1000.0)
    assert m == pytest.approx(1000.0 * 4 / 3 * math.pi * 0.125)
    np.testing.assert_allclose(i, [0.4 * m * 0.25] * 3)
    m, i = mass.box_mass((0.5, 1.0, 1.5), 2.0)
    assert m == pytest.approx(2.0 * 1 * 2 * 3)
    np.testing.assert_allclose(i, m / 12 * np.array([4 + 9, 1 + 9, 1 + 4]))


def test_cylinder_closed_form():
    m, i = mass.cylinder_mass(0.2, 0.5, 500.0)
    assert m == pytest.approx(500.0 * math.pi * 0.04 * 1.0)
    np.testing.assert_allclose(i, [m * (3 * 0.04 + 1.0) / 12, m * (3 * 0.04 + 1.0) / 12,
                                   m * 0.04 / 2])


@pytest.mark.parametrize("radius,half", [(0.1, 0.2), (0.3, 0.05)])
def test_capsule_against_sampling(radius, half):
    m, i = mass.capsule_mass(radius, half, 1000.0)
    v = math.pi * radius ** 2 * 2 * half + 4 / 3 * math.pi * radius ** 3
    assert m == pytest.approx(1000.0 * v, rel=1e-12)

    def inside(x):
        z = np.clip(x[:, 2], -half, half)
        return x[:, 0] ** 2 + x[:, 1] ** 2 + (x[:, 2] - z) ** 2 <= radius ** 2
    ms, com, isamp = sampled_mass_properties(inside, np.array([radius, radius, half + radius]),
                                             1000.0)
    assert ms == pytest.approx(m, rel=0.01)
    np.testing.assert_allclose(np.diag(isamp), i, rtol=0.02)


def test_composite_is_parallel_axis_sum():
    # two unit cubes side by side along x = one 2 x 1 x 1 box
    m1, i1 = mass.box_mass((0.5, 0.5, 0.5), 3.0)
    m, com, inertia = mass.combine([m1, m1], [(-0.5, 0, 0), (0.5, 0, 0)], [np.diag(i1)] * 2)
    mb, ib = mass.box_mass((1.0, 0.5, 0.5), 3.0)
    assert m == pytest.approx(mb)
    np.testing.assert_allclose(com, 0.0, atol=1e-15)
    np.testing.assert_allclose(inertia, np.diag(ib), rtol=1e-12, atol=1e-15)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.1, 5.0), min_size=3, max_size=3),
       st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1))
def test_principal_axes_match_eigh(moments, q):
    moments = np.sort(moments)
    if moments[2] > moments[0] + moments[1]:
        moments[2] = moments[0] + moments[1]
    r = Rotation.from_quat(np.array(q) / np.linalg.norm(q)).as_matrix()
    tensor = r @ np.diag(moments) @ r.T
    pm, axes = mass.principal_axes(tensor)
    np.testing.assert_allclose(np.sort(pm), np.linalg.eigh(tensor)[0], rtol=1e-9)
    assert np.linalg.det(axes) == pytest.approx(1.0)
    np.testing.assert_allclose(axes @ np.diag(pm) @ axes.T, tensor, atol=1e-10)


def test_diagonal_inertia_keeps_its_axes():
    pm, axes = mass.principal_axes(np.diag([3.0, 1.0, 2.0]))
    np.testing.assert_array_equal(pm, [3.0, 1.0, 2.0])
    np.testing.assert_array_equal(axes, np.eye(3))


@pytest.mark.parametrize("inertia,message", [
    ((1.0, 1.0, -1.0), "positive definite"),
    ((1.0, 1.0, 3.0), "triangle inequality"),
    (((1.0, 0.5, 0), (0.0, 1.0, 0), (0, 0, 1.0)), "not symmetric"),
    ((1.0, np.nan, 1.0), "non-finite"),
    ((0.0, 0.0, 0.0), "zero"),
    ((1.0, 1.0), "shape"),
])
def test_bad_inertia_is_refused(inertia, message):
    with pytest.raises(tumble.ModelError, match=message):
        mass.check_inertia(inertia, "body 'x'")
