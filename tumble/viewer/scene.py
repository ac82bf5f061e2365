"""What the viewer and the video exporter draw: a model's geoms as coloured triangle meshes.

A :class:`Scene` holds everything needed to redraw a simulation without the model that
made it: each geom's shape, size, pose in its body's COM principal frame and colour, the
convex hulls and heightfields, the joints' anchors and frames (for the joint-axis overlay),
the body masses (for the centre of mass) and gravity (to know which way is up). It is
built from a :class:`tumble.Model` and stored inside every recording (``.npz``).

Meshes come out in the geom's own frame: vertices ``(n, 3)`` in m and triangles ``(m, 3)``
of vertex indices, wound counter-clockwise seen from outside. Only NumPy is needed.
"""
from dataclasses import dataclass, fields

import numpy as np

from ..errors import ModelError
# quat_to_matrix and the shape codes are also imported from here by render and app.
from ..math.quat_np import qmatrix as quat_to_matrix
from ..math.quat_np import qmul
from ..model.types import (BOX, CAPSULE, CONVEX, CYLINDER, DYNAMIC, GEOM_TYPES,  # noqa: F401
                           HEIGHTFIELD, PLANE, SPHERE, STATIC)

GEOM_NAMES = {code: name for name, code in GEOM_TYPES.items()}

# Body colours, RGB in 0..1, cycled by body index (muted, distinguishable, colour-blind safe
# enough for neighbouring limbs).
PALETTE = np.array([
    (0.90, 0.45, 0.20), (0.25, 0.55, 0.85), (0.40, 0.72, 0.35), (0.86, 0.70, 0.20),
    (0.65, 0.42, 0.78), (0.20, 0.70, 0.70), (0.85, 0.35, 0.50), (0.55, 0.55, 0.30),
    (0.35, 0.45, 0.70), (0.78, 0.55, 0.40),
])
STATIC_COLOR = np.array([0.62, 0.62, 0.66])     # static and world geoms
GROUND_COLOR = np.array([0.93, 0.93, 0.91])

_INT_FIELDS = ("body_kind", "geom_type", "geom_body", "geom_dataid", "mesh_vert_adr",
               "mesh_vert_num", "hfield_adr", "hfield_nrow", "hfield_ncol", "joint_parent",
               "joint_child")
_STR_FIELDS = ("body_names", "geom_names", "joint_names", "joint_types")


def _rgb(value, where):
    c = np.asarray(value, dtype=float).reshape(-1)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise ModelError(f"{where}: a colour is (r, g, b), got {value!r}")
    if c.max() > 1.0:          # 0..255 given
        c = c / 255.0
    if c.min() < 0.0 or c.max() > 1.0:
        raise ModelError(f"{where}: colour components must be in 0..1 (or 0..255), got {value!r}")
    return c


