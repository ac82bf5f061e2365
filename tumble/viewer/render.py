"""Software rendering of a scene to RGB images, without a display or a GPU.

The geometry work is NumPy: geom meshes are posed, back faces culled, faces flat-shaded
with a sun and a little ambient light, and sorted back to front (the painter's
algorithm; fine for the convex shapes characters are made of). Drawing the sorted 2-D
triangles, the ground grid and the shadows is done by matplotlib's Agg rasteriser, which is
antialiased and needs no system libraries. ``Renderer.render`` returns an ``(H, W, 3)``
uint8 image.
"""
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ModelError
from .scene import HEIGHTFIELD, PLANE, GROUND_COLOR, quat_to_matrix

_NEAR = 0.05                  # m: faces closer to the camera than this are dropped
_SHADOW = 0.72                # shadow brightness relative to the ground
_BACKGROUND = (0.86, 0.89, 0.93)


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def horizontal_axes(up):
    """Two horizontal unit vectors (h1, h2) with h1 x h2 = up: h1 follows world x unless up
    is (nearly) x, then world y."""
    up = _unit(up)
    e = np.eye(3)[0] if abs(up[0]) < 0.9 else np.eye(3)[1]
    h1 = _unit(e - (e @ up) * up)
    return h1, np.cross(up, h1)


@dataclass(frozen=True)
class Camera:
    """A perspective camera orbiting ``target``.

    target : (3,) world point looked at, m.  distance : from the target, m.
    azimuth : degrees about the up axis, 0 looking from the first horizontal axis
        (+x for z-up and y-up scenes) towards the target.
    elevation : degrees above the horizon.  fov : vertical field of view, degrees.
    follow : None, 'com' or a body name or index: the camera then looks at that point
        (the centre of mass, or the body's) plus ``offset``, frame by frame, and ``target``
        is ignored.
    offset : (3,) m, added to the followed point.
    """
    target: tuple = (0.0, 0.0, 0.0)
    distance: float = 4.0
    azimuth: float = -75.0
    elevation: float = 15.0
    fov: float = 40.0
    follow: object = None
    offset: tuple = (0.0, 0.0, 0.0)

    def eye(self, up):
        """Camera position (3,) for a scene whose up axis is ``up``."""
        h1, h2 = horizontal_axes(up)
        az, el = np.radians(self.azimuth), np.radians(self.elevation)
        d = np.cos(el) * (np.cos(az) * h1 + np.sin(az) * h2) + np.sin(el) * _unit(up)
        return np.asarray(self.target, float) + self.distance * d


def auto_camera(scene, body_pos, *, follow=None, azimuth=-75.0, elevation=15.0, fov=40.0,
                aspect=16 / 9, margin=1.0):
    """A camera that keeps the moving bodies of ``body_pos`` ((F, nbody, 3) frames or
    (nbody, 3)) in view over all frames; with ``follow`` ('com' or a body) it frames the
    character's own size around that point instead of the whole path. ``margin`` is the
    fraction of the image the bodies may fill."""
    pos = np.asarray(body_pos, float).reshape(-1, scene.nbody, 3)
    moving = scene.body_kind != 2
    pts = pos[:, moving] if moving.any() else pos
    if pts.size == 0:
        return Camera(target=(0.0, 0.0, 0.0), distance=4.0, azimuth=azimuth,
                      elevation=elevation, fov=fov, follow=follow)
    r_geom = scene.extent()
    if follow is None:
        lo, hi = pts.reshape(-1, 3).min(0), pts.reshape(-1, 3).max(0)
    else:
        rel = pts - _follow_point(scene, pos, follow)[:, None]
        lo, hi = rel.reshape(-1, 3).min(0), rel.reshape(-1, 3).max(0)
    lo, hi = lo - r_geom, hi + r_geom
    centre = 0.5 * (lo + hi)
    first = None if follow is None else _follow_point(scene, pos, follow)[0]
    target = centre if follow is None else first + centre
    # the distance at which every corner of the box projects inside the image
    probe = Camera(target=(0.0, 0.0, 0.0), distance=1.0, azimuth=azimuth,
                   elevation=elevation, fov=fov)
    back = probe.eye(scene.up)                               # unit vector target -> eye
    fwd = -back
    right = np.cross(fwd, scene.up)
    right = right / np.linalg.norm(right) if np.linalg.norm(right) > 1e-9 \
        else horizontal_axes(scene.up)[1]
    upv = np.cross(right, fwd)
    tan_v = margin * np.tan(np.radians(fov) / 2)
    tan_h = tan_v * aspect
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])]) - centre
    depth = corners @ fwd
    need = np.maximum(np.abs(corners @ right) / tan_h, np.abs(corners @ upv) / tan_v) - depth
    distance = max(float(need.max()), 4 * _NEAR)
    return Camera(target=tuple(float(x) for x in target), distance=distance,
                  azimuth=azimuth, elevation=elevation, fov=fov, follow=follow,
                  offset=(0.0, 0.0, 0.0) if follow is None else tuple(float(x) for x in centre))


