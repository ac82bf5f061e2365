"""Mass properties: primitives from a density, composites, principal axes.

Everything here runs once, when a model is built, so it is plain NumPy. Inertia tensors
are about the centre of mass in kg m^2; sizes follow the geom conventions (half extents
for boxes, radius and half the cylinder length for capsules and cylinders, axis local z).
"""
import math

import numpy as np

from ..errors import ModelError

# Relative tolerances for refusing an inertia tensor.
SYMMETRY_TOL = 1e-9
TRIANGLE_TOL = 1e-9


def sphere_mass(radius, density):
    """Solid sphere: ``(mass, principal moments (3,))``."""
    m = density * 4.0 / 3.0 * math.pi * radius ** 3
    i = 0.4 * m * radius ** 2
    return m, np.array([i, i, i])


def box_mass(half_extents, density):
    """Solid box from half extents (hx, hy, hz): ``(mass, principal moments (3,))``."""
    hx, hy, hz = (float(v) for v in half_extents)
    m = density * 8.0 * hx * hy * hz
    return m, m / 3.0 * np.array([hy * hy + hz * hz, hx * hx + hz * hz, hx * hx + hy * hy])


def cylinder_mass(radius, half_length, density):
    """Solid cylinder, axis local z, length ``2 half_length``."""
    m = density * math.pi * radius ** 2 * 2.0 * half_length
    axial = 0.5 * m * radius ** 2
    transverse = m * (3.0 * radius ** 2 + 4.0 * half_length ** 2) / 12.0
    return m, np.array([transverse, transverse, axial])


def capsule_mass(radius, half_length, density):
    """Solid capsule: a cylinder of length ``2 half_length`` capped by two hemispheres.

    Each hemisphere's transverse moment about the capsule centre is
    ``m_h (2/5 r^2 + h^2 + 3 h r / 4)`` (its COM sits 3r/8 beyond the cylinder end).
    """
    r, h = radius, half_length
    m_cyl, i_cyl = cylinder_mass(r, h, density)
    m_caps = density * 4.0 / 3.0 * math.pi * r ** 3      # both hemispheres together
    axial = i_cyl[2] + 0.4 * m_caps * r * r
    transverse = i_cyl[0] + m_caps * (0.4 * r * r + h * h + 0.75 * h * r)
    return m_cyl + m_caps, np.array([transverse, transverse, axial])


def shape_mass(kind, size, density):
    """Mass and principal moments (in the geom frame) of a named primitive.

    ``kind`` is 'sphere', 'box', 'capsule' or 'cylinder'; ``size`` is the geom's
    (3,) size vector. Planes have no mass.
    """
    if kind == "sphere":
        return sphere_mass(size[0], density)
    if kind == "box":
        return box_mass(size, density)
    if kind == "capsule":
        return capsule_mass(size[0], size[1], density)
    if kind == "cylinder":
        return cylinder_mass(size[0], size[1], density)
    raise ModelError(f"shape '{kind}' has no volume, so no mass")


def combine(masses, coms, inertias):
    """Mass, COM and inertia of rigidly joined parts (parallel-axis theorem).

    masses (k,), coms (k, 3) in a common frame, inertias (k, 3, 3) about each part's
    own COM in that frame. Returns ``(mass, com (3,), inertia (3, 3) about com)``.
    """
    masses = np.asarray(masses, float)
    coms = np.asarray(coms, float).reshape(-1, 3)
    inertias = np.asarray(inertias, float).reshape(-1, 3, 3)
    total = masses.sum()
    com = (masses[:, None] * coms).sum(0) / total
    inertia = np.zeros((3, 3))
    for m, c, i in zip(masses, coms, inertias):
        d = c - com
        inertia += i + m * (d @ d * np.eye(3) - np.outer(d, d))
    return total, com, inertia


def check_inertia(inertia, where):
    """Refuse a tensor (3,) diagonal or (3, 3) that is not a physical inertia.

    Returns it as a symmetric (3, 3) array. ``where`` names the owner in messages,
    e.g. "body 'thigh'".
    """
    a = np.asarray(inertia, dtype=float)
    if a.shape == (3,):
        a = np.diag(a)
    elif a.shape != (3, 3):
        raise ModelError(f"{where}: inertia must be (3,) principal moments or a (3, 3) tensor, "
                         f"got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ModelError(f"{where}: inertia has non-finite entries: {a.tolist()}")
    scale = np.abs(a).max()
    if scale == 0.0:
        raise ModelError(f"{where}: inertia is zero")
    if np.abs(a - a.T).max() > SYMMETRY_TOL * scale:
        raise ModelError(f"{where}: inertia is not symmetric: {a.tolist()}")
    a = 0.5 * (a + a.T)
    moments = np.linalg.eigvalsh(a)
    if moments[0] <= 0.0:
        raise ModelError(f"{where}: inertia is not positive definite "
                         f"(principal moments {moments.tolist()})")
    # A real mass distribution has each principal moment <= the sum of the other two.
    if moments[2] > (moments[0] + moments[1]) * (1.0 + TRIANGLE_TOL):
        raise ModelError(f"{where}: inertia breaks the triangle inequality: principal moments "
                         f"{moments.tolist()}, but the largest may not exceed the sum of the others")
    return a


def principal_axes(inertia):
    """Principal moments (3,) and rotation ``R`` (3, 3), det +1, with ``I = R diag R^T``.

    A tensor that is already diagonal keeps its axes (R = identity), so a body given
    diagonal moments is never silently re-oriented.
    """
    a = np.asarray(inertia, float)
    off = np.abs(a - np.diag(np.diag(a))).max()
    if off <= 1e-12 * np.abs(a).max():
        return np.diag(a).copy(), np.eye(3)
    moments, axes = np.linalg.eigh(a)
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes
