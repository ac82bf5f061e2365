"""The reference a policy imitates: a motion clip on a ragdoll, as body and joint states.

``ReferenceMotion(ragdoll, motion)`` turns a :class:`~tumble.Motion` into what the
imitation task compares the simulated character with, on the ragdoll's own bodies and
joints: for every clip frame the bodies' centre-of-mass positions, orientations, linear and
angular velocities (world frame, m, m/s, rad/s), the joint coordinates exactly as
``World.joint_quat``, ``joint_q`` and ``joint_qd`` read them, and the character's centre of
mass. :meth:`ReferenceMotion.sample` interpolates all of it at any time, for many worlds at
once (a compiled kernel).

Cycles. A walking clip holds one gait cycle whose last frame is almost, but not exactly, its
first (the course's ``walk_forward.bvh``: the best match, frame 96 of 100, still differs by
up to 0.13 rad at a joint). With ``loop=True`` the cycle end is the frame whose pose is
closest to the first, and the mismatch of every joint rotation (the root's included) and of
the root height is spread linearly over the cycle, so frame K equals frame 0 but for the
root's horizontal displacement over a cycle, ``cycle_offset``. Played past its end, the
cycle repeats shifted by that offset, as DeepMimic's cyclic clips do: the character walks
on instead of jumping back.
"""
import numpy as np
from numba import njit

from ..errors import ModelError
from ..io.bvh import Motion
from ..math import quat_np as Q
from ..character.pose import _body_poses, _motion_index, _skeleton_globals, rest_alignment
from ..character.ragdoll import Ragdoll

__all__ = ["ReferenceMotion", "ReferenceFrames", "cycle_end_frame", "lowest_points"]

# Where the cycle end is looked for: the last part of the clip (fraction of its frames).
_LOOP_SEARCH_FROM = 0.6


def cycle_end_frame(motion, up=1):
    """Frame K (> 0) whose pose is closest to frame 0: the sum over joints of the angle
    between local rotations, the root's turn about the vertical axis ``up`` (index: 1 for
    Y up, 2 for Z up) left out (a cycle may turn the walker). Looked for in the last 40% of
    the clip."""
    lr = motion.local_rotations
    F = motion.num_frames
    if F < 3:
        raise ModelError(f"ReferenceMotion: a looped clip needs at least 3 frames, got {F}")
    first = max(int(F * _LOOP_SEARCH_FROM), 2)
    root = motion.root
    cost = np.zeros(F)
    for k in range(first, F):
        d = np.abs(np.sum(lr[0] * lr[k], axis=-1))
        ang = 2.0 * np.arccos(np.clip(d, 0.0, 1.0))
        ang[root] = 0.0
        cost[k] = ang.sum() + _tilt_difference(lr[0, root], lr[k, root], up)
    cost[:first] = np.inf
    return int(np.argmin(cost))


def _tilt_difference(qa, qb, up):
    """Angle between the two root orientations once their turn about the vertical axis
    ``up`` is removed (the vertical seen in each)."""
    e = np.zeros(3)
    e[up] = 1.0
    a = Q.qrot(Q.qconj(qa), e)
    b = Q.qrot(Q.qconj(qb), e)
    return float(np.arccos(np.clip(np.dot(a, b), -1.0, 1.0)))


def _close_cycle(motion, K, up):
    """Local rotations (K + 1, J, 4) and root positions (K + 1, 3) of frames 0..K with the
    mismatch of frame K against frame 0 spread over the cycle, and the horizontal cycle
    offset (3,) (zero along the vertical axis ``up``)."""
    lr = motion.local_rotations[:K + 1].copy()
    root_pos = motion.root_positions[:K + 1].copy()
    # delta turns frame K's rotations onto frame 0's: lr0 = delta lrK
    delta = Q.qmul(lr[0], Q.qconj(lr[K]))
    alpha = (np.arange(K + 1) / K)[:, None, None]
    ident = np.broadcast_to(Q.IDENTITY, delta.shape)
    lr = Q.qmul(Q.qslerp(ident[None], delta[None], alpha), lr)
    lr[K] = lr[0]
    root_pos[:, up] += (root_pos[0, up] - root_pos[K, up]) * np.arange(K + 1) / K
    offset = root_pos[K] - root_pos[0]
    offset[up] = 0.0
    root_pos[K] = root_pos[0] + offset
    return lr, root_pos, offset


