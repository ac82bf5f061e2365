"""The solve stage's choice of method (``tumble.pipeline.solve``): Lemke's back-off, and
the contact sweeps taken as they are (``World(contact_sweeps=n)``).

A world whose exact (Lemke) solve fails gets PGS at once for 1, 2, 4, ... up to
``LEMKE_BACKOFF_MAX`` steps while Lemke keeps failing, and Lemke every step again after an
exact solve. The case that needs it: the course ragdoll, servos on, lying on the ground at
60 Hz (64 redundant contacts, on which Lemke's answer fails its verification)."""
import numpy as np
import pytest

import tumble
from tumble.character.ragdoll import games105_ragdoll
from tumble.errors import ModelError
from tumble.pipeline.solve import LEMKE_BACKOFF_MAX

from tests.pipeline.solvers.test_tree import boxes_on_a_free_box, sliding_chain


@pytest.fixture(scope="module")
def fallen():
    """The course ragdoll, servos holding its pose, knocked over and lying on the ground
    (contact='lcp', 1/60 s), and its per-step record over 100 steps on the ground:
    (fallbacks added, steps left to skip, window) after each step."""
    w = games105_ragdoll().make_world(dt=1 / 60, contact="lcp")
    for j in w.model.joint_names[1:]:
        w.set_pd_gains(j, 500.0, 50.0)
    w.body_vel[:, 0] = 2.0                        # knocked over forwards
    w.step(240)
    record = []
    for _ in range(100):
        before = w.lcp_fallbacks
        w.step(1)
        left, window = w.state_arrays.lcp_backoff[0]
        record.append((w.lcp_fallbacks - before, int(left), int(window)))
    return w, np.array(record)


def test_lemke_backs_off_on_a_heap_of_contacts(fallen):
    w, rec = fallen
    assert w.state_arrays.contact_count[0] >= 20            # lying down, not standing
    attempts = failures = 0
    prev_left, prev_window = rec[0][1], rec[0][2]
    for added, left, window in rec[1:]:
        if added == 0:                    # solved exactly (the fast path or Lemke): reset
            assert left == 0 and window == 0
            attempts += prev_left == 0
        elif prev_left > 0:               # backing off: PGS without trying Lemke
            assert left == prev_left - 1 and window == prev_window
        else:                             # Lemke tried and failed: the window doubles
            attempts += 1
            failures += 1
            assert window == min(max(2 * prev_window, 1), LEMKE_BACKOFF_MAX)
            assert left == window
        prev_left, prev_window = left, window
    # Lemke is attempted on a few steps only (it fails on nearly every one here)
    assert failures >= 1 and attempts <= 15
    assert 0 <= rec[:, 1].max() <= LEMKE_BACKOFF_MAX


def test_the_heap_stays_at_rest_under_the_back_off(fallen):
    w, _ = fallen
    speed = np.linalg.norm(w.body_vel, axis=-1)
    assert np.all(np.isfinite(speed)) and speed.max() < 0.5     # m/s: lying, not jittering


def test_a_restored_state_tries_lemke_at_once(fallen):
    w, _ = fallen
    state = w.get_state()
    w.state_arrays.lcp_backoff[:] = (5, 8)
    w.set_state(state)
    assert np.all(w.state_arrays.lcp_backoff == 0)
    w.state_arrays.lcp_backoff[:] = (5, 8)
    w.reset()
    assert np.all(w.state_arrays.lcp_backoff == 0)



def run_boxes(slide, sweeps, seconds):
    """``boxes_on_a_free_box(slide)`` stepped ``seconds`` with ``contact_sweeps``: the base
    box's x (m) each step and the deepest penetration (m) seen."""
    world = boxes_on_a_free_box(slide)
    world.contact_sweeps = sweeps
    xs, deepest = [], 0.0
    for _ in range(int(round(seconds / world.dt))):
        world.step(1)
        xs.append(world.body_pos[0, 0])
        n = world.state_arrays.contact_count[0]
        if n:
            deepest = max(deepest, float(world.contact_arrays.depth[0, :n].max()))
    return np.array(xs), deepest


def test_contact_sweeps_stop_a_sliding_load_where_the_exact_contacts_do():
    """Jointed boxes riding a free box that slides at 2 m/s on the ground (mu 0.9): with 20
    sweeps taken as they are (sliding, the step it stops, corners that land, resting),
    the box stops within 0.1 mm of where exact contacts stop it (13 cm on), then stays
    put, sinking no deeper than 0.1 mm."""
    exact, deep_exact = run_boxes(2.0, 0, 2.0)
    swept, deep_swept = run_boxes(2.0, 20, 2.0)
    assert 0.1 < exact[-1] < 0.2
    assert abs(swept[-1] - exact[-1]) < 1e-4
    assert abs(swept[-1] - swept[-120]) < 1e-6          # at rest over the last second
    assert deep_swept < deep_exact + 1e-4


def test_contact_sweeps_keep_coulombs_deceleration():
    """Balls joined in a chain sliding at 2 m/s with mu 0.1 (sliding pyramids) decelerate
    at mu g with the sweeps on, as without."""
    world = sliding_chain(2.0, mu=0.1)
    world.contact_sweeps = 20
    world.step(12)
    v0 = world.body_vel[:, 0].mean()
    world.step(30)
    v1 = world.body_vel[:, 0].mean()
    assert (v0 - v1) / 0.25 == pytest.approx(0.1 * 9.81, rel=0.02)


def test_contact_sweeps_default_to_exact_and_refuse_a_bad_count():
    world = boxes_on_a_free_box()
    assert world.contact_sweeps == 0
    for bad in (-1, 2.5, "many"):
        with pytest.raises(ModelError, match="contact_sweeps"):
            world.contact_sweeps = bad
    with pytest.raises(ModelError, match="contact_sweeps"):
        tumble.World(world.model, contact_sweeps=-3)
    assert world.contact_sweeps == 0
