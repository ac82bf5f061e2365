"""Ground for characters to walk on: flat, a tilted plane, or a heightfield (Y up).

Each terrain adds its static geoms to a model builder (``add_to``) and answers where its
surface is (``height``, ``normal``), so a controller or a test can measure heights above
the ground under a body without a ray cast. Pass one to ``games105_ragdoll(terrain=...)``
or ``build_ragdoll(terrain=...)``; the characters are Y up, so are the terrains: the
ground spans x and z, heights are along +y (m).

    Flat()                            the plane y = 0
    Slope(angle, direction=(0, 0, 1))  a plane through the origin rising by ``angle`` (rad)
                                      along ``direction`` (x, z); negative angles go down
    Heightfield(heights, spacing, origin=(x0, z0))
                                      samples ``heights[k, j]`` at (x0 + j s, z0 + k s),
                                      two triangles per cell; ``Heightfield.hill`` and
                                      ``Heightfield.bumps`` make the usual test courses
"""
import math

import numpy as np

from ..errors import ModelError
from ..model.validate import positive

__all__ = ["Terrain", "Flat", "Slope", "Heightfield"]

_UP = np.array([0.0, 1.0, 0.0])


def _check_up(up, where):
    if up is not None and np.linalg.norm(np.asarray(up, float) - _UP) > 1e-9:
        raise ModelError(f"{where}: terrains are Y up; the character's up axis is {tuple(up)}")


class Terrain:
    """Base of the terrains: ``add_to(builder)``, ``height(x, z)``, ``normal(x, z)``."""

    friction = 1.0

    def add_to(self, builder, *, friction=None, up=None):
        """Add this terrain's static geoms to ``builder`` (a ModelBuilder); returns their
        indices. friction : Coulomb coefficient (default the terrain's own)."""
        raise NotImplementedError

    def height(self, x, z):
        """Height y (m) of the surface above the point (x, z), world frame."""
        raise NotImplementedError

    def normal(self, x, z):
        """Unit upward normal (3,) of the surface at (x, z), world frame."""
        raise NotImplementedError

    def slope_along(self, x, z, direction):
        """Rise per unit run (tan of the slope angle) at (x, z) along the horizontal
        ``direction`` (x, z) (need not be unit)."""
        n = self.normal(x, z)
        d = np.array([direction[0], 0.0, direction[1]], float)
        d /= np.linalg.norm(d)
        # the surface tangent over d rises by -(n . d) / n_y per unit run
        return float(-(n @ d) / n[1])


class Flat(Terrain):
    """The ground plane y = ``level`` (m)."""

    def __init__(self, level=0.0, friction=1.0):
        self.level = float(level)
        self.friction = positive(friction, "Flat", "friction", allow_zero=True)

    def add_to(self, builder, *, friction=None, up=None):
        _check_up(up, "Flat")
        fr = self.friction if friction is None else friction
        return [builder.add_geom(None, "plane", normal=(0.0, 1.0, 0.0), pos=(0.0, self.level, 0.0),
                                 friction=fr, name="ground")]

    def height(self, x, z):
        return self.level

    def normal(self, x, z):
        return _UP.copy()

    def __repr__(self):
        return f"Flat(level={self.level})"


