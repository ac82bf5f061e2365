"""Training: PPO from rsl-rl (``pip install "tumble[rl]"``) on tumble's batched tasks.

Why rsl-rl: it is the PPO that Isaac Lab trains its locomotion policies with, written for
many environments stepped as one batch (tensors of all worlds in, no per-world loop), small
(a few thousand lines), with observation normalisation and an adaptive learning rate. skrl
(which also has AMP) was the other candidate; its generic memory and wrapper layers cost
more per step on two cores, and its AMP expects its own environment wrappers. What rsl-rl
does not provide is written here: the bridge from tumble's NumPy arrays to its TensorDicts
(zero-copy ``torch.from_numpy``), the training loop with a progress bar, CSV (and
TensorBoard when installed) logs, periodic evaluation, checkpoints that resume from the
learner's whole state (networks, normalisers, optimiser, counters and random generators;
the episodes in flight start afresh), and the export of the actor to a PyTorch-free policy file (:class:`tumble.rl.policy.Policy`).

Files written to ``out_dir``: ``checkpoint.pt`` (everything needed to resume: networks,
optimiser, iteration, samples, wall time, random generators' states, configuration),
``policy.npz`` (the latest actor), ``best.npz`` (the actor of the best evaluation),
``progress.csv`` (one row per iteration), ``eval.csv`` (one row per evaluation) and
``tb/`` (TensorBoard, if installed).
"""
import csv
import dataclasses
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ModelError
from .policy import Policy
from .tasks.amp import DEFAULT_CLIPS, AMPEnv
from .tasks.imitation import ImitationEnv

try:
    import torch
    from tensordict import TensorDict
    from rsl_rl.algorithms import PPO
    from rsl_rl.env import VecEnv
except ImportError as exc:          # the optional extra is missing
    raise ImportError('tumble.rl.train needs PyTorch and rsl-rl: pip install "tumble[rl]"') \
        from exc

__all__ = ["TrainConfig", "Trainer", "evaluate", "train"]


# AMPEnv settings a run's spec may lack, with what runs from before them had: all joints seen
# by the discriminator, clips shown as recorded
_AMP_SETTINGS_BEFORE = {"amp_exclude": (), "turn_rate": 0.0}


