"""Pose transfer between motions and ragdoll worlds.

* :func:`set_pose` places a ragdoll's bodies in a world at a frame of a
  :class:`~tumble.Motion` (poses and velocities, world frame);
* :func:`get_pose` reads the pose back: joint-local rotations, root position and
  orientation, in the ragdoll's skeleton order or in any motion's;
* :func:`joint_targets` turns a motion frame into the values ``World.joint_quat`` takes
  in that pose, which is what a PD controller compares;
* :func:`rest_alignment` says how the motion's rest pose sits against the ragdoll's.

Frames and conventions. A motion gives each joint a global rotation ``Qm_j`` (joint frame
-> world) relative to *its* rest pose. The ragdoll was built in its skeleton's rest pose,
in which every global rotation is the identity. When the two rest poses differ (an A-pose
file on a T-pose ragdoll), the rest alignment ``G_j`` is the global rotation that brings
motion joint ``j`` from its rest pose to the ragdoll's; the ragdoll joint then turns by
``Q_j = Qm_j G_j^-1``. Body ``b`` of joint ``j`` sits at ``x_b = P_j + Q_j d_b`` with
orientation ``q_b = Q_j q0_b``, where ``d_b`` and ``q0_b`` are its rest-pose offset from
the joint and its rest orientation (``Ragdoll.body_offset``, ``body_rest_quat``).
Joint positions ``P_j`` chain the ragdoll's own bone offsets from the root, so bodies
stay joined even when the motion's bones are longer or shorter. Joints are matched by
name, so the motion's joint order does not matter.

Joint-local rotations are ``L_j = Q_parent^-1 Q_j`` (child frame -> parent frame, like
``Motion.local_rotations``); quaternions are (x, y, z, w) and equal up to sign.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..io.bvh import Motion
from ..math import quat_np as Q
from .ragdoll import Ragdoll
from .skeleton import Skeleton

__all__ = ["Pose", "set_pose", "get_pose", "joint_targets", "rest_alignment"]

# Rest alignments closer than this to the identity (rad) are taken as the identity. The
# course's character_model.npy was computed in single precision: its bones disagree with
# the BVH offsets by up to 4e-7 m, 6e-6 rad on the 6 cm toe; a real rest-pose difference
# (an A-pose) is tens of degrees.
ALIGN_TOL = 1e-4


@dataclass
class Pose:
    """A skeleton pose read from a world (see :func:`get_pose`); J joints.

    joint_names : the J names, in the order asked for.
    root_position : (3,) world position of the root joint, m.
    root_rotation : (4,) root joint frame -> world, (x, y, z, w).
    local_rotations : (J, 4) each joint frame -> its parent's (the root's: -> world).
    global_rotations : (J, 4) each joint frame -> world.
    joint_positions : (J, 3) world positions of the joints, m.
    """
    joint_names: list
    root_position: np.ndarray
    root_rotation: np.ndarray
    local_rotations: np.ndarray
    global_rotations: np.ndarray
    joint_positions: np.ndarray


def _check_ragdoll(ragdoll, where):
    if not isinstance(ragdoll, Ragdoll):
        raise ModelError(f"{where}: needs a tumble Ragdoll, got {type(ragdoll).__name__}")


def _check_motion(motion, where):
    if not isinstance(motion, Motion):
        raise ModelError(f"{where}: needs a tumble Motion, got {type(motion).__name__}")


def _motion_index(ragdoll, motion, where):
    """(J_ragdoll,) index in ``motion`` of every skeleton joint of the ragdoll (-1: absent).

    Every joint that drives a body must be in the motion (ModelError lists those missing).
    """
    names = ragdoll.skeleton.joint_names
    lookup = {n: i for i, n in enumerate(motion.joint_names)}
    idx = np.array([lookup.get(n, -1) for n in names], dtype=np.int64)
    missing = [names[j] for j in ragdoll.body_joints if idx[j] < 0]
    if missing:
        raise ModelError(f"{where}: the motion has no joints named {missing}; they drive "
                         f"bodies of the ragdoll (joints are matched by name)")
    return idx


def _fit_rotation(u, v):
    """Rotation R (4,) that best turns the directions ``u`` (n, 3) onto ``v`` (n, 3).

    One direction (or parallel ones): the shortest arc. Several: the least-squares
    rotation of the unit vectors (Kabsch, by SVD).
    """
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    h = u.T @ v
    uu, sv, vt = np.linalg.svd(h)
    if len(u) == 1 or sv[1] < 1e-9 * max(sv[0], 1e-300):
        return Q.qarc(u[0], v[0])
    d = np.sign(np.linalg.det(vt.T @ uu.T)) or 1.0
    r = vt.T @ np.diag([1.0, 1.0, d]) @ uu.T
    return Q.qfrom_matrix(r)


def rest_alignment(ragdoll, motion, tol=ALIGN_TOL):
    """Rest alignment ``G`` (J, 4) of the motion against the ragdoll, per skeleton joint.

    ``G_j`` turns motion joint j's rest-pose bones (its offsets to the children both
    skeletons share) onto the ragdoll's rest-pose bones, in the least-squares sense; a
    joint with one such bone gets the shortest arc (a twist about a single bone cannot be
    seen from positions and is taken as none). Joints without shared children take their
    parent's alignment. Rotations within ``tol`` rad of the identity are the identity.
    The GAMES-105 files and ``character_model.npy`` share one T-pose: G is the identity.
    """
    where = "rest_alignment"
    _check_ragdoll(ragdoll, where)
    _check_motion(motion, where)
    # Cached per rest skeleton: set_pose and joint_targets ask for it on every call.
    key = (tuple(motion.joint_names), motion.parents.tobytes(), motion.offsets.tobytes(),
           float(tol))
    cache = ragdoll._alignment_cache
    if key in cache:
        return cache[key].copy()
    sk = ragdoll.skeleton
    idx = _motion_index(ragdoll, motion, where)
    mrest = Skeleton.from_motion(motion).rest_positions
    out = np.tile(Q.IDENTITY, (sk.num_joints, 1))
    for j in sk.order:
        kids = [c for c in sk.children(j) if idx[c] >= 0]
        u = mrest[idx[kids]] - mrest[idx[j]] if kids and idx[j] >= 0 else np.zeros((0, 3))
        v = sk.rest_positions[kids] - sk.rest_positions[j] if kids else np.zeros((0, 3))
        ok = (np.linalg.norm(u, axis=1) > 1e-12) & (np.linalg.norm(v, axis=1) > 1e-12)
        if not np.any(ok):
            p = sk.parents[j]
            out[j] = out[p] if p >= 0 else Q.IDENTITY
            continue
        g = _fit_rotation(u[ok], v[ok])
        out[j] = Q.IDENTITY if Q.qangle(g) < tol else g
    if len(cache) >= 16:
        cache.clear()
    cache[key] = out.copy()
    return out


def _motion_globals(motion, frames):
    """Global rotations (n, Jm, 4) and positions (n, Jm, 3) of the motion at ``frames``,
    a contiguous increasing range of frame indices."""
    pos, quat = motion.sub(int(frames[0]), int(frames[-1]) + 1).forward_kinematics()
    return quat, pos


def _skeleton_globals(ragdoll, motion, frames, align, idx):
    """Ragdoll-skeleton global rotations Q (n, nb, 4) and joint positions P (n, nb, 3) of
    the ragdoll bodies' joints at motion ``frames``."""
    sk = ragdoll.skeleton
    qm, pm = _motion_globals(motion, frames)
    slot = ragdoll.slot_of_joint
    n, nb = len(frames), len(ragdoll.body_joints)
    rot = np.empty((n, nb, 4))
    pos = np.empty((n, nb, 3))
    offsets = sk.offsets
    for j in sk.order:
        k = slot[j]
        if k < 0:
            continue
        rot[:, k] = Q.qmul(qm[:, idx[j]], Q.qconj(align[j]))
        p = sk.parents[j]
        if p < 0:
            if ragdoll.root == "pinned":
                # The pin holds the root joint at its rest position whatever the motion says.
                pos[:, k] = sk.rest_positions[j]
            else:
                pos[:, k] = pm[:, idx[j]]
        else:
            kp = slot[p]
            pos[:, k] = pos[:, kp] + Q.qrot(rot[:, kp], offsets[j])
    return rot, pos