def lowest_points(model, body_pos, body_quat, up):
    """(F,) height along axis ``up`` of the lowest point of the colliding geoms (sphere,
    capsule, box, cylinder) of the model's bodies, for F poses ``body_pos`` (F, nb, 3) and
    ``body_quat`` (F, nb, 4) (COM frames, world)."""
    from ..model.model import GEOM_TYPES
    low = np.full(len(body_pos), np.inf)
    for g in range(model.ngeom):
        b = model.geom_body[g]
        if b < 0 or (model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0):
            continue
        centre = body_pos[:, b] + Q.qrot(body_quat[:, b], model.geom_pos[g])
        rot = Q.qmul(body_quat[:, b], model.geom_quat[g])
        size = model.geom_size[g]
        kind = model.geom_type[g]
        # the geom's local axes seen along the vertical: their up components (F, 3)
        axes_up = np.stack([Q.qrot(rot, e)[:, up] for e in np.eye(3)], axis=-1)
        if kind == GEOM_TYPES["sphere"]:
            reach = np.full(len(centre), size[0])
        elif kind == GEOM_TYPES["capsule"]:
            reach = size[0] + size[1] * np.abs(axes_up[:, 2])
        elif kind == GEOM_TYPES["box"]:
            reach = np.abs(axes_up) @ size[:3]
        elif kind == GEOM_TYPES["cylinder"]:
            tilt = np.sqrt(np.clip(1.0 - axes_up[:, 2] ** 2, 0.0, 1.0))
            reach = size[1] * np.abs(axes_up[:, 2]) + size[0] * tilt
        else:
            continue
        low = np.minimum(low, centre[:, up] - reach)
    return low


class ReferenceFrames:
    """Reference states at frames 0..K (K + 1 entries; frame K is the next cycle's frame 0
    when looped). Arrays, world frame:

    body_pos (K+1, nb, 3) m, body_quat (K+1, nb, 4) xyzw, body_vel (K+1, nb, 3) m/s,
    body_angvel (K+1, nb, 3) rad/s: every model body of the ragdoll, in model body order;
    joint_quat (K+1, nj, 4), joint_q (K+1, nj, 3), joint_qd (K+1, nj, 3): what
    ``World.joint_quat``/``joint_q``/``joint_qd`` read in that state;
    com_pos, com_vel (K+1, 3): the character's centre of mass and its velocity.
    """

    def __init__(self, body_pos, body_quat, body_vel, body_angvel, joint_quat, joint_q,
                 joint_qd, com_pos, com_vel):
        self.body_pos, self.body_quat = body_pos, body_quat
        self.body_vel, self.body_angvel = body_vel, body_angvel
        self.joint_quat, self.joint_q, self.joint_qd = joint_quat, joint_q, joint_qd
        self.com_pos, self.com_vel = com_pos, com_vel
        for a in vars(self).values():
            a.setflags(write=False)


