"""The contact arrays a world carries, one set per world (capacity C)."""
from collections import namedtuple

import numpy as np
from numba import njit

from ..._jit import noalloc

ContactArrays = namedtuple("ContactArrays", [
    "geom",         # (..., C, 2) int32 geoms A, B
    "body",         # (..., C, 2) int32 their bodies (-1: the world)
    "point",        # (..., C, 3) world point midway between the surfaces, m
    "normal",       # (..., C, 3) unit normal from A to B
    "depth",        # (..., C) penetration, m (negative: apart, within the margin)
    "feature",      # (..., C) int64 feature id, stable while the contact persists
    "friction",     # (..., C) combined Coulomb coefficient (the larger of the two)
    "restitution",  # (..., C) combined restitution (the larger of the two)
    "impulse",      # (..., C, 6) impulses of the last step: normal, tangent-1, tangent-2
                    # (N s), then torsional (about the normal), rolling about tangent 1 and
                    # about tangent 2 (N m s; 0 unless the pair has those frictions)
])

# Impulse components kept per contact (see ``impulse`` above).
NIMPULSE = 6


def make_contacts(nworld, capacity):
    """Empty contact arrays with a leading world axis."""
    return ContactArrays(
        np.zeros((nworld, capacity, 2), np.int32), np.zeros((nworld, capacity, 2), np.int32),
        np.zeros((nworld, capacity, 3)), np.zeros((nworld, capacity, 3)),
        np.zeros((nworld, capacity)), np.zeros((nworld, capacity), np.int64),
        np.zeros((nworld, capacity)), np.zeros((nworld, capacity)),
        np.zeros((nworld, capacity, NIMPULSE)))


@njit(cache=True)
def make_contacts_nb(capacity):
    """Scratch contact arrays for one world (compiled code)."""
    return ContactArrays(
        np.zeros((capacity, 2), np.int32), np.zeros((capacity, 2), np.int32),
        np.zeros((capacity, 3)), np.zeros((capacity, 3)), np.zeros(capacity),
        np.zeros(capacity, np.int64), np.zeros(capacity), np.zeros(capacity),
        np.zeros((capacity, NIMPULSE)))


@noalloc
def copy_contact(src, i, dst, j, whole=True):
    """Contact ``i`` of ``src`` into slot ``j`` of ``dst`` (one world's ContactArrays
    each; the same one moves a contact within a world); without ``whole`` only what the
    narrow phase matches a new contact by: geoms, feature id, point and impulses."""
    for k in range(2):
        dst.geom[j, k] = src.geom[i, k]
    for k in range(3):
        dst.point[j, k] = src.point[i, k]
    dst.feature[j] = src.feature[i]
    for k in range(src.impulse.shape[1]):
        dst.impulse[j, k] = src.impulse[i, k]
    if whole:
        for k in range(2):
            dst.body[j, k] = src.body[i, k]
        for k in range(3):
            dst.normal[j, k] = src.normal[i, k]
        dst.depth[j] = src.depth[i]
        dst.friction[j] = src.friction[i]
        dst.restitution[j] = src.restitution[i]


@njit(cache=True, inline="always")
def pair_before(a, i, b, j):
    """Whether contact ``i`` of ``a`` comes before contact ``j`` of ``b`` in pair order
    (by geom A, then geom B), the order the narrow phase writes them in."""
    return a.geom[i, 0] < b.geom[j, 0] or (a.geom[i, 0] == b.geom[j, 0]
                                           and a.geom[i, 1] < b.geom[j, 1])
