"""PD control of a character's joints: the lecture's explicit torques and the compiled servos.

Two routes, same gains:

- ``pd_torques`` + ``apply_joint_torques``: the lecture's PD, vectorised in NumPy over all
  joints, ``tau = kp log(q_target q_rel^-1) - kd (w_rel - w_target)`` in the world frame,
  applied +tau to the child and -tau to the parent. Computed from Python, so the caller
  recomputes it every substep (the course runs ODE at 1920 Hz for this reason).
- ``PDController``: the same servo inside the compiled step (``World(pd=...)``): targets
  set once per control frame, applied every substep of ``step(n)``; ``mode`` switches the
  same gains between 'implicit' (a soft constraint row, stable at any step), 'explicit'
  and 'stable' (Tan et al. 2011).
"""
import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ModelError
from ..model.validate import positive

_ROTATIONAL = ("ball", "hinge", "universal")


def _per_joint(model, value, what, default=0.0):
    """A scalar, an (njoint,) array or a {joint name: value} dict as an (njoint,) array."""
    out = np.full(model.njoint, float(default))
    if isinstance(value, dict):
        for name, v in value.items():
            out[model.joint_index(name)] = positive(v, f"joint '{name}'", what, allow_zero=True)
        return out
    a = np.asarray(value, float)
    if a.ndim == 0:
        out[:] = positive(float(a), "PD", what, allow_zero=True)
        return out
    if a.shape != (model.njoint,):
        raise ModelError(f"PD: {what} must be a number, a dict by joint name or shape "
                         f"({model.njoint},), got shape {a.shape}")
    for j, v in enumerate(a):
        positive(v, f"joint '{model.joint_names[j]}'", what, allow_zero=True)
    return a.copy()


def _joint_frames_w(world, w=0):
    """World rotation of each joint's parent and child joint frames: two Rotation stacks."""
    m = world.model
    s = world.state_arrays
    qa, qb = [], []
    for j in range(m.njoint):
        p, c = m.joint_parent[j], m.joint_child[j]
        fa = Rotation.from_quat(m.joint_frame_a[j])
        qa.append((fa if p < 0 else Rotation.from_quat(s.body_quat[w, p]) * fa).as_quat())
        qb.append((Rotation.from_quat(s.body_quat[w, c]) * Rotation.from_quat(m.joint_frame_b[j])).as_quat())
    return Rotation.from_quat(np.array(qa)), Rotation.from_quat(np.array(qb))


def pd_torques(world, target_quat, kp, kd, max_torque=None, target_angvel=None, *, world_index=0):
    """The lecture's PD torques of every rotational joint, world frame, (njoint, 3) N m.

    target_quat : (njoint, 4) targets of the child joint frame relative to the parent's
        (x, y, z, w), as ``World.joint_quat`` reports it (hinges: a rotation about x).
    kp, kd : gains, scalars, (njoint,) arrays or {joint name: gain}.
    max_torque : bound on the torque's norm per joint (same forms), default none.
    target_angvel : (njoint, 3) relative angular velocity targets in the parent joint frame.
    The error ``log(q_target q_rel^-1)`` is taken in the parent's joint frame, so a hinge's
    error lies on its axis; other axes of a hinge carry no torque (the joint holds them).
    Joints that are not ball, hinge or universal get zero.
    """
    m = world.model
    t = np.asarray(target_quat, float)
    if t.shape != (m.njoint, 4) or not np.all(np.isfinite(t)):
        raise ModelError(f"pd_torques: target_quat must be finite with shape ({m.njoint}, 4), "
                         f"got {t.shape}")
    kp = _per_joint(m, kp, "kp")
    kd = _per_joint(m, kd, "kd")
    fa, fb = _joint_frames_w(world, world_index)
    rel = fa.inv() * fb
    err = (Rotation.from_quat(t) * rel.inv()).as_rotvec()         # parent joint frame
    s = world.state_arrays
    w_child = s.body_angvel[world_index, m.joint_child]
    w_parent = np.where((m.joint_parent >= 0)[:, None],
                        s.body_angvel[world_index, np.maximum(m.joint_parent, 0)], 0.0)
    w_rel = fa.inv().apply(w_child - w_parent)                     # parent joint frame
    if target_angvel is not None:
        w_rel = w_rel - np.asarray(target_angvel, float)
    tau = kp[:, None] * err - kd[:, None] * w_rel
    types = np.array(m.joint_type_names)
    tau[types == "hinge", 1:] = 0.0
    tau[types == "universal", 2] = 0.0
    tau[~np.isin(types, _ROTATIONAL)] = 0.0
    if max_torque is not None:
        lim = _per_joint(m, max_torque, "max_torque", default=np.inf)
        norm = np.linalg.norm(tau, axis=1)
        scale = np.where(norm > lim, lim / np.maximum(norm, 1e-300), 1.0)
        tau *= scale[:, None]
    return fa.apply(tau)


