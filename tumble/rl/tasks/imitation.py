"""DeepMimic-style motion imitation (Peng et al. 2018) on batched worlds.

``ImitationEnv(num_envs, clip)`` makes N copies of a character (the GAMES-105 course
ragdoll by default) follow a motion clip. Per policy step (30 Hz by default, over physics at
60 Hz: 2 physics steps in one ``World.step`` call):

Observation (float32, D = 1 + 15 nb + 2), in the character's heading frame (see
``tumble.rl.kernels``): the root body's height; for every body, its position relative to the
root, its rotation as two axes (6-D tangent-normal), its linear and angular velocity; then
sin and cos of the clip's phase.

Action (float32, in [-1, 1]^A): PD servo targets of the actuated joints, in model joint
order: 3 components for a ball joint (a rotation vector in its joint frame), 1 for a hinge
(its angle), 2 for a universal joint; multiplied by ``action_scale`` (rad). With
``residual=True`` (the default) the target is the clip's own joint rotation at the end of
the policy step, turned by the action (``q_ref * exp(scale a)``, ``angle_ref + scale a``):
the policy learns corrections to the clip rather than the whole pose, which is what makes
imitation trainable in hours on two cores. ``residual=False`` makes the action the absolute
target, as DeepMimic's. The servos are the world's implicit PD (stable at any gain at
60 Hz) with DeepMimic's per-joint gains scaled to the character (:func:`deepmimic_gains`).

Reward: DeepMimic's imitation terms, ``r = sum_k w_k exp(-s_k err_k)`` (see
``tumble.rl.kernels.imitation_reward`` for the errors), with DeepMimic's weights and scales:

=============  ======  =====
term           weight  scale
=============  ======  =====
pose           0.5     2
velocity       0.05    0.1
end effectors  0.15    40
root           0.2     5
centre of mass 0.1     10
=============  ======  =====

The reward is 1 when the character is exactly on the reference.

Episodes start at a random phase of the clip in its pose and velocity (reference state
initialisation), end early when a body other than the feet touches the ground (or the root
sinks below ``min_root_height``), and are cut at ``episode_seconds``.
"""
from pathlib import Path

import numpy as np

from ...errors import ModelError
from ...io.bvh import Motion, load_bvh
from ...character.ragdoll import Ragdoll, games105_ragdoll
from ...data.games105 import CLIPS, clip_path
from ..env import BatchedEnv, check_task_settings
from ..kernels import (BODY_OBS, DOF_BALL, DOF_HINGE, DOF_UNIVERSAL, fallen, imitation_reward,
                       observe, pd_targets)
from ..reference import ReferenceMotion, ReferenceSample

__all__ = ["ImitationEnv", "deepmimic_gains", "REWARD_WEIGHTS", "REWARD_SCALES",
           "action_layout", "load_clip"]

# DeepMimic's imitation reward (SceneImitate): pose, velocity, end effectors, root, COM.
REWARD_TERMS = ("pose", "velocity", "end_effector", "root", "com")
REWARD_WEIGHTS = (0.5, 0.05, 0.15, 0.2, 0.1)
REWARD_SCALES = (2.0, 0.1, 40.0, 5.0, 10.0)

# DeepMimic's humanoid (humanoid3d): per joint role, the PD stiffness kp (N m/rad), the
# torque limit (N m) and the pose-error weight; kd = kp / 10. Its humanoid weighs 45 kg;
# the gains are scaled by the character's mass over that.
DEEPMIMIC_MASS = 45.0
_ROLES = (  # (name fragments, kp, torque limit, pose weight)
    (("hip", "thigh", "upleg"), 500.0, 200.0, 0.5),
    (("knee", "shin", "leg"), 500.0, 150.0, 0.3),
    (("ankle", "foot"), 400.0, 90.0, 0.2),
    (("toe",), 200.0, 45.0, 0.1),
    (("clavicle", "collar"), 400.0, 100.0, 0.2),
    (("shoulder", "upperarm", "arm"), 400.0, 100.0, 0.3),
    (("elbow", "forearm"), 300.0, 60.0, 0.2),
    (("wrist", "hand"), 100.0, 30.0, 0.1),
    (("neck", "head"), 100.0, 50.0, 0.3),
    (("spine", "back", "chest", "torso", "abdomen", "pelvis", "waist"), 1000.0, 200.0, 0.5),
)
_DEFAULT_ROLE = (300.0, 100.0, 0.2)
ROOT_POSE_WEIGHT = 1.0


