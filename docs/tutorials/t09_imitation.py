# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 9. Training an imitation policy (short)
#
# Tracking a clip with PD servos ([tutorial 7](../t07_tracking/)) needed a hand of god to
# stay upright. DeepMimic (Peng et al. 2018) learns the missing balance instead: a neural
# network policy observes the character and the clip's phase and chooses the servos'
# targets (here as corrections added to the clip's own pose), rewarded for staying close
# to the clip. tumble's `tumble.rl` runs N characters in one batched `World(nworld=N)`
# and computes observations, rewards and resets for all of them in compiled kernels;
# PPO comes from rsl-rl.
#
# Needs the `rl` extra: `pip install "tumble[rl]"` (PyTorch, rsl-rl, Gymnasium). A real
# run takes hours (the shipped policy: 4.3 million samples, 1.9 hours on two cores); this
# tutorial looks at the task, measures the policy shipped with tumble, and runs a few
# iterations of training to show the loop and its files.

# %%
import os
import tempfile

import matplotlib.pyplot as plt
import numpy as np

import tumble
from tumble.rl import ImitationEnv
from tumble.rl.play import load_policy, policy_world
from tumble.rl.train import TrainConfig, evaluate, train

QUICK = os.environ.get("TUMBLE_DOCS_QUICK") == "1"

# %% [markdown]
# ## The task, as arrays
#
# `ImitationEnv(num_envs, clip)` holds N characters; `reset` returns their observations
# (N, 303): root height, every body's position, rotation and velocities in the heading
# frame of the root, and the clip's phase. An action (N, 45) is a target correction for
# each joint, in [-1, 1] times `action_scale` (0.5 rad). The reward is DeepMimic's, 1 on
# the clip exactly.

# %%
env = ImitationEnv(8, "walk", seed=0)
obs = env.reset(seed=0)
print(f"{env.num_envs} characters; observations {obs.shape}, actions "
      f"({env.num_envs}, {env.action_size}); policy step {env.dt:.4f} s, "
      f"{env.substeps} physics steps each")
obs, reward, terminated, truncated, info = env.step(np.zeros((8, env.action_size)))
print("reward of a zero correction after one step:", np.round(reward, 3))

# %% [markdown]
# ## The shipped policy against no policy
#
# `evaluate` starts episodes at random phases of the clip and runs them until they fall
# or reach the time limit. With zero corrections the servos only follow the clip — open
# loop, as in tutorial 7 without the hand of god — and the character falls within a
# couple of seconds. The shipped policy (`load_policy("walk")`, a NumPy network: no
# PyTorch needed to run it) walks on, a few centimetres from the clip.

# %%
policy = load_policy("walk")
config = TrainConfig(clip="walk", contact=policy.spec["contact"])
EPISODES, SECONDS = (4, 3.0) if QUICK else (16, 10.0)


class NoCorrection:
    """A 'policy' that always outputs zero: servos on the clip's pose, nothing learnt."""

    def check(self, spec):
        pass

    def act(self, obs):
        return np.zeros((len(obs), policy.action_size), np.float32)


scores = {}
for label, p in (("shipped policy", policy), ("no correction", NoCorrection())):
    r = evaluate(p, config, episodes=EPISODES, seconds=SECONDS)
    scores[label] = r
    print(f"{label:15s}: {100 * r['survived']:3.0f}% of {EPISODES} episodes reach "
          f"{SECONDS:g} s (mean {r['mean_seconds']:.2f} s), body position error "
          f"{1000 * r['mean_error']:.0f} mm, mean reward {r['mean_reward']:.3f}")

assert scores["shipped policy"]["survived"] == 1.0
assert scores["shipped policy"]["mean_error"] < 0.05
assert scores["no correction"]["survived"] < 0.5
assert scores["shipped policy"]["mean_reward"] > scores["no correction"]["mean_reward"]

# %% [markdown]
# Played in one world, as `tumble play walk` does in the browser viewer:

# %%
world, driver, _ = policy_world("walk", seed=1)
recorder = tumble.Recorder(world)
recorder.run(3.0 if QUICK else 6.0, fps=20, control=driver)
recorder.recording().animation(size=(400, 225), fps=10 if QUICK else 15,
                               follow="RootJoint")

# %% [markdown]
# ## A few iterations of training
#
# `train(out_dir, TrainConfig(...))` builds the batched task and rsl-rl's PPO, collects
# rollouts, updates, evaluates and writes checkpoints; `tumble train imitate walk --out
# runs/walk --hours 4` is the same from the command line, and `--resume` goes on from the
# checkpoint. Here: 16 worlds, a small network, a handful of iterations — enough to see
# the loop and its files, far too few to learn to walk.

# %%
out = tempfile.mkdtemp(prefix="tumble-train-")
iterations = 3 if QUICK else 30
run_config = TrainConfig(num_envs=16, steps_per_env=16, iterations=iterations,
                         eval_every=iterations, eval_episodes=2, eval_seconds=1.0,
                         hidden=(64, 64), threads=1, save_every=iterations, seed=0)
trainer = train(out, run_config, progress=False, log=print)
print("files:", sorted(os.listdir(out)))

from tumble.rl.report import read_run  # noqa: E402

progress, _ = read_run(out)                     # columns as arrays
samples, rewards = progress["samples"].astype(int), progress["reward"]
print(f"{len(samples)} iterations, {samples[-1]} samples; mean reward per step "
      + ", ".join(f"{r:.3f}" for r in rewards))
assert samples[-1] == iterations * 16 * 16 and all(0 < r <= 1 for r in rewards)
assert {"checkpoint.pt", "policy.npz", "progress.csv"} <= set(os.listdir(out))

plt.figure(figsize=(6, 2.5))
plt.plot(samples, rewards, marker="o")
plt.xlabel("samples")
plt.ylabel("mean reward per step")
plt.show()

# %% [markdown]
# The shipped policy's learning curve, over its 1,060 iterations:
#
# ![Learning curve](../../imitation_walk_curve.png)
#
# See [Learning](../../concepts/learning/) for the observation, action and reward in
# full, AMP's steering task, and the throughput figures.
