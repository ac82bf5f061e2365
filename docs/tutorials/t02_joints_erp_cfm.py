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
# # 2. A pendulum and a chain: joints, ERP and CFM
#
# tumble keeps every body's six coordinates (maximal coordinates, as ODE does) and holds
# bodies together with joint *constraints*: rows of a linear system solved each step for
# the impulses that keep the anchor points moving together. Solved at the velocity level,
# the constraints still drift apart in position a little every step; two numbers of
# ODE's control that:
#
# - **ERP**, the error reduction parameter (0..1): the fraction of the joint's position
#   error the next step removes;
# - **CFM**, constraint force mixing (≥ 0): softness. A joint with CFM > 0 behaves like a
#   spring-damper, with stiffness k = ERP / (h · CFM) at step h.
#
# tumble adds a third, **projection**: after the positions are updated, a few
# Gauss–Newton iterations move the bodies back onto their joints without touching the
# velocities. To see what ERP alone does, we switch projection off (`projection=0`).

# %%
import os

import matplotlib.pyplot as plt
import numpy as np

import tumble

QUICK = os.environ.get("TUMBLE_DOCS_QUICK") == "1"
G = 9.81

# %% [markdown]
# ## A pendulum
#
# A rod (a capsule 1 m long) hangs from a hinge at its top end. It starts at the bottom
# with a small angular velocity; `world.joint_q` reads the hinge angle. A physical
# pendulum with small swings has the period T = 2π √(I_pivot / (m g d)), with d the
# distance from the pivot to the centre of mass and I_pivot = I_com + m d².

# %%
def pendulum(swing=0.1):
    b = tumble.ModelBuilder(gravity=(0, 0, -G))
    b.add_body("rod", pos=(0, 0, 1.5), density=1000.0,
               angvel=(0, swing, 0), vel=(-0.5 * swing, 0, 0))   # v = w x r, r from pivot
    b.add_geom("rod", "capsule", radius=0.02, half_length=0.48)
    b.add_joint("hinge", "hinge", None, "rod", anchor=(0, 0, 2), axis=(0, 1, 0))
    return tumble.World(b.build(), dt=1 / 240)


world = pendulum()
m, inertia = world.model.body_mass[0], world.model.body_inertia[0]
d = 0.5
T_formula = 2 * np.pi * np.sqrt((inertia[0] + m * d**2) / (m * G * d))

t, q = [], []
for _ in range(240 * 5):
    world.step()
    t.append(world.time)
    q.append(world.joint_q[0, 0])
t, q = np.array(t), np.array(q)
up = np.where((q[:-1] < 0) & (q[1:] >= 0))[0]          # upward zero crossings
T_measured = np.diff(t[up]).mean()
print(f"pendulum period: measured {T_measured:.4f} s, formula {T_formula:.4f} s")
assert abs(T_measured - T_formula) < 0.01 * T_formula

plt.figure(figsize=(7, 2.5))
plt.plot(t, np.degrees(q))
plt.xlabel("time (s)")
plt.ylabel("hinge angle (deg)")
plt.show()

# %% [markdown]
# ## A chain released from horizontal
#
# Ten capsules joined by ball joints hang from the world at one end; the chain starts
# straight and horizontal and falls. `world.joint_separation()` measures, for each joint,
# the distance between the anchor points on its two bodies: zero for a perfect joint.

# %%
def chain(n=10, link=0.2, **options):
    b = tumble.ModelBuilder(gravity=(0, 0, -G))
    along_x = (0, np.sin(np.pi / 4), 0, np.cos(np.pi / 4))     # capsule axis z -> x
    parent = None
    for i in range(n):
        b.add_body(f"link{i}", pos=((i + 0.5) * link, 0, 2), density=1000.0)
        b.add_geom(f"link{i}", "capsule", radius=0.02, half_length=link / 2 - 0.02,
                   quat=along_x, contype=0, conaffinity=0)       # no self-collision
        b.add_joint(f"j{i}", "ball", parent, f"link{i}", anchor=(i * link, 0, 2))
        parent = f"link{i}"
    return tumble.World(b.build(), dt=1 / 240, **options)


