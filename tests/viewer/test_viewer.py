"""The viewer's playback logic without a browser: replay, live stepping, scrubbing back and
resuming, pushing through the API, controllers, and refused sources."""
import time

import numpy as np
import pytest

import tumble
from tests.viewer.helpers import synthetic_recording

pytest.importorskip("viser")
from tumble.viewer import Viewer  # noqa: E402


def _box_world():
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_geom(None, "plane", friction=0.5)
    box = b.add_body("box", pos=(0.0, 0.0, 0.2), density=300.0)
    b.add_geom(box, "box", size=(0.2, 0.2, 0.2), friction=0.5)
    ball = b.add_body("ball", pos=(1.0, 0.0, 1.0), density=300.0)
    b.add_geom(ball, "sphere", radius=0.1)
    return tumble.World(b.build(), dt=1.0 / 240.0, contact="pgs")


def _wait(predicate, timeout=5.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.02)
    return False


def test_replay_plays_pauses_steps_and_seeks():
    rec = synthetic_recording(seconds=2.0, fps=30)
    with Viewer(rec, port=0, paused=True, fps=30) as v:
        assert not v.live and v.nframes == len(rec) and v.frame == 0
        v.step()
        assert v.frame == 1 and v.time == rec.time[1] and not v.playing
        v.seek(-1)
        assert v.frame == len(rec) - 1
        v.seek(10)
        v.speed = 2.0
        v.play()
        t0 = time.monotonic()
        assert _wait(lambda: v.frame >= 40)
        # two recorded seconds per second: 30 frames in about half a second
        assert time.monotonic() - t0 < 2.0
        v.pause()
        f = v.frame
        time.sleep(0.2)
        assert v.frame == f
        with pytest.raises(tumble.ModelError, match="frame must be in"):
            v.seek(len(rec))
        with pytest.raises(tumble.ModelError, match="speed"):
            v.speed = 10.0
        with pytest.raises(tumble.ModelError, match="live world"):
            v.push(0, (0, 0, 0))


def test_replay_without_loop_stops_at_the_end():
    rec = synthetic_recording(seconds=0.5, fps=30)
    with Viewer(rec, port=0, loop=False, speed=4.0) as v:
        assert _wait(lambda: not v.playing)
        assert v.frame == len(rec) - 1


def test_live_world_steps_scrubs_back_and_resumes():
    world = _box_world()
    with Viewer(world, port=0, paused=True, fps=30) as v:
        assert v.live and v.nframes == 1
        for _ in range(5):
            v.step()                           # 8 steps of 1/240 s per frame at 30 fps
        assert v.nframes == 6 and world.time == pytest.approx(5 * 8 / 240)
        ball_z = [v._history.frame(i)["body_pos"][1, 2] for i in range(6)]
        assert np.all(np.diff(ball_z) < 0)     # the ball falls
        v.seek(2)                              # scrub back: the world is not touched yet
        assert world.time == pytest.approx(5 * 8 / 240)
        v.play()                               # resume from frame 2, later frames dropped
        assert _wait(lambda: v.nframes >= 5)
        v.pause()
        assert v._history.frame(2)["time"] == pytest.approx(2 * 8 / 240)
        assert v._history.frame(3)["time"] > v._history.frame(2)["time"]
        times = [v._history.frame(i)["time"] for i in range(v.nframes)]
        assert np.all(np.diff(times) > 0)
        v.reset()
        assert world.time == 0.0 and v.nframes == 1


def test_push_through_the_api_pulls_the_body_to_the_target():
    world = _box_world()
    world.step(60)
    start = world.body_pos[0].copy()
    with Viewer(world, port=0, paused=True) as v:
        v.push("box", start + (0.5, 0.0, 0.0))
        v.play()
        assert _wait(lambda: world.body_pos[0, 0] > start[0] + 0.3)
        v.release()
        v.pause()
    assert abs(world.body_pos[0, 1] - start[1]) < 0.05       # pulled along x only


def test_controller_runs_before_every_step():
    world = _box_world()
    calls = []

    def control(w):
        calls.append(w.time)
        w.apply_force("ball", (0.0, 0.0, 9.81 * w.model.body_mass[1]))   # hover

    with Viewer(world, port=0, paused=True, fps=30, control=control) as v:
        for _ in range(3):
            v.step()
    assert len(calls) == 24
    assert world.body_pos[1, 2] == pytest.approx(1.0, abs=1e-9)


