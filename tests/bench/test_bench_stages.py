"""The stage profiler (bench/bench_stages.py) steps exactly as World.step does.

Its loop mirrors ``step.step_worlds`` with clock reads between the stages; if a stage is
added to or changed in the step, this test fails until the profiler follows."""
import numpy as np
import pytest

import tumble
from bench.bench_stages import profile_world


def scene():
    """A hinged pendulum with a limit and a box that lands on the ground: joints, limits,
    contacts and projection all run."""
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    arm = b.add_body("arm", pos=(0.25, 0, 1.0), mass=1.0, inertia=(0.01, 0.02, 0.02))
    b.add_joint("pivot", "hinge", None, arm, anchor=(0, 0, 1.0), axis=(0, 1, 0),
                limit=(-0.6, 0.6))
    box = b.add_body("box", pos=(1.0, 0, 0.12), mass=1.0, inertia=(0.01, 0.01, 0.01))
    b.add_geom(box, "box", size=(0.1, 0.1, 0.1))
    return b.build()


@pytest.mark.parametrize("contact", ["lcp", "pgs"])
def test_profiled_steps_match_world_step(contact):
    model = scene()
    a, b = tumble.World(model, contact=contact), tumble.World(model, contact=contact)
    t_stage, _, counts, done = profile_world(a, 90, chunk=32)
    b.step(32)
    b.step(32)
    b.step(26)
    assert done == 90
    for field in ("body_pos", "body_quat", "body_vel", "body_angvel", "joint_q"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    assert np.all(t_stage >= 0) and t_stage.sum() > 0
    assert counts[4] > 0                                  # contacts were met
