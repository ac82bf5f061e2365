"""Build-time mesh and heightfield helpers: hulls, exact mass properties, validation."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull, Delaunay
from scipy.spatial.transform import Rotation

from tumble.errors import ModelError
from tumble.model.meshes import MAX_HULL_VERTICES, convex_hull, convex_mass, heightfield

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


def box_corners(h):
    return np.array([[sx * h[0], sy * h[1], sz * h[2]]
                     for sz in (-1, 1) for sy in (-1, 1) for sx in (-1, 1)])


# ------------------------------------------------------------------------ convex_hull

def test_hull_keeps_only_hull_vertices_in_input_order():
    corners = box_corners([0.3, 0.2, 0.1])
    rng = np.random.default_rng(0)
    inner = rng.uniform(-1, 1, (30, 3)) * [0.3, 0.2, 0.1] * 0.9
    pts = np.vstack([inner[:10], corners[:4], inner[10:], corners[4:]])
    v = convex_hull(pts, "geom 'foot'")
    assert v.shape == (8, 3) and v.dtype == np.float64 and v.flags.c_contiguous
    assert np.array_equal(v, np.vstack([corners[:4], corners[4:]]))
    # lists work too, and duplicates are harmless
    assert convex_hull(np.vstack([corners, corners]).tolist(), "m").shape == (8, 3)


@pytest.mark.parametrize("points, match", [
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "at least 4 points"),
    (np.zeros((0, 3)), "at least 4 points"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.2, 0]], "coplanar"),
    ([[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3]], "coplanar|collinear"),
    ([[0, 0, 0]] * 5, "coincide"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, np.nan]], "finite"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, np.inf]], "finite"),
    ([[0, 0], [1, 0], [0, 1], [1, 1]], r"\(n, 3\)"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1e-14]], "coplanar"),
    ("abc", "numbers|\\(n, 3\\)"),
])
def test_hull_refuses_bad_points(points, match):
    with pytest.raises(ModelError, match=match) as err:
        convex_hull(points, "geom 'foot'")
    assert str(err.value).startswith("geom 'foot': ")


def test_hull_refuses_too_many_vertices():
    rng = np.random.default_rng(1)
    p = rng.normal(size=(MAX_HULL_VERTICES + 40, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)          # all on a sphere: all on the hull
    with pytest.raises(ModelError, match="more than 256") as err:
        convex_hull(p, "geom 'rock'")
    assert str(err.value).startswith("geom 'rock': ")
    assert convex_hull(p[:MAX_HULL_VERTICES], "g").shape == (MAX_HULL_VERTICES, 3)


# ------------------------------------------------------------------------ convex_mass

def test_cube_hull_mass_is_the_box_formula():
    h = np.array([0.3, 0.2, 0.1])
    rho = 750.0
    R = Rotation.from_rotvec([0.3, -0.5, 0.2]).as_matrix()
    c = np.array([1.0, -2.0, 0.5])
    v = c + box_corners(h) @ R.T
    mass, com, inertia = convex_mass(v, rho)
    m = rho * 8 * h.prod()
    assert np.isclose(mass, m, rtol=1e-12)
    assert np.allclose(com, c, atol=1e-12)
    ib = m / 3 * np.diag([h[1] ** 2 + h[2] ** 2, h[0] ** 2 + h[2] ** 2, h[0] ** 2 + h[1] ** 2])
    assert np.allclose(inertia, R @ ib @ R.T, atol=1e-12 * m)
    assert np.allclose(inertia, inertia.T)


def test_tetrahedron_mass_closed_form():
    # unit right tetrahedron: volume 1/6, com 1/4, inertia about the origin known
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    mass, com, inertia = convex_mass(v, 6.0)
    assert np.isclose(mass, 1.0) and np.allclose(com, 0.25)
    # second moments about the origin: int x^2 = 1/60 (x6), int xy = 1/120 (x6)
    c = 6.0 * (np.full((3, 3), 1 / 120) + np.eye(3) / 120)
    c -= mass * np.outer(com, com)
    assert np.allclose(inertia, np.trace(c) * np.eye(3) - c, atol=1e-12)


def tetrahedra_mass(v, rho):
    """Mass, COM and inertia about the COM of the hull of ``v`` summed over the tetrahedra
    of its Delaunay triangulation, each by the closed form: covariance about the origin
    ``V/20 (sum_i v_i v_i^T + s s^T)`` with ``s`` the sum of its four corners."""
    mass, first, second = 0.0, np.zeros(3), np.zeros((3, 3))
    for simplex in Delaunay(v).simplices:
        p = v[simplex]
        vol = abs(np.linalg.det(p[1:] - p[0])) / 6.0
        s = p.sum(axis=0)
        mass += rho * vol
        first += rho * vol * s / 4.0
        second += rho * vol / 20.0 * (p.T @ p + np.outer(s, s))
    com = first / mass
    cov = second - mass * np.outer(com, com)
    return mass, com, np.trace(cov) * np.eye(3) - cov


@settings(max_examples=15, deadline=None)
@given(seed=SEEDS)
def test_random_hull_mass_matches_its_tetrahedra(seed):
    """The hull's mass properties (surface integrals) against a sum over a Delaunay
    tetrahedralisation of the same points (volume integrals, closed form per tetrahedron):
    two independent exact methods, so they agree to round-off."""
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(rng.integers(5, 25), 3)) * rng.uniform(0.2, 1.0, 3) + rng.normal(size=3)
    v = convex_hull(pts, "g")
    rho = rng.uniform(100, 2000)
    mass, com, inertia = convex_mass(v, rho)
    assert np.isclose(mass, rho * ConvexHull(v).volume, rtol=1e-10)
    ref_mass, ref_com, ref_inertia = tetrahedra_mass(v, rho)
    size = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    assert abs(mass - ref_mass) < 1e-9 * mass
    assert np.linalg.norm(com - ref_com) < 1e-9 * size
    assert np.linalg.norm(inertia - ref_inertia) < 1e-9 * np.linalg.norm(inertia)
    assert np.all(np.linalg.eigvalsh(inertia) > 0)


def test_mass_refuses_bad_input():
    v = box_corners([1, 1, 1])
    for rho in (0.0, -1.0, np.nan, "x"):
        with pytest.raises(ModelError, match="density") as err:
            convex_mass(v, rho, "geom 'foot'")
        assert str(err.value).startswith("geom 'foot': ")
    with pytest.raises(ModelError, match="coplanar"):
        convex_mass(v * [1, 1, 0], 1.0, "geom 'foot'")


# ------------------------------------------------------------------------ heightfield

def test_heightfield_accepts_and_copies():
    h = np.arange(12.0).reshape(3, 4)[:, ::-1]        # not contiguous
    data, size = heightfield(h.tolist(), (2.0, 1.0, 0.0), "geom 'terrain'")
    assert data.shape == (3, 4) and data.flags.c_contiguous and np.array_equal(data, h)
    assert size.dtype == np.float64 and np.array_equal(size, [2.0, 1.0, 0.0])
    data[0, 0] = -5
    assert h[0, 0] == 3.0


@pytest.mark.parametrize("heights, size, match", [
    (np.zeros(5), (1, 1, 0), "2-D"),
    (np.zeros((2, 2, 2)), (1, 1, 0), "2-D"),
    (np.zeros((1, 5)), (1, 1, 0), "2 x 2"),
    (np.zeros((5, 1)), (1, 1, 0), "2 x 2"),
    ([[0, 1], [np.nan, 0]], (1, 1, 0), "finite"),
    ([[0, 1], [np.inf, 0]], (1, 1, 0), "finite"),
    (np.zeros((2, 2)), (0, 1, 0), "half extents"),
    (np.zeros((2, 2)), (1, -1, 0), "half extents"),
    (np.zeros((2, 2)), (1, 1, -0.1), "base"),
    (np.zeros((2, 2)), (1, 1), "half_x, half_y, base"),
    (np.zeros((2, 2)), (1, np.nan, 1), "finite"),
    ("abc", (1, 1, 0), "heights"),
])
def test_heightfield_refuses_bad_input(heights, size, match):
    with pytest.raises(ModelError, match=match) as err:
        heightfield(heights, size, "geom 'terrain'")
    assert str(err.value).startswith("geom 'terrain': ")