def _body_poses(ragdoll, rot, pos):
    """COM positions (n, nb, 3) and orientations (n, nb, 4) of the bodies."""
    x = pos + Q.qrot(rot, ragdoll.body_offset)
    q = Q.qmul(rot, ragdoll.body_rest_quat)
    return x, q


def _world_bodies(world, ragdoll, where):
    """Indices in ``world.model`` of the ragdoll's bodies, by name."""
    try:
        return np.array([world.model.body_index(n) for n in ragdoll.body_names], dtype=np.int64)
    except ModelError as exc:
        raise ModelError(f"{where}: the world's model lacks a ragdoll body ({exc})") from None


def _frame_index(motion, frame, where):
    F = motion.num_frames
    if isinstance(frame, bool) or not isinstance(frame, (int, np.integer)):
        raise ModelError(f"{where}: frame must be an integer, got {frame!r}")
    f = int(frame) + F if frame < 0 else int(frame)
    if not 0 <= f < F:
        raise ModelError(f"{where}: frame {frame} out of range for a motion of {F} frames")
    return f


def set_pose(world, ragdoll, motion, frame=0, *, velocities=True, world_index=None):
    """Put the ragdoll's bodies of ``world`` in the pose of ``motion`` at ``frame``.

    Positions (m) and orientations of every ragdoll body, world frame, follow the module
    rules (rest alignment, bone lengths of the ragdoll, joints matched by name). With
    ``velocities``, linear and angular body velocities (m/s, rad/s, world frame) are finite
    differences of those poses over the motion's frames: central over ``2 frame_time``
    inside, one-sided at the first and last frames (zero for a one-frame motion);
    otherwise they are set to zero. A pinned ragdoll keeps its root joint at the pin: the
    motion's root translation is not used. world_index: one world of a batch (default
    all). The joint coordinates (``world.joint_q``, ``joint_quat``) are refreshed; warm
    start impulses and contacts are left as they were. Motion rotations that a hinge
    cannot follow are set as given: the first steps pull the joint back onto its axis.
    """
    where = "set_pose"
    _check_ragdoll(ragdoll, where)
    _check_motion(motion, where)
    f = _frame_index(motion, frame, where)
    bodies = _world_bodies(world, ragdoll, where)
    idx = _motion_index(ragdoll, motion, where)
    align = rest_alignment(ragdoll, motion)
    F = motion.num_frames
    lo, hi = max(f - 1, 0), min(f + 1, F - 1)
    frames = np.array(sorted({lo, f, hi}), dtype=np.int64)
    rot, pos = _skeleton_globals(ragdoll, motion, frames, align, idx)
    x, q = _body_poses(ragdoll, rot, pos)
    at = int(np.flatnonzero(frames == f)[0])
    vel = np.zeros_like(x[0])
    angvel = np.zeros_like(x[0])
    if velocities and hi > lo:
        i_lo, i_hi = int(np.flatnonzero(frames == lo)[0]), int(np.flatnonzero(frames == hi)[0])
        span = (hi - lo) * motion.frame_time
        vel = (x[i_hi] - x[i_lo]) / span
        # Left increment q_hi = d q_lo: its rotation vector over the span is the world-frame
        # angular velocity.
        angvel = Q.qrotvec(Q.qmul(q[i_hi], Q.qconj(q[i_lo]))) / span
    if world_index is None:
        sel = (Ellipsis, bodies, slice(None))
    else:
        if not isinstance(world_index, (int, np.integer)) or not 0 <= world_index < world.nworld:
            raise ModelError(f"{where}: world_index must be in [0, {world.nworld}), got "
                             f"{world_index!r}")
        sel = (int(world_index) if world.nworld > 1 else Ellipsis, bodies, slice(None))
    world.body_pos[sel] = x[at]
    world.body_quat[sel] = q[at]
    world.body_vel[sel] = vel
    world.body_angvel[sel] = angvel
    world.update_joint_coordinates()


