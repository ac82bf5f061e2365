"""Per-geom contact stiffness and damping (issue 6): the spring a geom is given is the
spring its contacts are, in the penalty model and (through ERP/CFM) in LCP and PGS."""
import warnings

import numpy as np
import pytest

import tumble
from tumble.pipeline.contacts.pairs import pair_softness

G = 9.81


def resting(contact, shape, mass, k_body=None, k_ground=None, c=None, dt=1 / 240):
    """Depth (m) at which a sphere of radius 0.1 or a cube of half side 0.1 rests after 2 s."""
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", stiffness=k_ground)
    b.add_body("body", pos=(0, 0, 0.1), mass=mass, inertia=(0.01, 0.01, 0.01))
    size = dict(radius=0.1) if shape == "sphere" else dict(size=(0.1, 0.1, 0.1))
    b.add_geom("body", shape, stiffness=k_body, damping=c, **size)
    w = tumble.World(b.build(), dt=dt, contact=contact)
    w.step(int(2.0 / dt))
    return 0.1 - w.body_pos[0, 2], w


@pytest.mark.parametrize("contact", ["penalty", "lcp", "pgs"])
@pytest.mark.parametrize("shape,contacts", [("sphere", 1), ("box", 4)])
def test_resting_depth_is_weight_over_stiffness(contact, shape, contacts):
    """depth = m g / (n k) on n contacts of stiffness k (0.5%)."""
    k, m = 4000.0, 2.0
    depth, w = resting(contact, shape, m, k_body=k, c=40.0)
    assert len(w.contacts) == contacts
    assert depth == pytest.approx(m * G / (contacts * k), rel=5e-3)
    assert np.abs(w.body_vel).max() < 1e-4


@pytest.mark.parametrize("contact", ["penalty", "lcp"])
def test_two_soft_geoms_are_springs_in_series(contact):
    """A 4000 N/m ball on a 4000 N/m floor sinks as on one 2000 N/m spring."""
    depth, _ = resting(contact, "sphere", 2.0, k_body=4000.0, k_ground=4000.0, c=40.0)
    assert depth == pytest.approx(2.0 * G / 2000.0, rel=5e-3)


def test_pair_combination_rules():
    b = tumble.ModelBuilder()
    b.add_body("a", mass=1.0, inertia=(1, 1, 1))
    b.add_geom("a", "sphere", radius=0.1, stiffness=1000.0, damping=5.0)      # 0
    b.add_geom("a", "sphere", radius=0.1, stiffness=3000.0, damping=2.0)      # 1
    b.add_geom("a", "sphere", radius=0.1)                                     # 2
    b.add_geom("a", "sphere", radius=0.1, damping=7.0)                        # 3
    m = b.build().arrays
    assert pair_softness(m, 0, 1) == pytest.approx((750.0, 5.0))
    assert pair_softness(m, 0, 2) == pytest.approx((1000.0, 5.0))  # unset: rigid
    assert pair_softness(m, 2, 2) == (0.0, -1.0)                   # neither: the world's
    assert pair_softness(m, 2, 3) == (0.0, 7.0)


def test_geom_damping_sets_the_penalty_damper():
    """A soft ball dropped onto the floor: more geom damping, lower rebound; with damping
    above critical it does not leave the floor at all."""
    def rebound(c):
        b = tumble.ModelBuilder()
        b.add_geom(None, "plane")
        b.add_body("ball", pos=(0, 0, 0.3), mass=1.0, inertia=(0.004, 0.004, 0.004))
        b.add_geom("ball", "sphere", radius=0.1, stiffness=5000.0, damping=c)
        w = tumble.World(b.build(), dt=1 / 1000, contact="penalty")
        top, hit = 0.0, False
        for _ in range(800):
            w.step()
            hit = hit or (len(w.contacts) > 0 and w.contacts.depth.max() > 0.0)
            if hit:
                top = max(top, w.body_pos[0, 2] - 0.1)
        return top
    light, heavy, over = rebound(2.0), rebound(20.0), rebound(400.0)
    assert light > heavy > over
    assert over < 1e-3


@pytest.mark.parametrize("kwargs,message", [
    (dict(stiffness=0.0), "stiffness must be finite and > 0"),
    (dict(stiffness=-5.0), "stiffness must be finite and > 0"),
    (dict(stiffness=np.inf), "stiffness must be finite and > 0"),
    (dict(damping=-1.0), "damping must be finite and >= 0"),
])
def test_bad_softness_is_refused(kwargs, message):
    b = tumble.ModelBuilder()
    b.add_body("a", density=1000.0)
    with pytest.raises(tumble.ModelError, match=f"geom 'skin': {message}"):
        b.add_geom("a", "sphere", radius=0.1, name="skin", **kwargs)


def test_too_stiff_a_geom_for_its_body_is_warned_about():
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    b.add_body("pebble", pos=(0, 0, 0.01), mass=0.01, inertia=(1e-6, 1e-6, 1e-6))
    b.add_geom("pebble", "sphere", radius=0.01, stiffness=1e6, name="hard")
    model = b.build()
    with pytest.warns(tumble.errors.TumbleWarning, match=r"geom 'hard'.*body 'pebble'"):
        tumble.World(model, dt=1 / 240, contact="penalty", penalty_integration="explicit")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tumble.World(model, dt=1e-5, contact="penalty", penalty_integration="explicit")
        # a free body's springs are implicit by default: stable at any stiffness
        w = tumble.World(model, dt=1 / 240, contact="penalty")
        tumble.World(model, dt=1 / 240, contact="lcp")        # soft constraint: any k
    w.step(240)
    assert abs(w.body_pos[0, 2] - 0.01) < 2e-4 and abs(w.body_vel[0, 2]) < 0.05
