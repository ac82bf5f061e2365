"""Showing simulations inline in Jupyter, with no display server.

In a notebook cell, the last value is shown by its rich form:

    world                              # a World: a picture of its bodies (PNG)
    recorder.recording()               # a Recording: an animated GIF, played inline
    Animation(recording, format="mp4") # the same as an H.264 video, at a chosen size/speed
    viewer = Viewer(world, port=0)     # the browser viewer, embedded in the cell
    viewer                             # (an <iframe> of its page)

Pictures and animations are drawn by the software :class:`~tumble.viewer.render.Renderer`
and encoded by the ffmpeg that ships in ``imageio-ffmpeg`` (GIF, MP4) or matplotlib (PNG),
so they work on a headless server; the notebook stores them (base64) and shows them again
without the kernel. Needs the ``viewer`` extra; without it these objects show as text.

The embedded viewer's frame points at the viewer's own address (``Viewer.url``): it shows
when the browser that runs the notebook can reach the kernel's machine on that port (a
local Jupyter, or a forwarded port).
"""
import base64
import html
import io
import os
import tempfile

import numpy as np

from ..errors import ModelError

__all__ = ["Animation", "world_png", "recording_html", "viewer_html", "embed"]

DEFAULT_SIZE = (480, 270)
DEFAULT_FPS = 20
MAX_FRAMES = 200              # a longer recording is shown faster, to fit


def _size(size):
    try:
        width, height = (int(v) for v in size)
    except (TypeError, ValueError):
        raise ModelError(f"notebook: size must be (width, height), got {size!r}") from None
    return width, height


def world_png(world, *, size=DEFAULT_SIZE, camera=None, world_index=0, contacts=False,
              caption=True):
    """A PNG image (bytes) of ``world``'s bodies as they are now.

    size : (width, height) in pixels.  camera : a :class:`~tumble.viewer.render.Camera`
    (default: one that frames every moving body).  world_index : which world of a batch.
    contacts : draw the last step's contact points and forces.  caption : print the time.
    """
    from .render import Camera, Renderer, auto_camera
    from .scene import Scene

    if not 0 <= world_index < world.nworld:
        raise ModelError(f"notebook: world_index must be in [0, {world.nworld}), "
                         f"got {world_index!r}")
    width, height = _size(size)
    pick = (lambda a: a[world_index]) if world.nworld > 1 else (lambda a: a)
    pos, quat = np.array(pick(world.body_pos)), np.array(pick(world.body_quat))
    scene = Scene.from_model(world.model)
    if camera is None:
        camera = auto_camera(scene, pos, aspect=width / height)
    elif not isinstance(camera, Camera):
        raise ModelError("notebook: camera must be a tumble.viewer.Camera")
    con = None
    if contacts:
        c = world.contacts_of(world_index)
        con = (c.point, c.force)
    renderer = Renderer(scene, width, height)
    try:
        img = renderer.render(pos, quat, camera, contacts=con,
                              text=f"t = {world.time:.2f} s" if caption else None)
    finally:
        renderer.close()
    return png_bytes(img)


def png_bytes(img):
    """An ``(H, W, 3)`` uint8 image as PNG bytes (matplotlib's writer)."""
    from matplotlib.image import imsave
    buf = io.BytesIO()
    imsave(buf, np.asarray(img, dtype=np.uint8), format="png")
    return buf.getvalue()