def get_pose(world, ragdoll, motion=None, *, world_index=0):
    """The ragdoll's pose in ``world`` as a :class:`Pose`.

    Joint frames come from the bodies: ``Q_j = q_b q0_b^-1`` and ``P_j = x_b - Q_j d_b``.
    motion : None for the ragdoll skeleton's joints and rest pose; or a Motion (only its
        joint names, parents, offsets and rest pose are used), to get the pose in its joint
        order and relative to its rest pose (rest alignment applied), ready to compare
        with ``motion.local_rotations[f]``. Joints without a body (end sites, joints the
        ragdoll lacks) get the identity local rotation.
    So ``set_pose`` then ``get_pose`` gives back the motion's rotations and, for a
    floating root, its root position, to round-off.
    """
    where = "get_pose"
    _check_ragdoll(ragdoll, where)
    bodies = _world_bodies(world, ragdoll, where)
    w = 0 if world.nworld == 1 else int(world_index)
    if world.nworld > 1 and not 0 <= w < world.nworld:
        raise ModelError(f"{where}: world_index must be in [0, {world.nworld}), got {world_index!r}")
    nw = world.nworld
    x = np.reshape(world.body_pos, (nw, -1, 3))[w, bodies]
    q = np.reshape(world.body_quat, (nw, -1, 4))[w, bodies]
    rot = Q.qmul(q, Q.qconj(ragdoll.body_rest_quat))
    pos = x - Q.qrot(rot, ragdoll.body_offset)
    sk = ragdoll.skeleton
    J = sk.num_joints
    g_rot = np.empty((J, 4))
    g_pos = np.empty((J, 3))
    offsets = sk.offsets
    for j in sk.order:
        k, p = ragdoll.slot_of_joint[j], sk.parents[j]
        if k >= 0:
            g_rot[j], g_pos[j] = rot[k], pos[k]
        else:                                   # no body: rigid with its parent
            g_rot[j] = g_rot[p]
            g_pos[j] = g_pos[p] + Q.qrot(g_rot[p], offsets[j])
    if motion is None:
        names, parents = sk.joint_names, sk.parents
        order, root = sk.order, sk.root
    else:
        _check_motion(motion, where)
        idx = _motion_index(ragdoll, motion, where)
        align = rest_alignment(ragdoll, motion)
        names, parents = motion.joint_names, motion.parents
        mk = Skeleton(names, parents, np.zeros((len(names), 3)))
        order, root = mk.order, mk.root
        of_motion = {int(m): j for j, m in enumerate(idx) if m >= 0}
        m_rot = np.empty((len(names), 4))
        m_pos = np.empty((len(names), 3))
        for m in order:
            p = parents[m]
            j = of_motion.get(m, -1)
            if j >= 0 and ragdoll.slot_of_joint[j] >= 0:
                m_rot[m] = Q.qmul(g_rot[j], align[j])
            else:
                m_rot[m] = m_rot[p] if p >= 0 else Q.IDENTITY
            if j >= 0:
                m_pos[m] = g_pos[j]
            else:
                m_pos[m] = (m_pos[p] + Q.qrot(m_rot[p], motion.offsets[m]) if p >= 0
                            else motion.offsets[m])
        g_rot, g_pos = m_rot, m_pos
    local = np.empty_like(g_rot)
    for j in order:
        p = parents[j]
        local[j] = g_rot[j] if p < 0 else Q.qmul(Q.qconj(g_rot[p]), g_rot[j])
    return Pose(list(names), g_pos[root].copy(), g_rot[root].copy(), local, g_rot, g_pos)