@dataclass
class TrainConfig:
    """Everything a training run depends on (saved in its checkpoint).

    Environment: clip, num_envs, control_hz, physics_hz, contact, episode_seconds, residual,
    action_scale, env_kwargs (more ImitationEnv keywords).
    PPO (rsl-rl): steps_per_env (rollout length), epochs, minibatches, learning_rate (adaptive
    by the KL to ``desired_kl``), gamma, lam, clip, entropy_coef, init_std, hidden (MLP
    sizes of actor and critic), activation, learn_std (False: the action noise stays at
    init_std, as the AMP paper keeps it; learnt, it shrank from 0.05 to 0.02 in the AMP
    fine-tune, but held at 0.05 the discriminator's reward on the policy fell from 0.33 to
    0.10 within 50 iterations, so it stays learnt by default). Why the small learning rate:
    with 45 action dimensions at a standard deviation of 0.3, one Adam step of 3e-4 moves
    the policy by a KL of 0.6 (measured on the walk), 30x the target; near 1e-5 the KL of a
    whole update (20 minibatch steps) is about 0.03, the trust region PPO wants (AMP uses
    2e-5).
    Run: iterations, save_every, eval_every (iterations), eval_episodes, eval_seconds, seed,
    threads (PyTorch's CPU threads; Numba's step uses all of its own).
    AMP (task "amp", see ``tumble.rl.amp``): clips (default walk, run, idle), task_weight and
    style_weight (the reward's mix), disc_hidden, disc_learning_rate, disc_batches,
    disc_batch_size, gp_weight, replay_size. ``clip`` and ``residual`` are imitation's only.
    """
    task: str = "imitate"
    clip: str = "walk"
    num_envs: int = 128
    control_hz: int = 30
    physics_hz: int = 60
    contact: str = "lcp"
    episode_seconds: float = 10.0
    residual: bool = True
    action_scale: float = 0.5
    env_kwargs: dict = field(default_factory=dict)
    steps_per_env: int = 32
    epochs: int = 5
    minibatches: int = 4
    learning_rate: float = 1e-5
    desired_kl: float = 0.02
    gamma: float = 0.95
    lam: float = 0.95
    clip_param: float = 0.2
    entropy_coef: float = 0.0
    init_std: float = 0.3
    learn_std: bool = True
    hidden: tuple = (512, 256)
    activation: str = "elu"
    iterations: int = 1000
    save_every: int = 20
    eval_every: int = 50
    eval_episodes: int = 32
    eval_seconds: float = 20.0
    seed: int = 0
    threads: int = 2
    clips: tuple = ()
    task_weight: float = 0.5
    style_weight: float = 0.5
    disc_hidden: tuple = (512, 256)
    disc_learning_rate: float = 1e-4
    disc_batches: int = 8
    disc_batch_size: int = 512
    gp_weight: float = 5.0
    replay_size: int = 100_000
    init_from: str = ""
    clone_samples: int = 200_000
    clone_noise: float = 0.1
    clone_epochs: int = 30
    critic_warmup: int = 0

    @classmethod
    def for_task(cls, task, **overrides):
        """The defaults of a task ('imitate' or 'amp') with ``overrides``."""
        if task == "amp":
            # a small action noise: the discriminator tells jittering joints from the
            # clips' at once (AMP keeps its policy's standard deviation at 0.055 rad)
            base = dict(task="amp", clips=DEFAULT_CLIPS, num_envs=256, action_scale=1.0,
                        init_std=0.1, learning_rate=2e-5, gp_weight=10.0, eval_seconds=60.0,
                        eval_episodes=16)
            if overrides.get("init_from"):
                # fine-tuning a cloned walk: less noise and smaller steps than from scratch
                # (with the defaults it fell apart within 100 iterations), the critic
                # trained alone first, a slower discriminator
                base.update(init_std=0.05, desired_kl=0.01, critic_warmup=40,
                            disc_learning_rate=5e-5)
        elif task == "imitate":
            base = {}
        else:
            raise ModelError(f"train: unknown task {task!r} (known: 'imitate', 'amp')")
        base.update(overrides)
        return cls(**base)

    def env_options(self):
        opts = dict(control_hz=self.control_hz, physics_hz=self.physics_hz,
                    contact=self.contact, action_scale=self.action_scale, **self.env_kwargs)
        if self.task != "amp":
            opts["residual"] = self.residual
        return opts

    def to_dict(self):
        d = dataclasses.asdict(self)
        for k in ("hidden", "disc_hidden", "clips"):
            d[k] = list(d[k])
        return d

    @classmethod
    def from_dict(cls, d):
        d = dict(d)
        for k in ("hidden", "disc_hidden", "clips"):
            d[k] = tuple(d.get(k, getattr(cls, k)))
        known = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in d.items() if k in known})


class _TorchVecEnv(VecEnv):
    """rsl-rl's view of a tumble BatchedEnv: observations as a TensorDict group 'policy'
    (shared memory with the NumPy arrays), time-outs in ``extras`` for bootstrapping, the
    reward terms' means in ``extras['log']``."""

    def __init__(self, env, episode_steps):
        self.env = env
        self.num_envs = env.num_envs
        self.num_actions = env.action_size
        self.max_episode_length = episode_steps
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long)
        self.device = "cpu"
        self.cfg = {}
        self._obs = None

    def _wrap(self, obs):
        return TensorDict({"policy": torch.from_numpy(obs)}, batch_size=[self.num_envs])

    def reset(self):
        self._obs = self.env.reset()
        return self._wrap(self._obs)

    def get_observations(self):
        if self._obs is None:
            return self.reset()
        return self._wrap(self._obs)

    def step(self, actions):
        obs, reward, terminated, truncated, info = self.env.step(actions.numpy())
        self._obs = obs
        self.last_info = info
        self.episode_length_buf = torch.from_numpy(self.env.episode_steps)
        dones = torch.from_numpy(terminated | truncated)
        terms = self.env.reward_terms
        extras = {"time_outs": torch.from_numpy(truncated),
                  "log": {f"/reward/{n}": float(terms[:, k].mean())
                          for k, n in enumerate(self.env.reward_term_names)}}
        return (self._wrap(obs), torch.from_numpy(reward.astype(np.float32)), dones, extras)


