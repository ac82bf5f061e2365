"""The stage profiler (bench/bench_stages.py) reads the step's own stage timer."""
import numpy as np

import tumble
from bench.bench_stages import STAGES, profile_world
from tumble.apps import benchmarks


def test_profile_world_times_every_stage_and_restores_the_option():
    world = tumble.World(benchmarks.build("stack"), contact="lcp")
    t_stage, contacts, calls, done = profile_world(world, 90, chunk=32)
    assert done == 90 and calls == 3 and contacts > 0
    assert t_stage.shape == (len(STAGES),) and np.all(t_stage >= 0) and t_stage.sum() > 0
    assert world.options.profile is False
