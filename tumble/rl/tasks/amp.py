"""Adversarial motion priors (AMP, Peng et al. 2021): a steerable character in the style of
a set of clips, on batched worlds.

``AMPEnv(num_envs, clips)`` makes N copies of a character (the GAMES-105 course ragdoll by
default) walk and run where a command says, in the style of motion clips (the course's
walk, run and idle by default). The environment gives the *task* reward and, for every
step, the transition the discriminator judges; the *style* reward comes from the
discriminator, which the trainer owns (``tumble.rl.amp``).

Observation (float32, D = 1 + 15 nb + 3), in the character's heading frame: the root's
height, every body's position, rotation (6-D), linear and angular velocity as in the
imitation task, then the command: cos and sin of the commanded heading relative to the
character's, and the commanded speed (m/s).

Action (float32, in [-1, 1]^A): PD servo targets of the actuated joints, turned from the
clips' mean pose by ``action_scale`` rad per unit (``q_mean * exp(scale a)`` for a ball
joint, ``angle_mean + scale a`` for a hinge). The servos are the world's implicit PD with
DeepMimic's per-joint gains scaled to the character, as in the imitation task.

Task reward (``task_reward="vector"``): ``exp(-task_scale |v - v* d*|^2)``, v the centre of
mass's horizontal velocity, d* the commanded direction, v* the commanded speed (the whole
vector also asks the character to stop drifting sideways); ``task_reward="along"``: AMP's
target-heading reward, ``exp(-task_scale max(0, v* - d*.v)^2)``, only the speed along d*,
under which walking the wrong way is never worse than standing still (under "vector",
standing, 0.21 at 1.25 m/s, beats walking 90 degrees off, 0.04: a policy that cannot yet
turn learns to stand); ``task_reward="speed"``: ``exp(-task_scale (v* - d*.v)^2)``, the speed
along d* matched both ways (as "along", walking 90 degrees off earns what standing does, but
going faster than commanded costs as much as going slower: under "along" a policy that
walks at one brisk pace meets every slower command). Commands change at random times:
every ``command_seconds`` (a range, s) the heading turns by up to ``max_turn`` rad and a
new speed is drawn from ``speed_range``.

Discriminator observation of a transition (s, s'), ``info["amp_obs"]`` (N, 2F) after every
step (the ended episode's last transition for worlds that were reset): see
:func:`tumble.rl.kernels.amp_features` (root height, rotation and velocities in the heading
frame, joint rotations and rates, end-effector positions). :meth:`AMPEnv.reference_transitions`
draws the same from the clips. Two things the character cannot show are kept out of it, or
the discriminator tells it from the clips at once and its style reward says nothing: the
joints named in ``amp_exclude`` (the toes: the course's clips hold them still, while the
simulated toes flex against the ground at every step), and the clips' hinge rotations off
their axis (a clip's knee turns a little about other axes too; the simulated hinge cannot):
a hinge is seen by its angle, about its joint frame's x axis, on both sides.

Episodes start in a random frame of a random clip (reference state initialisation), turned
to a random heading; they end early when a body other than the feet touches the ground (or
the root sinks below ``min_root_height``), and are cut at ``episode_seconds``.
"""
import math

import numpy as np

from ...errors import ModelError
from ...character.ragdoll import Ragdoll, games105_ragdoll
from ...math import quat_np as Q
from ..env import BatchedEnv, check_task_settings
from ..kernels import (AMP_JOINT_FEATURES, AMP_ROOT_FEATURES, BODY_OBS, HEADING_REWARD_MODES,
                       amp_features, fallen, heading_command, heading_reward, observe,
                       pd_targets)
from ..reference import ReferenceMotion, ReferenceSample
from .imitation import _body_set, action_layout, deepmimic_gains, load_clip

__all__ = ["AMPEnv", "DEFAULT_CLIPS", "TASK_REWARD_TERMS"]

DEFAULT_CLIPS = ("walk", "run", "idle")
TASK_REWARD_TERMS = ("task",)

# where the root's angular velocity (heading frame) sits in a state's features (amp_features)
AMP_ROOT_ANGVEL = AMP_ROOT_FEATURES - 3