def apply_joint_torques(world, torques, *, world_index=None):
    """Apply world-frame joint torques (njoint, 3): +tau on each child, -tau on its parent.

    Held through the next ``step(n)`` call like ``World.apply_torque``.
    """
    m = world.model
    tau = np.asarray(torques, float)
    if tau.shape != (m.njoint, 3) or not np.all(np.isfinite(tau)):
        raise ModelError(f"apply_joint_torques: torques must be finite with shape "
                         f"({m.njoint}, 3), got {tau.shape}")
    w = slice(None) if world_index is None else world_index
    applied = world.control_arrays.applied_torque[w]
    np.add.at(applied, (..., m.joint_child, slice(None)), tau)
    has_parent = m.joint_parent >= 0
    np.add.at(applied, (..., m.joint_parent[has_parent], slice(None)), -tau[has_parent])


def targets_from_quats(model, quats):
    """Split (njoint, 4) joint-frame target rotations into the world's servo targets.

    Returns (target_quat (njoint, 4), target_q (njoint, 3)): ball joints keep the quaternion;
    hinges get the angle about the joint axis (x of the joint frame); universal joints the
    rotation-vector components on their two axes.
    """
    q = np.asarray(quats, float)
    if q.shape[-2:] != (model.njoint, 4) or not np.all(np.isfinite(q)):
        raise ModelError(f"targets: expected finite (..., {model.njoint}, 4) quaternions, "
                         f"got shape {q.shape}")
    rv = Rotation.from_quat(q.reshape(-1, 4)).as_rotvec().reshape(q.shape[:-1] + (3,))
    target_q = np.zeros(q.shape[:-1] + (3,))
    types = np.array(model.joint_type_names)
    hinge = types == "hinge"
    # a hinge target is a rotation about x; the angle keeps its sign through the quaternion
    target_q[..., hinge, 0] = 2.0 * np.arctan2(q[..., hinge, 0], q[..., hinge, 3])
    target_q[..., hinge, 0] = (target_q[..., hinge, 0] + np.pi) % (2 * np.pi) - np.pi
    uni = types == "universal"
    target_q[..., uni, :2] = rv[..., uni, :2]
    return q, target_q


