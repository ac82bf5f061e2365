"""The step of a model with nothing to collide, constrain or actuate
(tumble/pipeline/step_free.py): bit for bit the full step's results, the same checks and
rollback, and chosen only when it applies, without loading the full step."""
import os
import subprocess
import sys

import numpy as np
import pytest

import tumble
from tumble.errors import SimulationError, StateError
from tumble.pipeline.step_free import is_free
from tumble.world import world as world_module


def free_world(nworld=1, gravity=(0.0, 0.0, -9.81), **options):
    b = tumble.ModelBuilder(gravity=gravity)
    b.add_body("box", density=700.0, pos=(0.0, 0.0, 1.0), vel=(0.3, -0.2, 1.0),
               angvel=(0.5, 4.0, 0.2))
    b.add_geom("box", "box", size=(0.05, 0.15, 0.3))
    b.add_body("ball", mass=2.0, inertia=(0.02, 0.03, 0.04), pos=(1.0, 0.0, 2.0),
               angvel=(0.0, 0.0, 9.0))
    return tumble.World(b.build(), dt=1.0 / 240.0, nworld=nworld, **options)


def state(w):
    return [np.array(a, copy=True) for a in (w.body_pos, w.body_quat, w.body_vel,
                                             w.body_angvel)]


def run(w, calls, forces=True):
    for k in range(calls):
        if forces:
            w.apply_force("box", (0.0, 2.0 * np.sin(k), 1.0))
            w.apply_torque("ball", (0.1, 0.0, -0.05 * k))
        w.step(1 + k % 3)


@pytest.mark.parametrize("gyroscopic", ["implicit", "explicit", "variational"])
@pytest.mark.parametrize("nworld", [1, 3])
def test_the_free_step_is_the_full_step_bit_for_bit(monkeypatch, gyroscopic, nworld):
    lean = free_world(nworld, gyroscopic=gyroscopic)
    assert is_free(lean.model, lean._control.body_servo)
    run(lean, 40)
    monkeypatch.setattr(world_module, "is_free", lambda model, servo: False)
    full = free_world(nworld, gyroscopic=gyroscopic)
    run(full, 40)
    for a, b in zip(state(lean), state(full)):
        assert np.array_equal(a, b)
    assert lean.time == full.time
    assert lean._free_box is not None and full._free_box is None


def test_a_free_world_with_stage_times_profiles_its_stages():
    w = free_world(profile=True)
    w.step(20)
    times = w.stage_times()
    assert times["integrate_velocities"] > 0 and times["divergence_check"] > 0
    assert times["rows"] == 0 and times["solve"] == 0


def test_a_runaway_free_body_is_reported_and_undone():
    w = free_world(2)
    w.step(3)
    before = state(w)
    w.body_vel[1, 1] = (0.0, 0.0, 1e30)
    with pytest.raises(SimulationError, match="body 'ball' in world 1") as err:
        w.step(5)
    assert err.value.body == "ball" and err.value.step == 0
    after = state(w)
    after[2][1, 1] = before[2][1, 1]
    for a, b in zip(before, after):
        assert np.array_equal(a, b)


def test_a_bad_free_state_is_refused_untouched():
    w = free_world()
    w.body_quat[0] = (0.0, 0.0, 0.0, 2.0)        # not unit: the step would normalise it
    w.body_vel[1] = (np.nan, 0.0, 0.0)
    before = state(w)
    with pytest.raises(StateError, match="body 'ball'"):
        w.step(1)
    for a, b in zip(before, state(w)):
        assert np.array_equal(a, b, equal_nan=True)


def test_the_full_step_takes_over_when_something_can_interact():
    w = free_world()
    assert is_free(w.model, w._control.body_servo)
    w.set_body_servo("box", kp=100.0, kd=10.0)
    assert not is_free(w.model, w._control.body_servo)
    w.step(2)                                   # the full step, with the servo's rows
    assert w._box is not None
    b = tumble.ModelBuilder()
    for name, x in (("a", 0.0), ("b", 1.0)):
        b.add_body(name, pos=(x, 0.0, 0.0), mass=1.0)
        b.add_geom(name, "sphere", size=0.1)
    assert not is_free(b.build(), np.zeros((1, 2, 4)))
    assert not is_free(tumble.games105_ragdoll("floating").model, np.zeros((1, 20, 4)))


def test_stepping_a_free_body_does_not_load_the_full_step():
    """In a fresh process: the full step's kernel is neither compiled nor loaded from the
    cache (what makes a first run of the demo take seconds, not minutes)."""
    code = ("import tumble\n"
            "from tumble.apps import racket\n"
            "from tumble.pipeline import call, parallel, step_free\n"
            "w = racket.build()\n"
            "w.step(10)\n"
            "print(len(call.step_span.signatures), len(parallel.step_boxed_parallel.signatures),"
            " len(step_free.step_free_boxed.signatures))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=dict(os.environ), timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["0", "0", "1"]
