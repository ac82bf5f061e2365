"""The contact arrays a world carries, one set per world (capacity C)."""
from collections import namedtuple

import numpy as np
from numba import njit

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
