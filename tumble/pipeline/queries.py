"""Queries on a world's current state: ray casts, distances between geoms, contact wrenches."""
from numba import njit

from .._jit import noalloc
from .collision.dispatch import geom_distance_any, raycast_any
from .collide import geom_world_poses
from .contacts.rows import tangents


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


@noalloc
def contact_wrenches(normal, impulse, dt, force, torque):
    """The force (N) and spin-friction torque (N m) each of n contacts put on its second
    body over a step of ``dt``, world frame, from its stored ``impulse`` (n, 6) (normal,
    two tangents, then spin about the normal and the tangents) and ``normal`` (n, 3):
    written into ``force`` and ``torque`` (n, 3), in the tangents the rows used."""
    for i in range(normal.shape[0]):
        n = normal[i]
        if n[0] == 0.0 and n[1] == 0.0 and n[2] == 0.0:      # a hand-written state's
            t1 = t2 = (0.0, 0.0, 0.0)
        else:
            t1, t2 = tangents(n)
        p0, p1, p2 = impulse[i, 0] / dt, impulse[i, 1] / dt, impulse[i, 2] / dt
        r0, r1, r2 = impulse[i, 3] / dt, impulse[i, 4] / dt, impulse[i, 5] / dt
        for k in range(3):
            force[i, k] = p0 * normal[i, k] + p1 * t1[k] + p2 * t2[k]
            torque[i, k] = r0 * normal[i, k] + r1 * t1[k] + r2 * t2[k]
