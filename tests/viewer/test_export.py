"""Headless export: files that play back with the expected frame count and size, frames that
show the bodies where the camera sees them, and clear errors."""
import numpy as np
import pytest

import tumble
from tests.viewer.helpers import demo_model, synthetic_recording
from tumble.viewer import Recording, Scene

pytest.importorskip("matplotlib")
imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
from PIL import Image  # noqa: E402

from tumble.viewer.export import export_video, frame_times  # noqa: E402
from tumble.viewer.render import Camera, Renderer, auto_camera  # noqa: E402


def _mp4_frames(path):
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    frames = [np.frombuffer(f, np.uint8).reshape(meta["size"][1], meta["size"][0], 3)
              for f in reader]
    return meta, frames


def test_mp4_has_the_expected_frames_and_size(tmp_path):
    rec = synthetic_recording(seconds=2.0, fps=30)
    path = tmp_path / "clip.mp4"
    n = export_video(rec, path, fps=24, size=(320, 240), progress=False)
    assert n == 48 == len(frame_times(rec, 24))               # 2 s at 24 fps
    nframes, secs = imageio_ffmpeg.count_frames_and_secs(str(path))
    assert nframes == 48 and secs == pytest.approx(2.0, abs=0.05)
    meta, frames = _mp4_frames(path)
    assert tuple(meta["size"]) == (320, 240) and meta["fps"] == pytest.approx(24)
    assert len(frames) == 48
    # the bodies move, so the first and last frames differ; neither is blank
    assert np.abs(frames[0].astype(int) - frames[-1]).max() > 50
    assert frames[0].std() > 10


def test_gif_has_every_frame_even_when_nothing_moves(tmp_path):
    rec = synthetic_recording(seconds=1.0, fps=30)
    still = Recording(rec.scene, rec.time, np.repeat(rec.body_pos[:1], len(rec), 0),
                      np.repeat(rec.body_quat[:1], len(rec), 0), dt=rec.dt)
    path = tmp_path / "still.gif"
    n = export_video(still, path, fps=10, size=(160, 90), caption=False, progress=False)
    with Image.open(path) as im:
        assert (im.n_frames, im.size) == (n, (160, 90)) == (10, (160, 90))
    # slow motion: half speed doubles the frames
    n = export_video(rec, tmp_path / "slow.gif", fps=10, size=(96, 64), speed=0.5,
                     progress=False)
    with Image.open(tmp_path / "slow.gif") as im:
        assert im.n_frames == n == 20 and im.size == (96, 64)


def test_a_caption_function_writes_its_text_on_each_frame(tmp_path):
    rec = synthetic_recording(seconds=1.0, fps=30)
    asked = []

    def caption(t):
        asked.append(t)
        return f"command {len(asked)}" if t >= 0.5 else ""

    kwargs = dict(fps=4, size=(160, 90), progress=False)
    assert export_video(rec, tmp_path / "c.gif", caption=caption, **kwargs) == 4
    assert asked == pytest.approx(list(frame_times(rec, 4)))

    def still(start, caption):
        path = tmp_path / f"{start}-{bool(caption)}.png"
        export_video(rec, path, start=start, size=(160, 90), caption=caption)
        with Image.open(path) as im:
            return np.asarray(im.convert("RGB"))

    # text only where the function returned some
    assert np.array_equal(still(0.25, caption), still(0.25, False))
    assert not np.array_equal(still(0.75, caption), still(0.75, False))


def test_png_and_recordings_from_paths_and_recorders(tmp_path):
    rec = synthetic_recording(seconds=1.0)
    saved = rec.save(tmp_path / "r.npz")
    assert export_video(saved, tmp_path / "still.png", size=(200, 100), start=0.5) == 1
    with Image.open(tmp_path / "still.png") as im:
        assert im.size == (200, 100)
    world = tumble.World(demo_model())
    assert export_video(tumble.Recorder(world), tmp_path / "one.png", size=(64, 48)) == 1