def _role(name):
    n = name.lower()
    for fragments, kp, limit, weight in _ROLES:
        if any(f in n for f in fragments):
            return kp, limit, weight
    return _DEFAULT_ROLE


def deepmimic_gains(ragdoll, scale=None):
    """Per model joint (nj,): kp (N m/rad), kd (N m s/rad), max torque (N m) and pose weight,
    from DeepMimic's humanoid gains by joint role (hip, knee, ankle, spine, ...: matched on
    the joint's name), scaled by ``scale`` (default: the character's mass / 45 kg). The
    root's free joint and joints without a degree of freedom get zeros."""
    m = ragdoll.model
    if scale is None:
        scale = float(m.body_mass.sum()) / DEEPMIMIC_MASS
    kp = np.zeros(m.njoint)
    limit = np.full(m.njoint, np.inf)
    weight = np.zeros(m.njoint)
    for j, (name, kind) in enumerate(zip(m.joint_names, m.joint_type_names)):
        if kind not in ("ball", "hinge", "universal"):
            continue
        k, lim, w = _role(name)
        kp[j], limit[j], weight[j] = k * scale, lim * scale, w
    return kp, kp / 10.0, limit, weight


def action_layout(model, joints=None):
    """The action components of each actuated joint: arrays (dof_joint, dof_kind, dof_start)
    over the actuated joints in model order (ball 3, hinge 1, universal 2 components), and
    the action size. ``joints``: a mask (nj,) of the joints to actuate (default: every ball,
    hinge and universal joint)."""
    kinds = {"ball": (DOF_BALL, 3), "hinge": (DOF_HINGE, 1), "universal": (DOF_UNIVERSAL, 2)}
    dof_joint, dof_kind, dof_start = [], [], []
    start = 0
    for j, kind in enumerate(model.joint_type_names):
        if kind not in kinds or (joints is not None and not joints[j]):
            continue
        code, n = kinds[kind]
        dof_joint.append(j)
        dof_kind.append(code)
        dof_start.append(start)
        start += n
    return (np.array(dof_joint, np.int64), np.array(dof_kind, np.int64),
            np.array(dof_start, np.int64), start)


def load_clip(clip):
    """A Motion from a course clip name ('walk', 'run', 'idle'), a BVH path or a Motion."""
    if isinstance(clip, Motion):
        return clip
    if isinstance(clip, str) and clip in CLIPS:
        return load_bvh(clip_path(clip))
    if isinstance(clip, (str, Path)):
        return load_bvh(clip)
    raise ModelError(f"imitation: clip must be a course clip name {sorted(CLIPS)}, a BVH path "
                     f"or a tumble Motion, got {type(clip).__name__}")


def _body_set(ragdoll, names, default_fragments, what):
    """(nb,) mask of model bodies by name (default: names containing a fragment)."""
    m = ragdoll.model
    if names is None:
        return np.array([any(f in n.lower() for f in default_fragments) for n in m.body_names])
    mask = np.zeros(m.nbody, np.bool_)
    for n in names:
        mask[m.body_index(n)] = True        # ModelError names an unknown body
    return mask