SECONDS = 2.0 if QUICK else 4.0
runs = {"ERP 0, no projection": dict(erp=0.0, projection=0),
        "ERP 0.2, no projection": dict(erp=0.2, projection=0),
        "ERP 0.8, no projection": dict(erp=0.8, projection=0),
        "ERP 0.2 + projection (default)": {}}
drift = {}
plt.figure(figsize=(7, 3))
for label, options in runs.items():
    world = chain(**options)
    times, sep = [], []
    while world.time < SECONDS - 1e-9:
        world.step(6)
        times.append(world.time)
        sep.append(world.joint_separation().max())
    drift[label] = (max(sep), sep[-1])
    print(f"{label:31s}: largest joint gap {1000 * max(sep):8.4f} mm, "
          f"at the end {1000 * sep[-1]:8.4f} mm")
    plt.semilogy(times, np.maximum(sep, 1e-9), label=label)
plt.xlabel("time (s)")
plt.ylabel("largest joint gap (m)")
plt.legend(fontsize=8)
plt.show()

# %% [markdown]
# Without ERP the velocity-level solve lets the gaps grow while the chain moves fast and
# nothing ever closes them; with ERP they open during the fall too but are pulled back
# every step, by more at a larger ERP; projection removes nearly all of them. (Pulling
# joints together dissipates a little energy: the README's *Known limits* gives the
# figures.)

# %%
no_erp, erp02, erp08 = (drift[k] for k in list(runs)[:3])
assert no_erp[1] > 0.95 * no_erp[0]                 # never closed again
assert erp02[1] < 0.2 * no_erp[1] and erp08[1] < 0.5 * erp02[1]
assert drift["ERP 0.2 + projection (default)"][0] < 1e-3

# %% [markdown]
# ## CFM: soft joints
#
# Now let the chain hang straight down at rest. With CFM > 0 each joint is a spring of
# stiffness k = ERP / (h · CFM), so the top joint, which carries the weight F of the whole
# chain, stretches by F / k = F h CFM / ERP. `world.joint_force` reads the force each
# joint transmits.

# %%
def hanging(n=10, link=0.2, **options):
    b = tumble.ModelBuilder(gravity=(0, 0, -G))
    parent = None
    for i in range(n):
        b.add_body(f"link{i}", pos=(0, 0, 2 - (i + 0.5) * link), density=1000.0)
        b.add_geom(f"link{i}", "capsule", radius=0.02, half_length=link / 2 - 0.02,
                   contype=0, conaffinity=0)
        b.add_joint(f"j{i}", "ball", parent, f"link{i}", anchor=(0, 0, 2 - i * link))
        parent = f"link{i}"
    return tumble.World(b.build(), dt=1 / 240, projection=0, **options)


for cfm in (1e-10, 1e-4, 1e-3):
    world = hanging(cfm=cfm)
    world.step(240)
    F = np.linalg.norm(world.joint_force[0])
    predicted = F * world.dt * cfm / world.erp
    stretch = world.joint_separation()[0]
    print(f"CFM {cfm:6.0e}: top joint carries {F:6.2f} N, stretches {1000 * stretch:.5f} mm "
          f"(F h CFM / ERP = {1000 * predicted:.5f} mm)")
    assert abs(stretch - predicted) <= 1e-3 * predicted + 1e-9

# %% [markdown]
# Per joint, `add_joint(..., erp=, cfm=)` overrides the world's values, and
# `add_joint(..., spring=(k, c))` asks for a spring-damper directly (tumble converts it to
# ERP and CFM at the world's step). See [Joints, ERP and CFM](../../concepts/joints/).
#
# **Next:** [contacts](../t03_contacts/).