def _make_env(config, num_envs, *, seed, episode_seconds, autoreset=True):
    if config.task == "amp":
        return AMPEnv(num_envs, list(config.clips or DEFAULT_CLIPS),
                      episode_seconds=episode_seconds, seed=seed, autoreset=autoreset,
                      **config.env_options())
    if config.task != "imitate":
        raise ModelError(f"train: unknown task {config.task!r} (known: 'imitate', 'amp')")
    return ImitationEnv(num_envs, config.clip, episode_seconds=episode_seconds, seed=seed,
                        autoreset=autoreset, **config.env_options())


def export_policy(alg, spec, info=None):
    """The deterministic actor of an rsl-rl PPO as a :class:`Policy`."""
    actor = alg.get_policy()
    layers = [m for m in actor.mlp if isinstance(m, torch.nn.Linear)]
    norm = actor.obs_normalizer
    if isinstance(norm, torch.nn.Identity):
        D = layers[0].in_features
        mean, std, eps = np.zeros(D), np.ones(D), 0.0
    else:
        mean = norm._mean.squeeze(0).double().numpy()
        std = norm._std.squeeze(0).double().numpy()
        eps = float(norm.eps)
    act = type(actor.mlp[1]).__name__.lower()
    return Policy([l.weight.detach().double().numpy() for l in layers],
                  [l.bias.detach().double().numpy() for l in layers], act, mean, std, eps,
                  spec, info)


def evaluate(policy, config=None, *, episodes=32, seconds=20.0, seed=12345, env=None):
    """Roll ``policy`` (a :class:`Policy`) out from random clip phases until every world's
    first episode ends (a fall or ``seconds``). Returns a dict: survived (fraction of
    episodes that reached the time limit), mean_seconds (time before the end), mean_error
    (m, root-relative body position error over all steps of all episodes while alive),
    body_error (per body, m), mean_reward (per step)."""
    if env is None:
        env = _make_env(config, episodes, seed=seed, episode_seconds=seconds)
    policy.check(env.spec())
    obs = env.reset(seed=seed)
    N = env.num_envs
    active = np.ones(N, np.bool_)
    survived = np.zeros(N, np.bool_)
    alive_steps = np.zeros(N)
    err_sum = np.zeros(env.model.nbody)
    err_count = 0
    rew_sum, rew_count = 0.0, 0
    for _ in range(env.max_episode_steps + 1):
        obs, reward, terminated, truncated, info = env.step(policy.act(obs))
        err = env.body_position_error()
        live = active & ~info["done"]
        err_sum += err[live].sum(axis=0)
        err_count += int(live.sum())
        rew_sum += float(reward[active].sum())
        rew_count += int(active.sum())
        alive_steps[active] += 1
        survived |= active & truncated
        active &= ~info["done"]
        if not active.any():
            break
    body_error = err_sum / max(err_count, 1)
    return {"survived": float(survived.mean()), "mean_seconds": float(alive_steps.mean() * env.dt),
            "mean_error": float(body_error.mean()), "body_error": body_error.tolist(),
            "mean_reward": rew_sum / max(rew_count, 1), "episodes": N}



def algorithm_config(c):
    """rsl-rl's configuration of PPO and its networks for a TrainConfig."""
    return {
        "num_steps_per_env": c.steps_per_env, "obs_groups": {"actor": ["policy"],
                                                             "critic": ["policy"]},
        "multi_gpu": None,
        "algorithm": {"class_name": "PPO", "num_learning_epochs": c.epochs,
                      "num_mini_batches": c.minibatches, "learning_rate": c.learning_rate,
                      "schedule": "adaptive", "desired_kl": c.desired_kl, "gamma": c.gamma,
                      "lam": c.lam, "clip_param": c.clip_param,
                      "entropy_coef": c.entropy_coef, "max_grad_norm": 1.0,
                      "value_loss_coef": 1.0, "use_clipped_value_loss": True},
        "actor": {"class_name": "MLPModel", "hidden_dims": list(c.hidden),
                  "activation": c.activation, "obs_normalization": True,
                  "distribution_cfg": {"class_name": "GaussianDistribution",
                                       "init_std": c.init_std, "learn_std": c.learn_std}},
        "critic": {"class_name": "MLPModel", "hidden_dims": list(c.hidden),
                   "activation": c.activation, "obs_normalization": True},
    }


