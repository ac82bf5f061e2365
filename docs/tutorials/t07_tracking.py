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
# # 7. Tracking motion capture
#
# The simplest way to make a simulated character move like a clip: at each frame, set
# every joint's PD target to the clip's rotation and let the servos pull. The joints
# follow; the character as a whole does not necessarily — its root is not actuated, and
# whether it stays upright depends on the ground reaction forces the motion happens to
# produce. A *hand of god* (a spring-damper on the root body towards the clip's root
# pose, an external force no real character has) keeps it on the clip while we look at
# the joints.
#
# `tumble.character.MotionTracker` does both: per frame it sets the servos' targets
# (`joint_targets`) and, if asked, drives the hand of god; `run()` returns per-frame
# errors.

# %%
import os

import matplotlib.pyplot as plt
import numpy as np

import tumble
from tumble.character import MotionTracker
from tumble.data.games105 import clip_path

QUICK = os.environ.get("TUMBLE_DOCS_QUICK") == "1"
motion = tumble.load_bvh(clip_path("walk"))
HAND = dict(kp=2000, kd=200, kp_rot=1000, kd_rot=100)    # N/m, N s/m, N m/rad, N m s/rad


def track(kp=1000.0, hand=True, recorder=False):
    ragdoll = tumble.games105_ragdoll(root="floating")
    world = ragdoll.make_world()
    tracker = MotionTracker(world, ragdoll, motion, kp=kp, kd=0.03 * kp, max_torque=200.0,
                            hand_of_god=HAND if hand else None)
    rec = tumble.Recorder(world, capture_now=False) if recorder else None
    result = tracker.run(on_frame=(lambda w, f: rec.capture()) if rec is not None else None)
    return result, rec


# %% [markdown]
# ## Servos and a hand of god
#
# The course character tracks the walking clip (one cycle, 100 frames at 100 Hz; the
# physics steps once per frame, `substeps=1`), with and without the hand of god:

# %%
with_hand, recorder = track(hand=True, recorder=True)
without, _ = track(hand=False)
for label, r in (("hand of god", with_hand), ("no hand of god", without)):
    print(f"{label:15s}: mean joint error {r.mean_joint_error:.4f} rad, root off the clip "
          f"by {100 * r.root_error.mean():.1f} cm on average, {100 * r.root_error.max():.1f} "
          f"cm at most; hand-of-god force {r.root_force.mean():.0f} N on average")

fig, axes = plt.subplots(1, 2, figsize=(9, 3))
for label, r in (("hand of god", with_hand), ("no hand", without)):
    axes[0].plot(r.time, r.joint_error, label=label)
    axes[1].plot(r.time, 100 * r.root_error, label=label)
axes[0].set_ylabel("mean joint error (rad)")
axes[1].set_ylabel("root off the clip (cm)")
for ax in axes:
    ax.set_xlabel("time (s)")
    ax.legend(fontsize=8)
fig.tight_layout()
plt.show()

# %% [markdown]
# The joints follow the clip about equally well either way (a few degrees); without the
# hand of god the root strays from where the clip puts it twice as far, and nothing in the
# servos brings it back — which is why controllers add balance feedback
# ([SIMBICON](../t08_simbicon/)) or learn it ([imitation](../t09_imitation/), where
# servos on the clip alone fall within seconds).

# %%
assert with_hand.mean_joint_error < 0.1 and without.mean_joint_error < 0.1
assert with_hand.root_error.mean() < 0.6 * without.root_error.mean()

# %% [markdown]
# ## Stiffer or softer servos
#
# Softer gains leave larger joint errors (gravity and the motion's accelerations pull
# the joints off their targets); stiffer gains follow closer. With implicit PD the gains
# can rise without making the step unstable ([tutorial 5](../t05_pd_control/)).

# %%
gains = (300.0, 1000.0) if QUICK else (100.0, 300.0, 1000.0, 3000.0)
errors = {kp: track(kp=kp)[0].mean_joint_error for kp in gains}
for kp, e in errors.items():
    print(f"k_p = {kp:6.0f} N m/rad, k_d = {0.03 * kp:5.1f}: mean joint error {e:.4f} rad")
assert errors[300.0] > errors[1000.0]

# %% [markdown]
# The tracked cycle, with the hand of god:

# %%
recorder.recording().animation(size=(400, 225), fps=20, follow="RootJoint")

# %% [markdown]
# **Next:** [SIMBICON](../t08_simbicon/) — walking with no hand of god at all.
