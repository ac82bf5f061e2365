"""Batched worlds on threads: each world bit-identical to the serial path, failures
reported as the serial path reports them."""
import numpy as np
import pytest

import tumble
from tumble.apps import benchmarks

FIELDS = ("body_pos", "body_quat", "body_vel", "body_angvel", "joint_q", "joint_force")


def batch(model, nworld, parallel, seed=0, **kwargs):
    """A batch whose worlds differ: each ragdoll starts with its own velocity."""
    w = tumble.World(model, nworld=nworld, parallel=parallel, **kwargs)
    rng = np.random.default_rng(seed)
    w.body_vel[:] += rng.normal(scale=0.5, size=(nworld, 1, 3))
    return w


@pytest.mark.parametrize("contact", ["lcp", "pgs"])
def test_parallel_worlds_are_bit_identical_to_serial(contact):
    """A falling ragdoll (joints, then contacts) in 5 worlds, stepped on threads and
    serially, in two calls: every state array and contact agrees to the bit."""
    model = benchmarks.ragdoll(600)
    par, ser = batch(model, 5, True, contact=contact), batch(model, 5, False, contact=contact)
    for n in (300, 150):
        par.step(n)
        ser.step(n)
    for field in FIELDS:
        np.testing.assert_array_equal(getattr(par, field), getattr(ser, field), err_msg=field)
    for w in range(5):
        a, b = par.contacts_of(w), ser.contacts_of(w)
        assert len(a) > 0
        np.testing.assert_array_equal(a.point, b.point)
        np.testing.assert_array_equal(a.force, b.force)
    assert par.lcp_fallbacks == ser.lcp_fallbacks


def test_parallel_failure_names_the_first_failing_world_and_restores_all():
    model = benchmarks.ragdoll(600)
    reports = []
    for parallel in (True, False):
        w = batch(model, 4, parallel)
        w.step(10)
        before = {f: getattr(w, f).copy() for f in FIELDS[:4]}
        for bad in (3, 1):                       # two worlds blow up; world 1 comes first
            w.body_angvel[bad, 5] = 1e9
        with pytest.raises(tumble.SimulationError) as err:
            w.step(20)
        reports.append((err.value.world, err.value.step, err.value.body, str(err.value)))
        for f in FIELDS[:2]:
            np.testing.assert_array_equal(getattr(w, f), before[f])
        assert w.time == pytest.approx(10 / 600)
    assert reports[0] == reports[1]
    assert reports[0][0] == 1


def test_parallel_checks_report_what_the_serial_ones_do_and_change_nothing():
    """Each thread checks its own world; the report is still the serial one (a drive
    field before a later field of an earlier world; a bad state before any drive), and
    the worlds that passed -- normalised, stepped -- are put back too."""
    model = benchmarks.ragdoll(600)
    reports = []
    for parallel in (True, False):
        w = batch(model, 4, parallel)
        w.step(400)                                   # on the floor: live contacts
        w.body_quat[0, 3] *= 1.5                      # the checks normalise it
        before = {f: getattr(w, f).copy() for f in FIELDS[:4]}
        contacts = [w.contacts_of(k) for k in range(4)]
        assert min(len(c) for c in contacts) > 0
        drives = w.control_arrays
        drives.joint_applied[1, 2, 0] = np.inf        # field 4 in world 1
        drives.pd_target_q[3, 1, 0] = np.nan          # field 2 in world 3: reported
        with pytest.raises(tumble.StateError) as drive_err:
            w.step(5)
        for f, a in before.items():
            np.testing.assert_array_equal(getattr(w, f), a, err_msg=f)
        w.body_vel[2, 4, 1] = before["body_vel"][2, 4, 1] = np.nan
        with pytest.raises(tumble.StateError) as state_err:
            w.step(5)
        reports.append((str(drive_err.value), str(state_err.value)))
        for f, a in before.items():
            np.testing.assert_array_equal(getattr(w, f), a, err_msg=f)      # NaN == NaN here
        for k in range(4):
            after = w.contacts_of(k)
            np.testing.assert_array_equal(after.point, contacts[k].point)
            np.testing.assert_array_equal(after.force, contacts[k].force)
        assert w.time == pytest.approx(400 / 600)
    assert reports[0] == reports[1]
    assert "world 3" in reports[0][0] and "pd_target_q" in reports[0][0]
    assert "world 2" in reports[0][1]


def test_parallel_batch_grows_its_buffers_like_the_serial_one():
    """One world of the batch piles 40 spheres into one spot: more overlapping pairs and
    contacts than the buffers hold. Both paths grow them and end in the same state."""
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    for i in range(40):
        body = b.add_body(f"s{i}", pos=(0.3 * (i % 7), 0.3 * (i // 7), 0.1), mass=1.0,
                          inertia=(0.004, 0.004, 0.004))
        b.add_geom(body, "sphere", radius=0.1)
    model = b.build()
    out = []
    for parallel in (True, False):
        w = tumble.World(model, nworld=3, parallel=parallel, contact="pgs")
        capacity = w.contact_capacity, w.pair_capacity
        w.body_pos[1] = np.random.default_rng(1).uniform(-0.05, 0.05, (40, 3)) + (0, 0, 1.0)
        w.step(5)
        assert w.contact_capacity > capacity[0] and w.pair_capacity > capacity[1]
        out.append((w.body_pos.copy(), w.contact_capacity))
    np.testing.assert_array_equal(out[0][0], out[1][0])
    assert out[0][1] == out[1][1]


def test_parallel_option_is_checked():
    model = benchmarks.chain()
    assert tumble.World(model, nworld=2).parallel
    assert not tumble.World(model).parallel
    with pytest.raises(tumble.ModelError, match="parallel"):
        tumble.World(model, parallel="yes")
