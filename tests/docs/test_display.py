"""Inline display in Jupyter (tumble/viewer/notebook.py): a World shows as a PNG of its
bodies, a Recording as an inline animation (GIF or MP4, base64 HTML), a Viewer as an
<iframe> of its page; none needs a display server."""
import base64
import io
import re

import numpy as np
import pytest

pytest.importorskip("matplotlib")
pytest.importorskip("imageio_ffmpeg")

import tumble                                                    # noqa: E402
from tumble.errors import ModelError                            # noqa: E402
from tumble.viewer import notebook                              # noqa: E402


def falling_boxes(nworld=1):
    b = tumble.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_geom(None, "plane", normal=(0, 0, 1))
    b.add_body("red", pos=(0, 0, 0.5), density=500.0)
    b.add_geom("red", "box", size=(0.1, 0.1, 0.1))
    b.add_body("ball", pos=(0.4, 0, 0.8), density=500.0)
    b.add_geom("ball", "sphere", radius=0.1)
    return tumble.World(b.build(), dt=1 / 120, nworld=nworld)


def decode_png(data):
    from PIL import Image
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


def test_world_shows_a_png_of_its_bodies():
    world = falling_boxes()
    img = decode_png(world._repr_png_())
    assert img.shape == (270, 480, 3)
    # the bodies are drawn in their palette colours, not only sky and ground greys
    saturation = img.max(axis=2).astype(int) - img.min(axis=2)
    assert (saturation > 60).sum() > 200
    # a different state gives a different picture
    world.step(60)
    assert not np.array_equal(decode_png(world._repr_png_()), img)


def test_world_png_options_and_batches():
    world = falling_boxes(nworld=2)
    world.body_pos[1, :, 0] += 3.0                        # world 1 differs
    a = decode_png(notebook.world_png(world, size=(200, 120), world_index=0))
    b = decode_png(notebook.world_png(world, size=(200, 120), world_index=1,
                                      caption=False))
    assert a.shape == b.shape == (120, 200, 3)
    with pytest.raises(ModelError, match="world_index"):
        notebook.world_png(world, world_index=2)
    with pytest.raises(ModelError, match="size"):
        notebook.world_png(world, size=(10,))


def test_import_tumble_still_loads_no_viewer_until_a_world_is_shown():
    import subprocess
    import sys
    code = ("import sys, tumble\n"
            "b = tumble.ModelBuilder(); b.add_body('a', mass=1.0, inertia=(1, 1, 1))\n"
            "w = tumble.World(b.build(), dt=0.01)\n"
            "print(any(m.startswith('tumble.viewer') for m in sys.modules))\n"
            "w._repr_png_()\n"
            "print('tumble.viewer.notebook' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["False", "True"]


def recording(seconds=1.0):
    world = falling_boxes()
    rec = tumble.Recorder(world)
    rec.run(seconds, fps=30, progress=False)
    return rec.recording()


def test_recording_shows_as_an_inline_gif():
    html = recording()._repr_html_()
    m = re.fullmatch(r'<img src="data:image/gif;base64,([A-Za-z0-9+/=]+)" width="480" '
                     r'height="270" alt="([^"]*)" title="[^"]*"/>', html)
    assert m, html[:200]
    data = base64.b64decode(m.group(1))
    assert data[:6] in (b"GIF87a", b"GIF89a")
    from PIL import Image
    gif = Image.open(io.BytesIO(data))
    assert gif.n_frames == 20                       # 1 s at the default 20 fps
    assert "31 frames" in m.group(2)


def test_animation_as_video_and_long_recordings_sped_up(tmp_path):
    rec = recording(seconds=2.0)
    anim = rec.animation(format="mp4", size=(160, 90), fps=10, max_frames=10)
    assert anim.speed == pytest.approx(2.0)         # 2 s at 10 fps would be 20 frames
    html = anim._repr_html_()
    assert html.startswith('<video width="160" height="90" controls autoplay loop muted')
    data = base64.b64decode(re.search(r'base64,([A-Za-z0-9+/=]+)"', html).group(1))
    assert data[4:8] == b"ftyp"                      # an MP4 file
    assert anim.frames == 10 and "shown at 2x" in html
    path = anim.save(tmp_path / "a.mp4")
    assert open(path, "rb").read() == data
    with pytest.raises(ModelError, match="format"):
        rec.animation(format="webm")
    with pytest.raises(ModelError, match="max_frames"):
        rec.animation(max_frames=0)


def test_recording_without_ffmpeg_falls_back_to_text(monkeypatch):
    import tumble.viewer.export as export

    def missing():
        raise ModelError("export to video needs imageio-ffmpeg: pip install 'tumble[viewer]'")
    monkeypatch.setattr(export, "_ffmpeg", missing)
    assert recording(0.2)._repr_html_() is None


def test_viewer_embeds_as_an_iframe_of_its_page():
    pytest.importorskip("viser")
    world = falling_boxes()
    embedded = notebook.embed(world, height=300, paused=True)
    try:
        url = embedded.viewer.url
        assert re.fullmatch(r"http://127\.0\.0\.1:\d+", url) and not url.endswith(":0")
        html = embedded._repr_html_()
        assert f'<iframe src="{url}" width="100%" height="300"' in html
        assert embedded.viewer._repr_html_().startswith(f'<iframe src="{url}"')
        import urllib.request
        with urllib.request.urlopen(url, timeout=10) as page:    # the page is served
            assert page.status == 200 and b"<html" in page.read().lower()
    finally:
        embedded.close()