def make_algorithm(c, num_envs, observation_size, action_size):
    """rsl-rl's PPO for ``num_envs`` worlds (its rollout storage holds them all)."""
    import contextlib
    import io
    from types import SimpleNamespace
    obs = TensorDict({"policy": torch.zeros(num_envs, observation_size)},
                     batch_size=[num_envs])
    env = SimpleNamespace(num_envs=num_envs, num_actions=action_size)
    with contextlib.redirect_stdout(io.StringIO()):     # rsl-rl prints the networks
        return PPO.construct_algorithm(obs, env, algorithm_config(c), "cpu")


def make_style(c, env):
    """The AMP discriminator of a run (None for other tasks)."""
    if c.task != "amp":
        return None
    from .amp import AMPStyle
    return AMPStyle(env, task_weight=c.task_weight, style_weight=c.style_weight,
                    hidden=c.disc_hidden, learning_rate=c.disc_learning_rate,
                    batches=c.disc_batches, batch_size=c.disc_batch_size,
                    gp_weight=c.gp_weight, replay_size=c.replay_size, seed=c.seed)


class RolloutStats:
    """What a rollout reports for the log: sums over its steps of the mean reward, of the
    task's reward terms and of the style reward, and the returns and lengths (steps) of
    the episodes that ended in it."""

    def __init__(self, nterms):
        self.steps = 0
        self.parts = 1
        self.reward = 0.0
        self.style = 0.0
        self.terms = np.zeros(nterms)
        self.episode_returns = []
        self.episode_steps = []

    @classmethod
    def merged(cls, parts):
        """One RolloutStats of rollouts of the same steps on equally many worlds each: their
        means averaged, their episodes pooled."""
        out = cls(len(parts[0].terms))
        k = len(parts)
        out.steps, out.parts = parts[0].steps, k
        out.reward = sum(p.reward for p in parts) / k
        out.style = sum(p.style for p in parts) / k
        out.terms = sum(p.terms for p in parts) / k
        for p in parts:
            out.episode_returns += p.episode_returns
            out.episode_steps += p.episode_steps
        return out


def collect_rollout(alg, vec, style, steps, obs):
    """``steps`` policy steps of every world of ``vec`` into ``alg``'s rollout storage
    (the actions sampled by ``alg.act`` from torch's generator; the AMP reward mixed in by
    ``style``). Returns the last observations and a RolloutStats."""
    names = vec.env.reward_term_names
    stats = RolloutStats(len(names))
    with torch.inference_mode():
        for _ in range(steps):
            actions = alg.act(obs)
            obs, reward, dones, extras = vec.step(actions)
            info = vec.last_info
            if style is not None:
                reward = style.combine(reward, info["amp_obs"])
                stats.style += style.last_style
            alg.process_env_step(obs, reward, dones, extras)
            stats.reward += float(reward.mean())
            stats.terms += [extras["log"][f"/reward/{n}"] for n in names]
            if "episode_return" in info:
                done = info["done"]
                stats.episode_returns.extend(info["episode_return"][done].tolist())
                stats.episode_steps.extend(info["episode_steps"][done].tolist())
    stats.steps = steps
    return obs, stats


def warm_up_observations(alg, vec, steps):
    """The observations (steps N, D) of one rollout of the initial policy, for the
    normalisers (see ``Trainer._warm_up_normalizers``)."""
    alg.train_mode()
    seen = []
    with torch.inference_mode():
        obs = vec.get_observations()
        for _ in range(steps):
            seen.append(obs["policy"].clone())
            obs, _, _, _ = vec.step(alg.actor(obs, stochastic_output=True))
    return torch.cat(seen).clone()


def update_normalizers(alg, data):
    """Fold observations (n, D) into the actor's and critic's normalisers."""
    batch = TensorDict({"policy": data}, batch_size=[data.shape[0]])
    alg.actor.update_normalization(batch)
    alg.critic.update_normalization(batch)


