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
        assert "not finite" in v._status


def test_viewer_refuses_what_it_cannot_show():
    with pytest.raises(tumble.ModelError, match="World, Model, Recording"):
        Viewer("nothing.npz", port=0)
    with pytest.raises(tumble.ModelError, match="nworld=1"):
        Viewer(tumble.World(_box_world().model, nworld=2), port=0)
    with pytest.raises(tumble.ModelError, match="lighting"):
        Viewer(synthetic_recording(), port=0, lighting="disco")
    with pytest.raises(tumble.ModelError, match="unknown body"):
        Viewer(synthetic_recording(), port=0, follow="nobody")