class ReferenceMotion:
    """A motion clip played on a ragdoll: reference states at any time.

    ragdoll : the :class:`~tumble.Ragdoll` (its model's bodies are all the ragdoll's; a
        ground geom may follow).
    motion : a :class:`~tumble.Motion` with every joint of the ragdoll (matched by name).
    loop : True to close the clip into a cycle (see the module docs), False to play it once,
        or an int K to end the cycle at frame K.
    ground : place the clip on the ground (the plane through the origin normal to gravity):
        in every frame whose lowest colliding point (of the ragdoll's geoms) is below it, the
        whole character is lifted by that much. A mocap skeleton's feet rarely match its
        ragdoll's foot boxes: the course walk's stance foot is 0 to 4 cm inside the ground,
        which the contacts would push out at every start. Frames in the air (a run's flight)
        are left as they are. ``ground_lift`` (K+1,) holds the lifts (m).

    Attributes: ``frame_time`` (s), ``num_frames`` (K: frames of one cycle, or of the clip
    minus one when not looped), ``period`` (s, K frame times), ``cycle_offset`` (3,) m,
    ``frames`` (:class:`ReferenceFrames`), ``looped``, ``cycle_end`` (the clip frame the
    cycle ends at).
    """

    def __init__(self, ragdoll, motion, *, loop=True, ground=True):
        where = "ReferenceMotion"
        if not isinstance(ragdoll, Ragdoll):
            raise ModelError(f"{where}: needs a tumble Ragdoll, got {type(ragdoll).__name__}")
        if not isinstance(motion, Motion):
            raise ModelError(f"{where}: needs a tumble Motion, got {type(motion).__name__}")
        model = ragdoll.model
        if ragdoll.root != "floating":
            raise ModelError(f"{where}: the ragdoll's root must be 'floating' to imitate a "
                             f"moving clip, got '{ragdoll.root}'")
        if len(ragdoll.body_index) != model.nbody:
            raise ModelError(f"{where}: every body of the model must belong to the ragdoll "
                             f"({model.nbody} bodies, {len(ragdoll.body_index)} in the ragdoll)")
        idx = _motion_index(ragdoll, motion, where)          # names every missing joint
        F = motion.num_frames
        # the clip is in the ragdoll's world frame (pose transfer maps frames one to one):
        # up is against the model's gravity
        self.up = int(np.argmax(np.abs(model.gravity))) if np.any(model.gravity) else 1
        if isinstance(loop, bool):
            self.looped = loop
            K = cycle_end_frame(motion, self.up) if loop else F - 1
        elif isinstance(loop, (int, np.integer)) and 1 <= int(loop) < F:
            self.looped, K = True, int(loop)
        else:
            raise ModelError(f"{where}: loop must be True, False or a frame in [1, {F}), "
                             f"got {loop!r}")
        if K < 1:
            raise ModelError(f"{where}: the clip needs at least 2 frames, got {F}")
        self.ragdoll, self.motion = ragdoll, motion
        self.frame_time = float(motion.frame_time)
        self.num_frames = K
        self.cycle_end = K
        self.period = K * self.frame_time
        if self.looped:
            lr, root_pos, offset = _close_cycle(motion, K, self.up)
        else:
            lr = motion.local_rotations[:K + 1]
            root_pos = motion.root_positions[:K + 1]
            offset = np.zeros(3)
        self.cycle_offset = offset
        clip = Motion.from_arrays(motion.joint_names, motion.parents, motion.offsets, lr,
                                  frame_time=motion.frame_time, root_positions=root_pos)
        self.clip = clip
        frames = np.arange(K + 1)
        rot, pos = _skeleton_globals(ragdoll, clip, frames, rest_alignment(ragdoll, clip), idx)
        x_s, q_s = _body_poses(ragdoll, rot, pos)            # ragdoll slot order
        nb = model.nbody
        x = np.empty((K + 1, nb, 3))
        q = np.empty((K + 1, nb, 4))
        x[:, ragdoll.body_index] = x_s
        q[:, ragdoll.body_index] = q_s
        self.ground_lift = np.zeros(K + 1)
        if ground:
            self.ground_lift = np.maximum(-lowest_points(model, x, q, self.up), 0.0)
            if self.looped:          # frame K is frame 0 of the next cycle
                self.ground_lift[K] = self.ground_lift[0]
            x[:, :, self.up] += self.ground_lift[:, None]
        # make consecutive quaternions share a hemisphere so interpolation takes the short arc
        for k in range(1, K + 1):
            flip = np.sum(q[k] * q[k - 1], axis=-1) < 0.0
            q[k, flip] *= -1.0
        v, w = self._velocities(x, q)
        joint_quat, joint_q, joint_qd = self._joint_coordinates(x, q, v, w)
        mass = model.body_mass
        com = np.einsum("b,fbi->fi", mass, x) / mass.sum()
        com_vel = np.einsum("b,fbi->fi", mass, v) / mass.sum()
        self.frames = ReferenceFrames(x, q, v, w, joint_quat, joint_q, joint_qd, com, com_vel)
        self.total_mass = float(mass.sum())

    def _velocities(self, x, q):
        """Central differences over frames; around a loop the neighbours of frames 0 and K
        come from the cycle shifted by the offset, else one-sided at the ends."""
        K, h = self.num_frames, self.frame_time
        if self.looped:
            prev_x = np.concatenate([x[K - 1:K] - self.cycle_offset, x[:-1]])
            next_x = np.concatenate([x[1:], x[1:2] + self.cycle_offset])
            prev_q = np.concatenate([q[K - 1:K], q[:-1]])
            next_q = np.concatenate([q[1:], q[1:2]])
            span = np.full(K + 1, 2.0 * h)
        else:
            prev_x = np.concatenate([x[:1], x[:-1]])
            next_x = np.concatenate([x[1:], x[-1:]])
            prev_q = np.concatenate([q[:1], q[:-1]])
            next_q = np.concatenate([q[1:], q[-1:]])
            span = np.full(K + 1, 2.0 * h)
            span[0] = span[-1] = h
        v = (next_x - prev_x) / span[:, None, None]
        # left increment next = d prev: its rotation vector over the span is the world angular velocity
        w = Q.qrotvec(Q.qmul(next_q, Q.qconj(prev_q))) / span[:, None, None]
        return v, w

    def _joint_coordinates(self, x, q, v, w):
        """joint_quat, joint_q, joint_qd of every frame, by the world's own kernel."""
        from ..pipeline.joints.rows import joint_coordinates
        m = self.ragdoll.model
        n = len(x)
        jq = np.zeros((n, m.njoint, 3))
        jqd = np.zeros((n, m.njoint, 3))
        jquat = np.zeros((n, m.njoint, 4))
        qn = q / np.linalg.norm(q, axis=-1, keepdims=True)
        for f in range(n):
            joint_coordinates(m.arrays, np.ascontiguousarray(x[f]), np.ascontiguousarray(qn[f]),
                              np.ascontiguousarray(v[f]), np.ascontiguousarray(w[f]),
                              jq[f], jqd[f], jquat[f])
        for k in range(1, n):
            flip = np.sum(jquat[k] * jquat[k - 1], axis=-1) < 0.0
            jquat[k, flip] *= -1.0
        return jquat, jq, jqd

    @property
    def duration(self):
        """Length (s) of the clip as played: inf when looped."""
        return np.inf if self.looped else self.period

    def sample(self, times, out=None):
        """Reference states at ``times`` (n,) s: a :class:`ReferenceSample` of (n, ...) arrays
        (written into ``out`` when given, a ReferenceSample of the same n)."""
        t = np.ascontiguousarray(times, dtype=np.float64).reshape(-1)
        if out is None:
            out = ReferenceSample.empty(len(t), self.ragdoll.model)
        f = self.frames
        sample_reference(t, self.frame_time, self.num_frames, self.looped, self.cycle_offset,
                         f.body_pos, f.body_quat, f.body_vel, f.body_angvel, f.joint_quat,
                         f.joint_q, f.joint_qd, f.com_pos, f.com_vel,
                         out.body_pos, out.body_quat, out.body_vel, out.body_angvel,
                         out.joint_quat, out.joint_q, out.joint_qd, out.com_pos, out.com_vel)
        return out

    def __repr__(self):
        kind = f"looped, cycle of {self.num_frames} frames" if self.looped else "played once"
        return (f"<tumble.rl.ReferenceMotion: {kind}, {self.period:.3g} s, cycle offset "
                f"{np.round(self.cycle_offset, 3).tolist()} m>")


