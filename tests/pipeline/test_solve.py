"""The solve stage's choice of method (``tumble.pipeline.solve``): Lemke's back-off, and
PGS at once for contacts beyond the exact path's size.

A world whose exact (Lemke) solve fails gets PGS at once for 1, 2, 4, ... up to
``LEMKE_BACKOFF_MAX`` steps while Lemke keeps failing, and Lemke every step again after an
exact solve. The case that needs it: the course ragdoll, servos on, lying on the ground at
60 Hz (64 redundant contacts, on which Lemke's answer fails its verification)."""
import numpy as np
import pytest

import tumble
from tumble.apps import benchmarks
from tumble.character.ragdoll import games105_ragdoll
from tumble.pipeline.solve import LEMKE_BACKOFF_MAX
from tumble.pipeline.solvers.mlcp import EXACT_MAX_ROWS


def knocked_over(contact="lcp"):
    """The course ragdoll, servos holding its pose, knocked over and lying on the ground
    (1/60 s)."""
    w = games105_ragdoll().make_world(dt=1 / 60, contact=contact)
    for j in w.model.joint_names[1:]:
        w.set_pd_gains(j, 500.0, 50.0)
    w.body_vel[:, 0] = 2.0                        # knocked over forwards
    w.step(240)
    return w


@pytest.fixture(scope="module")
def fallen():
    """``knocked_over``'s world and its per-step record over 100 steps on the ground:
    (fallbacks added, steps left to skip, window) after each step."""
    w = knocked_over()
    record = []
    for _ in range(100):
        before = w.lcp_fallbacks
        w.step(1)
        left, window, _ = w.state_arrays.lcp_backoff[0]
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


def test_a_character_getting_up_is_solved_exactly_at_once():
    """Backing off on the heap, then lifted to its built pose by a body servo on the root:
    Lemke is tried in the step the contacts drop below the fewest of its failures, not at
    the end of the window (PGS's impulses give the fast path no guess to start from)."""
    w = knocked_over()
    for _ in range(200):
        w.step(1)
        if w.state_arrays.lcp_backoff[0, 0] >= 30:
            break
    left, window, fewest = w.state_arrays.lcp_backoff[0]
    assert left >= 30 and fewest >= 20                      # a long skip ahead, on the heap
    w.set_body_servo(w.model.body_names[0], 1e4, 1e3, 1e3, 1e2)
    before = w.lcp_fallbacks
    w.step(60)
    assert w.state_arrays.contact_count[0] < fewest         # standing on its feet
    assert w.lcp_fallbacks - before <= 3                    # not the `left` steps of PGS
    assert np.all(w.state_arrays.lcp_backoff == 0)


def test_a_restored_state_tries_lemke_at_once(fallen):
    w, _ = fallen
    state = w.get_state()
    w.state_arrays.lcp_backoff[:] = (5, 8, 64)
    w.set_state(state)
    assert np.all(w.state_arrays.lcp_backoff == 0)
    w.state_arrays.lcp_backoff[:] = (5, 8, 64)
    w.reset()
    assert np.all(w.state_arrays.lcp_backoff == 0)


def boxes_on_ground(count):
    """``count`` 0.2 m cubes of 1 kg resting side by side on a plane, 0.1 m apart (four
    corner contacts, 12 rows, each), on contact='lcp' at 1/60 s."""
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    for i in range(count):
        b.add_body(f"box{i}", pos=(0.3 * (i % 10), 0.3 * (i // 10), 0.1), mass=1.0,
                   inertia=(1 / 150, 1 / 150, 1 / 150))
        b.add_geom(f"box{i}", "box", size=(0.1, 0.1, 0.1), friction=0.8)
    return tumble.World(b.build(), dt=1 / 60, contact="lcp")


@pytest.mark.parametrize("count", [EXACT_MAX_ROWS // 12, EXACT_MAX_ROWS // 12 + 1])
def test_more_contact_rows_than_the_exact_path_takes_go_to_pgs_at_once(count):
    w = boxes_on_ground(count)
    w.step(30)
    assert w.state_arrays.contact_count[0] == 4 * count
    exact = 12 * count <= EXACT_MAX_ROWS
    # every step's solve exact below the cap; PGS on every step above it (nothing tried)
    assert w.lcp_fallbacks == (0 if exact else 30)
    assert np.all(w.state_arrays.lcp_backoff == 0)         # a refusal by size: no back-off
    z = w.body_pos[:, 2]
    assert np.all(np.abs(z - 0.1) < 1e-3), z.min()         # resting either way
    assert np.abs(w.body_vel).max() < 1e-3


def test_small_lcps_lemke_fails_on_are_solved_with_a_slight_compliance():
    """The bench's passive ragdoll (15 bodies, no CFM anywhere) dropped at 600 Hz: it
    lands on its feet, stands for a second and topples; as it lands on its boxes' faces,
    Lemke's pivots ended in a basis that failed its check on 12 steps, and PGS stood in on
    26 (with the back-off); once more with the contact rows slightly compliant
    (``mlcp._regularised_lcp``) Lemke solves them all."""
    model = benchmarks.build("ragdoll600")
    w = tumble.World(model, dt=model.timestep)
    w.step(benchmarks.steps("ragdoll600"))                  # 3 s
    assert w.lcp_fallbacks <= 2                             # issue 26's bound: 1% = 18
    low = w.body_pos[:, 2].min()
    assert 0.0 < low < 0.2                                  # fallen onto the ground
