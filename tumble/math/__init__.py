"""Numba kernels for rotations and rigid-body spatial algebra.

Quaternions are (x, y, z, w), scalar last, like ``scipy.spatial.transform.Rotation``.
"""
from .quat import (quat_conj, quat_exp, quat_from_axis_angle, quat_from_mat, quat_identity,
                   quat_integrate_exp, quat_integrate_linear, quat_log, quat_mul,
                   quat_normalize, quat_rotate, quat_rotate_inv, quat_to_mat)
from .spatial import (apply_inertia, cross, dot, inertia_world, inertia_world_inv, mat_vec,
                      point_velocity, skew)

__all__ = [
    "quat_conj", "quat_exp", "quat_from_axis_angle", "quat_from_mat", "quat_identity",
    "quat_integrate_exp", "quat_integrate_linear", "quat_log", "quat_mul", "quat_normalize",
    "quat_rotate", "quat_rotate_inv", "quat_to_mat",
    "apply_inertia", "cross", "dot", "mat_vec", "inertia_world", "inertia_world_inv", "point_velocity", "skew",
]
