"""ModelBuilder and Model: validation, frames, mass from geoms, immutability."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tumble
from tumble.model import mass


def builder_with_body():
    b = tumble.ModelBuilder()
    b.add_body("a", pos=(0, 0, 1), mass=1.0, inertia=(0.1, 0.1, 0.1))
    return b


@pytest.mark.parametrize("kwargs,field", [
    (dict(mass=0.0, inertia=(1, 1, 1)), "mass"),
    (dict(mass=-2.0, inertia=(1, 1, 1)), "mass"),
    (dict(mass=float("nan"), inertia=(1, 1, 1)), "mass"),
    (dict(mass=1.0, inertia=(1, 1, 1), pos=(0, float("inf"), 0)), "pos"),
    (dict(mass=1.0, inertia=(1, 1, 1), quat=(0, 0, 0, 0)), "quat is zero"),
    (dict(mass=1.0, inertia=(1, 1, 1), quat=(0, 0, 0, 2)), "quat has norm"),
    (dict(mass=1.0, inertia=(1, 1, 1), vel=(0, 1)), "vel"),
    (dict(mass=1.0, inertia=(1, 2, 5)), "triangle"),
    (dict(mass=1.0, inertia=(1, 1, 0)), "positive definite"),
    (dict(inertia=(1, 1, 1)), "without mass"),
    (dict(), "needs mass"),
    (dict(mass=1.0, density=2.0), "not both"),
    (dict(mass=1.0, inertia=(1, 1, 1), kind="floating"), "kind"),
    (dict(kind="static", vel=(1, 0, 0)), "static body cannot move"),
])
def test_bad_body_is_refused_and_changes_nothing(kwargs, field):
    b = builder_with_body()
    with pytest.raises(tumble.ModelError, match=field) as err:
        b.add_body("thigh", **kwargs)
    assert "body 'thigh'" in str(err.value)
    b.add_body("thigh", mass=1.0, inertia=(1, 1, 1))   # the name is still free
    assert b.build().body_names == ["a", "thigh"]


def test_duplicate_and_unknown_names():
    b = builder_with_body()
    with pytest.raises(tumble.ModelError, match="already exists"):
        b.add_body("a", mass=1.0, inertia=(1, 1, 1))
    with pytest.raises(tumble.ModelError, match="unknown body 'nope'"):
        b.add_geom("nope", "sphere", radius=0.1)
    b.add_geom("a", "sphere", radius=0.1, name="ball")
    with pytest.raises(tumble.ModelError, match="geom 'ball'.*already exists"):
        b.add_geom("a", "sphere", radius=0.1, name="ball")
    model = b.build()
    with pytest.raises(tumble.ModelError, match="unknown body 'b'"):
        model.body_index("b")
    with pytest.raises(tumble.ModelError, match="out of range"):
        model.body_index(3)


@pytest.mark.parametrize("args,kwargs,message", [
    (("sphere",), dict(radius=-1.0), "radius"),
    (("sphere",), dict(), "needs a radius"),
    (("box",), dict(size=(1, 0, 1)), r"size\[1\]"),
    (("capsule",), dict(radius=0.1), "radius and half_length"),
    (("cone",), dict(size=(1, 1, 1)), "type must be"),
    (("box",), dict(size=(1, 1, 1), friction=-1), "friction"),
    (("box",), dict(size=(1, 1, 1), restitution=2), "restitution"),
    (("box",), dict(size=(1, 1, 1), quat=(0, 0, 0, 0)), "quat is zero"),
    (("plane",), dict(), "plane is infinite"),
])
def test_bad_geom_is_refused(args, kwargs, message):
    b = builder_with_body()
    with pytest.raises(tumble.ModelError, match=message):
        b.add_geom("a", *args, **kwargs)
    assert b.build().ngeom == 0


def test_builder_refuses_bad_options():
    with pytest.raises(tumble.ModelError, match="timestep"):
        tumble.ModelBuilder(timestep=0.0)
    with pytest.raises(tumble.ModelError, match="gravity"):
        tumble.ModelBuilder(gravity=(0, 0))
    with pytest.raises(tumble.ModelError, match="empty"):
        tumble.ModelBuilder().build()


def test_full_inertia_is_diagonalised_and_frame_rotated():
    rot = Rotation.from_euler("xyz", [0.3, -0.7, 1.1])
    moments = np.array([0.2, 0.5, 0.6])
    tensor = rot.as_matrix() @ np.diag(moments) @ rot.as_matrix().T
    b = tumble.ModelBuilder()
    b.add_body("a", pos=(1, 2, 3), mass=2.0, inertia=tensor)
    b.add_geom("a", "box", size=(0.1, 0.2, 0.3), pos=(0.5, 0, 0))
    m = b.build()
    np.testing.assert_allclose(np.sort(m.body_inertia[0]), moments, rtol=1e-12)
    r_body = Rotation.from_quat(m.body_quat0[0]).as_matrix()
    # The tensor seen in the world is unchanged by the choice of body frame.
    np.testing.assert_allclose(r_body @ np.diag(m.body_inertia[0]) @ r_body.T, tensor, atol=1e-12)
    # The geom stays where it was put, in the world.
    world_geom = m.body_pos0[0] + r_body @ m.geom_pos[0]
    np.testing.assert_allclose(world_geom, [1.5, 2, 3], atol=1e-12)


def test_mass_from_density_moves_com_and_uses_parallel_axes():
    b = tumble.ModelBuilder()
    b.add_body("dumbbell", pos=(0, 0, 1), density=1000.0)
    b.add_geom("dumbbell", "sphere", radius=0.1, pos=(0, 0, 0))
    b.add_geom("dumbbell", "sphere", radius=0.1, pos=(1.0, 0, 0))
    b.add_geom("dumbbell", "box", size=(0.05, 0.05, 0.05), pos=(0.5, 0, 0), density=500.0)
    m = b.build()
    ms, isph = mass.sphere_mass(0.1, 1000.0)
    mb, ibox = mass.box_mass((0.05, 0.05, 0.05), 500.0)
    assert m.body_mass[0] == pytest.approx(2 * ms + mb)
    np.testing.assert_allclose(m.body_pos0[0], [0.5, 0, 1], atol=1e-12)
    expected_transverse = 2 * (isph[0] + ms * 0.25) + ibox[0]
    np.testing.assert_allclose(m.body_inertia[0], [2 * isph[0] + ibox[0], expected_transverse,
                                                   expected_transverse], rtol=1e-12)
    np.testing.assert_allclose(m.geom_pos[:, 0], [-0.5, 0.5, 0.0], atol=1e-12)
    np.testing.assert_allclose(m.body_ipos[0], [0.5, 0, 0], atol=1e-12)


def test_mass_without_inertia_scales_the_geoms_shape():
    b = tumble.ModelBuilder()
    b.add_body("box", mass=6.0)
    b.add_geom("box", "box", size=(0.5, 1.0, 1.5))
    m = b.build()
    np.testing.assert_allclose(m.body_inertia[0], 6.0 / 12 * np.array([13, 10, 5]))


def test_body_with_density_but_no_solid_geom():
    b = tumble.ModelBuilder()
    b.add_body("ghost", density=1000.0)
    with pytest.raises(tumble.ModelError, match="body 'ghost'.*no sphere"):
        b.build()


def test_model_is_immutable():
    m = builder_with_body().build()
    with pytest.raises(ValueError):
        m.body_mass[0] = 3.0
    with pytest.raises(AttributeError):
        m.gravity = np.zeros(3)
    assert m.body_names == ["a"] and m.joint_names == []


def test_plane_normal_and_static_kinds():
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", normal=(0, 1, 0))
    b.add_body("wall", kind="static")
    b.add_geom("wall", "plane", normal=(1, 0, 0), pos=(2, 0, 0))
    m = b.build()
    z = Rotation.from_quat(m.geom_quat[0]).apply([0, 0, 1])
    np.testing.assert_allclose(z, [0, 1, 0], atol=1e-15)
    assert m.body_kind[0] == 2 and np.isinf(m.body_mass[0])
