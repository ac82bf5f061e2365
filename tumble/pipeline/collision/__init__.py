"""Collision detection kernels: broad phase, contacts, distances and ray casts.

All kernels are Numba ``@njit(cache=True)`` functions over arrays and tuples; the
per-pair routines do not allocate (they write into caller-provided arrays).

Geometry (``shapes``): type codes ``PLANE=0, SPHERE=1, CAPSULE=2, BOX=3, CYLINDER=4``
(defined in ``model.types``);
``size`` (3,) per geom; world poses ``pos`` (3,), ``quat`` (4,) as (x, y, z, w).

Contacts (``collide_pair`` and the ``collide_X_Y`` routines, ``type_X <= type_Y``)::

    collide_X_Y(pos_a, quat_a, size_a, pos_b, quat_b, size_b, margin,
                out_point, out_normal, out_depth, out_feature, start) -> count

write at most 4 rows from ``start``. ``normal`` is unit, from A to B; ``depth > 0``
is penetration and rows are written only when ``depth > -margin``; the point is
midway between the two surfaces (``p +- depth/2 normal`` lie on A and on B), so
swapping A and B flips the normal and keeps points and depths. ``out_feature`` is a
small integer naming the contact feature, stable while the contact persists:

* 0: single-contact pairs (sphere-*, the closest points of capsule-capsule, the
  deepest point of capsule-box near an edge, the GJK/MPR point of cylinder pairs);
* plane-*: box vertex ``bx + 2 by + 4 bz``; capsule end 0/1; cylinder rim point
  ``4 cap + kind`` (``manifold``);
* capsule-capsule parallel: 1, 2 (ends of the overlap); capsule-box on a face:
  ``1 + 2 face + end`` (``primitives``);
* box-box: face contacts below 1728, edge-edge ``2000 + 12 edge_a + edge_b``, 3000
  (``box_box``);
* cylinder pairs on a face or cap: ``1 + 8 ref + candidate`` (``convex``).

Also: ``geom_aabb``/``geom_aabbs`` (planes are unbounded, +-inf),
``broadphase_pairs`` (sort and sweep, exact), ``grid_pairs`` (hashed grid, exact), ``geom_distance`` (signed distance and
closest points), ``raycast_geom``, and the GJK/MPR building blocks.
"""
from .box_box import box_box_deepest, box_sat, collide_box_box
from .broadphase import (BROADPHASE_GRID, BROADPHASE_SAP, BROADPHASES, broadphase_pairs,
                         find_pairs, geom_aabbs, grid_pairs, overlapping_pairs, sweep_axis)
from .convex import (collide_box_cylinder, collide_capsule_cylinder, collide_cylinder_cylinder,
                     convex_contact)
from .dispatch import (collide_geoms, collide_pair, geom_aabb_any, geom_distance,
                       geom_distance_any, raycast_any)
from .gjk import gjk_distance, mpr_penetration
from .primitives import (collide_capsule_box, collide_capsule_capsule, collide_plane_box,
                         collide_plane_capsule, collide_plane_cylinder, collide_plane_plane,
                         collide_plane_sphere, collide_sphere_box, collide_sphere_capsule,
                         collide_sphere_cylinder, collide_sphere_sphere)
from .raycast import raycast_geom
from .shapes import (BOX, CAPSULE, CYLINDER, MAX_CONTACTS_PER_PAIR, NUM_GEOM_TYPES, PLANE,
                     SPHERE, core_radius, geom_aabb, support, support_core)

__all__ = [
    "PLANE", "SPHERE", "CAPSULE", "BOX", "CYLINDER", "NUM_GEOM_TYPES", "MAX_CONTACTS_PER_PAIR",
    "geom_aabb", "geom_aabbs", "support", "support_core", "core_radius",
    "broadphase_pairs", "find_pairs", "sweep_axis", "grid_pairs", "overlapping_pairs",
    "BROADPHASES", "BROADPHASE_SAP", "BROADPHASE_GRID",
    "collide_pair", "geom_distance", "raycast_geom",
    "collide_plane_sphere", "collide_plane_capsule", "collide_plane_box", "collide_plane_cylinder",
    "collide_plane_plane", "collide_sphere_sphere", "collide_sphere_capsule", "collide_sphere_box",
    "collide_sphere_cylinder", "collide_capsule_capsule", "collide_capsule_box",
    "collide_capsule_cylinder", "collide_box_box", "collide_box_cylinder",
    "collide_cylinder_cylinder",
    "box_sat", "box_box_deepest", "convex_contact", "gjk_distance", "mpr_penetration",
]
