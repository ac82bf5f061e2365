"""Scene: meshes of every geom type (closed, outward, with the shape's volume), geom and joint
poses against World's own transforms, colours, and the array round trip."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tumble
from tests.viewer.helpers import demo_model
from tumble.viewer import Scene
from tumble.viewer import scene as S


def _volume(v, f):
    return np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6.0


def _weld(v, f):
    """Merge coincident vertices (meshes split them at sharp edges for shading)."""
    _, first, inverse = np.unique(np.round(v, 9), axis=0, return_index=True,
                                  return_inverse=True)
    return v[first], inverse.reshape(-1)[f]


def _check_closed_outward(v, f):
    v, f = _weld(v, f)
    # every directed edge appears once and its reverse once: a closed, consistently wound surface
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    fwd = {tuple(e) for e in edges}
    assert len(fwd) == len(edges)
    assert all((b, a) in fwd for a, b in fwd)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert np.all(np.linalg.norm(n, axis=1) > 0)              # no degenerate triangles
    assert _volume(v, f) > 0                                  # counter-clockwise from outside


@pytest.mark.parametrize("kind, mesh, exact, rel", [
    ("box", lambda d: S.box_mesh((0.3, 0.2, 0.1)), 8 * 0.3 * 0.2 * 0.1, 1e-12),
    ("sphere", lambda d: S.sphere_mesh(0.5, d), 4 / 3 * np.pi * 0.125, None),
    ("capsule", lambda d: S.capsule_mesh(0.2, 0.3, d),
     np.pi * 0.04 * 0.6 + 4 / 3 * np.pi * 0.008, None),
    ("cylinder", lambda d: S.cylinder_mesh(0.2, 0.3, d), np.pi * 0.04 * 0.6, None),
])
def test_primitive_meshes_are_closed_and_have_the_shapes_volume(kind, mesh, exact, rel):
    for detail in (8, 16, 48):
        v, f = mesh(detail)
        _check_closed_outward(v, f)
        vol = _volume(v, f)
        # an inscribed polyhedron: a little smaller, converging as detail grows
        if rel is None:
            assert vol < exact
            assert vol > exact * (1 - 25.0 / detail ** 2)
        else:
            assert vol == pytest.approx(exact, rel=rel)


def test_box_mesh_faces_point_out_and_cover_six_sides():
    v, f = S.box_mesh((1.0, 2.0, 3.0))
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    centre = v[f].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", n, centre) > 0)
    assert len({tuple(np.round(x, 9)) for x in n}) == 6


def test_hull_mesh_of_a_point_cloud_is_its_convex_hull():
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(40, 3)) + (2.0, 0.0, 0.0)       # off the origin on purpose
    v, f = S.hull_mesh(pts)
    _check_closed_outward(v, f)
    from scipy.spatial import ConvexHull
    assert _volume(v, f) == pytest.approx(ConvexHull(pts).volume, rel=1e-12)


def test_heightfield_mesh_is_the_grid_surface_facing_up():
    h = np.array([[0.0, 0.1, 0.2], [0.3, 0.4, 0.5]])
    v, f = S.heightfield_mesh(h, (1.0, 0.5, 0.1))
    assert v.shape == (6, 3) and f.shape == (4, 3)
    assert v[:, 0].min() == -1.0 and v[:, 0].max() == 1.0      # columns along x
    assert v[:, 1].min() == -0.5 and v[:, 1].max() == 0.5      # rows along y
    np.testing.assert_array_equal(v[:, 2], h.ravel())
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert np.all(n[:, 2] > 0)


def test_every_geom_of_a_model_has_a_mesh():
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    b.add_geom(None, "heightfield", heights=np.zeros((4, 5)), size=(2.0, 1.0, 0.2))
    model_scene = Scene.from_model(demo_model())
    for g in range(model_scene.ngeom):
        v, f = model_scene.geom_mesh(g, detail=10)
        assert v.ndim == 2 and v.shape[1] == 3 and f.max() < len(v)
    s2 = Scene.from_model(b.build())
    assert len(s2.geom_mesh(1)[1]) == 2 * 3 * 4


def test_geom_poses_match_the_world(tmp_path):
    world = tumble.World(demo_model())
    world.body_quat[:] = np.array([0.2, -0.3, 0.4, 0.8]) / np.linalg.norm([0.2, -0.3, 0.4, 0.8])
    world.body_pos[:] += (0.1, 0.2, 0.3)
    scene = Scene.from_model(world.model)
    r, p = scene.geom_poses(world.body_pos, world.body_quat)
    for g in range(scene.ngeom):
        b = scene.geom_body[g]
        if b < 0:
            np.testing.assert_allclose(p[g], world.model.geom_pos[g])
            continue
        np.testing.assert_allclose(p[g], world.body_to_world(b, world.model.geom_pos[g]),
                                   atol=1e-12)
        ex = r[g] @ np.array([1.0, 0.0, 0.0])
        local_x = S.quat_to_matrix(world.model.geom_quat[g])[:, 0]
        np.testing.assert_allclose(ex, world.vector_to_world(b, local_x), atol=1e-12)


def test_joint_axes_follow_the_bodies():
    b = tumble.ModelBuilder(gravity=(0, 0, -9.81))
    upper = b.add_body("upper", pos=(0, 0, 1.0), mass=1.0, inertia=(0.1, 0.1, 0.1))
    lower = b.add_body("lower", pos=(0, 0, 0.5), mass=1.0, inertia=(0.1, 0.1, 0.1))
    b.add_joint("hip", "ball", None, upper, anchor=(0, 0, 1.2))
    b.add_joint("knee", "hinge", upper, lower, anchor=(0, 0, 0.75), axis=(0, 1, 0))
    b.add_joint("wrist", "universal", None, lower, anchor=(0, 0, 0.3), axis=(1, 0, 0),
                axis2=(0, 0, 1))
    world = tumble.World(b.build())
    scene = Scene.from_model(world.model)
    anchors, axes = scene.joint_axes(world.body_pos, world.body_quat)
    np.testing.assert_allclose(anchors, [(0, 0, 1.2), (0, 0, 0.75), (0, 0, 0.3)], atol=1e-12)
    np.testing.assert_allclose(axes[1], [(0, 1, 0)], atol=1e-12)
    np.testing.assert_allclose(axes[2], [(1, 0, 0), (0, 0, 1)], atol=1e-12)
    assert axes[0].shape == (3, 3)
    # turn the upper body a quarter about z: the knee's axis (carried by it) turns to -x
    q = np.array([0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)])
    quat = world.body_quat.copy()
    quat[0] = q
    _, axes = scene.joint_axes(world.body_pos, quat)
    np.testing.assert_allclose(axes[1], [(-1, 0, 0)], atol=1e-12)


def test_colours_up_and_com():
    model = demo_model()
    scene = Scene.from_model(model, body_colors={"sphere_body": (255, 0, 0), 0: (0, 0, 1.0)})
    np.testing.assert_allclose(scene.body_color[1], (1, 0, 0))
    np.testing.assert_allclose(scene.body_color[0], (0, 0, 1))
    g = model.geom_index("geom3")            # the sphere's geom takes its body's colour
    assert scene.geom_body[g] == 1
    np.testing.assert_allclose(scene.geom_color[g], (1, 0, 0))
    np.testing.assert_allclose(scene.up, (0, 0, 1))
    pos = np.arange(15.0).reshape(5, 3)
    m = np.asarray(model.body_mass)
    np.testing.assert_allclose(scene.com(pos), (m[:, None] * pos).sum(0) / m.sum())
    with pytest.raises(tumble.ModelError, match="colour"):
        Scene.from_model(model, body_colors={"box_body": (1, 2)})
    with pytest.raises(tumble.ModelError, match="unknown body"):
        Scene.from_model(model, body_colors={"nobody": (1, 0, 0)})


def test_scene_arrays_round_trip_exactly():
    scene = Scene.from_model(demo_model())
    arrays = scene.to_arrays()
    again = Scene.from_arrays(arrays)
    for key, value in arrays.items():
        got = again.to_arrays()[key]
        assert got.dtype == value.dtype and np.array_equal(got, value), key
    del arrays["scene_geom_quat"]
    with pytest.raises(tumble.ModelError, match="scene_geom_quat"):
        Scene.from_arrays(arrays)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.01, 5.0), st.floats(0.0, 5.0), st.integers(3, 40))
def test_capsule_mesh_stays_inside_the_capsule(radius, half_length, detail):
    v, f = S.capsule_mesh(radius, half_length, detail)
    # distance of each vertex from the segment [-h, h] on z is the radius (on the surface)
    z = np.clip(v[:, 2], -half_length, half_length)
    d = np.linalg.norm(v - np.stack([0 * z, 0 * z, z], -1), axis=1)
    np.testing.assert_allclose(d, radius, rtol=1e-9)
    assert _volume(v, f) > 0
