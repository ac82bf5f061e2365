"""World: state access, errors that change nothing, divergence reports, batches, determinism."""
import numpy as np
import pytest

import tumble


def two_bodies(**world_kwargs):
    b = tumble.ModelBuilder()
    b.add_body("pelvis", pos=(0, 0, 1), mass=8.0, inertia=(0.1, 0.12, 0.14), angvel=(1, 2, 3))
    b.add_body("thigh", pos=(0, 0.1, 0.7), mass=7.0, inertia=(0.05, 0.05, 0.01), vel=(1, 0, 0))
    return tumble.World(b.build(), dt=1 / 240, **world_kwargs)


def snapshot(w):
    return [a.copy() for a in (w.body_pos, w.body_quat, w.body_vel, w.body_angvel)] + [w.time]


def assert_same(a, b):
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_bad_world_options():
    model = two_bodies().model
    for kwargs, field in [(dict(dt=0.0), "dt"), (dict(dt=-1.0), "dt"),
                          (dict(contact="magic"), "contact"), (dict(gyroscopic="x"), "gyroscopic"),
                          (dict(nworld=0), "nworld"), (dict(quat_integration="rk4"), "quat")]:
        with pytest.raises(tumble.ModelError, match=field):
            tumble.World(model, **kwargs)
    with pytest.raises(tumble.ModelError, match="Model"):
        tumble.World("model.xml")
    w = tumble.World(model)
    with pytest.raises(tumble.ModelError, match="dt"):
        w.dt = 0.0
    with pytest.raises(tumble.ModelError, match="non-negative integer"):
        w.step(-1)


def test_nan_written_into_the_state_is_refused_and_nothing_changes():
    w = two_bodies()
    w.step(3)
    before = snapshot(w)
    w.body_vel[1, 2] = np.nan
    with pytest.raises(tumble.StateError, match="body 'thigh': body_vel is not finite"):
        w.step()
    w.body_vel[1, 2] = before[2][1, 2]
    assert_same(snapshot(w), before)
    w.body_quat[0] = 0.0
    with pytest.raises(tumble.StateError, match="body 'pelvis': body_quat is zero"):
        w.step()


def test_slightly_unnormalised_quaternions_are_normalised():
    w = two_bodies()
    w.body_quat[0] = [0, 0, 0, 1.01]
    w.step()
    assert np.linalg.norm(w.body_quat[0]) == pytest.approx(1.0, abs=1e-15)


def test_divergence_names_body_and_step_and_restores_the_world():
    w = two_bodies()
    w.step(5)
    before = snapshot(w)
    w.apply_force("thigh", (0, 0, 1e12))             # 1.4e11 m/s^2: past the limit in a few steps
    with pytest.raises(tumble.SimulationError) as err:
        w.step(100)
    e = err.value
    assert e.body == "thigh" and e.step == 0 and e.world == 0
    assert "body 'thigh'" in str(e) and "step 0" in str(e)
    assert_same(snapshot(w), before)
    w.clear_forces()
    w.step()                                           # the world still works


def test_divergence_to_infinity_is_caught():
    w = two_bodies(divergence_limit=1e300)
    w.apply_torque("pelvis", (1e300, 1e300, 1e300))
    with pytest.raises(tumble.SimulationError, match="pelvis"):
        w.step(2)


def test_bad_force_arguments():
    w = two_bodies()
    with pytest.raises(tumble.ModelError, match="unknown body 'arm'"):
        w.apply_force("arm", (0, 0, 1))
    with pytest.raises(tumble.ModelError, match="force is not finite"):
        w.apply_force("thigh", (0, np.inf, 1))
    with pytest.raises(tumble.ModelError, match="shape"):
        w.apply_torque(0, (0, 1))
    np.testing.assert_array_equal(w.control_arrays.applied_force, 0.0)


def test_two_worlds_from_one_model_are_bit_identical():
    a, b = two_bodies(), two_bodies()
    for w in (a, b):
        w.apply_force("thigh", (3.0, 1.0, 0.5), point=(0.1, 0.2, 0.3))
        w.step(100)
        w.step(17)
    assert_same(snapshot(a), snapshot(b))