class Animation:
    """A recording as an animation for a notebook cell (or any HTML page).

    Parameters
    ----------
    recording : a :class:`~tumble.viewer.recorder.Recording`, a ``Recorder`` or a ``.npz``
        path.
    format : 'gif' (an ``<img>``: shown everywhere, larger) or 'mp4' (an H.264 ``<video>``
        with controls: small; width and height must be even).
    fps : frames per second of the animation.  size : (width, height) in pixels.
    speed : recording seconds per animation second; default 1, or faster for a recording
        longer than ``max_frames / fps`` s so that at most ``max_frames`` frames are drawn.
    start, end, camera, follow, contacts, com : as for
        :func:`~tumble.viewer.export.export_video`.

    The animation is drawn once, on first use (``data``, ``_repr_html_``, ``save``).
    """

    def __init__(self, recording, *, format="gif", fps=DEFAULT_FPS, size=DEFAULT_SIZE,
                 speed=None, max_frames=MAX_FRAMES, start=None, end=None, camera=None,
                 follow=None, contacts=False, com=False):
        from .export import _as_recording
        if format not in ("gif", "mp4"):
            raise ModelError(f"notebook: format must be 'gif' or 'mp4', got {format!r}")
        if not (np.isfinite(fps) and fps > 0):
            raise ModelError(f"notebook: fps must be > 0, got {fps!r}")
        if isinstance(max_frames, bool) or not isinstance(max_frames, (int, np.integer)) \
                or max_frames < 1:
            raise ModelError(f"notebook: max_frames must be a positive integer, "
                             f"got {max_frames!r}")
        self.recording = _as_recording(recording)
        self.format = format
        self.fps = float(fps)
        self.size = _size(size)
        rec = self.recording
        t0 = rec.time[0] if start is None else float(start)
        t1 = rec.time[-1] if end is None else float(end)
        if speed is None:
            speed = max(1.0, (t1 - t0) * self.fps / max_frames)
        self.speed = float(speed)
        self._options = dict(start=start, end=end, camera=camera, follow=follow,
                             contacts=contacts, com=com)
        self._data = None
        self.frames = None              # number of frames, once drawn

    @property
    def mimetype(self):
        return "image/gif" if self.format == "gif" else "video/mp4"

    @property
    def data(self):
        """The encoded animation (bytes), drawn on first use."""
        if self._data is None:
            from .export import export_video
            fd, path = tempfile.mkstemp(suffix="." + self.format, prefix="tumble-")
            os.close(fd)
            try:
                self.frames = export_video(self.recording, path, fps=self.fps,
                                           size=self.size, speed=self.speed,
                                           progress=False, **self._options)
                with open(path, "rb") as f:
                    self._data = f.read()
            finally:
                os.remove(path)
        return self._data

    def save(self, path):
        """Write the animation to ``path``; returns the path."""
        with open(path, "wb") as f:
            f.write(self.data)
        return os.fspath(path)

    def to_html(self):
        """The animation as a self-contained HTML element (base64 data URI)."""
        b64 = base64.b64encode(self.data).decode("ascii")
        width, height = self.size
        rec = self.recording
        title = html.escape(f"tumble recording: {len(rec)} frames, "
                            f"{rec.duration:.2f} s" + (f", shown at {self.speed:.3g}x"
                                                       if self.speed != 1 else ""))
        if self.format == "gif":
            return (f'<img src="data:image/gif;base64,{b64}" width="{width}" '
                    f'height="{height}" alt="{title}" title="{title}"/>')
        return (f'<video width="{width}" height="{height}" controls autoplay loop muted '
                f'playsinline title="{title}"><source type="video/mp4" '
                f'src="data:video/mp4;base64,{b64}"/></video>')

    def _repr_html_(self):
        return self.to_html()

    def __repr__(self):
        return (f"<tumble.viewer.notebook.Animation: {self.format}, {self.size[0]}x"
                f"{self.size[1]}, {self.fps:g} fps, speed {self.speed:g}>")


def recording_html(recording, **kwargs):
    """HTML showing ``recording`` as an animation (keywords as for :class:`Animation`)."""
    return Animation(recording, **kwargs).to_html()


def viewer_html(viewer, *, height=480, width="100%"):
    """An ``<iframe>`` of a running :class:`~tumble.viewer.app.Viewer`'s page."""
    url = html.escape(viewer.url, quote=True)
    w = html.escape(str(width), quote=True)
    return (f'<iframe src="{url}" width="{w}" height="{int(height)}" '
            f'style="border: 1px solid #ccc" title="tumble viewer"></iframe>'
            f'<div style="font-size: smaller">tumble viewer at '
            f'<a href="{url}" target="_blank">{url}</a> (close it with '
            f'<code>viewer.close()</code>)</div>')


class _Embedded:
    """A viewer shown in a notebook cell; the viewer itself is ``.viewer``."""

    def __init__(self, viewer, height, width):
        self.viewer, self.height, self.width = viewer, height, width

    def _repr_html_(self):
        return viewer_html(self.viewer, height=self.height, width=self.width)

    def close(self):
        self.viewer.close()

    def __repr__(self):
        return f"<embedded {self.viewer!r}>"


def embed(source, *, height=480, width="100%", port=0, **kwargs):
    """Start a :class:`~tumble.viewer.app.Viewer` on ``source`` (a World, Model, Recording
    or Recorder) on a free port and return an object that shows its page in the cell.
    Keywords go to the Viewer; ``.viewer`` is the Viewer (call ``.close()`` when done)."""
    from .app import Viewer
    return _Embedded(Viewer(source, port=port, **kwargs), height, width)
