"""The PD servo of a joint: its error and its implicit constraint-row form.

Shared by the explicit path (``pipeline/actuators.py``) and the constraint rows
(``joints/rows.py``) so both see the same error for the same gains.
"""
import math
from collections import namedtuple

from numba import njit

from ..._jit import noalloc

from ...math.quat import quat_conj, quat_log, quat_mul
from ...model.types import BALL, HINGE, SLIDER, UNIVERSAL

# One world's joint drives, slices of the state arrays of the same names.
JointDrive = namedtuple("JointDrive", [
    "motor_target",   # (njoint, 3) velocity-motor target rate per DoF (rad/s or m/s)
    "kp",             # (njoint,) servo stiffness, N m/rad or N/m (0 with kd 0: servo off)
    "kd",             # (njoint,) servo damping, N m s/rad or N s/m
    "max_torque",     # (njoint,) bound on each DoF's servo torque (N m or N)
    "target_quat",    # (njoint, 4) ball target: child joint frame in the parent's (x, y, z, w)
    "target_q",       # (njoint, 3) hinge/universal/slider target coordinates (rad or m)
    "target_qd",      # (njoint, 3) target rates along the DoF axes
    "applied",        # (njoint, 3) torque (or force) per DoF applied through the call
])


@njit(cache=True, inline="always")
def wrap_angle(x):
    """``x`` wrapped into (-pi, pi]."""
    return x - 2.0 * math.pi * math.floor((x + math.pi) / (2.0 * math.pi))


@noalloc
def pd_error(t, q, frame_a, frame_b, target_quat, target_q):
    """Servo error (3,) along the joint's DoF axes: target minus current (rad or m)."""
    if t == BALL:
        rel = quat_mul(quat_conj(frame_a), frame_b)
        return quat_log(quat_mul(target_quat, quat_conj(rel)))
    if t == HINGE:
        return (wrap_angle(target_q[0] - q[0]), 0.0, 0.0)
    if t == UNIVERSAL:
        return (wrap_angle(target_q[0] - q[0]), wrap_angle(target_q[1] - q[1]), 0.0)
    if t == SLIDER:
        return (target_q[0] - q[0], 0.0, 0.0)
    return (0.0, 0.0, 0.0)


@njit(cache=True, inline="always")
def servo_active(drive, j):
    return drive.kp[j] > 0.0 or drive.kd[j] > 0.0


@noalloc
def servo_row_terms(kp, kd, h, err, target_qd):
    """(rhs, cfm) of the implicit servo row: the implicit-Euler spring-damper.

    With the end-of-step rate v and impulse p, ``p / h = kp (e - h v) - kd (v - v_t)``,
    i.e. ``v + p / (h (h kp + kd)) = (kp e + kd v_t) / (h kp + kd)``.
    """
    s = h * kp + kd
    return (kp * err + kd * target_qd) / s, 1.0 / (h * s)
