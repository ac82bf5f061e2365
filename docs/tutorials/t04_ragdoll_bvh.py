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
# # 4. A ragdoll from a BVH file
#
# Motion capture arrives as BVH: a skeleton (joint names, parents, offsets) and, per
# frame, a root position and every joint's rotation relative to its parent. This
# tutorial reads a clip, builds a ragdoll with one body per bone, puts the ragdoll in a
# frame of the clip, checks that the pose reads back exactly, and lets it fall.
#
# The clip is the GAMES-105 course's walking cycle, shipped with tumble.

# %%
import os

import matplotlib.pyplot as plt
import numpy as np

import tumble
from tumble.data.games105 import clip_path

QUICK = os.environ.get("TUMBLE_DOCS_QUICK") == "1"

motion = tumble.load_bvh(clip_path("walk"))
print(motion)
print(f"{motion.num_joints} joints, {motion.num_frames} frames at {motion.fps:g} fps "
      f"({motion.duration:.2f} s); root: {motion.joint_names[0]}")
print("first joints:", ", ".join(motion.joint_names[:6]), "...")

# %% [markdown]
# ## Forward kinematics
#
# `motion.forward_kinematics()` composes the rotations down the tree: world positions
# (frames, joints, 3) and orientations (frames, joints, 4). BVH is y-up; the character
# walks along +z. Here are a few frames from the side:

# %%
positions, rotations = motion.forward_kinematics()
fig, ax = plt.subplots(figsize=(8, 3))
for f in range(0, motion.num_frames, 20):
    p = positions[f]
    for j, parent in enumerate(motion.parents):
        if parent >= 0:
            ax.plot(p[[parent, j], 2], p[[parent, j], 1], color=plt.cm.viridis(f / 100))
ax.set_aspect("equal")
ax.set_xlabel("z (m, forward)")
ax.set_ylabel("y (m, up)")
ax.set_title("walk_forward.bvh, every 20th frame")
plt.show()

# %% [markdown]
# ## The ragdoll
#
# `ragdoll_from_motion` builds one body per bone: capsules along single bones, boxes
# around joints with several children (the pelvis, the chest); ball joints unless told
# otherwise (`joint_types={"lKnee": "hinge", ...}` with `joint_axes`), and a ground plane.
# Mass comes from a density or, as here, a total mass shared by volume.

# %%
ragdoll = tumble.ragdoll_from_motion(motion, shape="capsule", total_mass=70.0)
model = ragdoll.model
print(ragdoll)
print(f"{model.nbody} bodies, {model.njoint} joints, total mass "
      f"{model.body_mass.sum():.1f} kg")
world = ragdoll.make_world()

# %% [markdown]
# ## Motion frame → world pose, and back
#
# `set_pose` places every body as the clip's frame says (and gives them the clip's
# velocities by finite differences); `get_pose` reads the joint rotations back from the
# bodies. The round trip is exact to round-off:

# %%
tumble.set_pose(world, ragdoll, motion, frame=0)
pose = tumble.get_pose(world, ragdoll, motion)
dots = np.abs(np.einsum("ji,ji->j", pose.local_rotations, motion.local_rotations[0]))
roundtrip = float(np.max(1 - np.minimum(dots, 1)))
root_error = float(np.linalg.norm(pose.root_position - motion.root_positions[0]))
print(f"pose round trip: largest rotation mismatch 1 - |q.q'| = {roundtrip:.1e}, "
      f"root position error {root_error:.1e} m")
assert roundtrip < 1e-12 and root_error < 1e-12
world

# %% [markdown]
# ## Let it fall
#
# Nothing drives the joints, so the ragdoll collapses onto the ground. A `Recorder`
# captures it; the recording plays inline.

# %%
root = model.body_index(ragdoll.body_of[motion.joint_names[0]])
start_height = world.body_pos[root, 1]
E0 = sum(world.energy())
recorder = tumble.Recorder(world, energy=True)
recorder.run(2.0 if QUICK else 4.0, fps=30)
print(f"pelvis height: {start_height:.3f} m -> {world.body_pos[root, 1]:.3f} m; "
      f"energy {E0:.1f} J -> {sum(world.energy()):.1f} J")
assert world.body_pos[root, 1] < 0.35 and np.all(np.isfinite(world.body_pos))
recording = recorder.recording()
recording.animation(size=(400, 225), fps=10 if QUICK else 20, follow="com")

# %% [markdown]
# `tumble.games105_ragdoll()` builds the course's own character (boxes, hinged knees and
# elbows, its masses), the one the next tutorials control.
#
# **Next:** [PD control](../t05_pd_control/).
