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
# # 5. PD control: explicit and implicit
#
# A PD servo drives a joint towards a target angle with the torque
# τ = k_p (θ_target − θ) − k_d θ̇. Computed from the state at the start of the step and
# applied as an ordinary torque (**explicit** PD, as in the lecture), it is a stiff spring
# integrated explicitly: stable only while the step is small against the servo's period,
# roughly ω h < 2 with ω = √(k_p / I). That is why the course runs its character at 32
# physics steps per 60 Hz frame.
#
# tumble's default, **implicit** PD (`World(..., pd="implicit")`), solves the servo as a
# soft constraint row with the joints and contacts: the spring-damper is mapped to ERP and
# CFM at the step h, so the servo can never add energy, whatever the gains. `pd="stable"`
# is stable PD (Tan et al. 2011). The gains mean the same in all three.

# %%
import os

import matplotlib.pyplot as plt
import numpy as np

import tumble
from tumble.character import PDController

QUICK = os.environ.get("TUMBLE_DOCS_QUICK") == "1"

# %% [markdown]
# ## One joint, a gain sweep
#
# An arm hangs from a hinge and its servo holds it at 0.5 rad against gravity. The
# joint's gains and target are live arrays of the world: `world.joint_kp`,
# `world.joint_kd` and `world.pd_target_q` (hinge angles; ball joints take
# `pd_target_quat`). We step at 60 Hz and raise k_p (k_d = 0.1 √k_p).

# %%
def arm(kp, mode, dt=1 / 60):
    b = tumble.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_body("arm", pos=(0, 0, 1.75), density=1000.0)
    b.add_geom("arm", "capsule", radius=0.03, half_length=0.22, contype=0, conaffinity=0)
    b.add_joint("shoulder", "hinge", None, "arm", anchor=(0, 0, 2), axis=(0, 1, 0),
                kp=kp, kd=0.1 * np.sqrt(kp))
    world = tumble.World(b.build(), dt=dt, pd=mode)
    world.pd_target_q[0] = 0.5
    return world


def hold(kp, mode, seconds=2.0):
    """How the servo does: 'holds' at an angle (rad; it stays within 0.01 rad over the
    last second), 'swings' (over that many rad: it does not settle) or 'diverged' at a time
    (tumble raised SimulationError, leaving the world as it was before the failing step)."""
    world = arm(kp, mode)
    angles = []
    for _ in range(int(round(seconds / world.dt))):
        try:
            world.step()
        except tumble.SimulationError:
            return "diverged", f"diverged {world.time:.3f}s"
        angles.append(world.joint_q[0, 0])
    last = np.array(angles[-60:])
    if np.ptp(last) < 0.01:
        return "holds", f"holds {last[-1]:.5f}"
    return "swings", f"swings {np.ptp(last):.2f}"


inertia = arm(1.0, "implicit").model.body_inertia[0]
m = arm(1.0, "implicit").model.body_mass[0]
I_pivot = inertia[1] + m * 0.25**2                # about the hinge (y), COM 0.25 m below
outcome = {}
print(f"{'k_p':>7s} {'w h':>6s} {'explicit':>16s} {'implicit':>16s} {'stable':>16s}")
for kp in (1e2, 1e3, 1e4, 1e5, 1e6):
    row = []
    for mode in ("explicit", "implicit", "stable"):
        outcome[kp, mode], text = hold(kp, mode)
        row.append(text)
    print(f"{kp:7.0e} {np.sqrt(kp / I_pivot) / 60:6.2f} " + "".join(f"{r:>17s}" for r in row))
final = hold(1e6, "implicit")[1]

# %% [markdown]
# Explicit PD holds the arm while ω h is below about 2; above it the arm swings about
# wildly, and at higher gains the step diverges. Implicit and stable PD hold it at every
# gain, closer to the target as k_p grows (the gap left is gravity's torque over k_p).

# %%
assert outcome[1e2, "explicit"] == outcome[1e3, "explicit"] == "holds"
assert outcome[1e4, "explicit"] != "holds" and outcome[1e6, "explicit"] == "diverged"
assert all(outcome[kp, mode] == "holds" for kp in (1e2, 1e3, 1e4, 1e5, 1e6)
           for mode in ("implicit", "stable"))
assert abs(float(final.split()[1]) - 0.5) < 1e-4

# %% [markdown]
# ## A whole character in its T-pose
#
# The course character, pinned at the pelvis, holds its T-pose with k_p = 1000, k_d = 30
# on every joint (`PDController` sets the world's gains; `set_targets` takes one
# rotation per joint). Implicit PD at 60 Hz against explicit PD at 60 Hz and at the
# course's 1920 Hz:

# %%
SECONDS = 1.0 if QUICK else 3.0


def tpose(mode, hz):
    ragdoll = tumble.games105_ragdoll(root="pinned")
    world = ragdoll.make_world(dt=1 / hz)
    pd = PDController(world, kp=1000.0, kd=30.0, max_torque=200.0, mode=mode)
    pd.set_targets(np.tile([0.0, 0.0, 0.0, 1.0], (world.model.njoint, 1)))
    errors = []
    while world.time < SECONDS - 1e-9:
        world.step(max(1, hz // 60))                 # one 60 Hz control frame
        errors.append(pd.joint_error().max())
    return np.array(errors), world


results = {}
for mode, hz in (("implicit", 60), ("stable", 60), ("explicit", 1920), ("explicit", 60)):
    err, world = tpose(mode, hz)
    results[mode, hz] = err
    print(f"{mode:>8s} PD at {hz:4d} Hz: largest joint error over the last 0.5 s "
          f"{err[-30:].max():.4f} rad")

fig, ax = plt.subplots(figsize=(7, 3))
for (mode, hz), err in results.items():
    ax.semilogy(np.arange(1, len(err) + 1) / 60, err, label=f"{mode}, {hz} Hz")
ax.set_xlabel("time (s)")
ax.set_ylabel("largest joint error (rad)")
ax.legend(fontsize=8)
plt.show()
world

# %% [markdown]
# Implicit PD at 60 Hz holds the pose as well as explicit PD does at 1920 Hz — at one
# thirty-second of the steps; explicit PD at 60 Hz collapses.

# %%
assert results["implicit", 60][-30:].max() < 0.05
assert results["explicit", 1920][-30:].max() < 0.05
assert results["explicit", 60][-30:].max() > 0.5

# %% [markdown]
# **Next:** [static balance](../t06_static_balance/).