class ImitationEnv(BatchedEnv):
    """N copies of a character imitating a clip (see the module docs).

    num_envs : worlds stepped together (``World(nworld=num_envs)``, on all threads).
    clip : a course clip name ('walk', the default; 'run'; 'idle'), a BVH path or a Motion.
    ragdoll : the character (default ``tumble.games105_ragdoll()``); its joints must be in
        the clip (matched by name).
    loop : close the clip into a cycle (True), play it once (False), or end the cycle at a
        given frame (see ``ReferenceMotion``).
    control_hz, physics_hz : policy and physics rates; physics_hz must be a multiple.
    contact : the world's contact model: 'lcp' (the default, as the trainer's and the shipped
        policies'; about 5x the samples/s of 'pgs' on a walking character), 'pgs', 'penalty'.
    episode_seconds : time limit of an episode (s).
    residual, action_scale : see the module docs; action_scale is rad per unit action (a
        scalar or one per action component).
    gains : None for :func:`deepmimic_gains`, or (kp, kd, max_torque) arrays (nj,).
    torque_limits : bound the servo torques by the gains' max_torque. Off by default: the
        residual action already bounds how far a target strays from the clip, and bounded
        servo rows leave the step's fast path (about 5x slower a step today).
    reward_weights, reward_scales : the five terms' (see ``REWARD_TERMS``).
    end_effectors : body names (default: wrists and ankles).
    contact_bodies : bodies allowed to touch the ground (default: ankles, feet and toes).
    min_root_height : the episode ends if the root body falls below it (m).
    random_start : reference state initialisation at a random phase (else phase 0).
    seed : seed of the start states; autoreset: Gymnasium's same-step autoreset.
    projection_tolerance : the world's option of that name (m or rad,
        ``World(projection_tolerance=...)``): joints are projected back together once they
        drift apart by more than this. 1 mm here against the World's default 0.05 mm: at
        60 Hz a swinging limb drifts by about a millimetre a step, and projecting to 0.05 mm
        then costs two Gauss-Newton iterations nearly every step (30% of a walking step).
    """

    def __init__(self, num_envs=1, clip="walk", *, ragdoll=None, loop=True, control_hz=30,
                 physics_hz=60, contact="lcp", episode_seconds=10.0, residual=True,
                 action_scale=0.5, gains=None, torque_limits=False, reward_weights=REWARD_WEIGHTS,
                 reward_scales=REWARD_SCALES, end_effectors=None, contact_bodies=None,
                 min_root_height=0.3, random_start=True, projection_tolerance=1e-3, seed=None,
                 autoreset=True, parallel=None):
        where = "ImitationEnv"
        check_task_settings(where, num_envs, control_hz, physics_hz, episode_seconds)
        self.ragdoll = games105_ragdoll("floating") if ragdoll is None else ragdoll
        if not isinstance(self.ragdoll, Ragdoll):
            raise ModelError(f"{where}: ragdoll must be a tumble Ragdoll, got "
                             f"{type(self.ragdoll).__name__}")
        self.motion = load_clip(clip)
        self.clip_name = clip if isinstance(clip, str) else getattr(clip, "name", "motion")
        self.reference = ReferenceMotion(self.ragdoll, self.motion, loop=loop)
        model = self.ragdoll.model
        self.model = model
        self.control_hz, self.physics_hz = int(control_hz), int(physics_hz)
        self.up = self.reference.up
        self.root = int(self.ragdoll.body_index[self.ragdoll.slot_of_joint[
            self.ragdoll.skeleton.root]])
        self.dof_joint, self.dof_kind, self.dof_start, A = action_layout(model)
        self.action_size = A
        self.observation_size = 1 + BODY_OBS * model.nbody + 2
        scale = np.broadcast_to(np.asarray(action_scale, float), (A,)).copy()
        if not np.all(np.isfinite(scale)) or np.any(scale <= 0):
            raise ModelError(f"{where}: action_scale must be > 0 and finite")
        self.action_scale = scale
        self.residual = bool(residual)
        kp, kd, limit, weight = deepmimic_gains(self.ragdoll)
        if gains is not None:
            kp, kd, limit = (np.broadcast_to(np.asarray(g, float), (model.njoint,)).copy()
                             for g in gains)
        if not torque_limits:
            limit = np.full(model.njoint, np.inf)
        self.kp, self.kd, self.max_torque = kp, kd, limit
        total = weight.sum() + ROOT_POSE_WEIGHT
        self.joint_weight = weight / total
        self.root_weight = ROOT_POSE_WEIGHT / total
        self.reward_weights = np.asarray(reward_weights, float)
        self.reward_scales = np.asarray(reward_scales, float)
        if self.reward_weights.shape != (5,) or self.reward_scales.shape != (5,):
            raise ModelError(f"{where}: reward_weights and reward_scales need 5 values "
                             f"({', '.join(REWARD_TERMS)})")
        self.reward_weights = self.reward_weights / self.reward_weights.sum()
        ee = _body_set(self.ragdoll, end_effectors, ("wrist", "hand", "ankle", "foot"),
                       "end_effectors")
        self.end_effectors = np.flatnonzero(ee).astype(np.int64)
        self.allowed_contacts = _body_set(self.ragdoll, contact_bodies, ("ankle", "foot", "toe"),
                                          "contact_bodies")
        self.min_root_height = float(min_root_height)
        self.random_start = bool(random_start)
        world = self.ragdoll.make_world(dt=1.0 / physics_hz, contact=contact, nworld=int(num_envs),
                                        parallel=parallel,
                                        projection_tolerance=projection_tolerance)
        world.joint_kp = kp
        world.joint_kd = kd
        world.joint_max_torque = limit
        N = int(num_envs)
        self.ref_time = np.zeros(N)
        self._ref = ReferenceSample.empty(N, model)
        self._terms = np.zeros((N, 5))
        self._fallen = np.zeros(N, np.bool_)
        self.episode_seconds = float(episode_seconds)
        super().__init__(world, substeps=physics_hz // control_hz,
                         max_episode_steps=max(1, int(round(episode_seconds * control_hz))),
                         seed=seed, autoreset=autoreset)
        self._view_character(where)

    # -- task hooks --------------------------------------------------------------------
    @property
    def phase(self):
        """(N,) clip phase of every world, in cycles (0..1 over the clip or one cycle)."""
        p = self.ref_time / self.reference.period
        return p - np.floor(p) if self.reference.looped else np.minimum(p, 1.0)

    def _observe(self, obs):
        observe(self._pos, self._quat, self._vel, self._angvel, self.root, self.up,
                self.phase, True, obs)

    def _advance(self):
        self.ref_time += self.dt
        self.reference.sample(self.ref_time, out=self._ref)

    def _act(self, actions):
        r = self._ref
        pd_targets(actions, self.action_scale, self.residual, self.dof_joint, self.dof_kind,
                   self.dof_start, r.joint_quat, r.joint_q, self._target_quat, self._target_q)

    def _evaluate(self, reward, terminated):
        r = self._ref
        imitation_reward(self._pos, self._quat, self._vel, self._angvel, self._joint_quat,
                         self._joint_qd, r.body_pos, r.body_quat, r.body_vel, r.body_angvel,
                         r.joint_quat, r.joint_qd, r.com_vel, self.model.body_mass, self.root,
                         self.up, self.joint_weight, self.root_weight, self.end_effectors,
                         self.reward_weights, self.reward_scales, reward, self._terms)
        ground = np.reshape(self.world.ground_contacts(), (self.num_envs, self.model.nbody))
        fallen(ground, self.allowed_contacts, self.root, self.up, self._pos,
               self.min_root_height, terminated)

    def _time_up(self):
        if self.reference.looped:
            return np.zeros(self.num_envs, np.bool_)
        return self.ref_time >= self.reference.period - 1e-9

    def _restart(self, worlds, rng):
        """Reference state initialisation: each world at a random phase of the clip (or
        its start), in the clip's pose and velocity, servos aimed at the clip's pose."""
        n = len(worlds)
        if self.random_start:
            span = self.reference.period if self.reference.looped else \
                max(self.reference.period - self.dt, 0.0)
            t0 = rng.uniform(0.0, span, n)
        else:
            t0 = np.zeros(n)
        self.ref_time[worlds] = t0
        s = self.reference.sample(t0)
        self.world.set_body_state(s.body_pos, s.body_quat, s.body_vel, s.body_angvel,
                                  worlds=worlds)
        self._target_quat[worlds] = s.joint_quat
        self._target_q[worlds] = s.joint_q
        for name in ReferenceSample.__slots__:
            getattr(self._ref, name)[worlds] = getattr(s, name)

    # -- reading -----------------------------------------------------------------------
    @property
    def reward_terms(self):
        """(N, 5) the last step's reward terms, each exp(-scale err) in [0, 1], in the
        order of ``REWARD_TERMS``."""
        return self._terms.copy()

    reward_term_names = REWARD_TERMS

    def reference_sample(self):
        """The reference states at the worlds' current clip times (a ReferenceSample)."""
        return self.reference.sample(self.ref_time)

    def body_position_error(self):
        """(N, nb) distance (m) of every body from the clip's, both relative to their root
        body: the imitation error the README reports."""
        r = self.reference.sample(self.ref_time)
        sim = self._pos - self._pos[:, self.root:self.root + 1]
        ref = r.body_pos - r.body_pos[:, self.root:self.root + 1]
        return np.linalg.norm(sim - ref, axis=-1)

    def spec(self):
        """What a policy trained here depends on (saved with it, checked on load)."""
        m = self.model
        return {
            "task": "imitate", "clip": str(self.clip_name),
            "clip_frames": int(self.motion.num_frames), "cycle_end": int(self.reference.cycle_end),
            "body_names": list(m.body_names), "joint_names": list(m.joint_names),
            "total_mass": float(m.body_mass.sum()),
            "observation_size": int(self.observation_size), "action_size": int(self.action_size),
            "control_hz": self.control_hz, "physics_hz": self.physics_hz,
            "residual": self.residual, "action_scale": self.action_scale.tolist(),
            "contact": self.world.contact,
            "projection_tolerance": float(self.world.options.projection_tolerance),
        }