def _follow_point(scene, pos, follow):
    """(F, 3) the followed point of frames (F, nbody, 3)."""
    if follow == "com":
        return scene.com(pos)
    return pos[:, scene.body_index(follow)]


def _clip_segments(a, b, near):
    """Clip segments (n, 3)-(n, 3) in camera coordinates to z >= near; returns the clipped
    ends and a mask of the segments that are (partly) in front."""
    a, b = a.copy(), b.copy()
    ok = (a[:, 2] >= near) | (b[:, 2] >= near)
    for p, q in ((a, b), (b, a)):
        cut = ok & (p[:, 2] < near)
        t = (near - p[cut, 2]) / (q[cut, 2] - p[cut, 2])
        p[cut] = p[cut] + t[:, None] * (q[cut] - p[cut])
    return a, b, ok


def _clip_near(poly_cam, near):
    """Clip a convex polygon (n, 3) in camera coordinates (z forward) to z >= near
    (Sutherland-Hodgman against one plane)."""
    out = []
    n = len(poly_cam)
    for i in range(n):
        a, b = poly_cam[i], poly_cam[(i + 1) % n]
        ina, inb = a[2] >= near, b[2] >= near
        if ina:
            out.append(a)
        if ina != inb:
            t = (near - a[2]) / (b[2] - a[2])
            out.append(a + t * (b - a))
    return np.array(out) if out else np.zeros((0, 3))