class Slope(Terrain):
    """A plane through the origin rising by ``angle`` (rad) along the horizontal
    ``direction`` (x, z) (default +z, the course character's forward); a negative angle
    makes it fall along ``direction``."""

    def __init__(self, angle, direction=(0.0, 1.0), friction=1.0):
        a = float(angle)
        if not (math.isfinite(a) and abs(a) < math.radians(60.0)):
            raise ModelError(f"Slope: angle must be a finite number of radians below 60 degrees, "
                             f"got {angle!r}")
        d = np.asarray(direction, float)
        if d.shape != (2,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0.0:
            raise ModelError(f"Slope: direction must be a non-zero (x, z) pair, got {direction!r}")
        self.angle = a
        self.direction = d / np.linalg.norm(d)
        self.friction = positive(friction, "Slope", "friction", allow_zero=True)
        dx, dz = self.direction
        # tilt the up axis back against the direction of ascent
        self._normal = np.array([-math.sin(a) * dx, math.cos(a), -math.sin(a) * dz])

    def add_to(self, builder, *, friction=None, up=None):
        _check_up(up, "Slope")
        fr = self.friction if friction is None else friction
        return [builder.add_geom(None, "plane", normal=self._normal, friction=fr, name="ground")]

    def height(self, x, z):
        return math.tan(self.angle) * (self.direction[0] * x + self.direction[1] * z)

    def normal(self, x, z):
        return self._normal.copy()

    def __repr__(self):
        return f"Slope(angle={self.angle}, direction={tuple(self.direction)})"


class Heightfield(Terrain):
    """A heightfield: ``heights`` (nz, nx) m at world (x0 + j spacing, z0 + k spacing) for
    sample [k, j], two triangles per cell (split along the diagonal that tumble's
    heightfield geom uses), solid ``base`` m below its lowest sample. Outside the grid
    ``height`` holds the nearest edge value (the geom itself ends there)."""

    def __init__(self, heights, spacing, origin=(0.0, 0.0), base=1.0, friction=1.0):
        h = np.array(heights, dtype=float)
        if h.ndim != 2 or h.shape[0] < 2 or h.shape[1] < 2 or not np.all(np.isfinite(h)):
            raise ModelError(f"Heightfield: heights must be a finite (nz, nx) array with at "
                             f"least 2 x 2 samples, got shape {h.shape}")
        self.heights = h
        self.spacing = positive(spacing, "Heightfield", "spacing")
        o = np.asarray(origin, float)
        if o.shape != (2,) or not np.all(np.isfinite(o)):
            raise ModelError(f"Heightfield: origin must be a finite (x0, z0) pair, got {origin!r}")
        self.origin = o
        self.base = positive(base, "Heightfield", "base")
        self.friction = positive(friction, "Heightfield", "friction", allow_zero=True)

    @classmethod
    def hill(cls, angle, up_length, top_length, down_length=None, *, flat_before=2.0,
             flat_after=30.0, width=4.0, spacing=0.25, x0=-2.0, z0=None, friction=1.0):
        """A ridge along +z: flat, up at ``angle`` (rad) for ``up_length`` m (horizontal),
        flat top for ``top_length`` m, down at the same angle for ``down_length`` m (default
        ``up_length``), then flat. The slope starts at z = 0; spans x in [x0, x0 + width]."""
        down_length = up_length if down_length is None else down_length
        z0 = -flat_before if z0 is None else z0
        total = flat_before + up_length + top_length + down_length + flat_after
        nz = int(math.ceil(total / spacing)) + 1
        nx = int(math.ceil(width / spacing)) + 1
        z = z0 + spacing * np.arange(nz)
        rise = math.tan(angle)
        top = rise * up_length
        prof = np.interp(z, [0.0, up_length, up_length + top_length,
                             up_length + top_length + down_length],
                         [0.0, top, top, top - rise * down_length])
        return cls(np.repeat(prof[:, None], nx, axis=1), spacing, (x0, z0), friction=friction)

    @classmethod
    def bumps(cls, amplitude, length, *, width=4.0, spacing=0.25, x0=-2.0, z0=-2.0,
              seed=0, friction=1.0):
        """Random terrain: heights uniform in [0, amplitude] m on a ``spacing`` grid over
        ``length`` m along +z from ``z0`` (seeded, so reproducible); flat (0) before z = 0."""
        nz = int(math.ceil(length / spacing)) + 1
        nx = int(math.ceil(width / spacing)) + 1
        rng = np.random.default_rng(seed)
        h = rng.uniform(0.0, amplitude, size=(nz, nx))
        z = z0 + spacing * np.arange(nz)
        h[z <= 0.0] = 0.0
        return cls(h, spacing, (x0, z0), friction=friction)

    @property
    def extent(self):
        """((x_min, x_max), (z_min, z_max)) covered by the samples, m."""
        nz, nx = self.heights.shape
        x0, z0 = self.origin
        return ((x0, x0 + (nx - 1) * self.spacing), (z0, z0 + (nz - 1) * self.spacing))

    def add_to(self, builder, *, friction=None, up=None):
        _check_up(up, "Heightfield")
        fr = self.friction if friction is None else friction
        nz, nx = self.heights.shape
        hx = 0.5 * (nx - 1) * self.spacing
        hz = 0.5 * (nz - 1) * self.spacing
        centre = (self.origin[0] + hx, 0.0, self.origin[1] + hz)
        # geom-local z is up: a quarter turn about x takes local (x, y, z) to world
        # (x, -z, y), so the geom's rows (local +y) run along world -z
        s = math.sqrt(0.5)
        base = self.base - min(0.0, float(self.heights.min()))
        return [builder.add_geom(None, "heightfield", size=(hx, hz, base), pos=centre,
                                 quat=(-s, 0.0, 0.0, s), heights=self.heights[::-1].copy(),
                                 friction=fr, name="ground")]

    def _cell(self, x, z):
        """(k, j, u, w): cell index and fractions along x (u) and z (w), clamped to the grid."""
        nz, nx = self.heights.shape
        fx = min(max((x - self.origin[0]) / self.spacing, 0.0), nx - 1.0)
        fz = min(max((z - self.origin[1]) / self.spacing, 0.0), nz - 1.0)
        j = min(int(fx), nx - 2)
        k = min(int(fz), nz - 2)
        return k, j, fx - j, fz - k

    def _plane(self, x, z):
        """(h0, dh/dx, dh/dz) of the triangle under (x, z)."""
        k, j, u, w = self._cell(x, z)
        H, s = self.heights, self.spacing
        # In geom rows (reversed k) the diagonal joins world samples (k+1, j) and (k, j+1);
        # the triangle with u + w <= 1 holds (k, j), the other (k+1, j+1).
        if u + w <= 1.0:
            h0 = H[k, j]
            gx = (H[k, j + 1] - H[k, j]) / s
            gz = (H[k + 1, j] - H[k, j]) / s
            return h0 + gx * s * u + gz * s * w, gx, gz
        h1 = H[k + 1, j + 1]
        gx = (H[k + 1, j + 1] - H[k + 1, j]) / s
        gz = (H[k + 1, j + 1] - H[k, j + 1]) / s
        return h1 - gx * s * (1.0 - u) - gz * s * (1.0 - w), gx, gz

    def height(self, x, z):
        return float(self._plane(x, z)[0])

    def normal(self, x, z):
        _, gx, gz = self._plane(x, z)
        n = np.array([-gx, 1.0, -gz])
        return n / np.linalg.norm(n)

    def __repr__(self):
        return (f"Heightfield({self.heights.shape[0]} x {self.heights.shape[1]} samples, "
                f"spacing {self.spacing}, origin {tuple(self.origin)})")
