"""How the two geoms of a contact combine their contact parameters.

    friction, restitution           the larger of the two (in ``collide.py``)
    torsional, rolling friction     the larger of the two (lengths, m)
    stiffness k                     springs in series, 1/k = 1/k_a + 1/k_b, of the geoms
                                    that have one; a geom without one is rigid, so a
                                    soft geom on default ground keeps its own k
    damping c                       the larger of the values given

A pair where neither geom sets a stiffness (or damping) uses the world's: penalty
``k``/``c``, or the contact ERP/CFM of the constraint models.
"""
from numba import njit

# Contact rows per contact: normal, 2 friction; with spin friction also torsional, 2 rolling.
ROWS_SLIDING, ROWS_SPIN = 3, 6


@njit(cache=True, inline="always")
def pair_softness(m, ga, gb):
    """(k, c) of geoms ``ga``, ``gb``: k (N/m) > 0 when either has a stiffness, else 0;
    c (N s/m) >= 0 when either has a damping, else -1."""
    ka, kb = m.geom_stiffness[ga], m.geom_stiffness[gb]
    if ka > 0.0 and kb > 0.0:
        k = ka * kb / (ka + kb)
    else:
        k = max(ka, kb)
    return k, max(m.geom_damping[ga], m.geom_damping[gb])


@njit(cache=True, inline="always")
def pair_spin_friction(m, ga, gb):
    """(torsional, rolling) friction of the pair, m: torque bound per unit normal force."""
    return (max(m.geom_torsional[ga], m.geom_torsional[gb]),
            max(m.geom_rolling[ga], m.geom_rolling[gb]))


@njit(cache=True)
def rows_per_contact(m):
    """ROWS_SPIN when any geom has torsional or rolling friction, else ROWS_SLIDING: a
    model without spin friction pays nothing for it."""
    for g in range(m.geom_type.shape[0]):
        if m.geom_rolling[g] > 0.0 or m.geom_torsional[g] > 0.0:
            return ROWS_SPIN
    return ROWS_SLIDING
