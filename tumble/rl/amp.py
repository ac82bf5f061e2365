"""The adversarial side of AMP (Peng et al. 2021): discriminator, style reward, replay.

The policy is trained by rsl-rl's PPO as in the imitation task (``tumble.rl.train``); this
module adds what no library we use provides in a form that fits tumble's batched worlds
(skrl's AMP wants its own environment wrappers and memory; rsl-rl has none):

- :class:`Discriminator`: an MLP on a transition's features (s, s') (``AMPEnv``'s
  ``amp_obs``), its inputs normalised by running statistics;
- the least-squares GAN objective of AMP: ``(D(clip) - 1)^2 + (D(policy) + 1)^2`` (each
  averaged, halved), a gradient penalty ``gp_weight / 2 * |grad_x D(clip)|^2`` on the clips'
  transitions (it keeps D smooth where the clips are, so the style reward has a slope to
  climb), weight decay and a penalty on the output layer's weights;
- the style reward ``max(0, 1 - 0.25 (D(s, s') - 1)^2)`` in [0, 1];
- a replay of the policy's past transitions (a ring of ``replay_size``), so the
  discriminator does not forget what older policies did.

:class:`AMPStyle` ties them to a training run: ``combine`` turns every step's task reward
into ``task_weight * task + style_weight * style`` and keeps the transitions, ``update``
fits the discriminator after each PPO update and returns its losses for the log.
"""
import numpy as np

try:
    import torch
    from torch import nn
except ImportError as exc:          # the optional extra is missing
    raise ImportError('tumble.rl.amp needs PyTorch: pip install "tumble[rl]"') from exc

__all__ = ["Discriminator", "AMPStyle", "style_reward", "gradient_penalty", "lsgan_loss"]


class RunningNorm(nn.Module):
    """Running mean and variance of inputs (merged batch by batch), applied as
    ``(x - mean) / sqrt(var + eps)``; frozen unless ``update`` is called."""

    def __init__(self, size, eps=1e-4):
        super().__init__()
        self.register_buffer("mean", torch.zeros(size))
        self.register_buffer("var", torch.ones(size))
        self.register_buffer("count", torch.zeros((), dtype=torch.float64))
        self.eps = eps

    @torch.no_grad()
    def update(self, x):
        n = x.shape[0]
        if n == 0:
            return
        mean = x.mean(dim=0)
        var = x.var(dim=0, unbiased=False)
        total = self.count + n
        delta = mean - self.mean
        frac = float(n / total)
        self.mean += delta * frac
        self.var = (self.var * (1 - frac) + var * frac + delta * delta * frac * (1 - frac))
        self.count = total

    def forward(self, x):
        return (x - self.mean) / torch.sqrt(self.var + self.eps)


class Discriminator(nn.Module):
    """D(s, s'): transition features (n, 2F) -> one score each (n,). Hidden layers of
    ``hidden`` units with ReLU, as AMP's (1024, 512) but smaller by default for two cores."""

    def __init__(self, size, hidden=(512, 256)):
        super().__init__()
        self.norm = RunningNorm(size)
        layers, d = [], size
        for h in hidden:
            layers += [nn.Linear(d, h), nn.ReLU()]
            d = h
        self.trunk = nn.Sequential(*layers)
        self.head = nn.Linear(d, 1)

    def forward(self, x, normalized=False):
        """Scores (n,) of raw features (or of already-normalised ones)."""
        if not normalized:
            x = self.norm(x)
        return self.head(self.trunk(x)).squeeze(-1)


def style_reward(scores):
    """AMP's least-squares style reward of discriminator scores: max(0, 1 - (d - 1)^2 / 4),
    in [0, 1]; 1 where D takes the transition for a clip's (d = 1)."""
    return torch.clamp(1.0 - 0.25 * (scores - 1.0) ** 2, min=0.0)


def lsgan_loss(d_clip, d_policy):
    """The least-squares GAN loss: clips scored towards +1, the policy towards -1."""
    return 0.5 * ((d_clip - 1.0) ** 2).mean() + 0.5 * ((d_policy + 1.0) ** 2).mean()


def gradient_penalty(disc, x_normalized):
    """mean over the batch of |grad_x D(x)|^2 at normalised clip transitions (zero for a
    D that does not depend on its input)."""
    x = x_normalized.detach().requires_grad_(True)
    d = disc(x, normalized=True)
    (grad,) = torch.autograd.grad(d.sum(), x, create_graph=True)
    return (grad * grad).sum(dim=-1).mean()