class Trainer:
    """A PPO training run in ``out_dir`` (see the module docs); ``run()`` trains,
    ``Trainer(out_dir, resume=True)`` picks a run up from its checkpoint."""

    def __init__(self, out_dir, config=None, *, resume=False, progress=True, log=print,
                 env_overrides=None):
        """``env_overrides`` (resume only): environment settings that replace the run's from
        here on (``{"task_reward": "along"}``); the networks carry over, the critic adapts."""
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.progress = progress
        self.log = log
        ckpt_path = self.out_dir / "checkpoint.pt"
        saved = None
        if resume and ckpt_path.exists():
            saved = torch.load(ckpt_path, weights_only=False, map_location="cpu")
            stored = TrainConfig.from_dict(saved["config"])
            if stored.task == "amp":
                # AMP settings added since a run began resume as that run had them
                for key, before in _AMP_SETTINGS_BEFORE.items():
                    if key not in saved.get("spec", {}) and key not in stored.env_kwargs:
                        stored.env_kwargs[key] = before
            if config is not None:       # iterations and schedule may change on resume
                stored.iterations = config.iterations
                stored.save_every, stored.eval_every = config.save_every, config.eval_every
            if env_overrides:
                stored.env_kwargs = {**stored.env_kwargs, **env_overrides}
            config = stored
        elif resume:
            raise ModelError(f"train: nothing to resume in {str(self.out_dir)!r} (no "
                             f"checkpoint.pt)")
        elif env_overrides:
            raise ModelError("train: env_overrides change a resumed run; give a new run's "
                             "settings in its TrainConfig.env_kwargs")
        self.config = config or TrainConfig()
        c = self.config
        torch.set_num_threads(c.threads)
        torch.manual_seed(c.seed)
        self._make_sampler()
        self.iteration = 0
        self.samples = 0
        self.wall = 0.0
        self.best = -np.inf
        if saved is not None:
            self.alg.load(saved["alg"], None, True)
            self.iteration = saved["iteration"]
            self.samples = saved["samples"]
            self.wall = saved["wall"]
            self.best = saved.get("best", -np.inf)
            if self.style is not None:
                self.style.load_state_dict(saved["style"])
            if self.config.init_from:       # a cloned actor's normaliser stays frozen
                from .clone import freeze_normalizer
                freeze_normalizer(self.alg)
            if not self.config.learn_std:
                self.fix_std(self.config.init_std)
            torch.set_rng_state(saved["torch_rng"])
            self._set_env_rng_state(saved["env_rng"])
            if self.log:
                self.log(f"resumed {self.out_dir} at iteration {self.iteration} "
                         f"({self.samples} samples, {self.wall / 3600:.2f} h)")
        elif c.init_from:
            self._clone_teacher()
        else:
            self._warm_up_normalizers()
        self._writer = None
        try:
            from torch.utils.tensorboard import SummaryWriter
            self._writer = SummaryWriter(str(self.out_dir / "tb"))
        except ImportError:
            pass

    def fix_std(self, std):
        """Hold the policy's action noise at ``std`` (per action dimension) from now on, also
        across resumes: the run's ``learn_std`` becomes False and its ``init_std`` ``std``."""
        if not (std > 0 and math.isfinite(std)):
            raise ModelError(f"train: the action noise must be positive and finite, got {std!r}")
        self.config.learn_std, self.config.init_std = False, float(std)
        dist = self.alg.actor.distribution
        if hasattr(dist, "std_param"):
            param, value = dist.std_param, float(std)
        else:                           # rsl-rl's log-parameterised noise
            param, value = dist.log_std_param, math.log(std)
        with torch.no_grad():
            param.fill_(value)
        param.requires_grad_(False)
        param.grad = None

    def set_gamma(self, gamma, critic_iterations=40):
        """Change the discount from here on (a longer horizon makes falls cost more); the
        critic's values no longer fit the new returns, so for ``critic_iterations`` only the
        critic trains (the actor stays as it was). Kept across resumes."""
        if not (0.0 < gamma < 1.0):
            raise ModelError(f"train: gamma must lie in (0, 1), got {gamma!r}")
        if gamma == self.config.gamma:
            return
        self.config.gamma = self.alg.gamma = float(gamma)
        self.config.critic_warmup = max(self.config.critic_warmup,
                                        self.iteration + int(critic_iterations))

    def _make_sampler(self):
        """The worlds that collect the samples (here, in this process) and the learner."""
        c = self.config
        self.env = _make_env(c, c.num_envs, seed=c.seed, episode_seconds=c.episode_seconds)
        self.vec = _TorchVecEnv(self.env, self.env.max_episode_steps)
        self.style = make_style(c, self.env)
        self.alg = make_algorithm(c, self.env.num_envs, self.env.observation_size,
                                  self.env.action_size)

    def _warm_up_normalizers(self):
        """One rollout of the initial policy fills the observation normalisers before the
        first update: rsl-rl updates them after each update, so the first one would
        otherwise see raw observations (velocities of tens of rad/s) and take a step whose
        KL divergence is 50x the target, which the adaptive learning rate then pays for."""
        update_normalizers(self.alg, warm_up_observations(self.alg, self.vec,
                                                          self.config.steps_per_env))

    def _clone_teacher(self):
        """A fresh run's actor cloned from ``init_from`` (see ``tumble.rl.clone``); the
        critic's normaliser from a rollout of the cloned actor."""
        from .clone import clone_into
        c = self.config
        mse = clone_into(self.alg, self.env, c.init_from, samples=c.clone_samples,
                         noise=c.clone_noise, epochs=c.clone_epochs, seed=c.seed, log=self.log)
        self.clone_error = mse
        data = warm_up_observations(self.alg, self.vec, c.steps_per_env)
        self.alg.critic.update_normalization(TensorDict({"policy": data},
                                                        batch_size=[data.shape[0]]))

    def _collect(self):
        """One rollout into the learner's storage and its returns; a RolloutStats."""
        obs, stats = collect_rollout(self.alg, self.vec, self.style, self.config.steps_per_env,
                                     self.vec.get_observations())
        with torch.inference_mode():
            self.alg.compute_returns(obs)
        return stats

    def _env_rng_state(self):
        return self.env.rng.bit_generator.state

    def _set_env_rng_state(self, state):
        self.env.rng.bit_generator.state = state

    def spec(self):
        s = self.env.spec()
        s["episode_seconds"] = self.config.episode_seconds
        return s

    def policy(self):
        """The current deterministic actor as a Policy."""
        return export_policy(self.alg, self.spec(), {
            "iteration": self.iteration, "samples": self.samples, "wall_hours": self.wall / 3600,
            "trained_with": "rsl-rl PPO", "config": self.config.to_dict()})

    def save(self):
        """checkpoint.pt (atomically) and policy.npz."""
        state = {"alg": self.alg.save(), "iteration": self.iteration, "samples": self.samples,
                 "wall": self.wall, "best": self.best, "config": self.config.to_dict(),
                 "torch_rng": torch.get_rng_state(), "env_rng": self._env_rng_state(),
                 "spec": self.spec()}
        if self.style is not None:
            state["style"] = self.style.state_dict()
        tmp = self.out_dir / "checkpoint.pt.tmp"
        torch.save(state, tmp)
        os.replace(tmp, self.out_dir / "checkpoint.pt")
        self.policy().save(self.out_dir / "policy.npz")

    def _csv(self, name, row):
        path = self.out_dir / name
        fields = list(row)
        new = not path.exists()
        if not new:
            with open(path, newline="") as f:
                old = next(csv.reader(f), [])
            if old != fields:
                # a run resumed by a tumble that logs other columns: the file is rewritten
                # with all of them (blank where a row has none), never misaligned
                fields = old + [k for k in fields if k not in old]
                with open(path, newline="") as f:
                    kept = list(csv.DictReader(f))
                with open(path, "w", newline="") as f:
                    w = csv.DictWriter(f, fieldnames=fields, restval="")
                    w.writeheader()
                    w.writerows(kept)
        with open(path, "a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=fields, restval="")
            if new:
                w.writeheader()
            w.writerow(row)
        if self._writer is not None:
            for k, v in row.items():
                if k not in ("iteration",) and isinstance(v, (int, float)):
                    self._writer.add_scalar(f"{Path(name).stem}/{k}", v, row["iteration"])

    def evaluate(self):
        c = self.config
        if c.task == "amp":
            from .amp_eval import evaluate_amp
            result = evaluate_amp(self.policy(), c, episodes=c.eval_episodes,
                                  seconds=c.eval_seconds, style=self.style)
            score = result["survived"] + result["speed_within"] + result["heading_within"]
        else:
            result = evaluate(self.policy(), c, episodes=c.eval_episodes, seconds=c.eval_seconds)
            score = result["survived"] - result["mean_error"]
        row = {"iteration": self.iteration, "samples": self.samples, "wall_hours": self.wall / 3600,
               **{k: v for k, v in result.items() if not isinstance(v, (list, dict))}}
        self._csv("eval.csv", row)
        if score > self.best:
            self.best = score
            self.policy().save(self.out_dir / "best.npz")
        return result

    def run(self, iterations=None, *, max_hours=None):
        """Train until ``iterations`` (default: the config's) in all, or until this call has
        run ``max_hours`` of wall time (then saves); returns the last evaluation (or None)."""
        c = self.config
        total = c.iterations if iterations is None else iterations
        deadline = None if max_hours is None else time.perf_counter() + 3600.0 * max_hours
        bar = None
        if self.progress:
            try:
                from tqdm import tqdm
                bar = tqdm(total=total, initial=self.iteration, unit="it", dynamic_ncols=True)
            except ImportError:
                bar = None
        self.alg.train_mode()
        last_eval = None
        ep_returns, ep_steps = [], []
        names = self.env.reward_term_names
        while self.iteration < total:
            start = time.perf_counter()
            stats = self._collect()
            ep_returns.extend(stats.episode_returns)
            ep_steps.extend(stats.episode_steps)
            collect = time.perf_counter() - start
            t1 = time.perf_counter()
            frozen = self.iteration < c.critic_warmup
            if frozen:          # the actor (weights, std, normaliser) stays as it was
                actor_state = {k: v.clone() for k, v in self.alg.actor.state_dict().items()}
            losses = self.alg.update()
            if frozen:
                self.alg.actor.load_state_dict(actor_state)
            if self.style is not None:
                losses.update(self.style.update())
            learn = time.perf_counter() - t1
            n = c.steps_per_env * self.alg.storage.num_envs
            self.samples += n
            self.iteration += 1
            self.wall += time.perf_counter() - start
            row = {"iteration": self.iteration, "samples": self.samples,
                   "wall_hours": round(self.wall / 3600, 5),
                   "reward": stats.reward / c.steps_per_env,
                   "episode_return": float(np.mean(ep_returns[-200:])) if ep_returns else np.nan,
                   "episode_seconds": float(np.mean(ep_steps[-200:])) * self.env.dt if ep_steps else np.nan,
                   **{f"r_{name}": stats.terms[k] / c.steps_per_env for k, name in enumerate(names)},
                   **({"r_style": stats.style / c.steps_per_env} if self.style is not None else {}),
                   **{f"loss_{k}": float(v) for k, v in losses.items()},
                   "learning_rate": float(self.alg.learning_rate),
                   "action_std": float(self.alg.get_policy().output_std.detach().mean()),
                   "collect_s": collect, "learn_s": learn, "samples_per_s": n / (collect + learn)}
            ep_returns, ep_steps = ep_returns[-200:], ep_steps[-200:]
            self._csv("progress.csv", row)
            if bar is not None:
                bar.set_postfix(r=f"{row['reward']:.3f}", ep=f"{row['episode_seconds']:.1f}s",
                                sps=f"{row['samples_per_s']:.0f}")
                bar.update(1)
            elif self.log and self.iteration % 10 == 0:
                self.log(f"it {self.iteration}: reward {row['reward']:.3f}, episode "
                         f"{row['episode_seconds']:.1f} s, {row['samples_per_s']:.0f} samples/s")
            out_of_time = deadline is not None and time.perf_counter() > deadline
            if self.iteration % c.save_every == 0 or self.iteration == total or out_of_time:
                self.save()
            if c.eval_every and (self.iteration % c.eval_every == 0 or self.iteration == total):
                last_eval = self.evaluate()
                if c.task == "amp":
                    what = (f"speed error {last_eval['speed_error']:.2f} m/s, "
                            f"{last_eval['speed_within']:.2f} within 0.2, heading "
                            f"{last_eval['heading_within']:.2f} within 3 s")
                else:
                    what = f"error {last_eval['mean_error'] * 1000:.1f} mm"
                self.log(f"eval at {self.iteration}: survived {last_eval['survived']:.2f}, "
                         f"{what}, {last_eval['mean_seconds']:.1f} s")
                self.alg.train_mode()
            if out_of_time:
                break
        if bar is not None:
            bar.close()
        return last_eval


def train(out_dir, config=None, *, resume=False, progress=True, log=print, max_hours=None):
    """Train (or resume) a run in ``out_dir``; returns the Trainer after it finished."""
    t = Trainer(out_dir, config, resume=resume, progress=progress, log=log)
    t.run(max_hours=max_hours)
    return t