def test_export_refuses_bad_requests(tmp_path):
    rec = synthetic_recording(seconds=0.5)
    with pytest.raises(tumble.ModelError, match="even width and height"):
        export_video(rec, tmp_path / "odd.mp4", size=(321, 240))
    with pytest.raises(tumble.ModelError, match=r"\.mp4, \.gif or \.png"):
        export_video(rec, tmp_path / "clip.avi")
    with pytest.raises(tumble.ModelError, match="no contacts"):
        export_video(rec, tmp_path / "c.gif", contacts=True)
    with pytest.raises(tumble.ModelError, match="fps"):
        export_video(rec, tmp_path / "c.gif", fps=0)
    with pytest.raises(tumble.ModelError, match="end"):
        export_video(rec, tmp_path / "c.gif", start=0.4, end=0.1)
    with pytest.raises(tumble.ModelError, match="Recording"):
        export_video(object(), tmp_path / "c.gif")
    with pytest.raises(tumble.ModelError, match="width"):
        Renderer(rec.scene, 8, 100)


def _one_box_scene(colour=(1.0, 0.0, 0.0)):
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_geom(None, "plane")
    box = b.add_body("box", pos=(0.0, 0.0, 0.5), density=100.0)
    b.add_geom(box, "box", size=(0.25, 0.25, 0.25))
    return Scene.from_model(b.build(), body_colors={"box": colour})


def _redness(img):
    img = img.astype(int)
    return (img[..., 0] - np.maximum(img[..., 1], img[..., 2])) > 60


def test_the_renderer_draws_a_body_where_the_camera_sees_it():
    scene = _one_box_scene()
    ren = Renderer(scene, 200, 150)
    cam = Camera(target=(0.0, 0.0, 0.5), distance=4.0, azimuth=0.0, elevation=0.0, fov=40.0)
    pos, quat = np.array([[0.0, 0.0, 0.5]]), np.array([[0.0, 0.0, 0.0, 1.0]])
    red = _redness(ren.render(pos, quat, cam))
    ys, xs = np.nonzero(red)
    # seen face on from 4 m - 0.25 m: half width 0.25 m projects to
    # 75 px * 0.25 / (3.75 tan 20 deg) = 13.7 px either side of the centre
    half = 75 * 0.25 / (3.75 * np.tan(np.radians(20)))
    assert abs(xs.mean() - 100) < 1.0 and abs(ys.mean() - 75) < 1.0
    assert xs.max() - xs.min() + 1 == pytest.approx(2 * half, abs=2)
    # moved 1 m to the camera's right (+y, seen from +x), it moves right on the image
    red2 = _redness(ren.render(pos + (0.0, 1.0, 0.0), quat, cam))
    assert np.nonzero(red2)[1].mean() == pytest.approx(100 + 75 / (4 * np.tan(np.radians(20))),
                                                       abs=2)
    # a following camera keeps it in the middle
    follow = Camera(distance=4.0, azimuth=0.0, elevation=0.0, fov=40.0, follow="box")
    red3 = _redness(ren.render(pos + (0.0, 1.0, 0.0), quat, follow))
    assert abs(np.nonzero(red3)[1].mean() - 100) < 1.0
    ren.close()


def test_auto_camera_keeps_every_frame_in_view():
    rec = synthetic_recording(seconds=2.0)
    ren = Renderer(rec.scene, 160, 120, shadows=False, grid=0)
    cam = auto_camera(rec.scene, rec.body_pos, aspect=160 / 120)
    eye = cam.eye(rec.scene.up)
    behind = eye + 5.0 * (eye - np.asarray(cam.target)) / cam.distance   # culled: not drawn
    background = ren.render(np.tile(behind, (rec.scene.nbody, 1)), rec.body_quat[0], cam)
    for i in (0, len(rec) // 2, len(rec) - 1):
        img = ren.render(rec.body_pos[i], rec.body_quat[i], cam)
        drawn = np.abs(img.astype(int) - background).max(-1) > 10
        ys, xs = np.nonzero(drawn)
        assert len(xs) > 100
        # nothing touches the image border: everything is inside the frame
        assert xs.min() > 0 and ys.min() > 0 and xs.max() < 159 and ys.max() < 119
    ren.close()