class AMPStyle:
    """The discriminator of a training run and its replay (see the module docs).

    env : the AMPEnv (it draws the clips' transitions).
    task_weight, style_weight : the reward's mix (AMP: 0.5 and 0.5).
    hidden : discriminator layers; learning_rate, weight_decay (Adam's, on all weights),
    logit_weight (penalty on the output layer's weights), gp_weight (gradient penalty);
    batches, batch_size : minibatches per update and their size (policy transitions, half
    from the last rollout and half from the replay, and as many clip transitions);
    replay_size : policy transitions kept.
    """

    def __init__(self, env, *, task_weight=0.5, style_weight=0.5, hidden=(512, 256),
                 learning_rate=1e-4, weight_decay=1e-4, logit_weight=0.05, gp_weight=5.0,
                 batches=8, batch_size=512, replay_size=100_000, seed=0):
        self.env = env
        self.task_weight, self.style_weight = float(task_weight), float(style_weight)
        self.size = env.amp_observation_size
        self.disc = Discriminator(self.size, tuple(hidden))
        self.optimizer = torch.optim.Adam(self.disc.parameters(), lr=learning_rate,
                                          weight_decay=weight_decay)
        self.logit_weight, self.gp_weight = float(logit_weight), float(gp_weight)
        self.batches, self.batch_size = int(batches), int(batch_size)
        self.replay = torch.zeros((int(replay_size), self.size))
        self.replay_fill = 0
        self.replay_next = 0
        self.rng = np.random.default_rng(seed)
        self._rollout = []
        self.last_style = 0.0
        self.last_task = 0.0

    @torch.no_grad()
    def score(self, amp_obs):
        """Discriminator scores (n,) of transitions (n, 2F) (NumPy or torch)."""
        x = torch.as_tensor(np.asarray(amp_obs, np.float32))
        return self.disc(x)

    @torch.no_grad()
    def combine(self, task_reward, amp_obs):
        """The reward PPO learns from: ``task_weight * task + style_weight * style`` (a
        float32 tensor (N,)); keeps the transitions for the next discriminator update."""
        x = torch.as_tensor(np.asarray(amp_obs, np.float32))
        self._rollout.append(x.clone())
        style = style_reward(self.disc(x))
        task = torch.as_tensor(np.asarray(task_reward, np.float32))
        self.last_style, self.last_task = float(style.mean()), float(task.mean())
        return self.task_weight * task + self.style_weight * style

    def _push(self, x):
        n = x.shape[0]
        cap = self.replay.shape[0]
        if n >= cap:
            self.replay[:] = x[-cap:]
            self.replay_fill, self.replay_next = cap, 0
            return
        end = self.replay_next + n
        if end <= cap:
            self.replay[self.replay_next:end] = x
        else:
            k = cap - self.replay_next
            self.replay[self.replay_next:] = x[:k]
            self.replay[:n - k] = x[k:]
        self.replay_next = end % cap
        self.replay_fill = min(cap, self.replay_fill + n)

    def update(self):
        """Fit the discriminator on the last rollout's transitions, the replay and as many
        clip transitions; returns mean losses and scores for the log."""
        if not self._rollout:
            return {}
        current = torch.cat(self._rollout)
        self._rollout = []
        log = {"disc_loss": 0.0, "disc_gp": 0.0, "disc_clip": 0.0, "disc_policy": 0.0}
        half = self.batch_size // 2
        self.disc.train()
        for _ in range(self.batches):
            cur = current[torch.as_tensor(self.rng.integers(0, len(current), half))]
            if self.replay_fill:
                old = self.replay[torch.as_tensor(self.rng.integers(0, self.replay_fill,
                                                                    self.batch_size - half))]
                policy = torch.cat([cur, old])
            else:
                policy = current[torch.as_tensor(self.rng.integers(0, len(current),
                                                                   self.batch_size))]
            clip = torch.from_numpy(self.env.reference_transitions(self.batch_size, self.rng))
            self.disc.norm.update(torch.cat([clip, policy]))
            xc, xp = self.disc.norm(clip), self.disc.norm(policy)
            d_clip, d_policy = self.disc(xc, normalized=True), self.disc(xp, normalized=True)
            gan = lsgan_loss(d_clip, d_policy)
            gp = gradient_penalty(self.disc, xc)
            logit = (self.disc.head.weight ** 2).sum()
            loss = gan + 0.5 * self.gp_weight * gp + self.logit_weight * logit
            self.optimizer.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(self.disc.parameters(), 1.0)
            self.optimizer.step()
            log["disc_loss"] += gan.item()
            log["disc_gp"] += gp.item()
            log["disc_clip"] += d_clip.mean().item()
            log["disc_policy"] += d_policy.mean().item()
        self._push(current)
        return {k: v / self.batches for k, v in log.items()}

    @torch.no_grad()
    def clip_style(self, n=4096, held_out=True):
        """Mean style reward of n clip transitions (held-back frames by default)."""
        x = self.env.reference_transitions(n, self.rng, held_out=held_out)
        return float(style_reward(self.score(x)).mean())

    def state_dict(self):
        """Discriminator, optimiser and random generator. The replay is left out (100,000
        transitions would make the checkpoint 150 MB); a resumed run refills it in a few
        iterations, as it starts its episodes afresh."""
        return {"disc": self.disc.state_dict(), "optimizer": self.optimizer.state_dict(),
                "rng": self.rng.bit_generator.state}

    def load_state_dict(self, state):
        self.disc.load_state_dict(state["disc"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.rng.bit_generator.state = state["rng"]