def joint_targets(ragdoll, motion, frame=None):
    """What ``World.joint_quat`` reads when the ragdoll is in the motion's pose.

    Returns (njoint, 4) for one ``frame``, or (F, njoint, 4) for all frames (frame=None),
    in the ragdoll model's joint order (x, y, z, w). For the model joint of skeleton joint
    j with joint frame ``F_j`` (world frame at build: identity for ball joints, x along the
    axis for hinges), the value is ``F_j^-1 Q_parent^-1 Q_j F_j``: the motion's local
    rotation seen in the joint frame, rest alignment applied. A PD controller drives
    ``world.joint_quat`` towards it. One call for all frames costs about as much as one
    call for one frame (a few ms for the course character): precompute them. Joints of the model that are not ragdoll joints keep
    the identity.
    """
    where = "joint_targets"
    _check_ragdoll(ragdoll, where)
    _check_motion(motion, where)
    frames = (np.arange(motion.num_frames) if frame is None
              else np.array([_frame_index(motion, frame, where)]))
    idx = _motion_index(ragdoll, motion, where)
    align = rest_alignment(ragdoll, motion)
    rot, _ = _skeleton_globals(ragdoll, motion, frames, align, idx)
    m = ragdoll.model
    out = np.tile(Q.IDENTITY, (len(frames), m.njoint, 1))
    sk = ragdoll.skeleton
    for k, j in enumerate(ragdoll.body_joints):
        mj = ragdoll.joint_index[k]
        pb = m.joint_parent[mj]
        frame_w = m.joint_frame_a[mj] if pb < 0 else Q.qmul(m.body_quat0[pb], m.joint_frame_a[mj])
        p = sk.parents[j]
        local = rot[:, k] if p < 0 else Q.qmul(Q.qconj(rot[:, ragdoll.slot_of_joint[p]]), rot[:, k])
        out[:, mj] = Q.qmul(Q.qconj(frame_w), Q.qmul(local, frame_w))
    return out[0] if frame is not None else out