def _check_range(where, name, value, low=0.0):
    try:
        a, b = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: {name} must be a (low, high) pair, got {value!r}") from None
    if not (np.isfinite(a) and np.isfinite(b) and low <= a <= b):
        raise ModelError(f"{where}: {name} must be finite with {low} <= low <= high, got "
                         f"{value!r}")
    return a, b


class AMPEnv(BatchedEnv):
    """N steerable copies of a character in the style of clips (see the module docs).

    num_envs : worlds stepped together.
    clips : course clip names, BVH paths or Motions (default: walk, run, idle).
    ragdoll : the character (default ``tumble.games105_ragdoll("floating")``).
    control_hz, physics_hz, contact : policy and physics rates and the contact model.
    episode_seconds : time limit of an episode (s).
    action_scale : rad per unit action (scalar or one per component).
    speed_range : commanded speeds (m/s) drawn uniformly; command_seconds : (low, high) s
        between command changes; max_turn : largest heading change of a command (rad).
    task_scale : the task reward's scale (s^2/m^2); task_reward : "vector", "along" or "speed"
        (the module docs).
    end_effectors, contact_bodies, min_root_height : as in the imitation task.
    holdout : the fraction at the end of every clip kept out of
        ``reference_transitions`` (for measuring the discriminator on unseen frames).
    amp_exclude : name fragments of joints the discriminator does not see (module docs).
    turn_rate : the clips' transitions are shown to the discriminator as if walked along a
        curve: a yaw rate drawn uniformly from [-turn_rate, turn_rate] rad/s is added to the
        root's angular velocity about the vertical (the only feature a steady turn about the
        root changes: everything else is in the heading frame). The course's clips go
        straight ahead; without it turning looks unlike them. 0: as recorded.
    projection_tolerance, seed, autoreset, parallel : as in the imitation task.
    """

    def __init__(self, num_envs=1, clips=DEFAULT_CLIPS, *, ragdoll=None, control_hz=30,
                 physics_hz=60, contact="lcp", episode_seconds=20.0, action_scale=1.0,
                 speed_range=(0.4, 2.2), command_seconds=(2.0, 5.0), max_turn=math.pi,
                 task_scale=1.0, task_reward="vector", end_effectors=None, contact_bodies=None,
                 min_root_height=0.3, holdout=0.1, amp_exclude=("toe",), turn_rate=0.8,
                 projection_tolerance=1e-3, seed=None, autoreset=True, parallel=None):
        where = "AMPEnv"
        check_task_settings(where, num_envs, control_hz, physics_hz, episode_seconds)
        if isinstance(clips, (str, bytes)) or not hasattr(clips, "__len__") or len(clips) == 0:
            raise ModelError(f"{where}: clips must be a non-empty list of clip names, BVH paths "
                             f"or Motions, got {clips!r}")
        self.speed_range = _check_range(where, "speed_range", speed_range)
        self.command_seconds = _check_range(where, "command_seconds", command_seconds)
        if self.command_seconds[0] <= 0:
            raise ModelError(f"{where}: command_seconds must be > 0, got {command_seconds!r}")
        if not (np.isfinite(max_turn) and 0 <= max_turn <= math.pi):
            raise ModelError(f"{where}: max_turn must be in [0, pi] rad, got {max_turn!r}")
        if not (np.isfinite(task_scale) and task_scale > 0):
            raise ModelError(f"{where}: task_scale must be > 0, got {task_scale!r}")
        if task_reward not in HEADING_REWARD_MODES:
            raise ModelError(f"{where}: task_reward must be one of {HEADING_REWARD_MODES}, "
                             f"got {task_reward!r}")
        self.task_reward = task_reward
        if not (np.isfinite(holdout) and 0 <= holdout < 1):
            raise ModelError(f"{where}: holdout must be in [0, 1), got {holdout!r}")
        if not (np.isfinite(turn_rate) and 0 <= turn_rate <= 10):
            raise ModelError(f"{where}: turn_rate must be in [0, 10] rad/s, got {turn_rate!r}")
        self.turn_rate = float(turn_rate)
        self.max_turn, self.task_scale, self.holdout = float(max_turn), float(task_scale), \
            float(holdout)
        self.ragdoll = games105_ragdoll("floating") if ragdoll is None else ragdoll
        if not isinstance(self.ragdoll, Ragdoll):
            raise ModelError(f"{where}: ragdoll must be a tumble Ragdoll, got "
                             f"{type(self.ragdoll).__name__}")
        self.clip_names = [c if isinstance(c, str) else str(getattr(c, "name", f"clip{i}"))
                           for i, c in enumerate(clips)]
        self.references = [ReferenceMotion(self.ragdoll, load_clip(c), loop=True)
                           for c in clips]
        model = self.ragdoll.model
        self.model = model
        self.control_hz, self.physics_hz = int(control_hz), int(physics_hz)
        self.up = self.references[0].up
        self.root = int(self.ragdoll.body_index[self.ragdoll.slot_of_joint[
            self.ragdoll.skeleton.root]])
        self.dof_joint, self.dof_kind, self.dof_start, A = action_layout(model)
        self.action_size = A
        self.observation_size = 1 + BODY_OBS * model.nbody + 3
        scale = np.broadcast_to(np.asarray(action_scale, float), (A,)).copy()
        if not np.all(np.isfinite(scale)) or np.any(scale <= 0):
            raise ModelError(f"{where}: action_scale must be > 0 and finite")
        self.action_scale = scale
        kp, kd, _, _ = deepmimic_gains(self.ragdoll)
        self.kp, self.kd = kp, kd
        ee = _body_set(self.ragdoll, end_effectors, ("wrist", "hand", "ankle", "foot"),
                       "end_effectors")
        self.end_effectors = np.flatnonzero(ee).astype(np.int64)
        self.allowed_contacts = _body_set(self.ragdoll, contact_bodies, ("ankle", "foot", "toe"),
                                          "contact_bodies")
        self.min_root_height = float(min_root_height)
        try:
            self.amp_exclude = tuple(str(f) for f in amp_exclude)
            fragments = [f.lower() for f in self.amp_exclude]
        except TypeError:
            raise ModelError(f"{where}: amp_exclude must be a list of joint name fragments, "
                             f"got {amp_exclude!r}") from None
        self.amp_joints = np.array([j for j in self.dof_joint if not any(
            f in model.joint_names[j].lower() for f in fragments)], np.int64)
        if len(self.amp_joints) == 0:
            raise ModelError(f"{where}: amp_exclude {amp_exclude!r} leaves the discriminator "
                             f"no joint to see")
        self.amp_hinges = np.array([j for j in self.amp_joints
                                    if model.joint_type_names[j] == "hinge"], np.int64)
        self.amp_feature_size = (AMP_ROOT_FEATURES + AMP_JOINT_FEATURES * len(self.amp_joints)
                                 + 3 * len(self.end_effectors))
        self.amp_observation_size = 2 * self.amp_feature_size
        self._mean_quat, self._mean_q = self._mean_pose()
        self.forward = self._forward_angle()
        world = self.ragdoll.make_world(dt=1.0 / physics_hz, contact=contact, nworld=int(num_envs),
                                        parallel=parallel,
                                        projection_tolerance=projection_tolerance)
        world.joint_kp = kp
        world.joint_kd = kd
        N = int(num_envs)
        self.target_heading = np.zeros(N)
        self.target_speed = np.zeros(N)
        self.command_timer = np.zeros(N)
        self.commands_change = True
        self.com_velocity = np.zeros((N, 3))
        self._task = np.zeros(N)
        self._feat_prev = np.zeros((N, self.amp_feature_size), np.float32)
        self._feat_next = np.zeros((N, self.amp_feature_size), np.float32)
        self._ref_quat = np.ascontiguousarray(np.broadcast_to(self._mean_quat,
                                                              (N,) + self._mean_quat.shape))
        self._ref_q = np.ascontiguousarray(np.broadcast_to(self._mean_q, (N,) + self._mean_q.shape))
        self.episode_seconds = float(episode_seconds)
        super().__init__(world, substeps=physics_hz // control_hz,
                         max_episode_steps=max(1, int(round(episode_seconds * control_hz))),
                         seed=seed, autoreset=autoreset)
        self._view_character(where)

    def _mean_pose(self):
        """Every joint's mean local rotation (nj, 4) and coordinates (nj, 3) over all frames
        of all clips: the pose the actions turn from."""
        quats = np.concatenate([r.frames.joint_quat for r in self.references])
        qs = np.concatenate([r.frames.joint_q for r in self.references])
        sign = np.where(np.sum(quats * quats[:1], axis=-1, keepdims=True) < 0, -1.0, 1.0)
        mean = (quats * sign).sum(axis=0)
        norm = np.linalg.norm(mean, axis=-1, keepdims=True)
        mean = np.where(norm > 1e-9, mean / np.maximum(norm, 1e-300), [0.0, 0.0, 0.0, 1.0])
        return np.ascontiguousarray(mean), np.ascontiguousarray(qs.mean(axis=0))

    def _forward_angle(self):
        """The angle (rad about the vertical) from the root body's x axis to the direction
        the clips move in, in the root's heading frame: the course skeleton's pelvis x axis
        points sideways, so a character's heading is its root's turned by this much."""
        total = np.zeros(3)
        for ref in self.references:
            f = ref.frames
            feats = np.empty((len(f.body_pos), self.amp_feature_size), np.float32)
            amp_features(f.body_pos, f.body_quat, f.body_vel, f.body_angvel, f.joint_quat,
                         f.joint_qd, self.root, self.up, self.amp_joints, self.end_effectors,
                         feats)
            total += feats[:, 7:10].sum(axis=0)       # root velocity in its heading frame
        if np.hypot(*np.delete(total, self.up)) < 1e-6:
            return 0.0
        if self.up == 1:
            return float(np.arctan2(-total[2], total[0]))
        return float(np.arctan2(total[1], total[0]))

    # -- commands ------------------------------------------------------------------------
    @property
    def heading(self):
        """(N,) the characters' headings: where they face and walk (rad about the
        vertical; 0 is +x, and pi/2 is -z for Y up, +y for Z up)."""
        x = Q.qrot(self._quat[:, self.root], np.array([1.0, 0.0, 0.0]))
        if self.up == 1:
            h = np.arctan2(-x[:, 2], x[:, 0])
        else:
            h = np.arctan2(x[:, 1], x[:, 0])
        return np.angle(np.exp(1j * (h + self.forward)))

    def set_command(self, heading=None, speed=None, worlds=None, *, relative=False):
        """Command a heading (rad; with ``relative`` added to the character's own) and a
        speed (m/s) to some worlds (indices or a mask; all by default). Scalars or (k,)
        arrays. Set ``commands_change = False`` to stop the random command changes.
        Returns the observations (N, D) with the new command."""
        idx = np.arange(self.num_envs) if worlds is None else np.asarray(worlds)
        if idx.dtype == np.bool_:
            idx = np.flatnonzero(idx)
        if heading is not None:
            h = np.asarray(heading, float)
            if not np.all(np.isfinite(h)):
                raise ModelError(f"AMPEnv.set_command: heading must be finite, got {heading!r}")
            self.target_heading[idx] = h + (self.heading[idx] if relative else 0.0)
        if speed is not None:
            v = np.asarray(speed, float)
            if not np.all(np.isfinite(v)) or np.any(v < 0):
                raise ModelError(f"AMPEnv.set_command: speed must be finite and >= 0, got "
                                 f"{speed!r}")
            self.target_speed[idx] = v
        self._observe(self._obs)
        return self._obs.copy()

    def _draw_commands(self, idx, rng, base_heading):
        n = len(idx)
        self.target_heading[idx] = base_heading + rng.uniform(-self.max_turn, self.max_turn, n)
        self.target_speed[idx] = rng.uniform(*self.speed_range, n)
        self.command_timer[idx] = rng.uniform(*self.command_seconds, n)

    # -- task hooks ----------------------------------------------------------------------
    def _observe(self, obs):
        observe(self._pos, self._quat, self._vel, self._angvel, self.root, self.up,
                np.zeros(self.num_envs), False, obs)
        heading_command(self._quat, self.root, self.up, self.forward, self.target_heading,
                        self.target_speed, obs, self.observation_size - 3)

    def _features(self, out):
        amp_features(self._pos, self._quat, self._vel, self._angvel, self._joint_quat,
                     self._joint_qd, self.root, self.up, self.amp_joints, self.end_effectors, out)

    def _advance(self):
        if not self.commands_change:
            return
        self.command_timer -= self.dt
        due = np.flatnonzero(self.command_timer <= 0.0)
        if len(due):
            self._draw_commands(due, self.rng, self.target_heading[due])

    def _act(self, actions):
        self._features(self._feat_prev)
        pd_targets(actions, self.action_scale, True, self.dof_joint, self.dof_kind,
                   self.dof_start, self._ref_quat, self._ref_q, self._target_quat, self._target_q)

    def _evaluate(self, reward, terminated):
        self._features(self._feat_next)
        heading_reward(self._vel, self.model.body_mass, self.up, self.target_heading,
                       self.target_speed, self.task_scale,
                       HEADING_REWARD_MODES.index(self.task_reward), reward,
                       self.com_velocity)
        self._task[:] = reward
        ground = np.reshape(self.world.ground_contacts(), (self.num_envs, self.model.nbody))
        fallen(ground, self.allowed_contacts, self.root, self.up, self._pos,
               self.min_root_height, terminated)

    def step(self, actions):
        """As :meth:`BatchedEnv.step`; ``info["amp_obs"]`` (N, 2F) float32 holds every
        world's transition of this step (before any reset)."""
        obs, reward, terminated, truncated, info = super().step(actions)
        info["amp_obs"] = np.concatenate([self._feat_prev, self._feat_next], axis=1)
        self.step_amp_obs = info["amp_obs"]
        return obs, reward, terminated, truncated, info

    def _restart(self, worlds, rng):
        """Reference state initialisation: a random frame of a random clip, turned about
        the vertical to a random heading and put over the origin; the servos aimed at the
        clip's pose; a fresh random command."""
        worlds = np.asarray(worlds, np.int64)
        n = len(worlds)
        which = rng.integers(0, len(self.references), n)
        t = np.array([rng.uniform(0.0, self.references[k].period) for k in which])
        yaw = rng.uniform(-math.pi, math.pi, n)
        s = self._sample_clips(which, t)
        _turn(s, yaw, self.up, self.root)
        self.world.set_body_state(s.body_pos, s.body_quat, s.body_vel, s.body_angvel,
                                  worlds=worlds)
        self._target_quat[worlds] = s.joint_quat
        self._target_q[worlds] = s.joint_q
        self._draw_commands(worlds, rng, self.heading[worlds])

    def _sample_clips(self, which, times):
        """Reference states (a ReferenceSample of len(which)) of clip ``which[i]`` at
        ``times[i]``."""
        out = ReferenceSample.empty(len(which), self.model)
        for k, ref in enumerate(self.references):
            sel = np.flatnonzero(which == k)
            if len(sel):
                s = ref.sample(times[sel])
                for name in ReferenceSample.__slots__:
                    getattr(out, name)[sel] = getattr(s, name)
        return out

    # -- the clips' side of the discriminator ----------------------------------------------
    def reference_transitions(self, n, rng, *, held_out=False):
        """(n, 2F) float32 transitions (s, s') drawn from the clips (each clip equally
        likely, a uniform time within it; s' one policy step later), each turned at a random
        yaw rate up to ``turn_rate``. ``held_out``: only from the last ``holdout`` fraction
        of each clip (else only from the rest)."""
        which = rng.integers(0, len(self.references), n)
        periods = np.array([r.period for r in self.references])[which]
        u = rng.uniform(0.0, 1.0, n)
        if held_out:
            frac = (1.0 - self.holdout) + self.holdout * u
        else:
            frac = (1.0 - self.holdout) * u
        t = frac * periods
        out = np.empty((n, self.amp_observation_size), np.float32)
        F = self.amp_feature_size
        for part, dt in ((slice(0, F), 0.0), (slice(F, 2 * F), self.dt)):
            s = self._sample_clips(which, t + dt)
            self._hinges_on_axis(s)
            feats = np.empty((n, F), np.float32)
            amp_features(s.body_pos, s.body_quat, s.body_vel, s.body_angvel, s.joint_quat,
                         s.joint_qd, self.root, self.up, self.amp_joints, self.end_effectors,
                         feats)
            out[:, part] = feats
        if self.turn_rate > 0:
            yaw_rate = rng.uniform(-self.turn_rate, self.turn_rate, n).astype(np.float32)
            out[:, AMP_ROOT_ANGVEL + self.up] += yaw_rate
            out[:, F + AMP_ROOT_ANGVEL + self.up] += yaw_rate
        return out

    def _hinges_on_axis(self, s):
        """A ReferenceSample's hinge joints (in place) turned about their axis only, by their
        angle: what a simulated hinge can show (its joint frame's x axis)."""
        for j in self.amp_hinges:
            half = 0.5 * s.joint_q[:, j, 0]
            s.joint_quat[:, j] = 0.0
            s.joint_quat[:, j, 0] = np.sin(half)
            s.joint_quat[:, j, 3] = np.cos(half)
            s.joint_qd[:, j, 1:] = 0.0

    # -- reading -------------------------------------------------------------------------
    def clip_joint_speed(self):
        """RMS (rad/s) of the discriminator's joints' rates over every frame of the clips
        (hinges about their axis only, as the discriminator sees them): the figure to
        hold a policy's joint speeds (``evaluate_amp``'s ``joint_speed``) against."""
        hinge = np.isin(self.amp_joints, self.amp_hinges)
        total, count = 0.0, 0
        for ref in self.references:
            qd = np.array(ref.frames.joint_qd[:, self.amp_joints])
            qd[:, hinge, 1:] = 0.0
            total += float((qd ** 2).sum())
            count += qd.shape[0] * qd.shape[1]
        return float(np.sqrt(total / max(count, 1)))

    def direction(self, heading):
        """Unit horizontal vectors (n, 3) of headings (n,) rad (see ``heading``)."""
        h = np.asarray(heading, float)
        d = np.zeros(h.shape + (3,))
        d[..., 0] = np.cos(h)
        if self.up == 1:
            d[..., 2] = -np.sin(h)
        else:
            d[..., 1] = np.sin(h)
        return d

    @property
    def reward_terms(self):
        """(N, 1) the last step's task reward."""
        return self._task[:, None].copy()

    reward_term_names = TASK_REWARD_TERMS

    def spec(self):
        """What a policy trained here depends on (saved with it, checked on load)."""
        m = self.model
        return {
            "task": "amp", "clips": list(self.clip_names),
            "body_names": list(m.body_names), "joint_names": list(m.joint_names),
            "total_mass": float(m.body_mass.sum()),
            "observation_size": int(self.observation_size), "action_size": int(self.action_size),
            "amp_observation_size": int(self.amp_observation_size),
            "amp_exclude": list(self.amp_exclude), "turn_rate": self.turn_rate,
            "task_reward": self.task_reward,
            "control_hz": self.control_hz, "physics_hz": self.physics_hz,
            "action_scale": self.action_scale.tolist(), "contact": self.world.contact,
            "projection_tolerance": float(self.world.options.projection_tolerance),
        }


def _turn(s, yaw, up, root):
    """Turn reference states (a ReferenceSample, in place) about the vertical axis through
    each world's root by ``yaw`` (n,) rad, and move the root over the origin."""
    axis = np.zeros(3)
    axis[up] = 1.0
    q = np.zeros((len(yaw), 4))
    q[:, :3] = axis * np.sin(0.5 * yaw)[:, None]
    q[:, 3] = np.cos(0.5 * yaw)
    qb = q[:, None, :]
    centre = s.body_pos[:, root:root + 1].copy()
    centre[..., up] = 0.0
    s.body_pos[:] = Q.qrot(qb, s.body_pos - centre)
    s.body_quat[:] = Q.qmul(qb, s.body_quat)
    s.body_vel[:] = Q.qrot(qb, s.body_vel)
    s.body_angvel[:] = Q.qrot(qb, s.body_angvel)
    c = s.com_pos - centre[:, 0]
    s.com_pos[:] = Q.qrot(q, c)
    s.com_vel[:] = Q.qrot(q, s.com_vel)
