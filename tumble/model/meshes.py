"""Build-time geometry for convex meshes and heightfields (plain NumPy/SciPy).

* :func:`convex_hull` reduces a point cloud to its hull vertices (what the collision
  kernels store in ``mesh_vert``), refusing degenerate input with ``ModelError``.
* :func:`convex_mass` gives the exact mass, centre of mass and inertia of a solid
  convex polyhedron of uniform density (tetrahedral decomposition of the hull).
* :func:`heightfield` validates a height grid and its size.
"""
import numpy as np
from scipy.spatial import ConvexHull, QhullError

from ..errors import ModelError

#: Most hull vertices a convex geom may have (the support function is a linear scan).
MAX_HULL_VERTICES = 256
#: Largest coordinate (m) of a point given to the hull: Qhull fails beyond about 1e75 and
#: crashes the interpreter (segmentation fault) beyond about 1e155, so points are checked
#: before it sees them.
MAX_COORDINATE = 1e12
#: Most points given to the hull (Qhull crashes past 2**24: scipy issue 4985).
MAX_HULL_POINTS = 2 ** 23
# A hull thinner than this fraction of its extent counts as flat.
_FLAT_REL = 1e-9


def _points(points, where, name="points"):
    try:
        p = np.array(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{where}: {name} must be numbers, an (n, 3) array ({exc})") from None
    if p.ndim != 2 or p.shape[1] != 3:
        raise ModelError(f"{where}: {name} must be an (n, 3) array, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ModelError(f"{where}: {name} must be finite (found NaN or inf)")
    return p


def _hull(p, where):
    if p.shape[0] < 4:
        raise ModelError(f"{where}: a convex hull needs at least 4 points, got {p.shape[0]}")
    if p.shape[0] > MAX_HULL_POINTS:
        raise ModelError(f"{where}: {p.shape[0]} points, more than the {MAX_HULL_POINTS} a "
                         f"convex hull is computed from (tumble.model.meshes.MAX_HULL_POINTS)")
    reach = float(np.max(np.abs(p)))
    if reach > MAX_COORDINATE:
        raise ModelError(f"{where}: a point lies {reach:.3g} m from the origin, beyond the "
                         f"{MAX_COORDINATE:g} m a convex hull is computed within "
                         f"(tumble.model.meshes.MAX_COORDINATE)")
    ext = float(np.max(np.ptp(p, axis=0)))
    if not ext > 0.0:
        raise ModelError(f"{where}: the points all coincide; a convex hull needs volume")
    try:
        hull = ConvexHull(p)
    except QhullError:
        raise ModelError(f"{where}: the points are coplanar or collinear (degenerate); "
                         "a convex hull needs volume") from None
    # thickness: smallest extent over the facet normals
    thick = np.inf
    for eq in hull.equations:
        d = p @ eq[:3]
        thick = min(thick, float(d.max() - d.min()))
    if thick <= _FLAT_REL * ext:
        raise ModelError(f"{where}: the points are (nearly) coplanar (thickness {thick:.3g} "
                         f"for an extent of {ext:.3g}); a convex hull needs volume")
    return hull


def convex_hull(points, where="mesh"):
    """Hull vertices ``(k, 3)`` of ``points`` (n >= 4, finite, not coplanar), in the
    order they appear in ``points``. Raises ``ModelError`` (message starting with
    ``where``) for bad input or more than ``MAX_HULL_VERTICES`` hull vertices."""
    p = _points(points, where)
    hull = _hull(p, where)
    idx = np.sort(hull.vertices)
    if idx.size > MAX_HULL_VERTICES:
        raise ModelError(f"{where}: the convex hull has {idx.size} vertices, more than "
                         f"{MAX_HULL_VERTICES}; simplify the mesh")
    return np.ascontiguousarray(p[idx])


def convex_mass(vertices, density, where="mesh"):
    """``(mass, com (3,), inertia (3, 3) about the com)`` of the solid convex hull of
    ``vertices`` with uniform ``density``.

    Exact for polyhedra: the hull is split into tetrahedra from an interior point to
    each (outward-oriented) facet triangle; each contributes its volume, first moment
    and second moment ``V / 20 (sum_i v_i v_i^T + s s^T)`` (``s`` the vertex sum).
    """
    p = _points(vertices, where, "vertices")
    try:
        rho = float(density)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: density must be a number, got {density!r}") from None
    if not (np.isfinite(rho) and rho > 0.0):
        raise ModelError(f"{where}: density must be finite and > 0, got {density!r}")
    hull = _hull(p, where)
    c0 = p[hull.vertices].mean(axis=0)
    q = p - c0
    vol = 0.0
    first = np.zeros(3)
    second = np.zeros((3, 3))
    # (huge hulls overflow here: the result is checked below instead)
    with np.errstate(over="ignore", invalid="ignore"):
        for simplex, eq in zip(hull.simplices, hull.equations):
            a, b, c = q[simplex[0]], q[simplex[1]], q[simplex[2]]
            n = np.cross(b - a, c - a)
            if n @ eq[:3] < 0.0:          # orient the facet outwards
                b, c = c, b
            v = np.dot(a, np.cross(b, c)) / 6.0   # tetrahedron (0, a, b, c)
            s = a + b + c
            vol += v
            first += v * s / 4.0
            second += v / 20.0 * (np.outer(a, a) + np.outer(b, b) + np.outer(c, c)
                                  + np.outer(s, s))
        mass = rho * vol
        com_rel = first / vol
        cov = rho * second - mass * np.outer(com_rel, com_rel)   # about the com
        inertia = np.trace(cov) * np.eye(3) - cov
        inertia = 0.5 * (inertia + inertia.T)
    if not (np.isfinite(mass) and mass > 0.0 and np.all(np.isfinite(com_rel))
            and np.all(np.isfinite(inertia))):
        raise ModelError(f"{where}: the mass properties of the hull overflow (extent "
                         f"{float(np.max(np.ptp(p, axis=0))):.3g}, density {rho:.3g})")
    return float(mass), c0 + com_rel, inertia


def heightfield(heights, size, where="heightfield"):
    """Validate a heightfield: ``heights`` a finite 2-D array (nrow, ncol) with at
    least 2 x 2 samples (row ``i`` along y, column ``j`` along x), ``size`` =
    ``(half_x, half_y, base)`` with positive half extents and ``base >= 0``.
    Returns ``(heights (nrow, ncol) float64 C-contiguous copy, size (3,) float64)``."""
    try:
        h = np.array(heights, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{where}: heights must be a 2-D array of numbers ({exc})") from None
    if h.ndim != 2:
        raise ModelError(f"{where}: heights must be a 2-D array (nrow, ncol), got {h.ndim} "
                         "dimension(s)")
    if h.shape[0] < 2 or h.shape[1] < 2:
        raise ModelError(f"{where}: heights needs at least 2 x 2 samples, got "
                         f"{h.shape[0]} x {h.shape[1]}")
    if not np.all(np.isfinite(h)):
        raise ModelError(f"{where}: heights must be finite (found NaN or inf)")
    try:
        s = np.array(size, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: size must be (half_x, half_y, base), got {size!r}") from None
    if s.shape != (3,):
        raise ModelError(f"{where}: size must be (half_x, half_y, base), got {size!r}")
    if not np.all(np.isfinite(s)):
        raise ModelError(f"{where}: size must be finite, got {size!r}")
    if not (s[0] > 0.0 and s[1] > 0.0):
        raise ModelError(f"{where}: size half extents must be > 0, got {s[0]:g}, {s[1]:g}")
    if s[2] < 0.0:
        raise ModelError(f"{where}: size base (thickness below z = 0) must be >= 0, "
                         f"got {s[2]:g}")
    return np.ascontiguousarray(h), s
