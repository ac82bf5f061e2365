"""Geometric queries on a world's current state: ray casts and distances between geoms."""
from numba import njit

from .collision.dispatch import geom_distance_any, raycast_any
from .collide import geom_world_poses


@njit(cache=True)
def raycast_scene(m, pos, quat, gpos, gquat, origin, direction, max_dist, skip_body):
    """Closest hit of a ray (unit ``direction``) with any geom not on ``skip_body``.

    Returns (distance m, geom, normal) with geom -1 when nothing is hit within ``max_dist``.
    """
    geom_world_poses(m, pos, quat, gpos, gquat)
    best, best_g, best_n = max_dist, -1, (0.0, 0.0, 0.0)
    for g in range(m.geom_type.shape[0]):
        if skip_body >= -1 and m.geom_body[g] == skip_body:
            continue
        t, n = raycast_any(m, g, gpos[g], gquat[g], origin, direction, best)
        if t >= 0.0 and (best_g < 0 or t < best):
            best, best_g, best_n = t, g, n
    return best, best_g, best_n


@njit(cache=True)
def distance_between(m, pos, quat, gpos, gquat, ga, gb):
    """Signed distance (m) and closest points of geoms ``ga`` and ``gb`` (see geom_distance)."""
    geom_world_poses(m, pos, quat, gpos, gquat)
    return geom_distance_any(m, ga, gpos[ga], gquat[ga], gb, gpos[gb], gquat[gb])
