"""Sleeping islands (``tumble.pipeline.sleep``): bodies at rest sleep, wake when touched,
pushed or driven, and the motion equals the run without sleeping within stated tolerances."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

import tumble
from tumble.errors import ModelError

DT = 1 / 240
HALF = 0.5


def boxes(stacks=1, height=3, ball_height=None, contact="lcp", first_stack=0, **options):
    """``stacks`` stacks of ``height`` unit boxes 3 m apart on a plane (those from
    ``first_stack`` on); with ``ball_height``, a 1 kg ball of radius 0.25 m above the
    first stack."""
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", normal=(0, 0, 1), friction=0.9)
    for s in range(first_stack, stacks):
        for i in range(height):
            name = f"box{s}_{i}"
            b.add_body(name, pos=(3.0 * s, 0.0, HALF + 2 * HALF * i), mass=1.0,
                       inertia=(1 / 6, 1 / 6, 1 / 6))
            b.add_geom(name, "box", size=(HALF, HALF, HALF), friction=0.9)
    if ball_height is not None:
        b.add_body("ball", pos=(0.1, 0.05, ball_height), mass=1.0,
                   inertia=(0.025, 0.025, 0.025))
        b.add_geom("ball", "sphere", size=(0.25,), friction=0.9)
    return tumble.World(b.build(), dt=DT, contact=contact, **options)


@pytest.mark.parametrize("contact", ["lcp", "pgs", "penalty"])
def test_a_stack_at_rest_sleeps_and_holds_still(contact):
    w = boxes(contact=contact, sleep_time=0.5)
    w.step(60)
    assert not w.sleeping.any()                      # 0.25 s: not yet
    w.step(240)
    assert w.sleeping.all()
    pos = w.body_pos.copy()
    w.step(240)
    assert np.array_equal(w.body_pos, pos)           # asleep: not a bit moves
    assert not w.body_vel.any() and not w.body_angvel.any()
    awake = boxes(contact=contact)
    awake.step(540)
    # the sleeping run stopped where the awake one rests (penalty springs settle last)
    assert np.abs(w.body_pos - awake.body_pos).max() < (2e-4 if contact == "penalty" else 1e-6)


def test_sleeping_is_off_by_default_and_the_step_is_unchanged():
    w, ref = boxes(), boxes(sleep_time=None)
    w.step(300)
    ref.step(300)
    assert not w.sleeping.any()
    assert np.array_equal(w.body_pos, ref.body_pos)


def test_a_falling_ball_wakes_the_sleeping_stack_it_hits():
    # the ball falls 2.2 s (from 26.75 m) onto the stack, asleep since 0.5 s
    w = boxes(ball_height=26.75, sleep_time=0.5)
    ref = boxes(ball_height=26.75)
    boxes_ = np.arange(3)
    w.step(240)
    ref.step(240)
    assert w.sleeping[boxes_].all() and not w.sleeping[3]
    hit = None
    for k in range(360):
        w.step()
        ref.step()
        if hit is None and not w.sleeping[boxes_].any():
            hit = k
            assert np.abs(w.body_vel[boxes_]).max() > 0.0     # woken the step of the touch
    assert hit is not None
    # the same impact, within the solvers' tolerance on a state 1e-9 from rest
    assert np.abs(w.body_pos - ref.body_pos).max() < 1e-4
    assert np.abs(w.body_vel - ref.body_vel).max() < 1e-3


def test_a_push_wakes_only_its_island():
    w = boxes(stacks=2, sleep_time=0.5)
    ref = boxes(stacks=2)
    w.step(300)
    ref.step(300)
    assert w.sleeping.all()
    for world in (w, ref):
        world.apply_force("box0_2", (-150.0, 0.0, 0.0))   # away from the other
        world.step(12)
    first, second = np.arange(3), np.arange(3, 6)
    assert not w.sleeping[first].any()               # the pushed stack's island woke
    assert w.sleeping[second].all()                  # the other, 3 m away, slept on
    w.step(360)
    ref.step(360)
    assert np.abs(w.body_pos - ref.body_pos).max() < 1e-4
    # the top box was pushed off: it fell beside the stack and sleeps again in the end
    assert w.body_pos[2, 2] < 1.0
    w.step(480)
    assert w.sleeping.all()


@settings(max_examples=12, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=6), st.data())
def test_a_push_wakes_exactly_the_bodies_linked_to_the_pushed_one(touching, data):
    """Boxes in a row on the floor, each next one 5 mm apart (within the contact margin:
    linked) or 30 cm: a push on one wakes the connected component of the link graph."""
    n = len(touching) + 1
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", normal=(0, 0, 1), friction=0.9)
    x = 0.0
    for i in range(n):
        b.add_body(f"b{i}", pos=(x, 0.0, HALF), mass=1.0, inertia=(1 / 6, 1 / 6, 1 / 6))
        b.add_geom(f"b{i}", "box", size=(HALF, HALF, HALF), friction=0.9)
        if i < n - 1:
            x += 2 * HALF + (0.005 if touching[i] else 0.3)
    w = tumble.World(b.build(), dt=DT, sleep_time=0.25)
    w.step(120)
    assert w.sleeping.all()
    pushed = data.draw(st.integers(0, n - 1))
    w.apply_force(f"b{pushed}", (0.0, 1e-3, 0.0))
    w.step(1)
    links = np.flatnonzero(touching)
    graph = coo_matrix((np.ones(len(links)), (links, links + 1)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    assert np.array_equal(~w.sleeping, label == label[pushed])


def test_a_body_whose_support_is_moved_away_falls():
    w = boxes(height=2, sleep_time=0.5)
    w.step(300)
    assert w.sleeping.all()
    pos = w.body_pos.copy()
    pos[0, 0] += 5.0                                 # the lower box, moved from under
    w.body_pos = pos                                 # the setter wakes every body
    assert not w.sleeping.any()
    w.step(120)
    assert w.body_pos[1, 2] < 0.6                    # the upper box fell to the floor


def test_driven_bodies_stay_awake():
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", normal=(0, 0, 1))
    b.add_body("base", pos=(0, 0, 0.25), mass=4.0, inertia=(0.1, 0.1, 0.1))
    b.add_geom("base", "box", size=(0.25, 0.25, 0.25))
    b.add_body("arm", pos=(0, 0, 0.75), mass=1.0, inertia=(0.02, 0.02, 0.01))
    b.add_joint("hinge", "hinge", "base", "arm", anchor=(0, 0, 0.5), axis=(1, 0, 0), kp=200.0,
                kd=20.0)
    w = tumble.World(b.build(), dt=DT, sleep_time=0.25)
    w.step(240)
    assert not w.sleeping.any()                      # a servo with stiffness drives it
    w.joint_kp[:] = 0.0
    w.joint_kd[:] = 0.0
    w.step(240)                                      # upright, undriven: at rest
    assert w.sleeping.all()
    w.apply_torque("arm", (0.0, 0.0, 1e-6))          # any applied load wakes it
    w.step(1)
    assert not w.sleeping.any()


def test_the_state_carries_the_times_at_rest():
    w = boxes(sleep_time=0.5)
    w.step(300)
    st = w.get_state()
    assert w.sleeping.all() and st.body_rest.min() >= 0.5
    w.wake()
    assert not w.sleeping.any()
    w.set_state(st)
    assert w.sleeping.all()
    st.body_rest = None                              # a state written by hand: all awake
    w.set_state(st)
    assert not w.sleeping.any()
    w.step(300)
    w.set_body_state(w.body_pos, w.body_quat, w.body_vel, w.body_angvel)
    assert not w.sleeping.any()


def test_batched_worlds_sleep_each_on_its_own():
    w = boxes(sleep_time=0.5, nworld=2)
    w.step(300)
    assert w.sleeping.all()
    w.apply_force("box0_2", (0.0, 50.0, 0.0), world=1)
    w.step(2)
    assert w.sleeping[0].all() and not w.sleeping[1].any()
    serial = boxes(sleep_time=0.5, nworld=2, parallel=False)
    serial.step(300)
    serial.apply_force("box0_2", (0.0, 50.0, 0.0), world=1)
    serial.step(2)
    assert np.array_equal(serial.body_pos, w.body_pos)


@pytest.mark.parametrize("name,value", [("sleep_time", 0.0), ("sleep_time", -1.0),
                                        ("sleep_speed", -0.1), ("sleep_spin", float("nan"))])
def test_bad_sleep_options_are_refused_by_name(name, value):
    with pytest.raises(ModelError, match=name):
        boxes(**{name: value})


# ------------------------------------------ contacts of sleeping pairs, and their order ---

def _narrow_phase_now(w):
    """world 0's contacts as the collision stage finds them at its current pose, every
    pair tested: {(geom a, geom b, feature): (point, normal, depth)}."""
    from tumble.pipeline.collide import collide_world
    from tumble.pipeline.contacts.arrays import make_contacts
    m, s, ng = w.model.arrays, w.state_arrays, w.model.ngeom
    con = make_contacts(1, 256)
    view = type(con)(*(a[0] for a in con))
    prev = type(con)(*(a[0].copy() for a in con))
    status, n = collide_world(m, s.body_pos[0], s.body_quat[0], np.zeros((ng, 3)),
                              np.zeros((ng, 4)), np.zeros((ng, 3)), np.zeros((ng, 3)),
                              np.zeros((ng * ng, 2), np.int32), view, np.int64(0), prev,
                              w.contact_margin, 0, np.zeros((0, 2), np.int32),
                              np.zeros(w.model.nbody), 0.0)
    assert status == 0
    return {(*view.geom[i], view.feature[i]): (view.point[i], view.normal[i], view.depth[i])
            for i in range(n)}


def test_a_sleeping_pair_keeps_the_contacts_a_test_would_find():
    # two stacks asleep; one pushed awake: the other's pairs are no longer tested, and their
    # contacts are still, to the bit, what testing them would give
    w = boxes(stacks=2, sleep_time=0.5)
    w.step(300)
    assert w.sleeping.all()
    w.apply_force("box1_2", (0.0, 40.0, 0.0))
    w.step(20)
    asleep = w.sleeping
    assert asleep[:3].all() and not asleep[3:].any()
    found = _narrow_phase_now(w)
    st = w.get_state()
    kept = 0
    for i in range(int(st.contact_count[0])):
        g0, g1 = st.contacts.geom[0, i]
        if w.model.geom_body[g1] >= 3:               # the awake stack's: moved since
            continue
        point, normal, depth = found[(g0, g1, st.contacts.feature[0, i])]
        assert np.array_equal(point, st.contacts.point[0, i])
        assert np.array_equal(normal, st.contacts.normal[0, i])
        assert depth == st.contacts.depth[0, i]
        kept += 1
    assert kept == 12                                # 4 corners under each sleeping box


def test_sleeping_pairs_are_not_tested_again():
    # a sleeping box moved in place (no wake: documented to stay asleep where put) keeps
    # the contacts found where it was: its pairs are no longer tested
    w = boxes(sleep_time=0.5)
    w.step(300)
    before = w.get_state().contacts
    w.state_arrays.body_pos[0, 2, 2] += 0.005       # its boxes still overlap
    w.step(5)
    assert w.sleeping.all()
    after = w.get_state().contacts
    for a, b in zip(before, after):
        assert np.array_equal(a, b)
    w.wake()                                          # woken, it is tested: and falls
    w.step(1)
    assert not np.array_equal(w.get_state().contacts.depth, after.depth)


def test_an_awake_island_behind_a_sleeping_one_steps_as_if_alone():
    # in pair order the pushed stack's contacts come after the sleeping stack's: moved
    # first, they keep their order and find last step's impulses (PGS's warm start), so
    # the stack steps to the bit as it does alone
    w = boxes(stacks=2, sleep_time=0.5, contact="pgs")
    alone = boxes(stacks=2, first_stack=1, sleep_time=0.5, contact="pgs")
    for world in (w, alone):
        world.step(300)
        assert world.sleeping.all()
        world.apply_force("box1_2", (0.0, 40.0, 0.0))
        world.step(30)
    assert w.sleeping[:3].all() and not w.sleeping[3:].any()
    assert np.array_equal(w.body_pos[3:], alone.body_pos)
    assert np.array_equal(w.body_vel[3:], alone.body_vel)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 7), st.integers(0, 7)), min_size=1, max_size=12,
                unique=True),
       st.lists(st.booleans(), min_size=8, max_size=8), st.integers(1, 3))
def test_awake_contacts_go_first_and_merge_back_into_pair_order(pairs, awake, per_pair):
    from collections import namedtuple
    from tumble.pipeline.contacts.arrays import make_contacts
    from tumble.pipeline.sleep import awake_contacts_first
    from tumble.pipeline.step import keep_previous_contacts
    pairs = sorted({(min(a, b), max(a, b)) for a, b in pairs if a != b})
    if not pairs:
        return
    cap = len(pairs) * per_pair
    con, spare, prev = (type(c)(*(a[0] for a in c)) for c in
                        (make_contacts(1, cap), make_contacts(1, cap), make_contacts(1, cap)))
    k = 0
    for a, b in pairs:
        for f in range(per_pair):
            con.geom[k] = a, b
            con.body[k] = a - 1, b - 1                   # geom 0 on the world
            con.feature[k] = f
            con.depth[k] = 0.01 * k
            con.impulse[k, 0] = k
            k += 1
    original = [a.copy() for a in con]
    flags = np.array(awake)
    n_awake = awake_contacts_first(con, cap, flags, spare)

    def touches(i):
        a, b = con.body[i]
        return (a >= 0 and flags[a]) or (b >= 0 and flags[b])
    assert all(touches(i) for i in range(n_awake))
    assert not any(touches(i) for i in range(n_awake, cap))
    for part in (range(n_awake), range(n_awake, cap)):      # each part keeps its order
        depths = con.depth[list(part)]
        assert np.all(np.diff(depths) > 0)
    state = namedtuple("S", ["contact_count"])(np.array([cap], np.int64))
    keep_previous_contacts(state, con, prev, True)
    for field, a, b in zip(con._fields, original, prev):
        assert np.array_equal(a, b), field


def test_a_state_without_contacts_starts_every_body_awake():
    w = boxes(sleep_time=0.5)
    w.step(300)
    st = w.get_state()
    assert w.sleeping.all()
    st.contacts, st.contact_count = None, None
    w.set_state(st)                  # asleep with no contacts would keep none of them
    assert not w.sleeping.any()
    w.step(240)
    assert abs(w.body_pos[0, 2] - HALF) < 1e-3      # found its floor again