class PDController:
    """A character's joint servos inside the compiled step.

    world : the World to drive; kp, kd, max_torque : scalars (for every joint with a degree
    of freedom), (njoint,) arrays or {joint name: value} (joints left out of a dict get 0:
    no servo; max_torque default unbounded). mode : 'implicit' (default), 'explicit' or 'stable', the World's ``pd``
    switch for these same gains.

    ``set_targets(quats)`` takes (njoint, 4) joint-frame rotations (``World.joint_quat``'s
    convention, e.g. from ``tumble.character.joint_targets``) once per control frame; the
    servos then act every substep of ``world.step(n)`` without a Python call per substep.
    """

    def __init__(self, world, kp, kd, max_torque=None, *, mode="implicit"):
        self.world = world
        m = world.model
        self.kp = _per_joint(m, kp, "kp")
        self.kd = _per_joint(m, kd, "kd")
        self.max_torque = (np.full(m.njoint, np.inf) if max_torque is None
                           else _per_joint(m, max_torque, "max_torque", default=np.inf))
        if np.any(self.max_torque <= 0):
            raise ModelError("PDController: max_torque must be > 0")
        types = np.array(m.joint_type_names)
        # a scalar gain means every joint that has a degree of freedom to servo
        rigid = np.isin(types, ("fixed", "free"))
        for name, given, arr in (("kp", kp, self.kp), ("kd", kd, self.kd)):
            if np.ndim(given) == 0 and not isinstance(given, dict):
                arr[rigid] = 0.0
        served = (self.kp > 0) | (self.kd > 0)
        bad = served & np.isin(types, ("fixed", "free"))
        if bad.any():
            raise ModelError(f"PDController: joint '{m.joint_names[np.flatnonzero(bad)[0]]}' "
                             f"is {types[bad][0]}: it has no degree of freedom to servo")
        self.mode = mode
        world.joint_kp = self.kp
        world.joint_kd = self.kd
        world.joint_max_torque = self.max_torque

    @property
    def mode(self):
        """'implicit', 'explicit' or 'stable' (the World's ``pd`` setting)."""
        return self.world.pd

    @mode.setter
    def mode(self, value):
        self.world.pd = value

    def set_targets(self, quats, angvel=None):
        """Servo targets from (njoint, 4) joint-frame rotations; ``angvel`` (njoint, 3)
        optional target rates along the DoF axes (rad/s). Refused (ModelError naming the
        joint) unless finite numbers of the right shape and unit quaternions up to scale."""
        m = self.world.model
        try:
            if isinstance(quats, (str, bytes)):
                raise TypeError
            q = np.asarray(quats, dtype=float)
            qd = None if angvel is None else np.asarray(angvel, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"set_targets: quats (..., {m.njoint}, 4) and angvel "
                             f"(..., {m.njoint}, 3) must be numbers") from None
        if isinstance(angvel, (str, bytes)):
            raise ModelError(f"set_targets: angvel must be numbers (..., {m.njoint}, 3), got "
                             f"{angvel!r}")
        if q.shape[-2:] == (m.njoint, 4) and np.all(np.isfinite(q)):
            zero = np.linalg.norm(q, axis=-1) < 1e-12
            if zero.any():
                j = int(np.argwhere(zero)[0][-1])
                raise ModelError(f"set_targets: the target of joint '{m.joint_names[j]}' is a "
                                 f"zero quaternion; give a unit quaternion (x, y, z, w)")
        if qd is not None and not np.all(np.isfinite(qd)):
            raise ModelError("set_targets: angvel is not finite")
        tq, tpos = targets_from_quats(m, q)
        self.world.pd_target_quat = tq
        self.world.pd_target_q = tpos
        self.world.pd_target_qd = 0.0 if qd is None else qd

    def joint_error(self, quats=None):
        """Angle (rad) between each joint's rotation and its target (or ``quats``): (njoint,)."""
        w = self.world
        target = w.pd_target_quat if quats is None else np.asarray(quats, float)
        if quats is None:
            # hinge targets live in pd_target_q: rebuild their quaternions about x
            target = np.array(target, float)
            hinge = np.array(w.model.joint_type_names) == "hinge"
            ang = w.pd_target_q[..., hinge, 0]
            target[..., hinge, :] = 0.0
            target[..., hinge, 0] = np.sin(ang / 2)
            target[..., hinge, 3] = np.cos(ang / 2)
        d = np.abs(np.sum(np.asarray(w.joint_quat) * target, axis=-1))
        return 2.0 * np.arccos(np.clip(d, -1.0, 1.0))
