"""Contact dynamics of each model against analytic answers (stated tolerances)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tumble
from tumble.apps import benchmarks

G = 9.81
MODELS = ["lcp", "pgs", "penalty"]


def box_on_plane(contact, normal=(0, 0, 1), mu=0.9, **world_kwargs):
    """A unit box resting on a plane through the origin with the given normal."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    rot = Rotation.align_vectors([n], [[0, 0, 1]])[0]
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", normal=n, friction=mu)
    b.add_body("box", pos=0.5 * n, quat=rot.as_quat(), mass=1.0, inertia=(1 / 6, 1 / 6, 1 / 6))
    b.add_geom("box", "box", size=(0.5, 0.5, 0.5), friction=mu)
    return tumble.World(b.build(), dt=1 / 240, contact=contact, **world_kwargs)


@pytest.mark.parametrize("contact", MODELS)
def test_box_rests_on_a_plane(contact):
    w = box_on_plane(contact)
    heights = []
    for _ in range(480):
        w.step()
        heights.append(w.body_pos[0, 2])
    assert max(abs(h - 0.5) for h in heights) < 1e-3          # within 1 mm of rest height
    assert np.abs(w.body_vel).max() < 1e-4 and np.abs(w.body_angvel).max() < 1e-4
    assert len(w.contacts) == 4
    force, torque = w.contact_force("box")
    np.testing.assert_allclose(force, [0, 0, G], atol=1e-3 * G)   # carries its weight
    np.testing.assert_allclose(w.contacts.normal, np.tile([0, 0, 1.0], (4, 1)))


@pytest.mark.parametrize("contact", MODELS)
def test_box_slides_down_an_incline_at_the_coulomb_rate(contact):
    mu = 0.5
    theta = np.arctan(mu * 1.2)                     # tan(theta) just above mu
    n = (np.sin(theta), 0.0, np.cos(theta))
    w = box_on_plane(contact, normal=n, mu=mu)
    down = np.array([np.cos(theta), 0.0, -np.sin(theta)])
    w.step(120)                                       # settle into sliding
    v0, t0 = w.body_vel[0] @ down, w.time
    w.step(240)
    accel = (w.body_vel[0] @ down - v0) / (w.time - t0)
    assert accel == pytest.approx(G * (np.sin(theta) - mu * np.cos(theta)), rel=0.02)


@pytest.mark.parametrize("contact", MODELS)
def test_box_sticks_just_below_the_friction_threshold(contact):
    mu = 0.5
    theta = np.arctan(mu * 0.9)
    w = box_on_plane(contact, normal=(np.sin(theta), 0.0, np.cos(theta)), mu=mu)
    w.step(24)                # penalty's springs settle first (0.7 mm in, 0.3 mm along)
    start = w.body_pos[0].copy()
    w.step(480)                                       # 2 s
    assert np.linalg.norm(w.body_pos[0] - start) < 1e-3


def test_penalty_static_friction_holds_for_10_s():
    """30 degrees, mu 0.7 > tan 30: penalty's stick spring holds the box within the
    spring's stretch (under 1 mm in 10 s; the regularised law creeps tens of cm)."""
    theta = np.radians(30.0)
    results = {}
    for slip in (None, G / 240):
        w = box_on_plane("penalty", normal=(np.sin(theta), 0.0, np.cos(theta)), mu=0.7,
                         slip_velocity=slip)
        w.step(24)
        start = w.body_pos[0].copy()
        w.step(2400)
        results[slip] = np.linalg.norm(w.body_pos[0] - start)
    assert results[None] < 1e-3, results
    assert results[G / 240] > 0.05, results                   # the lecture's law creeps


def test_penalty_stack_of_ten_boxes_stands_with_the_defaults():
    """The bench's stack at 1/240 s, 20 s: it stands, compressed like ten springs in
    series: box i sinks sum_{j <= i} (n - j) m g / (4 k), k = m / (16 h^2)."""
    w = tumble.World(benchmarks.stack(), contact="penalty")
    p0 = w.body_pos.copy()
    w.step(4800)
    n, h = w.model.nbody, w.dt
    k = 1.0 / (16 * h * h) * benchmarks.STACK["mass"]
    load = np.arange(n, 0, -1) * benchmarks.STACK["mass"] * G      # on each box's contacts
    sink = np.cumsum(load / (4 * k))
    np.testing.assert_allclose(p0[:, 2] - w.body_pos[:, 2], sink, rtol=0.05, atol=5e-4)
    assert np.abs(w.body_pos[:, :2] - p0[:, :2]).max() < 0.01     # no sideways drift
    assert np.abs(w.body_vel).max() < 1e-3


