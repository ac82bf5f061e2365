"""Where a foot is lowest: the bound of a foot geom from below along the up direction.

The controller places a character on the ground and measures its clearance with these;
they read the model's geom arrays (sizes in m, poses in the body's COM principal frame).
"""
import numpy as np

from ..errors import ModelError
from ..math import quat_np as Q
from ..model.types import GEOM_TYPES


def foot_points(m, g):
    """Points whose lowest bounds the geom from below (box corners, sphere/capsule centres
    with their radius), geom frame: (points (k, 3), radius)."""
    t = {v: k for k, v in GEOM_TYPES.items()}[int(m.geom_type[g])]
    size = m.geom_size[g]
    if t == "box":
        s = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
        return s * size[:3], 0.0
    if t == "sphere":
        return np.zeros((1, 3)), size[0]
    if t in ("capsule", "cylinder"):
        return np.array([[0, 0, -size[1]], [0, 0, size[1]]], float), size[0]
    raise ModelError(f"SimbiconController: foot geom '{m.geom_names[g]}' is a {t}; feet must "
                     f"be boxes, spheres, capsules or cylinders")


def foot_lowest_at(m, g, body_pos, body_quat, up):
    """Lowest coordinate along ``up`` of geom g with its body at (body_pos, body_quat)."""
    pts, r = foot_points(m, g)
    q = Q.qmul(body_quat, m.geom_quat[g])
    p = body_pos + Q.qrot(body_quat, m.geom_pos[g])
    world = p + Q.qrot(np.broadcast_to(q, (len(pts), 4)), pts)
    return float((world @ up).min()) - r