def test_a_diverging_world_pauses_with_a_status():
    world = _box_world()

    def control(w):
        w.apply_force("ball", (np.inf, 0.0, 0.0))

    with Viewer(world, port=0, paused=True, control=control) as v:
        v.play()
        assert _wait(lambda: not v.playing)
        assert "not finite" in v._status and v._status.startswith("stopped: ModelError")


def test_a_failing_controller_pauses_and_the_viewer_keeps_serving(capsys):
    world = _box_world()

    def control(w):
        raise KeyError("no such actuator")

    with Viewer(world, port=0, paused=True, control=control) as v:
        v.play()
        assert _wait(lambda: not v.playing)
        assert v._status.startswith("stopped: KeyError")
        assert "no such actuator" in capsys.readouterr().err      # the traceback is shown
        v.control = None
        v.play()                                                   # and it goes on
        assert _wait(lambda: world.time > 0.1)


def test_viewer_refuses_what_it_cannot_show():
    with pytest.raises(tumble.ModelError, match="World, Model, Recording"):
        Viewer("nothing.npz", port=0)
    with pytest.raises(tumble.ModelError, match="nworld=1"):
        Viewer(tumble.World(_box_world().model, nworld=2), port=0)
    with pytest.raises(tumble.ModelError, match="push_stiffness"):
        Viewer(synthetic_recording(), port=0, push_stiffness=0.0)
    with pytest.raises(tumble.ModelError, match="lighting"):
        Viewer(synthetic_recording(), port=0, lighting="disco")
    with pytest.raises(tumble.ModelError, match="unknown body"):
        Viewer(synthetic_recording(), port=0, follow="nobody")


def test_overlays_show_the_frames_contacts_joints_and_com():
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_geom(None, "plane")
    box = b.add_body("box", pos=(0.0, 0.0, 0.2), density=300.0)
    b.add_geom(box, "box", size=(0.2, 0.2, 0.2))
    arm = b.add_body("arm", pos=(0.0, 0.0, 0.6), density=300.0)
    b.add_geom(arm, "capsule", radius=0.05, half_length=0.15)
    b.add_joint("hinge", "hinge", box, arm, anchor=(0.0, 0.0, 0.4), axis=(0.0, 1.0, 0.0))
    tip = b.add_body("tip", pos=(0.0, 0.0, 0.85), density=300.0)
    b.add_geom(tip, "sphere", radius=0.05)
    b.add_joint("pin", "ball", arm, tip, anchor=(0.0, 0.0, 0.8))
    world = tumble.World(b.build(), dt=1.0 / 240.0, contact="pgs")
    rec = tumble.Recorder(world, contacts=True)
    rec.run(0.3, fps=30)
    recording = rec.recording()
    with Viewer(recording, port=0, paused=True, contacts=True, forces=True, joints=True,
                com=True) as v:
        v.seek(-1)
        points, forces, _ = recording.contacts(len(recording) - 1)
        assert len(points) > 0
        assert v._contact_points.visible and v._force_arrows.visible
        np.testing.assert_allclose(v._contact_points.points, points, atol=2e-3)   # float16
        np.testing.assert_allclose(v._force_arrows.points[:, 0], points, atol=1e-6)
        # joint axes: one for the hinge (along y), three for the ball joint
        segs = v._joint_lines.points
        assert segs.shape == (4, 2, 3)
        hinge = segs[0, 1] - segs[0, 0]
        np.testing.assert_allclose(hinge / np.linalg.norm(hinge), (0, 1, 0), atol=1e-5)
        com = recording.scene.com(recording.body_pos[-1])
        np.testing.assert_allclose(v._com_ball.position, com, atol=1e-6)
        np.testing.assert_allclose(v._com_line.points[0, 1], (com[0], com[1], 0.0), atol=1e-6)
        v._gui_contacts.value = False           # as the checkbox does
        assert not v._contact_points.visible
        v._gui_bodies.value = False
        assert not any(node.visible for node in v._body_nodes)