@pytest.mark.parametrize("contact", ["lcp", "pgs"])
@pytest.mark.parametrize("e", [0.0, 0.5, 0.8])
def test_ball_bounces_to_its_restitution_height(contact, e):
    h0 = 1.0
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", restitution=e)
    b.add_body("ball", pos=(0, 0, h0 + 0.1), density=1000.0)
    b.add_geom("ball", "sphere", radius=0.1, restitution=e)
    w = tumble.World(b.build(), dt=1 / 1000, contact=contact)
    bounced, apex = False, 0.0
    for _ in range(2000):
        w.step()
        if w.body_vel[0, 2] > 0.0:
            bounced = True
        if bounced:
            apex = max(apex, w.body_pos[0, 2] - 0.1)
    assert apex == pytest.approx(e * e * h0, abs=0.02 * h0)


def stack_world(contact, **kwargs):
    b = tumble.ModelBuilder(gravity=(0, 0, benchmarks.GRAVITY))
    b.add_geom(None, "plane", friction=benchmarks.FRICTION)
    half = benchmarks.STACK["half"]
    for i, p in enumerate(benchmarks.stack_positions()):
        b.add_body(f"box{i}", pos=p, mass=benchmarks.STACK["mass"],
                   inertia=benchmarks.box_inertia(benchmarks.STACK["mass"], half, half, half))
        b.add_geom(f"box{i}", "box", size=(half, half, half), friction=benchmarks.FRICTION)
    return tumble.World(b.build(), dt=benchmarks.STACK["dt"], contact=contact, **kwargs)


@pytest.mark.parametrize("contact", ["lcp", "pgs"])
def test_ten_box_stack_stands(contact):
    w = stack_world(contact)
    top0 = w.body_pos[-1].copy()
    w.step(benchmarks.STACK["steps"])
    assert np.linalg.norm(w.body_pos[-1] - top0) < 1e-3       # PyBullet drifts 5.8 mm
    assert np.abs(w.body_vel).max() < 1e-3
    assert w.lcp_fallbacks <= 0.01 * benchmarks.STACK["steps"]   # Lemke reports rare failures


def test_contact_filtering():
    b = tumble.ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", pos=(0, 0, 0), mass=1.0, inertia=(1, 1, 1))
    b.add_geom("a", "sphere", radius=0.5)
    b.add_body("b", pos=(0.8, 0, 0), mass=1.0, inertia=(1, 1, 1))
    b.add_geom("b", "sphere", radius=0.5)
    b.add_body("c", pos=(0, 0.8, 0), mass=1.0, inertia=(1, 1, 1))
    b.add_geom("c", "sphere", radius=0.5, contype=2, conaffinity=2)
    b.add_body("d", pos=(0, -0.8, 0), mass=1.0, inertia=(1, 1, 1))
    b.add_geom("d", "sphere", radius=0.5)
    b.add_joint("ab", "ball", "a", "b", anchor=(0.4, 0, 0))   # joined: no contact
    b.exclude_collision("a", "d")
    w = tumble.World(b.build())
    w.step()
    pairs = {tuple(p) for p in w.contacts.bodies}
    assert pairs == set()                    # a-b joined, a-c masks, a-d excluded, rest apart
    b2 = tumble.ModelBuilder(gravity=(0, 0, 0))
    b2.add_body("a", mass=1.0, inertia=(1, 1, 1))
    b2.add_geom("a", "sphere", radius=0.5)
    b2.add_body("b", pos=(0.8, 0, 0), mass=1.0, inertia=(1, 1, 1))
    b2.add_geom("b", "sphere", radius=0.5)
    b2.add_joint("ab", "ball", "a", "b", anchor=(0.4, 0, 0), collide=True)
    w2 = tumble.World(b2.build())
    w2.step()
    assert {tuple(p) for p in w2.contacts.bodies} == {(0, 1)}
    np.testing.assert_allclose(w2.contacts.normal[0], [1, 0, 0], atol=1e-9)


