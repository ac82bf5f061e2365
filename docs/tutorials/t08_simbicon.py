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
# # 8. Walking with SIMBICON
#
# SIMBICON (Yin, Loken and van de Panne 2007) makes a character walk with joint torques
# alone — no hand of god — from three simple parts:
#
# 1. a **finite-state machine** of target poses: per step, a timed state (swing leg
#    lifting), then a state that lasts until the swing foot touches the ground;
# 2. **PD servos** on the joints, with the torso and the swing thigh controlled in the
#    world (heading) frame, and the stance hip carrying the torso's torque;
# 3. **balance feedback** on the swing hip's target: θ_d = θ_d0 + c_d d + c_v v, where d
#    and v are the centre of mass's offset and velocity from the stance ankle. A character
#    falling forward places its foot further forward, and so catches itself.
#
# `tumble.character.SimbiconController` implements it on the course character with
# tumble's implicit PD, at a control and physics step of 1/60 s; `run_walk` walks it and
# measures the walk.

# %%
import os

import matplotlib.pyplot as plt
import numpy as np

import tumble
from tumble.character import Push, SimbiconController, run_walk
from tumble.character.terrain import Flat, Slope
from tumble.viewer import Camera

QUICK = os.environ.get("TUMBLE_DOCS_QUICK") == "1"
SECONDS = 10.0 if QUICK else 30.0


def walker(gait="walk", terrain=None):
    terrain = Flat() if terrain is None else terrain
    ragdoll = tumble.games105_ragdoll(root="floating", terrain=terrain)
    world = ragdoll.make_world(dt=1 / 60, contact="pgs")
    return SimbiconController(world, ragdoll, gait, control_dt=1 / 60, terrain=terrain)


# %% [markdown]
# ## Walk
#
# The gaits are JSON files (`tumble.character.gait_names()` lists the shipped ones;
# `load_gait(path)` reads your own). A `Recorder` captures a frame after every control
# step through `run_walk`'s `on_step`.

# %%
print("gaits:", tumble.character.gait_names())
ctrl = walker("walk")
recorder = tumble.Recorder(ctrl.world, capture_now=False)
walk = run_walk(ctrl, SECONDS, on_step=lambda c: recorder.capture())
print("walk:", walk.summary())

# %%
com = walk.com
plt.figure(figsize=(7, 2.5))
plt.plot(np.arange(1, len(com) + 1) / 60, com[:, 2])
for strike in walk.strikes:
    t = strike[0] if isinstance(strike, (tuple, list)) else getattr(strike, "time", None)
    if t is not None:
        plt.axvline(t, color="0.85", lw=0.8)
plt.xlabel("time (s)")
plt.ylabel("COM forward (m)")
plt.show()

recorder.recording().animation(size=(400, 225), fps=10 if QUICK else 15,
                               end=4.0 if QUICK else 10.0,
                               camera=Camera(
                                   follow="RootJoint", distance=3.6, azimuth=25.0,
                                   elevation=10.0))

# %% [markdown]
# ## A push, another gait, a slope
#
# A 150 N push on the chest for 0.2 s, forward, in the middle of the walk; the faster
# gait; the walk up a 5° slope (the terrain goes both to the ragdoll builder and to the
# controller, which leans into it).

# %%
pushed = run_walk(walker("walk"), SECONDS,
                  pushes=[Push("lowerback_torso", (0, 0, 150.0), SECONDS / 2, 0.2)])
fast = run_walk(walker("fast"), SECONDS)
uphill = run_walk(walker("walk", Slope(0.087)), SECONDS)
for label, r in (("pushed", pushed), ("fast", fast), ("5 deg uphill", uphill)):
    print(f"{label}:", r.summary())

# %% [markdown]
# None of them falls; the fast gait covers about twice the ground. The README's tables
# (made by `bench/bench_walk.py`) give the largest pushes each gait survives in each
# direction, slopes both ways and heightfields.

# %%
for r in (walk, pushed, fast, uphill):
    assert not r.fallen, r.summary()
assert 0.4 < walk.speed < 0.9 and walk.steps >= 10
assert fast.speed > 1.6 * walk.speed
assert uphill.forward_distance > 2.0

# %% [markdown]
# From the command line: `python examples/walk.py --gait fast --terrain hill`, and
# `--push 0,0,-300` to push. See [Walking controllers](../../concepts/walking/).
#
# **Next:** [training an imitation policy](../t09_imitation/).
