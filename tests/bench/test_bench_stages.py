"""The stage profiler (bench/bench_stages.py) reads the step's own stage timer."""
import numpy as np

import tumble
from bench.bench_stages import STAGES, profile_world


def test_profile_world_times_every_stage_and_restores_the_option():
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    arm = b.add_body("arm", pos=(0.25, 0, 1.0), mass=1.0, inertia=(0.01, 0.02, 0.02))
    b.add_joint("pivot", "hinge", None, arm, anchor=(0, 0, 1.0), axis=(0, 1, 0),
                limit=(-0.6, 0.6))
    box = b.add_body("box", pos=(1.0, 0, 0.12), mass=1.0, inertia=(0.01, 0.01, 0.01))
    b.add_geom(box, "box", size=(0.1, 0.1, 0.1))
    world = tumble.World(b.build(), contact="lcp")
    t_stage, contacts, calls, done = profile_world(world, 90, chunk=32)
    assert done == 90 and calls == 3 and contacts > 0
    assert t_stage.shape == (len(STAGES),) and np.all(t_stage >= 0) and t_stage.sum() > 0
    assert world.options.profile is False