def test_many_contacts_grow_the_buffers():
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    for i in range(30):
        b.add_body(f"b{i}", pos=(1.2 * (i % 6), 1.2 * (i // 6), 0.49), mass=1.0,
                   inertia=(1 / 6,) * 3)
        b.add_geom(f"b{i}", "box", size=(0.5, 0.5, 0.5))
    w = tumble.World(b.build(), contact="pgs", contact_capacity=8)   # a small buffer
    w.step(3)
    assert w.contact_capacity >= 120
    assert len(w.contacts) == 120


def test_raycast_and_geom_distance_queries():
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", name="ground")
    b.add_body("ball", pos=(0, 0, 2.0), mass=1.0, inertia=(0.1,) * 3)
    b.add_geom("ball", "sphere", radius=0.5, name="ball")
    b.add_body("crate", pos=(3, 0, 0.5), mass=1.0, inertia=(0.1,) * 3)
    b.add_geom("crate", "box", size=(0.5, 0.5, 0.5), name="crate")
    w = tumble.World(b.build())
    t, geom, body, point, normal = w.raycast((0, 0, 10), (0, 0, -1))
    assert (geom, body) == ("ball", "ball") and t == pytest.approx(7.5)
    np.testing.assert_allclose(normal, [0, 0, 1], atol=1e-12)
    t, geom, body, point, normal = w.raycast((0, 0, 10), (0, 0, -1), exclude_body="ball")
    assert geom == "ground" and body is None and t == pytest.approx(10.0)
    assert w.raycast((0, 0, 10), (0, 0, 1)) is None
    dist, pa, pb = w.geom_distance("ball", "crate")
    assert dist == pytest.approx(np.hypot(2.5, 1.0) - 0.5, abs=1e-6)   # to the box's top edge
    np.testing.assert_allclose(pb, [2.5, 0, 1.0], atol=1e-6)
    dist, pa, pb = w.geom_distance("ball", "ground")
    assert dist == pytest.approx(1.5, abs=1e-9)
    with pytest.raises(tumble.ModelError, match="unknown geom"):
        w.geom_distance("ball", "moon")


def test_a_free_joint_does_not_stop_collisions_with_the_world():
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    b.add_body("root", pos=(0, 0, 0.5), mass=1.0, inertia=(1 / 6,) * 3)
    b.add_geom("root", "box", size=(0.5, 0.5, 0.5))
    b.add_joint("float", "free", None, "root")
    w = tumble.World(b.build())
    w.step(60)
    assert w.body_pos[0, 2] == pytest.approx(0.5, abs=1e-3) and len(w.contacts) == 4


def test_convex_foot_rests_on_a_heightfield_terrain():
    """A convex hull (a wedge-free box of 8 points) on a sloped-then-flat heightfield."""
    x = np.linspace(-2, 2, 21)
    heights = np.tile(np.where(x < 0, 0.0, 0.0), (21, 1))      # flat terrain at z = 0
    heights[:, :5] = 0.3                                       # a raised ledge at x < -1.2
    corners = np.array([[sx * 0.1, sy * 0.05, sz * 0.03] for sx in (-1, 1)
                        for sy in (-1, 1) for sz in (-1, 1)])
    b = tumble.ModelBuilder()
    b.add_geom(None, "heightfield", heights=heights, size=(2.0, 2.0, 0.5), name="terrain")
    b.add_body("foot", pos=(0.5, 0, 0.2), density=1000.0)
    b.add_geom("foot", "convex", vertices=corners)
    model = b.build()
    assert model.body_mass[0] == pytest.approx(1000.0 * 0.2 * 0.1 * 0.06)
    w = tumble.World(model, contact="lcp")
    w.step(240)
    assert w.body_pos[0, 2] == pytest.approx(0.03, abs=1e-3)          # resting on the ground
    assert np.abs(w.body_vel[0]).max() < 1e-3
    t, geom, body, point, normal = w.raycast((-1.8, 0, 2), (0, 0, -1))
    assert geom == "terrain" and t == pytest.approx(1.7, abs=1e-6)      # onto the ledge
    with pytest.raises(tumble.ModelError, match="geom 'bad'"):
        b.add_geom("foot", "convex", vertices=np.zeros((4, 3)), name="bad")
    with pytest.raises(tumble.ModelError, match="heightfield may only belong"):
        b.add_geom("foot", "heightfield", heights=heights, size=(1, 1, 0.1))
