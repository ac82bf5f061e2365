"""Recorder and Recording: frames taken where they should be, exact .npz round trip, clear
errors for bad files and bad input, interpolation between frames."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import tumble
from tests.viewer.helpers import demo_model, synthetic_recording
from tumble.viewer import Recorder, Recording, Scene, simulate


def _falling_box(contact="pgs"):
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_geom(None, "plane", friction=0.6)
    box = b.add_body("box", pos=(0.0, 0.0, 0.5), density=500.0, angvel=(1.0, 2.0, 0.5))
    b.add_geom(box, "box", size=(0.1, 0.15, 0.2))
    arm = b.add_body("arm", pos=(0.0, 0.0, 0.85), density=500.0)
    b.add_geom(arm, "capsule", radius=0.05, half_length=0.1)
    b.add_joint("hinge", "hinge", box, arm, anchor=(0.0, 0.0, 0.7), axis=(1.0, 0.0, 0.0))
    return tumble.World(b.build(), dt=1.0 / 240.0, contact=contact)


def _assert_same(a, b):
    da, db = a.to_arrays(), b.to_arrays()
    assert sorted(da) == sorted(db)
    for key in da:
        assert da[key].dtype == db[key].dtype, key
        assert da[key].shape == db[key].shape, key
        # bit for bit (NaN-free data, so array_equal is exact equality)
        assert np.array_equal(da[key], db[key]), key


def test_a_recorded_run_round_trips_exactly(tmp_path):
    world = _falling_box()
    rec = tumble.Recorder(world, contacts=True, velocities=True, energy=True, joints=True)
    rec.run(1.0, fps=30)
    recording = rec.recording()
    assert len(recording) == 31
    assert recording.contact_start[-1] > 0                      # it landed
    path = recording.save(tmp_path / "run")                     # suffix added
    assert path.endswith("run.npz")
    loaded = Recording.load(path)
    _assert_same(recording, loaded)
    # and again through an uncompressed file
    _assert_same(loaded, Recording.load(loaded.save(tmp_path / "again.npz", compress=False)))
    # what was stored is what the world had
    np.testing.assert_array_equal(loaded.body_pos[-1], world.body_pos)
    np.testing.assert_array_equal(loaded.body_quat[-1], world.body_quat)
    np.testing.assert_array_equal(loaded.body_vel[-1], world.body_vel)
    np.testing.assert_array_equal(loaded.joint_q[-1], world.joint_q)
    assert (loaded.kinetic[-1], loaded.potential[-1]) == world.energy()
    points, forces, bodies = loaded.contacts(len(loaded) - 1)
    c = world.contacts
    np.testing.assert_array_equal(points, c.point)
    np.testing.assert_array_equal(forces, c.force)
    np.testing.assert_array_equal(bodies, c.bodies)


def test_frames_are_taken_every_1_over_fps_in_whole_steps():
    world = _falling_box()
    rec = Recorder(world)
    rec.run(0.5, fps=60)                   # 4 steps of 1/240 per frame
    t = rec.recording().time
    np.testing.assert_allclose(t, np.arange(31) * 4 / 240, atol=1e-12)
    calls = []
    rec2 = Recorder(world, capture_now=False)
    rec2.run(0.1, fps=100, control=lambda w: calls.append(w.time))
    assert len(calls) == 24                                    # once before every step
    assert len(rec2) == 12                                     # 24 steps, 2 per frame (1/120)


def test_simulate_steps_and_reports_frames():
    world = _falling_box()
    frames = []
    assert simulate(world, 0.25, fps=20, on_frame=lambda w: frames.append(w.time)) == 60
    np.testing.assert_allclose(frames, np.arange(1, 6) * 12 / 240)
    assert simulate(world, 0.0) == 0
    with pytest.raises(tumble.ModelError, match="seconds"):
        simulate(world, -1.0)
    with pytest.raises(tumble.ModelError, match="fps"):
        simulate(world, 1.0, fps=0)


def test_capture_step_max_frames_and_truncate():
    world = _falling_box()
    rec = Recorder(world, max_frames=3)
    for _ in range(5):
        rec.step(2)
    assert len(rec) == 3
    np.testing.assert_allclose(rec.recording().time, np.array([3, 4, 5]) * 2 / 240)
    rec.truncate(1)
    assert len(rec) == 1 and rec.frame(0)["time"] == pytest.approx(6 / 240)
    world.reset()
    with pytest.raises(tumble.StateError, match="went back"):
        rec.capture()
    rec.clear()
    rec.capture()
    with pytest.raises(tumble.StateError, match="no frames"):
        Recorder(world, capture_now=False).recording()


def test_recorder_refuses_bad_arguments():
    world = _falling_box()
    with pytest.raises(tumble.ModelError, match="World"):
        Recorder(world.model)
    with pytest.raises(tumble.ModelError, match="world_index"):
        Recorder(world, world_index=1)
    with pytest.raises(tumble.ModelError, match="max_frames"):
        Recorder(world, max_frames=0)


def test_a_batch_records_the_chosen_world():
    world = tumble.World(_falling_box().model, nworld=2)
    world.body_pos[1, :, 0] += 3.0
    rec = Recorder(world, world_index=1, energy=True)
    np.testing.assert_array_equal(rec.recording().body_pos[0], world.body_pos[1])
    assert rec.recording().kinetic[0] == world.energy()[0][1]


def test_interpolation_between_frames():
    rec = synthetic_recording(seconds=1.0, fps=10)
    # at frame times: the frames themselves
    pos, quat = rec.pose_at(rec.time[3])
    np.testing.assert_array_equal(pos, rec.body_pos[3])
    # half way: the mean position and the half-angle rotation (about z, 2 rad/s)
    t = 0.5 * (rec.time[3] + rec.time[4])
    pos, quat = rec.pose_at(t)
    np.testing.assert_allclose(pos, 0.5 * (rec.body_pos[3] + rec.body_pos[4]))
    np.testing.assert_allclose(quat[:, 2], np.sin(t), atol=2e-3)    # nlerp vs slerp
    np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0)
    # short way round: a sign-flipped quaternion is the same rotation
    flipped = Recording(rec.scene, rec.time, rec.body_pos,
                        rec.body_quat * np.where(np.arange(len(rec)) % 2, -1, 1)[:, None, None],
                        dt=rec.dt)
    np.testing.assert_allclose(np.abs(flipped.pose_at(t)[1]), np.abs(quat), atol=1e-12)
    # clamped outside
    np.testing.assert_array_equal(rec.pose_at(-5.0)[0], rec.body_pos[0])
    np.testing.assert_array_equal(rec.pose_at(99.0)[0], rec.body_pos[-1])
    assert rec.frame_index(rec.time[5] + 1e-9) == 5 and rec.frame_index(-1) == 0


def test_recording_checks_its_arrays():
    scene = Scene.from_model(demo_model())
    t = np.arange(3.0)
    pos, quat = np.zeros((3, 5, 3)), np.tile([0, 0, 0, 1.0], (3, 5, 1))
    with pytest.raises(tumble.ModelError, match="body_pos must have shape"):
        Recording(scene, t, pos[:, :4], quat, dt=0.01)
    with pytest.raises(tumble.ModelError, match="time must not decrease"):
        Recording(scene, t[::-1], pos, quat, dt=0.01)
    with pytest.raises(tumble.ModelError, match="non-empty"):
        Recording(scene, [], pos[:0], quat[:0], dt=0.01)
    with pytest.raises(tumble.ModelError, match="contact_start"):
        Recording(scene, t, pos, quat, dt=0.01, contact_start=[1, 1, 1, 1],
                  contact_point=np.zeros((1, 3)), contact_force=np.zeros((1, 3)),
                  contact_bodies=np.zeros((1, 2)))


def test_loading_bad_files_names_the_file_and_field(tmp_path):
    with pytest.raises(tumble.ModelError, match="no such file"):
        Recording.load(tmp_path / "missing.npz")
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip file")
    with pytest.raises(tumble.ModelError, match="junk.npz.*not a readable"):
        Recording.load(junk)
    np.savez(tmp_path / "other.npz", a=np.zeros(3))
    with pytest.raises(tumble.ModelError, match="not a tumble recording"):
        Recording.load(tmp_path / "other.npz")
    arrays = synthetic_recording().to_arrays()
    del arrays["body_quat"]
    np.savez(tmp_path / "cut.npz", **arrays)
    with pytest.raises(tumble.ModelError, match="cut.npz.*'body_quat' is missing"):
        Recording.load(tmp_path / "cut.npz")
    arrays = synthetic_recording().to_arrays()
    arrays["version"] = np.array(99)
    np.savez(tmp_path / "new.npz", **arrays)
    with pytest.raises(tumble.ModelError, match="version 99"):
        Recording.load(tmp_path / "new.npz")


_floats = st.floats(allow_nan=False, allow_infinity=False, allow_subnormal=True, width=64)


@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_any_recording_round_trips_bit_for_bit(tmp_path_factory, data):
    scene = Scene.from_model(demo_model())
    nf = data.draw(st.integers(1, 6))
    t = np.cumsum(data.draw(hnp.arrays(np.float64, nf, elements=st.floats(0, 1e6))))
    pos = data.draw(hnp.arrays(np.float64, (nf, 5, 3), elements=_floats))
    quat = data.draw(hnp.arrays(np.float64, (nf, 5, 4), elements=_floats))
    counts = data.draw(hnp.arrays(np.int64, nf, elements=st.integers(0, 3)))
    nc = int(counts.sum())
    rec = Recording(scene, t, pos, quat, dt=data.draw(st.floats(1e-6, 1.0)),
                    kinetic=data.draw(hnp.arrays(np.float64, nf, elements=_floats)),
                    potential=data.draw(hnp.arrays(np.float64, nf, elements=_floats)),
                    contact_start=np.concatenate([[0], np.cumsum(counts)]),
                    contact_point=data.draw(hnp.arrays(np.float64, (nc, 3), elements=_floats)),
                    contact_force=data.draw(hnp.arrays(np.float64, (nc, 3), elements=_floats)),
                    contact_bodies=data.draw(hnp.arrays(np.int32, (nc, 2),
                                                        elements=st.integers(-1, 4))))
    path = rec.save(tmp_path_factory.mktemp("rt") / "r.npz")
    loaded = Recording.load(path)
    _assert_same(rec, loaded)
    # -0.0 and subnormals too: compare the bits
    assert loaded.body_pos.tobytes() == rec.body_pos.tobytes()


def test_long_runs_show_a_progress_bar(capsys):
    pytest.importorskip("tqdm")
    world = _falling_box()
    simulate(world, 0.5, fps=10, progress=True, desc="falling")
    err = capsys.readouterr().err
    assert "falling:" in err and "/120" in err
    simulate(world, 0.5, progress=False)
    assert capsys.readouterr().err == ""