class ReferenceSample:
    """Reference states of n worlds (see :class:`ReferenceFrames` for the fields, with a
    leading axis of n instead of frames)."""

    __slots__ = ("body_pos", "body_quat", "body_vel", "body_angvel", "joint_quat", "joint_q",
                 "joint_qd", "com_pos", "com_vel")

    def __init__(self, **arrays):
        for k in self.__slots__:
            setattr(self, k, arrays[k])

    @classmethod
    def empty(cls, n, model):
        nb, nj = model.nbody, model.njoint
        return cls(body_pos=np.zeros((n, nb, 3)), body_quat=np.zeros((n, nb, 4)),
                   body_vel=np.zeros((n, nb, 3)), body_angvel=np.zeros((n, nb, 3)),
                   joint_quat=np.zeros((n, nj, 4)), joint_q=np.zeros((n, nj, 3)),
                   joint_qd=np.zeros((n, nj, 3)), com_pos=np.zeros((n, 3)),
                   com_vel=np.zeros((n, 3)))


@njit(cache=True)
def _nlerp(a, b, s, out):
    """Normalised linear interpolation of two quaternions (same hemisphere) into ``out``."""
    n = 0.0
    for c in range(4):
        out[c] = (1.0 - s) * a[c] + s * b[c]
        n += out[c] * out[c]
    n = 1.0 / np.sqrt(n)
    for c in range(4):
        out[c] *= n


