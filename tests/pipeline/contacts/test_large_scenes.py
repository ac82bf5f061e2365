"""The large contact scenes of tumble.apps.benchmarks, solved by PGS (the solver for them)."""
import numpy as np

import tumble
from tumble.apps import benchmarks


def test_pyramid_of_210_boxes_stands():
    """600 steps at dt = 1/60 (PyBullet's pyramid collapses; MuJoCo's moves 3 cm)."""
    world = tumble.World(benchmarks.pyramid(), dt=benchmarks.PYRAMID["dt"], contact="pgs")
    start = world.body_pos.copy()
    world.step(benchmarks.PYRAMID["steps"])
    assert np.all(np.isfinite(world.body_pos))
    assert np.linalg.norm(world.body_pos - start, axis=1).max() < 0.01   # every box within 1 cm
    assert world.contacts.depth.max() < 0.005


def test_1000_spheres_settle_in_their_box():
    s = benchmarks.SPHERES
    world = tumble.World(benchmarks.spheres(), dt=s["dt"], contact="pgs", iterations=30)
    world.step(s["steps"])
    p = world.body_pos
    half = s["inner"] / 2
    inside = (np.abs(p[:, 0]) < half) & (np.abs(p[:, 1]) < half) & (p[:, 2] > 0)
    assert inside.all()                                   # none escaped
    assert world.contacts.depth.max() < 0.005             # penetration under 5 mm
    assert np.abs(world.body_vel).max() < 1.0             # settling, not exploding
