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
# # 3. Contacts, three ways: penalty, LCP and PGS
#
# When geoms touch, something must stop them passing through each other and must apply
# friction. The lecture presents three answers, and tumble has each, selectable on the
# same model with `World(..., contact=...)`:
#
# | `contact=` | what | |
# |---|---|---|
# | `"penalty"` | a spring-damper pushes overlapping geoms apart; friction is a stick spring capped at μ f_n | cheap and simple; lets geoms sink in and springs back and forth |
# | `"lcp"` | contact impulses from a linear complementarity problem (non-penetration, Coulomb friction on a 4-sided pyramid), solved exactly by Lemke's algorithm together with the joints | exact; dense, for scenes of a few bodies |
# | `"pgs"` | the same problem solved by projected Gauss–Seidel sweeps, warm-started | scales to hundreds of contacts; converges to the exact answer as it iterates |
#
# Here one scene runs under all three: a stack of five boxes, and a sixth box thrown
# along the ground that must slide to a stop after v₀² / (2 μ g).

# %%
import os
import time

import matplotlib.pyplot as plt
import numpy as np

import tumble

QUICK = os.environ.get("TUMBLE_DOCS_QUICK") == "1"
G, MU, V0 = 9.81, 0.5, 2.0


def scene(contact, nstack=5):
    b = tumble.ModelBuilder(gravity=(0, 0, -G))
    b.add_geom(None, "plane", normal=(0, 0, 1), friction=MU)
    for i in range(nstack):
        b.add_body(f"box{i}", pos=(0, 0, 0.1 + 0.2 * i), density=500.0)
        b.add_geom(f"box{i}", "box", size=(0.1, 0.1, 0.1), friction=MU)
    b.add_body("slider", pos=(1.0, 0, 0.1), density=500.0, vel=(V0, 0, 0))
    b.add_geom("slider", "box", size=(0.1, 0.1, 0.1), friction=MU)
    return tumble.World(b.build(), dt=1 / 240, contact=contact)


scene("lcp")

# %% [markdown]
# ## Run it under each model
#
# We record the top box's height, the deepest overlap of any contact (`world.contacts`
# holds the last step's points, normals, depths and forces) and the slider's travel.

# %%
SECONDS = 2.0 if QUICK else 4.0
stats, heights = {}, {}
for contact in ("penalty", "lcp", "pgs"):
    world = scene(contact)
    world.step()                                 # first call: loads the compiled step
    top, slider = world.model.body_index("box4"), world.model.body_index("slider")
    h, deepest, wall = [], 0.0, 0.0
    while world.time < SECONDS - 1e-9:
        t0 = time.perf_counter()
        world.step(4)
        wall += time.perf_counter() - t0
        h.append((world.time, world.body_pos[top, 2]))
        if len(world.contacts.depth):
            deepest = max(deepest, world.contacts.depth.max())
    heights[contact] = np.array(h)
    stats[contact] = dict(sink=0.9 - world.body_pos[top, 2], deepest=deepest,
                          slide=world.body_pos[slider, 0] - 1.0,
                          kinetic=world.energy()[0],
                          us=1e6 * wall / (world.time / world.dt))
    s = stats[contact]
    print(f"{contact:8s}: top box {1000 * s['sink']:7.4f} mm below rest, deepest overlap "
          f"{1000 * s['deepest']:7.4f} mm, slid {s['slide']:.4f} m, kinetic energy left "
          f"{s['kinetic']:.2e} J, {s['us']:.0f} us per step")
print(f"Coulomb friction: a box thrown at {V0} m/s slides v0^2 / (2 mu g) = "
      f"{V0**2 / (2 * MU * G):.4f} m")

# %%
fig, ax = plt.subplots(figsize=(7, 3))
for contact, h in heights.items():
    ax.plot(h[:, 0], 1000 * (h[:, 1] - 0.9), label=contact)
ax.set_xlabel("time (s)")
ax.set_ylabel("top box height - rest (mm)")
ax.legend()
plt.show()

# %% [markdown]
# What the figures say:
#
# - **penalty** contacts must overlap to push: the stack settles millimetres into itself
#   and keeps some kinetic energy while the springs ring down (here integrated implicitly,
#   the default `penalty_integration`; `"explicit"` is the lecture's form, stable only for
#   small `sqrt(k/m) dt`);
# - **LCP** (Lemke) holds the stack to round-off: no overlap, no motion;
# - **PGS** stops a few micrometres short of the exact answer after its sweeps;
# - all three give Coulomb's sliding distance to within a step's worth of travel
#   (semi-implicit Euler stops the box a little early).
#
# The time per step depends on the machine and what else runs on it; the
# [benchmarks](../../concepts/benchmarks/) compare the models on larger scenes.

# %%
assert stats["penalty"]["sink"] > 1e-4 and stats["penalty"]["deepest"] > 1e-3
assert stats["lcp"]["sink"] < 1e-8 and stats["lcp"]["deepest"] < 1e-8
assert stats["pgs"]["sink"] < 1e-4 and stats["pgs"]["deepest"] < 1e-4
for s in stats.values():
    assert abs(s["slide"] - V0**2 / (2 * MU * G)) < 0.03 * V0**2 / (2 * MU * G)

# %% [markdown]
# ## Which one to use
#
# - A character's feet on the ground, a few boxes: `"lcp"` (the default) — exact, and the
#   joints of a character are solved with the contacts in one problem.
# - Many bodies and contacts (piles, crowds, batched training worlds): `"pgs"`.
# - A soft ground or when you want the lecture's spring model: `"penalty"`; give geoms
#   their own `stiffness`/`damping` to choose the spring.
#
# See [Contact models](../../concepts/contacts/) for friction, restitution, spin friction
# and the options (`contact_erp`, `contact_cfm`, `slop`, `contact_margin`).
#
# **Next:** [a ragdoll from a BVH file](../t04_ragdoll_bvh/).