def test_state_round_trip_and_reset():
    w = two_bodies()
    w.step(10)
    saved = w.get_state()
    after = snapshot(w)
    w.step(50)
    w.set_state(saved)
    assert_same(snapshot(w), after)
    bad = w.get_state()
    bad.body_pos[0, 0, 0] = np.nan
    with pytest.raises(tumble.StateError, match="body_pos"):
        w.set_state(bad)
    assert_same(snapshot(w), after)
    w.reset()
    np.testing.assert_array_equal(w.body_pos, w.model.body_pos0)
    assert w.time == 0.0


def test_state_arrays_are_live_and_assignable():
    w = two_bodies()
    w.body_pos[0] = (1.0, 2.0, 3.0)
    w.body_vel = np.zeros((2, 3))
    assert w.body_pos[0, 1] == 2.0 and np.all(w.body_vel == 0)
    with pytest.raises(tumble.StateError, match="shape"):
        w.body_angvel = np.zeros((3, 3))


def test_batched_worlds_match_single_worlds():
    single = two_bodies()
    batch = two_bodies(nworld=3)
    assert batch.body_pos.shape == (3, 2, 3)
    batch.apply_force("thigh", (0, 5.0, 0), world=1)
    batch.step(20)
    single.step(20)
    np.testing.assert_array_equal(batch.body_pos[0], single.body_pos)
    np.testing.assert_array_equal(batch.body_pos[2], single.body_pos)
    assert batch.body_vel[1, 1, 1] > 0.0 and batch.body_vel[0, 1, 1] == 0.0
    assert batch.energy()[0].shape == (3,)
    assert batch.linear_momentum().shape == (3, 3)


def test_queries():
    w = two_bodies()
    p = w.body_pos[0] + np.array([0.0, 0.5, 0.0])
    np.testing.assert_allclose(w.point_velocity("pelvis", p),
                               w.body_vel[0] + np.cross(w.body_angvel[0], [0, 0.5, 0]))
    local = w.world_to_body("thigh", (1.0, 2.0, 3.0))
    np.testing.assert_allclose(w.body_to_world("thigh", local), [1, 2, 3])
    np.testing.assert_allclose(w.vector_to_world(0, w.vector_to_body(0, (1, 0, 0))), [1, 0, 0],
                               atol=1e-15)
    ke, pe = w.energy()
    assert ke == pytest.approx(0.5 * 7.0 * 1.0 + 0.5 * (0.1 * 1 + 0.12 * 4 + 0.14 * 9))
    assert pe == pytest.approx(9.81 * (8.0 * 1.0 + 7.0 * 0.7))
    np.testing.assert_allclose(w.linear_momentum(), [7.0, 0, 0])
    L = w.angular_momentum(about=(0, 0, 0))
    np.testing.assert_allclose(L, [0.1, 0.24, 0.42] + np.cross([0, 0.1, 0.7], [7.0, 0, 0]))


# ------------------------------------------------------------- state: exact save and restore

def ragdoll_world(**kwargs):
    """The GAMES-105 ragdoll standing on its feet in frame 0 of the walk: joints and contacts."""
    from pathlib import Path
    rd = tumble.games105_ragdoll("floating")
    walk = tumble.load_bvh(Path(__file__).resolve().parents[1] / "data" / "games105" / "walk_forward.bvh")
    w = rd.make_world(**kwargs)
    tumble.set_pose(w, rd, walk, 0)
    return w


def full_snapshot(w):
    c = w.contacts
    return [a.copy() for a in w.state_arrays] + [a.copy() for a in w.control_arrays] + [w.time] + [np.asarray(x).copy() for x in c.__dict__.values()]


@pytest.mark.parametrize("contact", ["lcp", "pgs"])
def test_save_and_load_state_is_bit_exact(tmp_path, contact):
    w = ragdoll_world(contact=contact)
    w.step(100)
    assert len(w.contacts) > 0 and np.any(w.state_arrays.row_impulse != 0)
    w.joint_motor_target[0] = 0.0
    w.save_state(tmp_path / "a.npz")
    w.step(100)
    x = full_snapshot(w)
    w.load_state(tmp_path / "a.npz")
    w.step(100)
    assert_same(full_snapshot(w), x)
    # a fresh world of the same model, with the suffix left to load_state
    fresh = tumble.World(w.model, **{k: getattr(w, k) for k in ("dt", "contact", "contact_erp",
                                                                 "contact_cfm")})
    fresh.load_state(tmp_path / "a")
    fresh.step(100)
    assert_same(full_snapshot(fresh), x)


