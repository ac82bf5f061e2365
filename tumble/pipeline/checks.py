"""Checks of what a user hands the step: a state that is finite with non-zero
quaternions, and drive inputs (targets, gains, torques, controls, body servos) that are
finite, with non-negative gains and non-zero target quaternions.

Each check reports the first fault as (code, world, index) and changes nothing when it
finds one; only after everything passed does it normalise the quaternions. ``World``
turns the codes into errors that name the body, joint or actuator and the field.
"""
import numpy as np

from .._jit import noalloc

# What check_state found wrong, by field.
STATE_OK, STATE_NONFINITE_POS, STATE_NONFINITE_QUAT, STATE_ZERO_QUAT, \
    STATE_NONFINITE_VEL, STATE_NONFINITE_ANGVEL, STATE_NONFINITE_FORCE, \
    STATE_NONFINITE_TORQUE = range(8)


@noalloc
def check_state(s, c):
    """Validate a state ``s`` (and the applied forces of its controls ``c``) before
    stepping; normalise its quaternions (those not of unit length already).

    Returns (code, world, body) with code STATE_OK when all is well; quaternions
    are only normalised once every one has been checked, so a refused state is
    left untouched.
    """
    nw, nb = s.body_pos.shape[0], s.body_pos.shape[1]
    for w in range(nw):
        for b in range(nb):
            for k in range(3):
                if not np.isfinite(s.body_pos[w, b, k]):
                    return STATE_NONFINITE_POS, w, b
                if not np.isfinite(s.body_vel[w, b, k]):
                    return STATE_NONFINITE_VEL, w, b
                if not np.isfinite(s.body_angvel[w, b, k]):
                    return STATE_NONFINITE_ANGVEL, w, b
                if not np.isfinite(c.applied_force[w, b, k]):
                    return STATE_NONFINITE_FORCE, w, b
                if not np.isfinite(c.applied_torque[w, b, k]):
                    return STATE_NONFINITE_TORQUE, w, b
            n2 = 0.0
            for k in range(4):
                if not np.isfinite(s.body_quat[w, b, k]):
                    return STATE_NONFINITE_QUAT, w, b
                n2 += s.body_quat[w, b, k] ** 2
            if n2 < 1e-24:
                return STATE_ZERO_QUAT, w, b
    _normalise_rows(s.body_quat)
    return STATE_OK, -1, -1


# What check_drives reports: the field at fault (DRIVE_FIELDS order), or one of these.
DRIVE_OK = -1
DRIVE_FIELDS = ("motor_target", "pd_target_quat", "pd_target_q", "pd_target_qd",
                "joint_applied", "ctrl", "pd_kp", "pd_kd", "body_servo", "body_target_pos",
                "body_target_quat", "body_target_vel", "body_target_angvel")
DRIVE_ZERO_BODY_QUAT, DRIVE_BAD_MAX, DRIVE_ZERO_JOINT_QUAT = 100, 101, 102


@noalloc
def _first_bad_2d(a, nonneg):
    """(w, i) of the first non-finite (or, with ``nonneg``, negative) entry of the
    (nworld, n) array ``a``; (-1, -1) if none."""
    for w in range(a.shape[0]):
        for i in range(a.shape[1]):
            if not np.isfinite(a[w, i]) or (nonneg and a[w, i] < 0.0):
                return w, i
    return -1, -1


@noalloc
def _first_bad_3d(a, nonneg):
    """``_first_bad_2d`` for an (nworld, n, k) array: (w, i) of the first bad row."""
    for w in range(a.shape[0]):
        for i in range(a.shape[1]):
            for k in range(a.shape[2]):
                if not np.isfinite(a[w, i, k]) or (nonneg and a[w, i, k] < 0.0):
                    return w, i
    return -1, -1


# A quaternion whose squared length is this close to 1 is left as it is: the step leaves
# its own unit to round-off, and dividing again would change the last bits at every call,
# so that step(n) and n calls of step(1) would part.
UNIT_TOLERANCE = 1e-13


@noalloc
def _normalise_rows(q):
    """Divide each non-zero 4-vector of the (nworld, n, 4) array ``q`` by its length,
    unless that is 1 already (``UNIT_TOLERANCE``)."""
    for w in range(q.shape[0]):
        for i in range(q.shape[1]):
            n2 = q[w, i, 0] ** 2 + q[w, i, 1] ** 2 + q[w, i, 2] ** 2 + q[w, i, 3] ** 2
            if n2 > 0.0 and abs(n2 - 1.0) > UNIT_TOLERANCE:
                n = np.sqrt(n2)
                for k in range(4):
                    q[w, i, k] /= n


@noalloc
def check_drives(c, ball):
    """Validate the drive inputs of controls ``c`` (targets, gains, torques, controls, body
    servos) before stepping, then normalise the target quaternions.

    ``ball`` (njoint,) bool marks ball joints, whose ``pd_target_quat`` must not be zero.
    Returns (code, world, index): code DRIVE_OK, an index into DRIVE_FIELDS for a
    non-finite (or, for gains, negative) entry of that field, DRIVE_ZERO_BODY_QUAT for a
    zero target orientation of a servoed body, DRIVE_BAD_MAX for a servo torque bound
    that is not > 0, DRIVE_ZERO_JOINT_QUAT for a zero ball target; index is the joint,
    actuator or body. Nothing is changed when a check fails.
    """
    fields3 = (c.motor_target, c.pd_target_quat, c.pd_target_q, c.pd_target_qd,
               c.joint_applied)
    for f in range(5):
        w, i = _first_bad_3d(fields3[f], np.bool_(False))
        if w >= 0:
            return f, w, i
    w, i = _first_bad_2d(c.ctrl, np.bool_(False))
    if w >= 0:
        return 5, w, i
    w, i = _first_bad_2d(c.pd_kp, np.bool_(True))
    if w >= 0:
        return 6, w, i
    w, i = _first_bad_2d(c.pd_kd, np.bool_(True))
    if w >= 0:
        return 7, w, i
    w, i = _first_bad_3d(c.body_servo, np.bool_(True))
    if w >= 0:
        return 8, w, i
    targets = (c.body_target_pos, c.body_target_quat, c.body_target_vel, c.body_target_angvel)
    for f in range(4):
        w, i = _first_bad_3d(targets[f], np.bool_(False))
        if w >= 0:
            return 9 + f, w, i
    nw = c.body_servo.shape[0]
    for w in range(nw):
        for b in range(c.body_servo.shape[1]):
            if c.body_servo[w, b, 2] > 0.0 or c.body_servo[w, b, 3] > 0.0:
                n2 = 0.0
                for k in range(4):
                    n2 += c.body_target_quat[w, b, k] ** 2
                if n2 < 1e-24:
                    return DRIVE_ZERO_BODY_QUAT, w, b
        for j in range(c.pd_max.shape[1]):
            if not c.pd_max[w, j] > 0.0:
                return DRIVE_BAD_MAX, w, j
            if ball[j]:
                n2 = 0.0
                for k in range(4):
                    n2 += c.pd_target_quat[w, j, k] ** 2
                if n2 < 1e-24:
                    return DRIVE_ZERO_JOINT_QUAT, w, j
    _normalise_rows(c.body_target_quat)
    _normalise_rows(c.pd_target_quat)
    return DRIVE_OK, -1, -1