class Renderer:
    """Draws frames of a :class:`~tumble.viewer.scene.Scene` into RGB arrays.

    Parameters
    ----------
    scene : Scene.  width, height : image size in pixels.
    detail : segments around spheres, capsules and cylinders.
    grid : ground grid spacing in m (0: no grid).  shadows : drop shadows on the ground.
    """

    def __init__(self, scene, width=640, height=480, *, detail=12, grid=0.5, shadows=True,
                 background=_BACKGROUND, dpi=100):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import LineCollection, PolyCollection
        from matplotlib.figure import Figure

        for name, v in (("width", width), ("height", height)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 16:
                raise ModelError(f"renderer: {name} must be an integer >= 16 pixels, got {v!r}")
        self.scene = scene
        self.width, self.height = int(width), int(height)
        self.up = scene.up
        self.grid = float(grid)
        self.shadows = bool(shadows)
        self._prepare_meshes(int(detail))

        self.fig = Figure(figsize=(self.width / dpi, self.height / dpi), dpi=dpi,
                          facecolor=background)
        self.canvas = FigureCanvasAgg(self.fig)
        ax = self.fig.add_axes((0, 0, 1, 1))
        ax.set_xlim(0, self.width)
        ax.set_ylim(self.height, 0)             # pixel coordinates, y down
        ax.set_axis_off()
        ax.set_facecolor(background)
        self.ax = ax
        kw = dict(antialiased=True)
        self._ground = PolyCollection([], facecolors=GROUND_COLOR, edgecolors="none",
                                      zorder=1, **kw)
        self._gridlines = LineCollection([], colors=[(0.70, 0.71, 0.72)], linewidths=0.6,
                                         zorder=2, **kw)
        self._shadow = PolyCollection([], facecolors=GROUND_COLOR * _SHADOW, linewidths=0.4,
                                      edgecolors=GROUND_COLOR * _SHADOW, zorder=3, **kw)
        # edges drawn in the face colour hide the antialiasing seams between triangles
        self._faces = PolyCollection([], linewidths=0.5, zorder=4, **kw)
        self._lines = LineCollection([], linewidths=1.6, zorder=5, **kw)
        self._points = ax.scatter([], [], s=14, zorder=6, c=[(0.85, 0.1, 0.1)])
        for c in (self._ground, self._gridlines, self._shadow, self._faces, self._lines):
            ax.add_collection(c)
        self._text = ax.text(8, 8, "", ha="left", va="top", fontsize=max(7, self.height / 40),
                             color=(0.25, 0.25, 0.3), zorder=7, family="monospace")

    # ------------------------------------------------------------------ setup
    def _prepare_meshes(self, detail):
        s = self.scene
        verts, faces, vgeom, fgeom, closed = [], [], [], [], []
        nv = 0
        for g in range(s.ngeom):
            if s.geom_type[g] == PLANE:
                continue
            v, f = s.geom_mesh(g, detail=detail)
            verts.append(v)
            faces.append(f + nv)
            vgeom.append(np.full(len(v), g))
            fgeom.append(np.full(len(f), g))
            closed.append(np.full(len(f), s.geom_type[g] != HEIGHTFIELD))
            nv += len(v)
        if verts:
            self._v = np.concatenate(verts)
            self._f = np.concatenate(faces)
            self._vgeom = np.concatenate(vgeom)
            self._fgeom = np.concatenate(fgeom)
            self._closed = np.concatenate(closed)
        else:
            self._v, self._f = np.zeros((0, 3)), np.zeros((0, 3), np.int64)
            self._vgeom = self._fgeom = np.zeros(0, np.int64)
            self._closed = np.zeros(0, bool)
        self._fcolor = s.geom_color[self._fgeom] if len(self._fgeom) else np.zeros((0, 3))
        self._fmoving = s.geom_body[self._fgeom] >= 0 if len(self._fgeom) else np.zeros(0, bool)
        self._planes = [g for g in range(s.ngeom) if s.geom_type[g] == PLANE]
        h1, h2 = horizontal_axes(self.up)
        self._sun = _unit(0.45 * h1 + 0.3 * h2 + self.up)

    # ----------------------------------------------------------------- camera
    def _view(self, camera, body_pos):
        target = np.asarray(camera.target, float)
        if camera.follow is not None:
            target = _follow_point(self.scene, np.asarray(body_pos, float)[None],
                                   camera.follow)[0] + np.asarray(camera.offset, float)
        cam = replace(camera, target=tuple(target))
        eye = cam.eye(self.up)
        fwd = _unit(target - eye)
        right = np.cross(fwd, self.up)
        if np.linalg.norm(right) < 1e-9:          # looking straight down or up
            right = horizontal_axes(self.up)[1]
        right = _unit(right)
        upv = np.cross(right, fwd)
        focal = 0.5 * self.height / np.tan(np.radians(camera.fov) / 2)
        return eye, np.stack([right, upv, fwd]), focal, target

    def _project(self, pts_cam, focal):
        """Pixel coordinates (..., 2) of camera-space points (..., 3) with z > 0."""
        z = pts_cam[..., 2]
        x = 0.5 * self.width + focal * pts_cam[..., 0] / z
        y = 0.5 * self.height - focal * pts_cam[..., 1] / z
        return np.stack([x, y], -1)

    # ----------------------------------------------------------------- render
    def render(self, body_pos, body_quat, camera, *, contacts=None, com=False, text=None,
               force_scale=None):
        """An ``(height, width, 3)`` uint8 image of the bodies at ``body_pos`` (nbody, 3)
        and ``body_quat`` (nbody, 4) seen by ``camera`` (a :class:`Camera`).

        contacts : optional (points (n, 3), forces (n, 3)) drawn as red dots and lines
            (``force_scale`` m per N; default: the heaviest body's weight is 0.5 m).
        com : mark the centre of mass and its drop line to the ground.
        text : a caption in the top-left corner (e.g. the time).
        """
        pos = np.asarray(body_pos, float)
        quat = np.asarray(body_quat, float)
        eye, rot, focal, target = self._view(camera, pos)
        to_cam = lambda p: (np.asarray(p) - eye) @ rot.T       # noqa: E731

        self._draw_ground(target, eye, rot, focal, to_cam)
        r_g, p_g = self.scene.geom_poses(pos, quat)
        vw = np.einsum("nij,nj->ni", r_g[self._vgeom], self._v) + p_g[self._vgeom]
        tri = vw[self._f]                                         # (nf, 3, 3) world
        self._draw_shadows(tri)
        self._draw_faces(tri, eye, focal, to_cam)
        self._draw_overlays(pos, contacts, com, focal, to_cam, force_scale)
        self._text.set_text(text or "")
        self.canvas.draw()
        buf = np.asarray(self.canvas.buffer_rgba())
        return np.ascontiguousarray(buf[: self.height, : self.width, :3])

    def _draw_ground(self, target, eye, rot, focal, to_cam):
        polys, segs, shade = [], [], []
        dist = np.linalg.norm(eye - target)
        for g in self._planes:
            frame = quat_to_matrix(self.scene.geom_quat[g])
            a, b, normal = frame[:, 0], frame[:, 1], frame[:, 2]
            origin = self.scene.geom_pos[g]
            if (eye - origin) @ normal <= 0:                  # seen from below: skip
                continue
            # a square around the target's foot on the plane, big enough to reach the horizon
            half = max(20.0, 8.0 * dist)
            c = target - ((target - origin) @ normal) * normal
            corners = np.array([c + sa * half * a + sb * half * b
                                for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
            quad = _clip_near(to_cam(corners), _NEAR)
            if len(quad) >= 3:
                polys.append(self._project(quad, focal))
            if self.grid > 0:
                # grid lines fixed to the plane's frame (they slide past a following camera),
                # cut into cell-long pieces that fade out with distance from the target
                step, radius = self.grid, max(3.0, 1.6 * dist)
                n = int(np.ceil(radius / step))
                ca = np.floor(((c - origin) @ a) / step) * step
                cb = np.floor(((c - origin) @ b) / step) * step
                k = np.arange(-n, n + 1) * step
                i, j = np.meshgrid(k, k[:-1], indexing="ij")
                u0 = np.stack([i, j], -1).reshape(-1, 2)          # (line offset, start along)
                p0a = origin + (ca + u0[:, :1]) * a + (cb + u0[:, 1:]) * b
                p1a = p0a + step * b
                p0b = origin + (ca + u0[:, 1:]) * a + (cb + u0[:, :1]) * b
                p1b = p0b + step * a
                p0, p1 = np.concatenate([p0a, p0b]), np.concatenate([p1a, p1b])
                mid = 0.5 * (p0 + p1)
                fade = np.clip(1.0 - np.linalg.norm(mid - c, axis=1) / radius, 0.0, 1.0)
                keep = fade > 0.02
                q0, q1 = to_cam(p0[keep]), to_cam(p1[keep])
                q0, q1, ok = _clip_segments(q0, q1, _NEAR)
                segs.append(np.stack([self._project(q0[ok], focal),
                                      self._project(q1[ok], focal)], 1))
                shade.append(fade[keep][ok])
        self._ground.set_verts(polys)
        if segs:
            segs, shade = np.concatenate(segs), np.concatenate(shade)
            line = np.array([0.55, 0.56, 0.58])
            colour = GROUND_COLOR + (line - GROUND_COLOR) * shade[:, None] ** 0.7
            self._gridlines.set_segments(segs)
            self._gridlines.set_color(colour)
        else:
            self._gridlines.set_segments([])

    @staticmethod
    def _clip_segment(a, b):
        q0, q1, ok = _clip_segments(a[None], b[None], _NEAR)
        return np.stack([q0[0], q1[0]]) if ok[0] else None

    def _draw_shadows(self, tri):
        shadows = []
        if self.shadows and len(tri):
            parts = []
            for g in self._planes:
                normal = quat_to_matrix(self.scene.geom_quat[g])[:, 2]
                if normal @ self.up < 0.99:                      # shadows fall on level ground only
                    continue
                origin = self.scene.geom_pos[g]
                moving = tri[self._fmoving]
                n = np.cross(moving[:, 1] - moving[:, 0], moving[:, 2] - moving[:, 0])
                # faces looking up: for convex pieces their union is the silhouette from above
                keep = (n @ self.up > 0) & np.all((moving - origin) @ normal > -1e-6, axis=1)
                t = moving[keep]
                h = (t - origin) @ normal
                parts.append(t - h[..., None] * self.up[None, None, :] / (self.up @ normal))
            if parts:
                shadows = np.concatenate(parts)
        self._shadow_tri = shadows

    def _draw_faces(self, tri, eye, focal, to_cam):
        if len(tri):
            n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
            centre = tri.mean(axis=1)
            facing = np.einsum("ij,ij->i", n, centre - eye) < 0
            # open surfaces (heightfields) are seen from both sides
            n = np.where((~facing & ~self._closed)[:, None], -n, n)
            keep = facing | ~self._closed
            cam = to_cam(tri)                                     # (nf, 3, 3)
            keep &= np.all(cam[..., 2] > _NEAR, axis=1)
            cam, n, colour = cam[keep], n[keep], self._fcolor[keep]
            light = 0.42 + 0.58 * np.clip(n @ self._sun, 0.0, 1.0)
            rgb = np.clip(colour * light[:, None], 0.0, 1.0)
            order = np.argsort(-cam[..., 2].mean(axis=1), kind="stable")
            xy = self._project(cam[order], focal)
            rgb = rgb[order]
            self._faces.set_verts(xy)
            self._faces.set_facecolor(rgb)
            self._faces.set_edgecolor(rgb)
        else:
            self._faces.set_verts([])
        sh = self._shadow_tri
        if len(sh):
            cam = to_cam(sh)
            ok = np.all(cam[..., 2] > _NEAR, axis=1)
            self._shadow.set_verts(self._project(cam[ok], focal))
        else:
            self._shadow.set_verts([])

    def _draw_overlays(self, pos, contacts, com, focal, to_cam, force_scale):
        segs, colours, pts = [], [], []

        def add_seg(p0, p1, rgb):
            s = self._clip_segment(to_cam(p0), to_cam(p1))
            if s is not None:
                segs.append(self._project(s, focal))
                colours.append(rgb)

        if contacts is not None:
            points, forces = (np.asarray(a, float).reshape(-1, 3) for a in contacts[:2])
            if force_scale is None:
                m = self.scene.body_mass[np.isfinite(self.scene.body_mass)]
                weight = (m.max() if m.size else 1.0) * max(np.linalg.norm(self.scene.gravity), 1.0)
                force_scale = 0.5 / weight
            for p, f in zip(points, forces):
                add_seg(p, p + force_scale * f, (0.85, 0.1, 0.1))
            pts.extend(points)
        if com:
            c = self.scene.com(pos)
            pts.append(c)
            for g in self._planes:
                normal = quat_to_matrix(self.scene.geom_quat[g])[:, 2]
                h = (c - self.scene.geom_pos[g]) @ normal
                if h > 0 and normal @ self.up > 0.99:
                    add_seg(c, c - h * normal, (0.1, 0.1, 0.1))
        self._lines.set_segments(segs)
        self._lines.set_color(colours if colours else [(0, 0, 0)])
        if pts:
            cam = to_cam(np.array(pts))
            ok = cam[:, 2] > _NEAR
            self._points.set_offsets(self._project(cam[ok], focal))
        else:
            self._points.set_offsets(np.zeros((0, 2)))

    def close(self):
        """Release the figure."""
        self.fig.clear()
