"""Ball-and-socket joint: the two anchor points coincide; rotation is free (3 DoF).

Limits. A ball joint is limited either by a box on its three coordinates (the rotation
vector, ``joint_limit``) or by a swing cone and a twist range on the swing-twist
decomposition of the child joint frame relative to the parent's,

    rel = swing * twist,

where ``twist`` turns about x (the twist axis) and ``swing`` about an axis in the y-z
plane, taking the parent's x axis ``x_a`` onto the child's ``x_b`` along the shortest arc.
With the swing angle ``theta`` (between ``x_a`` and ``x_b``), its axis
``u = x_a x x_b / |x_a x x_b|`` and the relative angular velocity ``w = w_b - w_a``
(world), the rates are exact:

    theta' = u . w
    twist' = (x_a + x_b) . w / (1 + x_a . x_b)          (undefined at a half-turn swing)
    psi'   = (x_a - cot(theta) v) . w,  v = u x x_a      (azimuth of u about x_a)

The elliptical cone with half-angles (a, b) about the joint frame's y and z allows
``theta s(psi) <= 1`` with ``s = sqrt((cos psi / a)^2 + (sin psi / b)^2)``; its row is on
``theta + theta (s'/s) psi'``, the rate of the swing measured in radians along its own
direction, against the margin ``1/s - theta`` (the cone's radius in that direction minus
the swing). For a circular cone this is ``theta <= a`` on the axis ``u``.

The rows' torques lie along these gradients: the twist row's along
``(x_a + x_b) / (1 + x_a . x_b) = x_b - tan(theta / 2) v'`` (``v'`` perpendicular to
``x_b`` in the swing plane), so stopping the twist of a swung joint also nudges its swing:
the twist of the decomposition depends on where the swing points.
"""
import math

from numba import njit

from ..._jit import noalloc

from ...math.quat import quat_conj, quat_log, quat_mul, quat_rotate
from .common import angle_about_x, point_rows


@noalloc
def core_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, frame_a, frame_b, erp_h, cfm):
    point_rows(rows, r, a, b, anchor_a, anchor_b, r_a, r_b, erp_h, cfm)


@noalloc
def dofs(frame_a, frame_b, anchor_a, anchor_b):
    """Axes: the parent joint frame's x, y, z (world); coordinates: the rotation vector of
    the child joint frame relative to the parent's (rad), in the parent joint frame."""
    rel = quat_mul(quat_conj(frame_a), frame_b)
    rv = quat_log(rel)
    return (quat_rotate(frame_a, (1.0, 0.0, 0.0)), quat_rotate(frame_a, (0.0, 1.0, 0.0)),
            quat_rotate(frame_a, (0.0, 0.0, 1.0))), rv


@noalloc
def twist_terms(frame_a, frame_b):
    """The twist of the child joint frame and the axis of its rate.

    Returns (tau, e, ok): tau (rad, in (-pi, pi]) the rotation about x left once the swing
    is taken out; e (3,) world, not unit, with ``tau' = e . (w_b - w_a)``; ok is False when
    the swing is within about 0.1 degree of a half turn, where the twist is undefined.
    """
    tau = angle_about_x(frame_a, frame_b)
    xa = quat_rotate(frame_a, (1.0, 0.0, 0.0))
    xb = quat_rotate(frame_b, (1.0, 0.0, 0.0))
    den = 1.0 + xa[0] * xb[0] + xa[1] * xb[1] + xa[2] * xb[2]
    if den < 1e-6:
        return tau, (0.0, 0.0, 0.0), False
    return tau, ((xa[0] + xb[0]) / den, (xa[1] + xb[1]) / den, (xa[2] + xb[2]) / den), True


@noalloc
def swing_terms(frame_a, frame_b, cone_y, cone_z):
    """The swing of the child's x axis against the cone (half-angles about y and z, rad).

    Returns (margin, e, ok): margin (rad) the cone's radius in the swing's direction minus
    the swing angle (negative: outside); e (3,) world, not unit, with the rate at which the
    swing grows towards the boundary ``= e . (w_b - w_a)`` (see the module docstring); ok is
    False when the swing is too small to have a direction (then well inside any cone).
    """
    xa = quat_rotate(frame_a, (1.0, 0.0, 0.0))
    ya = quat_rotate(frame_a, (0.0, 1.0, 0.0))
    za = quat_rotate(frame_a, (0.0, 0.0, 1.0))
    xb = quat_rotate(frame_b, (1.0, 0.0, 0.0))
    c = (xa[1] * xb[2] - xa[2] * xb[1], xa[2] * xb[0] - xa[0] * xb[2], xa[0] * xb[1] - xa[1] * xb[0])
    sin_t = math.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
    cos_t = xa[0] * xb[0] + xa[1] * xb[1] + xa[2] * xb[2]
    theta = math.atan2(sin_t, cos_t)
    if sin_t < 1e-9:
        if cos_t > 0.0:
            return min(cone_y, cone_z) - theta, (0.0, 0.0, 0.0), False
        # a half-turn swing has no direction either: far outside, push back along y
        return min(cone_y, cone_z) - theta, ya, True
    u = (c[0] / sin_t, c[1] / sin_t, c[2] / sin_t)
    uy = u[0] * ya[0] + u[1] * ya[1] + u[2] * ya[2]
    uz = u[0] * za[0] + u[1] * za[1] + u[2] * za[2]
    s2 = (uy / cone_y) ** 2 + (uz / cone_z) ** 2
    # k = theta s'/s: zero for a circular cone
    k = theta * uy * uz * (1.0 / (cone_z * cone_z) - 1.0 / (cone_y * cone_y)) / s2
    v = (u[1] * xa[2] - u[2] * xa[1], u[2] * xa[0] - u[0] * xa[2], u[0] * xa[1] - u[1] * xa[0])
    cot = cos_t / sin_t
    e = (u[0] + k * (xa[0] - cot * v[0]), u[1] + k * (xa[1] - cot * v[1]),
         u[2] + k * (xa[2] - cot * v[2]))
    return 1.0 / math.sqrt(s2) - theta, e, True
