"""Torsional and rolling friction (issue 6): rates and thresholds against the analytic
answers, for each contact model; nothing changes for a model without them."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tumble

G = 9.81
R = 0.1                                  # sphere radius, m
MODELS = ["lcp", "pgs", "penalty"]


def sphere_on_plane(contact, *, rolling=0.0, torsional=0.0, friction=1.0, normal=(0, 0, 1),
                    vel=(0, 0, 0), angvel=(0, 0, 0), dt=1 / 240):
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", normal=n, friction=friction)
    b.add_body("ball", pos=R * n, density=1000.0, vel=vel, angvel=angvel)
    b.add_geom("ball", "sphere", radius=R, friction=friction, rolling_friction=rolling,
               torsional_friction=torsional)
    return tumble.World(b.build(), dt=dt, contact=contact)


@pytest.mark.parametrize("contact", MODELS)
def test_rolling_sphere_decelerates_at_the_rolling_resistance_rate(contact):
    """Rolling without slipping against a resisting torque mu_r N:
    (I / R + m R) a = -mu_r m g, so a = -5 mu_r g / (7 R) for a solid sphere (2%).

    Sliding friction 0.4: penalty's regularised friction is a damper on the slip that is
    only stable below mu = 2 / (1 + m R^2 / I) = 0.57 for a sphere (see the penalty
    module); above, the slip rings between -+ mu f_n each step around the same mean."""
    mu_r = 0.005
    v0 = 2.0
    w = sphere_on_plane(contact, rolling=mu_r, vel=(v0, 0, 0), angvel=(0, v0 / R, 0),
                        friction=0.4)
    w.step(24)                                      # settle onto the plane
    v1, t1 = w.body_vel[0, 0], w.time
    w.step(240)
    accel = (w.body_vel[0, 0] - v1) / (w.time - t1)
    assert accel == pytest.approx(-5 * mu_r * G / (7 * R), rel=0.02)
    # still rolling, not sliding (about the contact, R less the penetration)
    assert w.body_vel[0, 0] == pytest.approx(R * w.body_angvel[0, 1], rel=0.03)
    if contact != "penalty":
        assert w.body_vel[0, 0] == pytest.approx(R * w.body_angvel[0, 1], rel=1e-3)


@pytest.mark.parametrize("contact", ["lcp", "pgs"])
def test_sphere_on_an_incline_rolls_only_above_the_rolling_threshold(contact):
    """Gravity's torque about the contact, m g R sin(theta), beats mu_r m g cos(theta) only
    when tan(theta) > mu_r / R: just below the sphere stays put (< 1 mm in 2 s), just above
    it rolls down with a = 5/7 g (sin(theta) - mu_r / R cos(theta)) (2%)."""
    mu_r = 0.01
    for factor, rolls in ((0.9, False), (1.3, True)):
        theta = np.arctan(factor * mu_r / R)
        n = (np.sin(theta), 0.0, np.cos(theta))
        w = sphere_on_plane(contact, rolling=mu_r, normal=n)
        start = w.body_pos[0].copy()
        w.step(48)
        down = np.array([np.cos(theta), 0.0, -np.sin(theta)])
        v1, t1 = w.body_vel[0] @ down, w.time
        w.step(432)
        if rolls:
            accel = (w.body_vel[0] @ down - v1) / (w.time - t1)
            expected = 5 / 7 * G * (np.sin(theta) - mu_r / R * np.cos(theta))
            assert accel == pytest.approx(expected, rel=0.02)
        else:
            assert np.linalg.norm(w.body_pos[0] - start) < 1e-3


@pytest.mark.parametrize("contact", MODELS)
def test_spinning_sphere_stops_in_the_torsional_friction_time(contact):
    """Spinning about the normal against mu_t m g: I dw/dt = -mu_t m g, so it stops after
    t = w0 I / (mu_t m g) = 0.4 w0 R^2 / (mu_t g); the rate is checked halfway (2%) and the
    sphere is at rest just after t."""
    mu_t, w0 = 0.01, 20.0
    w = sphere_on_plane(contact, torsional=mu_t, angvel=(0, 0, w0))
    rate = mu_t * G / (0.4 * R * R)
    t_stop = w0 / rate
    w.step(12)
    s1, t1 = w.body_angvel[0, 2], w.time
    w.step(int(0.5 * t_stop * 240))
    assert (w.body_angvel[0, 2] - s1) / (w.time - t1) == pytest.approx(-rate, rel=0.02)
    # the contact reports the torsional torque on the sphere: -mu_t N about +z
    torque = w.contacts.torque.sum(0)
    np.testing.assert_allclose(torque, [0, 0, -mu_t * w.contacts.normal_force.sum()],
                               atol=0.02 * mu_t * G * w.model.body_mass[0])
    w.step(int((t_stop - w.time) * 240) + 24)
    assert abs(w.body_angvel[0, 2]) < 0.02 * w0


@pytest.mark.parametrize("contact", MODELS)
def test_spinning_box_stops_in_the_torsional_friction_time(contact):
    """A frictionless unit box spinning on its face: its four contacts share the weight,
    so together they resist with mu_t m g and dw/dt = -mu_t m g / I_zz (2%)."""
    mu_t, w0 = 0.02, 2.0
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", friction=0.0)
    b.add_body("box", pos=(0, 0, 0.5), mass=1.0, inertia=(1 / 6, 1 / 6, 1 / 6),
               angvel=(0, 0, w0))
    b.add_geom("box", "box", size=(0.5, 0.5, 0.5), friction=0.0, torsional_friction=mu_t)
    w = tumble.World(b.build(), dt=1 / 240, contact=contact)
    rate = mu_t * G / (1 / 6)
    w.step(12)
    s1, t1 = w.body_angvel[0, 2], w.time
    w.step(240)
    assert (w.body_angvel[0, 2] - s1) / (w.time - t1) == pytest.approx(-rate, rel=0.02)
    w.step(int((w0 / rate - w.time) * 240) + 48)
    assert abs(w.body_angvel[0, 2]) < 0.02 * w0
    assert abs(w.body_pos[0, 2] - 0.5) < 2e-3


def scene(contact, spin_elsewhere):
    """Boxes, spheres and a hinged capsule falling onto a plane; with ``spin_elsewhere`` a
    far static sphere has spin friction, so every contact carries six rows (three of them
    inactive) instead of three."""
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", friction=0.7)
    for i in range(4):
        b.add_body(f"b{i}", pos=(0.1 * i, 0.05 * i, 0.3 + 0.45 * i),
                   quat=Rotation.from_rotvec((0.2 * i, 0, 0.1)).as_quat(), density=500.0,
                   angvel=(0.3 * i, -0.2, 0.5), vel=(0.2, 0, 0))
        if i % 2 == 0:
            b.add_geom(f"b{i}", "box", size=(0.2, 0.15, 0.1), friction=0.5)
        else:
            b.add_geom(f"b{i}", "sphere", radius=0.15, friction=0.5, restitution=0.2)
    b.add_body("arm", pos=(1.0, 0, 0.5), mass=1.0, inertia=(0.01, 0.05, 0.05))
    b.add_geom("arm", "capsule", radius=0.05, half_length=0.3, quat=(0, 0.7071, 0, 0.7071))
    b.add_joint("pin", "hinge", None, "arm", anchor=(0.7, 0, 0.5), axis=(0, 1, 0),
                limit=(-0.5, 0.5))
    if spin_elsewhere:
        b.add_body("far", pos=(50, 50, 50), kind="static")
        b.add_geom("far", "sphere", radius=0.1, rolling_friction=0.01, torsional_friction=0.01)
    return tumble.World(b.build(), dt=1 / 240, contact=contact)


@pytest.mark.parametrize("contact", MODELS)
def test_pairs_without_spin_friction_are_bit_identical(contact):
    """Inactive spin rows cost nothing in the answer: the same trajectory to the bit."""
    plain, padded = scene(contact, False), scene(contact, True)
    for _ in range(60):
        plain.step(4)
        padded.step(4)
        n = plain.model.nbody
        for field in ("body_pos", "body_quat", "body_vel", "body_angvel"):
            np.testing.assert_array_equal(getattr(plain, field), getattr(padded, field)[:n])
    np.testing.assert_array_equal(plain.contacts.force, padded.contacts.force)
    assert len(plain.contacts) > 0 and not padded.contacts.torque.any()


def test_lcp_solves_sliding_rolling_and_torsion_together_without_fallback():
    """A sphere that slides, rolls and spins at once: Lemke solves the grouped pyramids
    (tangents, rolling, torsion) every step, each within its bound (the tangent and the
    rolling pairs in 4-sided pyramids, torsion in a box), and the spin about the normal
    still falls at exactly mu_t g / (0.4 R^2), as PGS has it too."""
    mu, mu_r, mu_t = 0.3, 0.004, 0.004
    kw = dict(rolling=mu_r, torsional=mu_t, friction=mu, vel=(1.0, 0.5, 0),
              angvel=(4.0, -3.0, 15.0))
    rate = mu_t * G / (0.4 * R * R)
    for contact in ("lcp", "pgs"):
        w = sphere_on_plane(contact, **kw)
        w.step(12)
        s1 = w.body_angvel[0, 2]
        for _ in range(60):
            w.step()
            imp = w.contact_arrays.impulse[0, 0]
            assert abs(imp[3]) <= mu_t * imp[0] * (1 + 1e-9)
            if contact == "lcp":
                assert abs(imp[1]) + abs(imp[2]) <= mu * imp[0] * (1 + 1e-9)
                assert abs(imp[4]) + abs(imp[5]) <= mu_r * imp[0] * (1 + 1e-9)
        assert (w.body_angvel[0, 2] - s1) / (60 * w.dt) == pytest.approx(-rate, rel=0.02)
        assert w.lcp_fallbacks == 0


@pytest.mark.parametrize("field", ["rolling_friction", "torsional_friction"])
@pytest.mark.parametrize("value", [-0.01, np.nan, "a"])
def test_bad_spin_friction_is_refused(field, value):
    b = tumble.ModelBuilder()
    b.add_body("ball", density=1000.0)
    with pytest.raises(tumble.ModelError, match=f"geom 'shell': {field} must be"):
        b.add_geom("ball", "sphere", radius=0.1, name="shell", **{field: value})
