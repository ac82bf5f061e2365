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
# # 6. Static balance
#
# PD servos can hold every joint of a standing character at its target, and it still
# falls: nothing keeps its centre of mass (COM) over its feet. Static balance adds a
# *virtual force* on the COM, pulling it horizontally towards the middle of the support,
# and a virtual torque keeping the pelvis upright. Neither is applied as such — there is
# no hand of god here — but turned into joint torques of the stance legs with the
# Jacobian transpose, τ = Jᵀ F: the torques that would produce F at the COM if the feet
# stay planted.
#
# `tumble.character.StaticBalance` does that on top of the world's PD servos; its
# `apply()` is called once per control frame, before `world.step()`.

# %%
import os

import matplotlib.pyplot as plt
import numpy as np

import tumble
from tumble.character import PDController, Push, StaticBalance, center_of_mass

QUICK = os.environ.get("TUMBLE_DOCS_QUICK") == "1"
SECONDS = 6.0 if QUICK else 12.0

# %% [markdown]
# The course character stands in its T-pose on a floating root (nothing holds it), with
# PD servos at k_p = 1000, k_d = 50 on every joint, stepped at 60 Hz. Two pushes of
# `push` newtons for 0.2 s hit the pelvis: forward at 2 s, backward at 4 s.

# %%
def stand(balance=True, push=50.0, seconds=SECONDS):
    ragdoll = tumble.games105_ragdoll(root="floating")
    world = ragdoll.make_world(dt=1 / 60)
    pd = PDController(world, kp=1000.0, kd=50.0, max_torque=200.0)
    pd.set_targets(np.tile([0.0, 0.0, 0.0, 1.0], (world.model.njoint, 1)))
    balancer = StaticBalance(world, ["lAnkle", "rAnkle"], "RootJoint", up=(0, 1, 0))
    pelvis = world.model.body_index("RootJoint")
    pushes = [Push(pelvis, (0, 0, push), 2.0, 0.2), Push(pelvis, (0, 0, -push), 4.0, 0.2)]
    t, offset, fell = [], [], None
    while world.time < seconds - 1e-9:
        if balance:
            balancer.apply()
        for p in pushes:
            p.apply(world)
        world.step()
        com, _ = center_of_mass(world)
        t.append(world.time)
        offset.append(com[2] - balancer.support_center()[2])    # forward (z) offset
        if fell is None and world.body_pos[pelvis, 1] < 0.6:
            fell = world.time
        if fell is not None and world.time > fell + 0.5:
            break                                   # down: no need to watch it lie there
    return np.array(t), np.array(offset), fell, world


t0, off0, fell0, _ = stand(balance=False)
t1, off1, fell1, world = stand(balance=True)
t2, off2, fell2, _ = stand(balance=True, push=100.0)
print("PD servos only, 50 N pushes:", f"fell at t = {fell0:.2f} s" if fell0 else "stood")
print("with static balance, 50 N pushes:", f"fell at t = {fell1:.2f} s" if fell1 else
      f"stood; COM at most {100 * np.abs(off1).max():.1f} cm ahead of or behind the "
      f"middle of the feet, {100 * abs(off1[-1]):.2f} cm at the end")
print("with static balance, 100 N pushes:", f"fell at t = {fell2:.2f} s" if fell2 else "stood")

# %%
fig, ax = plt.subplots(figsize=(7, 3))
ax.plot(t1, 100 * off1, label="balance, 50 N pushes")
ax.plot(t2, 100 * off2, label="balance, 100 N pushes")
ax.plot(t0, 100 * off0, label="PD only")
for start in (2.0, 4.0):
    ax.axvspan(start, start + 0.2, color="0.85")
ax.set_ylim(-30, 30)
ax.set_xlabel("time (s)")
ax.set_ylabel("COM ahead of the feet (cm)")
ax.legend(fontsize=8)
plt.show()
world

# %% [markdown]
# With servos alone the character topples within two seconds. With static balance it
# stands and recovers from both 50 N pushes, its COM returning over the middle of the
# feet (the controller's integral term removes the offset the pose servos leave); a
# 100 N push is more than feet that stay planted can take — stepping is needed, which
# is what the walking controllers do.

# %%
assert fell0 is not None and fell0 < 3.0
assert fell1 is None and abs(off1[-1]) < 0.02
assert fell2 is not None

# %% [markdown]
# **Next:** [tracking motion capture](../t07_tracking/).
