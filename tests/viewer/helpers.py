"""Helpers of the viewer tests: a synthetic recording (every drawable geom type, moving on
known paths; no simulation needed), projection of bodies into a browser screenshot, and a
browser tab wrapper."""
import io
import os
import shutil
import time

import numpy as np

import tumble
from tumble.viewer import Recording, Scene

CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
VIEWPORT = {"width": 1280, "height": 640}


def chromium_path():
    for p in (os.environ.get("TUMBLE_CHROMIUM"), "/usr/bin/chromium",
              shutil.which("chromium"), shutil.which("chromium-browser")):
        if p and os.path.exists(p):
            return p
    return None


def demo_model():
    """Ground plane, a static world box and one dynamic body of every solid geom type."""
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_geom(None, "plane", name="ground")
    b.add_geom(None, "box", size=(0.2, 0.2, 0.1), pos=(-1.2, 1.0, 0.1), name="step")
    shapes = [("box", dict(size=(0.25, 0.15, 0.1))), ("sphere", dict(radius=0.18)),
              ("capsule", dict(radius=0.1, half_length=0.2)),
              ("cylinder", dict(radius=0.12, half_length=0.15)),
              ("convex", dict(vertices=[(0.2, 0, 0), (-0.1, 0.17, 0), (-0.1, -0.17, 0),
                                        (0, 0, 0.25), (0, 0, -0.1)]))]
    for i, (kind, kw) in enumerate(shapes):
        body = b.add_body(f"{kind}_body", pos=(0.6 * (i - 2), 0.0, 0.5), density=500.0)
        b.add_geom(body, kind, **kw)
    return b.build()


def synthetic_recording(seconds=2.0, fps=30):
    """Bodies sliding along x and spinning about z, so every frame differs."""
    scene = Scene.from_model(demo_model())
    t = np.arange(int(round(seconds * fps)) + 1) / fps
    base = np.array([(0.6 * (i - 2), 0.0, 0.5) for i in range(scene.nbody)])
    pos = base[None] + np.stack([0.8 * np.sin(1.5 * t), 0.4 * t, 0.1 * t], -1)[:, None]
    ang = 2.0 * t
    quat = np.zeros((len(t), scene.nbody, 4))
    quat[..., 2] = np.sin(ang / 2)[:, None]
    quat[..., 3] = np.cos(ang / 2)[:, None]
    return Recording(scene, t, pos, quat, dt=1.0 / 240.0)


def _viser_projection(camera):
    eye, look = np.asarray(camera.position), np.asarray(camera.look_at)
    fwd = (look - eye) / np.linalg.norm(look - eye)
    right = np.cross(fwd, camera.up_direction)
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    h, w = camera.image_height, camera.image_width
    focal = 0.5 * h / np.tan(camera.fov / 2)

    def project(pts):
        rel = np.asarray(pts) - eye
        z = rel @ fwd
        return np.stack([0.5 * w + focal * (rel @ right) / z,
                         0.5 * h - focal * (rel @ up) / z], -1)
    return project


def _posed_meshes(scene, pos, quat):
    r_g, p_g = scene.geom_poses(pos, quat)
    for g in range(scene.ngeom):
        if scene.geom_body[g] >= 0:
            v, f = scene.geom_mesh(g, detail=16)
            yield v @ r_g[g].T + p_g[g], f


def projected_bodies(scene, pos, quat, camera):
    """Pixel coordinates (n, 2) of every body-geom mesh vertex seen by a viser camera."""
    project = _viser_projection(camera)
    return np.concatenate([project(v) for v, _ in _posed_meshes(scene, pos, quat)])


def body_silhouettes(scene, pos, quat, camera):
    """Boolean image (h, w) of the pixels the bodies cover, drawn from the scene's meshes
    and the viser camera's pose and field of view."""
    from PIL import Image, ImageDraw
    project = _viser_projection(camera)
    img = Image.new("1", (camera.image_width, camera.image_height), 0)
    draw = ImageDraw.Draw(img)
    for v, f in _posed_meshes(scene, pos, quat):
        uv = project(v)
        for tri in f:
            draw.polygon([tuple(p) for p in uv[tri]], fill=1)
    return np.asarray(img, bool)


def dilate(mask, r):
    """Grow (r > 0) or shrink (r < 0) a boolean mask by |r| pixels (square neighbourhood)."""
    out = mask.copy()
    pad = np.pad(mask, abs(r), constant_values=r < 0)
    h, w = mask.shape
    for dy in range(-abs(r), abs(r) + 1):
        for dx in range(-abs(r), abs(r) + 1):
            shifted = pad[abs(r) + dy: abs(r) + dy + h, abs(r) + dx: abs(r) + dx + w]
            out = (out | shifted) if r > 0 else (out & shifted)
    return out


class Page:
    """A browser tab on a viewer, collecting console errors."""

    def __init__(self, browser, url):
        self.page = browser.new_page(viewport=VIEWPORT)
        self.errors = []
        self.page.on("console", lambda m: self.errors.append(m.text) if m.type == "error" else None)
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.goto(url + "/?fixedDpr=1")

    def screenshot(self):
        from PIL import Image
        return np.asarray(Image.open(io.BytesIO(self.page.screenshot())).convert("RGB"),
                          dtype=np.int16)

    def settle(self, timeout=20.0, quiet=0.6, noise=100):
        """Wait until the picture stops changing (the client fades the scene in; up to
        ``noise`` pixels may flicker in the panel) and return it."""
        end = time.monotonic() + timeout
        last = self.screenshot()
        while time.monotonic() < end:
            time.sleep(quiet)
            now = self.screenshot()
            if changed_pixels(now, last) <= noise:
                return now
            last = now
        raise AssertionError("the page never stopped changing")

    def close(self):
        self.page.close()


def changed_pixels(a, b, threshold=24):
    """Number of pixels whose colour differs by more than ``threshold`` in some channel."""
    return int(np.count_nonzero(np.abs(a - b).max(axis=-1) > threshold))