@dataclass(frozen=True, eq=False)
class Scene:
    """Drawable description of a model (read-only arrays; nbody bodies, ngeom geoms).

    body_names, body_kind (nbody,) 0 dynamic 1 kinematic 2 static, body_mass (nbody,) kg
    (inf unless dynamic), body_color (nbody, 3) RGB 0..1; geom_names, geom_type (codes of
    ``tumble.model.model.GEOM_TYPES``), geom_body (-1 = world), geom_size (ngeom, 3),
    geom_pos (ngeom, 3) m and geom_quat (ngeom, 4) x, y, z, w in the body's COM principal
    frame (world frame for world geoms), geom_color (ngeom, 3); convex hull vertices
    (mesh_*) and heightfields (hfield_*) as in ``Model.arrays``; joint_names, joint_types
    (names), joint_parent, joint_child (-1 = world), joint_anchor_a/b (njoint, 3) and
    joint_frame_a/b (njoint, 4) in the parent's / child's COM frame; gravity (3,) m/s^2.
    """
    body_names: np.ndarray
    body_kind: np.ndarray
    body_mass: np.ndarray
    body_color: np.ndarray
    geom_names: np.ndarray
    geom_type: np.ndarray
    geom_body: np.ndarray
    geom_size: np.ndarray
    geom_pos: np.ndarray
    geom_quat: np.ndarray
    geom_color: np.ndarray
    geom_dataid: np.ndarray
    mesh_vert_adr: np.ndarray
    mesh_vert_num: np.ndarray
    mesh_vert: np.ndarray
    hfield_adr: np.ndarray
    hfield_nrow: np.ndarray
    hfield_ncol: np.ndarray
    hfield_data: np.ndarray
    joint_names: np.ndarray
    joint_types: np.ndarray
    joint_parent: np.ndarray
    joint_child: np.ndarray
    joint_anchor_a: np.ndarray
    joint_anchor_b: np.ndarray
    joint_frame_a: np.ndarray
    joint_frame_b: np.ndarray
    gravity: np.ndarray

    def __post_init__(self):
        for f in fields(self):
            a = getattr(self, f.name)
            if f.name in _STR_FIELDS:
                a = np.asarray([str(s) for s in a], dtype=str) if len(a) else np.zeros(0, "<U1")
            elif f.name in _INT_FIELDS:
                a = np.asarray(a, dtype=np.int32)
            else:
                a = np.asarray(a, dtype=float)
            a = np.ascontiguousarray(a)
            a.setflags(write=False)
            object.__setattr__(self, f.name, a)

    # ------------------------------------------------------------ construction
    @classmethod
    def from_model(cls, model, body_colors=None):
        """The scene of a :class:`tumble.Model`.

        body_colors : optional {body name or index: (r, g, b)} in 0..1 (or 0..255); other
            bodies take the palette colour of their index, static bodies grey.
        """
        nb = model.nbody
        colors = PALETTE[np.arange(nb) % len(PALETTE)].copy()
        colors[np.asarray(model.body_kind) == STATIC] = STATIC_COLOR
        for body, rgb in (body_colors or {}).items():
            b = model.body_index(body)
            colors[b] = _rgb(rgb, f"body '{model.body_names[b]}' colour")
        gb = np.asarray(model.geom_body)
        # world geoms (-1) take the static colour, stored past the last body
        gcol = np.vstack([colors, STATIC_COLOR])[np.where(gb >= 0, gb, nb)]
        gcol[np.asarray(model.geom_type) == PLANE] = GROUND_COLOR
        m = model.arrays
        return cls(body_names=model.body_names, body_kind=model.body_kind,
                   body_mass=model.body_mass, body_color=colors,
                   geom_names=model.geom_names, geom_type=model.geom_type, geom_body=gb,
                   geom_size=model.geom_size, geom_pos=model.geom_pos,
                   geom_quat=model.geom_quat, geom_color=gcol, geom_dataid=model.geom_dataid,
                   mesh_vert_adr=m.mesh_vert_adr, mesh_vert_num=m.mesh_vert_num,
                   mesh_vert=np.asarray(m.mesh_vert).reshape(-1, 3),
                   hfield_adr=m.hfield_adr, hfield_nrow=m.hfield_nrow,
                   hfield_ncol=m.hfield_ncol, hfield_data=m.hfield_data,
                   joint_names=model.joint_names, joint_types=model.joint_type_names,
                   joint_parent=model.joint_parent, joint_child=model.joint_child,
                   joint_anchor_a=np.asarray(model.joint_anchor_a).reshape(-1, 3),
                   joint_anchor_b=np.asarray(model.joint_anchor_b).reshape(-1, 3),
                   joint_frame_a=np.asarray(model.joint_frame_a).reshape(-1, 4),
                   joint_frame_b=np.asarray(model.joint_frame_b).reshape(-1, 4),
                   gravity=model.gravity)

    def to_arrays(self, prefix="scene_"):
        """A dict ``{prefix + field: array}`` for ``numpy.savez`` (no pickling needed)."""
        return {prefix + f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_arrays(cls, arrays, prefix="scene_", where="recording"):
        """Inverse of :meth:`to_arrays`; ModelError names a missing field."""
        kwargs = {}
        for f in fields(cls):
            key = prefix + f.name
            if key not in arrays:
                raise ModelError(f"{where}: the scene field '{key}' is missing")
            kwargs[f.name] = np.asarray(arrays[key])
        return cls(**kwargs)

    # --------------------------------------------------------------- queries
    @property
    def nbody(self):
        return len(self.body_names)

    @property
    def ngeom(self):
        return len(self.geom_names)

    @property
    def njoint(self):
        return len(self.joint_names)

    @property
    def up(self):
        """Unit vector opposite to gravity (+z when there is no gravity)."""
        g = np.linalg.norm(self.gravity)
        return -self.gravity / g if g > 0 else np.array([0.0, 0.0, 1.0])

    def body_index(self, body):
        """Index of a body given by name or index (ModelError if unknown)."""
        if isinstance(body, (int, np.integer)) and not isinstance(body, bool):
            if 0 <= body < self.nbody:
                return int(body)
            raise ModelError(f"body index {body} out of range [0, {self.nbody})")
        hits = np.flatnonzero(self.body_names == body)
        if len(hits) == 0:
            raise ModelError(f"unknown body {body!r}; bodies: {list(self.body_names)}")
        return int(hits[0])

    def com(self, body_pos):
        """Centre of mass (3,) of the dynamic bodies for positions ``(nbody, 3)`` (or
        ``(F, nbody, 3)`` -> ``(F, 3)``); the mean position when no body is dynamic."""
        pos = np.asarray(body_pos, float)
        w = np.where(self.body_kind == DYNAMIC, self.body_mass, 0.0)
        if w.sum() <= 0.0:
            w = np.ones(self.nbody)
        if self.nbody == 0:
            return np.zeros(pos.shape[:-2] + (3,))
        return np.einsum("b,...bi->...i", w / w.sum(), pos)

    def geom_poses(self, body_pos, body_quat):
        """World poses of every geom: rotation matrices (ngeom, 3, 3) and positions
        (ngeom, 3), m, for body COM positions (nbody, 3) and orientations (nbody, 4)."""
        r_g = quat_to_matrix(self.geom_quat)
        p_g = self.geom_pos.copy()
        moving = self.geom_body >= 0
        if moving.any():
            b = self.geom_body[moving]
            r_b = quat_to_matrix(np.asarray(body_quat, float)[b])
            r_g[moving] = r_b @ r_g[moving]
            p_g[moving] = np.asarray(body_pos, float)[b] + np.einsum(
                "nij,nj->ni", r_b, self.geom_pos[moving])
        return r_g, p_g

    def joint_axes(self, body_pos, body_quat):
        """Joint anchors (njoint, 3) (as carried by the child) and a list, per joint, of
        world-frame unit axes (k, 3): a hinge's or slider's axis, a universal's two axes,
        a ball's child frame (3 axes), none for fixed and free joints."""
        pos, quat = np.asarray(body_pos, float), np.asarray(body_quat, float)
        ident = np.array([0.0, 0.0, 0.0, 1.0])
        anchors, axes = np.zeros((self.njoint, 3)), []
        for j in range(self.njoint):
            a, c = self.joint_parent[j], self.joint_child[j]
            qa = quat[a] if a >= 0 else ident
            qc = quat[c]
            anchors[j] = pos[c] + quat_to_matrix(qc) @ self.joint_anchor_b[j]
            fa = quat_to_matrix(qmul(qa, self.joint_frame_a[j]))
            fb = quat_to_matrix(qmul(qc, self.joint_frame_b[j]))
            kind = self.joint_types[j]
            if kind in ("hinge", "slider"):
                axes.append(fa[:, :1].T)
            elif kind == "universal":
                axes.append(np.stack([fa[:, 0], fb[:, 1]]))
            elif kind == "ball":
                axes.append(fb.T.copy())
            else:
                axes.append(np.zeros((0, 3)))
        return anchors, axes

    def extent(self):
        """A typical size (m) of the moving geoms: the largest bounding radius, for framing."""
        r = 0.0
        for g in range(self.ngeom):
            if self.geom_body[g] < 0 or self.geom_type[g] in (PLANE, HEIGHTFIELD):
                continue
            v, _ = self.geom_mesh(g, detail=6)
            r = max(r, float(np.linalg.norm(v + self.geom_pos[g], axis=1).max()))
        return r if r > 0 else 0.5

    # ----------------------------------------------------------------- meshes
    def geom_mesh(self, g, detail=16, plane_size=10.0):
        """Triangle mesh of geom ``g`` in its own frame: vertices (n, 3) m, faces (m, 3).

        detail : segments around a circle (spheres, capsules, cylinders).
        plane_size : half side (m) of the square drawn for a plane.
        """
        t, s = int(self.geom_type[g]), self.geom_size[g]
        if t == BOX:
            return box_mesh(s)
        if t == SPHERE:
            return sphere_mesh(s[0], detail)
        if t == CAPSULE:
            return capsule_mesh(s[0], s[1], detail)
        if t == CYLINDER:
            return cylinder_mesh(s[0], s[1], detail)
        if t == CONVEX:
            k = self.geom_dataid[g]
            a, n = self.mesh_vert_adr[k], self.mesh_vert_num[k]
            return hull_mesh(self.mesh_vert[a:a + n])
        if t == HEIGHTFIELD:
            k = self.geom_dataid[g]
            a, nr, nc = self.hfield_adr[k], self.hfield_nrow[k], self.hfield_ncol[k]
            return heightfield_mesh(self.hfield_data[a:a + nr * nc].reshape(nr, nc), s)
        if t == PLANE:
            return plane_mesh(plane_size)
        raise ModelError(f"geom '{self.geom_names[g]}': no mesh for geom type code {t}")


# --------------------------------------------------------------------- meshes
def box_mesh(half):
    """Box of half extents (3,): 24 vertices (4 per face, so every face keeps its own
    normal under smooth shading), 12 triangles."""
    h = np.asarray(half, float)
    verts, faces = [], []
    for axis in range(3):
        u, w = (axis + 1) % 3, (axis + 2) % 3
        for sign in (1.0, -1.0):
            base = len(verts)
            # corners in the face, counter-clockwise seen from outside (u x w = axis)
            for cu, cw in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = np.zeros(3)
                p[axis], p[u], p[w] = sign * h[axis], cu * sign * h[u], cw * h[w]
                verts.append(p)
            faces += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    return np.array(verts), np.array(faces, np.int64)


def _merge(*meshes):
    """One mesh from several (vertex indices shifted)."""
    verts, faces, n = [], [], 0
    for v, f in meshes:
        verts.append(v)
        faces.append(f + n)
        n += len(v)
    return np.concatenate(verts), np.concatenate(faces)


def _rings(profile, detail):
    """Surface of revolution about z: ``profile`` is a list of (radius, z) going down from
    the top (radius 0 there: a pole); returns vertices and outward triangles."""
    n = max(int(detail), 3)
    ang = 2 * np.pi * np.arange(n) / n
    verts, rows = [], []
    for r, z in profile:
        if abs(r) < 1e-12:          # a pole (sin(pi) is not exactly 0)
            rows.append([len(verts)])
            verts.append((0.0, 0.0, z))
        else:
            rows.append(list(range(len(verts), len(verts) + n)))
            verts.extend(zip(r * np.cos(ang), r * np.sin(ang), np.full(n, z)))
    faces = []
    for top, bot in zip(rows[:-1], rows[1:]):
        for k in range(n):
            k1 = (k + 1) % n
            if len(top) == 1:
                faces.append((top[0], bot[k], bot[k1]))
            elif len(bot) == 1:
                faces.append((top[k], bot[0], top[k1]))
            else:
                faces.append((top[k], bot[k], bot[k1]))
                faces.append((top[k], bot[k1], top[k1]))
    return np.array(verts, float), np.array(faces, np.int64)


def sphere_mesh(radius, detail=16):
    """UV sphere of ``radius`` with ``detail`` segments around and detail/2 rings."""
    nlat = max(detail // 2, 2)
    th = np.pi * np.arange(nlat + 1) / nlat
    return _rings([(radius * np.sin(t), radius * np.cos(t)) for t in th], detail)


def capsule_mesh(radius, half_length, detail=16):
    """Capsule along z: a cylinder of half length ``half_length`` with hemispherical caps."""
    nq = max(detail // 4, 1)
    th = 0.5 * np.pi * np.arange(nq + 1) / nq
    top = [(radius * np.sin(t), half_length + radius * np.cos(t)) for t in th]
    bottom = [(r, -z) for r, z in reversed(top)]
    return _rings(top + bottom, detail)


def cylinder_mesh(radius, half_length, detail=16):
    """Closed cylinder along z (caps and side share no vertices: sharp rims)."""
    h = half_length
    return _merge(_rings([(0.0, h), (radius, h)], detail),
                  _rings([(radius, h), (radius, -h)], detail),
                  _rings([(radius, -h), (0.0, -h)], detail))


def hull_mesh(points):
    """Triangles of the convex hull of ``points`` (n, 3), wound outward."""
    from scipy.spatial import ConvexHull
    p = np.asarray(points, float)
    hull = ConvexHull(p)
    f = hull.simplices.copy()
    # flip triangles whose normal points towards the interior
    c = p.mean(axis=0)
    n = np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]])
    flip = np.einsum("ij,ij->i", n, p[f[:, 0]] - c) < 0
    f[flip] = f[flip][:, ::-1]
    return p.copy(), f


def heightfield_mesh(heights, size):
    """Top surface of a heightfield (nrow, ncol) over ``size = (half_x, half_y, base)``:
    column j at x = -half_x + 2 half_x j / (ncol - 1), row i at y likewise; heights are z."""
    h = np.asarray(heights, float)
    nr, nc = h.shape
    x = np.linspace(-size[0], size[0], nc)
    y = np.linspace(-size[1], size[1], nr)
    xx, yy = np.meshgrid(x, y)
    v = np.stack([xx.ravel(), yy.ravel(), h.ravel()], -1)
    i, j = np.meshgrid(np.arange(nr - 1), np.arange(nc - 1), indexing="ij")
    a = (i * nc + j).ravel()
    b, c, d = a + 1, a + nc + 1, a + nc
    f = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)])
    return v, f


def plane_mesh(half):
    """A square of half side ``half`` in the plane's xy (its normal is +z)."""
    v = np.array([[-half, -half, 0.0], [half, -half, 0.0], [half, half, 0.0], [-half, half, 0.0]])
    return v, np.array([[0, 1, 2], [0, 2, 3]])