def test_get_and_set_state_keep_impulses_and_contacts():
    w = ragdoll_world(contact="pgs", iterations=20)
    w.step(50)
    saved = w.get_state()
    w.step(30)
    x = full_snapshot(w)
    w.step(40)
    w.set_state(saved)
    w.step(30)
    assert_same(full_snapshot(w), x)
    # a hand-made State (bodies only) starts from no impulses and no contacts
    bare = tumble.State(saved.time, saved.body_pos, saved.body_quat, saved.body_vel,
                        saved.body_angvel)
    w.set_state(bare)
    assert len(w.contacts) == 0 and not w.state_arrays.row_impulse.any()
    w.step(30)
    assert not np.array_equal(w.body_pos, x[0][0])      # PGS without its warm start differs


def test_load_state_refuses_other_models_and_files(tmp_path):
    w = two_bodies()
    w.step(3)
    w.save_state(tmp_path / "two.npz")
    b = tumble.ModelBuilder()
    b.add_body("pelvis", pos=(0, 0, 1), mass=8.0, inertia=(0.1, 0.12, 0.14))
    b.add_body("shin", pos=(0, 0.1, 0.7), mass=7.0, inertia=(0.05, 0.05, 0.01))
    other = tumble.World(b.build())
    before = snapshot(other)
    with pytest.raises(tumble.StateError, match=r"two.npz belongs to a model with 2 bodies "
                                                r"\['pelvis', 'thigh'\]; .* \['pelvis', 'shin'\]"):
        other.load_state(tmp_path / "two.npz")
    assert_same(snapshot(other), before)
    with pytest.raises(tumble.StateError, match="holds 1 worlds, this world has nworld=2"):
        two_bodies(nworld=2).load_state(tmp_path / "two.npz")
    np.savez(tmp_path / "plain.npz", x=np.zeros(3))
    with pytest.raises(tumble.StateError, match="plain.npz is not a tumble state file"):
        w.load_state(tmp_path / "plain.npz")
    (tmp_path / "junk.npz").write_text("not a zip")
    with pytest.raises(tumble.StateError, match="junk.npz is not a tumble state file"):
        w.load_state(tmp_path / "junk.npz")
    with pytest.raises(FileNotFoundError):
        w.load_state(tmp_path / "missing.npz")
    bad = dict(np.load(tmp_path / "two.npz"))
    bad["body_vel"] = np.full_like(bad["body_vel"], np.nan)
    np.savez(tmp_path / "nan.npz", **bad)
    with pytest.raises(tumble.StateError, match="nan.npz: set_state: body_vel is not finite"):
        w.load_state(tmp_path / "nan.npz")


def test_scratch_kept_between_calls_changes_nothing():
    """The serial step keeps its scratch memory (rows, tree plans) from call to call: a world
    whose scratch has served another motion gives the same bits as a fresh one, also when
    a body servo switched on between calls makes the scratch anew and when the contact
    buffer has to grow."""
    def run(w, chunks, servo_at):
        done = 0
        for n in chunks:
            if done == servo_at:
                w.set_body_servo("RootJoint", kp=200.0, kd=20.0, kp_rot=50.0, kd_rot=5.0)
                w.body_target_pos[0] = w.body_pos[0] + 0.01
                w.body_target_quat[0] = w.body_quat[0]
            w.step(n)
            done += n
        return full_snapshot(w)

    chunks = [1] * 10 + [30, 1, 39]
    fresh = ragdoll_world(contact_capacity=1)            # the contact buffer grows
    expected = run(fresh, chunks, servo_at=40)
    used = ragdoll_world(contact_capacity=1)
    start = used.get_state()
    used.apply_force(0, (300.0, 0.0, 0.0))
    used.step(50)                                        # another motion, other contacts
    used.set_state(start)
    used.set_body_servo("RootJoint", 0.0, 0.0)
    assert_same(run(used, chunks, servo_at=40), expected)