@njit(cache=True)
def sample_reference(t, frame_time, K, looped, offset, body_pos, body_quat, body_vel,
                     body_angvel, joint_quat, joint_q, joint_qd, com_pos, com_vel,
                     o_body_pos, o_body_quat, o_body_vel, o_body_angvel, o_joint_quat,
                     o_joint_q, o_joint_qd, o_com_pos, o_com_vel):
    """Interpolate the reference frames (K + 1, ...) at times ``t`` (n,) into the outputs
    (n, ...): linear in positions, velocities and hinge coordinates, normalised linear in
    quaternions; a looped clip repeats shifted by ``offset`` each cycle, a clip played once
    holds its last frame."""
    period = K * frame_time
    nb = body_pos.shape[1]
    nj = joint_quat.shape[1]
    for w in range(t.shape[0]):
        tw = t[w]
        cycle = 0.0
        if looped:
            cycle = np.floor(tw / period)
            tw = tw - cycle * period
        f = tw / frame_time
        if f < 0.0:
            f = 0.0
        i = int(np.floor(f))
        if i >= K:
            i = K - 1
            s = 1.0
        else:
            s = f - i
        for b in range(nb):
            for c in range(3):
                o_body_pos[w, b, c] = ((1.0 - s) * body_pos[i, b, c] + s * body_pos[i + 1, b, c]
                                       + cycle * offset[c])
                o_body_vel[w, b, c] = (1.0 - s) * body_vel[i, b, c] + s * body_vel[i + 1, b, c]
                o_body_angvel[w, b, c] = ((1.0 - s) * body_angvel[i, b, c]
                                          + s * body_angvel[i + 1, b, c])
            _nlerp(body_quat[i, b], body_quat[i + 1, b], s, o_body_quat[w, b])
        for j in range(nj):
            for c in range(3):
                o_joint_q[w, j, c] = (1.0 - s) * joint_q[i, j, c] + s * joint_q[i + 1, j, c]
                o_joint_qd[w, j, c] = (1.0 - s) * joint_qd[i, j, c] + s * joint_qd[i + 1, j, c]
            _nlerp(joint_quat[i, j], joint_quat[i + 1, j], s, o_joint_quat[w, j])
        for c in range(3):
            o_com_pos[w, c] = (1.0 - s) * com_pos[i, c] + s * com_pos[i + 1, c] + cycle * offset[c]
            o_com_vel[w, c] = (1.0 - s) * com_vel[i, c] + s * com_vel[i + 1, c]
