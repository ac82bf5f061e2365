"""Headless export of a recording to MP4, GIF or a PNG, with no display and no GPU.

    from tumble.viewer import export_video
    export_video(recording, "fall.mp4", fps=30, size=(640, 360))

Frames are drawn by the software :class:`~tumble.viewer.render.Renderer` and encoded by
the ffmpeg binary that ships inside the ``imageio-ffmpeg`` wheel (H.264 in MP4; GIF with a
palette computed over the whole clip). A clip of ``D`` s of recording at ``fps`` frames per
second and ``speed`` has ``max(1, round(D / speed * fps))`` frames, showing the recording at
times ``t0 + k * speed / fps``, interpolated between recorded frames.
"""
import os
import subprocess

import numpy as np

from ..errors import ModelError
from .progress import progress_bar
from .recorder import Recording
from .render import Camera, Renderer, auto_camera


def frame_times(recording, fps, speed=1.0, start=None, end=None):
    """Times (s) of the frames an export of ``recording`` shows (see the module notes)."""
    t0 = recording.time[0] if start is None else float(start)
    t1 = recording.time[-1] if end is None else float(end)
    if not t1 >= t0:
        raise ModelError(f"export: end ({t1:g} s) is before start ({t0:g} s)")
    n = max(1, int(round((t1 - t0) / speed * fps)))
    return t0 + np.arange(n) * speed / fps


def _ffmpeg():
    try:
        import imageio_ffmpeg
    except ImportError:
        raise ModelError("export to video needs imageio-ffmpeg: pip install 'tumble[viewer]'") \
            from None
    return imageio_ffmpeg.get_ffmpeg_exe()


class _FfmpegWriter:
    """Raw RGB frames piped into an ffmpeg process."""

    def __init__(self, path, width, height, fps, kind, quality):
        exe = _ffmpeg()
        cmd = [exe, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24",
               "-s", f"{width}x{height}", "-r", f"{fps:g}", "-i", "-", "-an"]
        if kind == "mp4":
            crf = int(round(np.interp(quality, [0, 10], [40, 12])))
            cmd += ["-c:v", "libx264", "-preset", "veryfast", "-crf", str(crf),
                    "-pix_fmt", "yuv420p", "-movflags", "+faststart"]
        else:
            # one palette for the whole clip (no flicker); Bayer dithering keeps files small
            cmd += ["-filter_complex",
                    "[0:v]split[a][b];[a]palettegen=stats_mode=full:max_colors=128[p];"
                    "[b][p]paletteuse=dither=bayer:bayer_scale=4",
                    "-loop", "0", "-f", "gif"]
        cmd.append(path)
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE)
        self.path = path

    def write(self, frame):
        try:
            self.proc.stdin.write(np.ascontiguousarray(frame, dtype=np.uint8).tobytes())
        except BrokenPipeError:
            self.close()

    def close(self):
        if self.proc.stdin and not self.proc.stdin.closed:
            try:
                self.proc.stdin.close()
            except BrokenPipeError:
                pass
        err = self.proc.stderr.read().decode(errors="replace")
        self.proc.stderr.close()
        if self.proc.wait() != 0:
            raise ModelError(f"export '{self.path}': ffmpeg failed: {err.strip()}")


def _as_recording(source):
    from .recorder import Recorder
    if isinstance(source, Recording):
        return source
    if isinstance(source, Recorder):
        return source.recording()
    if isinstance(source, (str, os.PathLike)):
        return Recording.load(source)
    raise ModelError(f"export: expected a Recording, Recorder or .npz path, got "
                     f"{type(source).__name__}")


def export_video(recording, path, *, fps=30, size=(640, 360), speed=1.0, start=None,
                 end=None, camera=None, follow=None, contacts=False, com=False,
                 caption=True, detail=12, quality=6, progress=None):
    """Write ``recording`` (a Recording, Recorder or ``.npz`` path) to ``path``.

    The format comes from the suffix: ``.mp4`` (H.264, width and height must be even),
    ``.gif`` or ``.png`` (one frame, at ``start``). Returns the number of frames written.

    fps : frames per second of the clip.  size : (width, height) in pixels.
    speed : recording seconds per clip second (0.5 is slow motion).
    start, end : part of the recording to show (s; default all of it).
    camera : a :class:`~tumble.viewer.render.Camera`; default frames every moving body
        over the clip, or with ``follow`` ('com' or a body) keeps that in the middle.
    contacts : draw contact points and forces (if recorded).  com : mark the centre of mass.
    caption : print the time in the corner; a function ``caption(t)`` of the recording's
        time (s) prints the text it returns instead.  detail : mesh segments around curved
        shapes.
    quality : 0..10, for MP4 (H.264 CRF from 40 down to 12).
    progress : progress bar (True, False, None: when stderr is a terminal).
    """
    rec = _as_recording(recording)
    path = os.fspath(path)
    kind = os.path.splitext(path)[1].lower().lstrip(".")
    if kind not in ("mp4", "gif", "png"):
        raise ModelError(f"export '{path}': the file must end in .mp4, .gif or .png")
    try:
        width, height = (int(v) for v in size)
    except (TypeError, ValueError):
        raise ModelError(f"export '{path}': size must be (width, height), got {size!r}") from None
    if kind == "mp4" and (width % 2 or height % 2):
        raise ModelError(f"export '{path}': an MP4 (H.264, yuv420p) needs an even width and "
                         f"height, got {width} x {height}")
    if not (np.isfinite(fps) and fps > 0):
        raise ModelError(f"export '{path}': fps must be > 0, got {fps!r}")
    if not (np.isfinite(speed) and speed > 0):
        raise ModelError(f"export '{path}': speed must be > 0, got {speed!r}")
    if contacts and not rec.has_contacts:
        raise ModelError(f"export '{path}': contacts=True but the recording has no contacts "
                         f"(record with Recorder(world, contacts=True))")
    times = frame_times(rec, fps, speed, start, end)
    if kind == "png":
        times = times[:1]
    if camera is None:
        lo, hi = rec.frame_index(times[0]), rec.frame_index(times[-1]) + 1
        camera = auto_camera(rec.scene, rec.body_pos[lo:hi], follow=follow,
                             aspect=width / height)
    elif not isinstance(camera, Camera):
        raise ModelError(f"export '{path}': camera must be a tumble.viewer.Camera")
    renderer = Renderer(rec.scene, width, height, detail=detail)
    writer = None if kind == "png" else _FfmpegWriter(path, width, height, fps, kind, quality)
    try:
        with progress_bar(len(times), f"exporting {os.path.basename(path)}", "frame",
                          progress) as bar:
            for t in times:
                pos, quat = rec.pose_at(t)
                con = rec.contacts(rec.frame_index(t))[:2] if contacts else None
                img = renderer.render(pos, quat, camera, contacts=con, com=com,
                                      text=_caption(caption, t))
                if writer is None:
                    _save_png(img, path)
                else:
                    writer.write(img)
                bar.update(1)
    finally:
        renderer.close()
        if writer is not None:
            writer.close()
    return len(times)


def _caption(caption, t):
    """The text in the corner at recording time ``t``: the time, ``caption(t)``, or none."""
    if callable(caption):
        return str(caption(t))
    return f"t = {t:6.2f} s" if caption else None


def _save_png(img, path):
    from PIL import Image
    Image.fromarray(img).save(path)
