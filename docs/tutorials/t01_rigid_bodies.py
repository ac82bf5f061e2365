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
# # 1. Rigid bodies and the tennis-racket flip
#
# A free rigid body carries a mass, an inertia tensor and a state: position and
# orientation, linear and angular velocity. Without gravity or contact its angular
# momentum **L** and its kinetic energy stay constant — yet the way it turns need not be
# simple. Spin a box (or a tennis racket, or a phone) about the axis of its *middle*
# moment of inertia and it turns over, again and again: the tennis-racket or
# Dzhanibekov effect. About the largest or smallest axis the spin is stable.
#
# This tutorial builds a box, spins it about each principal axis and checks both facts,
# then compares the implicit gyroscopic term tumble uses by default with the explicit
# one of the lecture.
#
# Set `TUMBLE_DOCS_QUICK=1` to run the short version (the docs' tests do).

# %%
import os

import matplotlib.pyplot as plt
import numpy as np

import tumble

QUICK = os.environ.get("TUMBLE_DOCS_QUICK") == "1"

# %% [markdown]
# ## A box and its inertia
#
# `add_body(..., density=...)` takes mass, centre of mass and inertia from the body's
# geoms. A box of half extents (a, b, c) has the moments m/3 (b² + c²), ... about its
# axes; tumble simulates each body in its principal frame.

# %%
HALF = (0.04, 0.12, 0.25)            # m: half extents along x, y, z


def spinning_box(axis, spin=np.pi, wobble=0.01, **world_options):
    """A world with one box spinning at `spin` rad/s about body axis `axis` (0, 1, 2),
    plus a small `wobble` of that about the next axis."""
    w = np.zeros(3)
    w[axis] = spin
    w[(axis + 1) % 3] = wobble * spin
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_body("box", density=500.0, angvel=tuple(w))
    b.add_geom("box", "box", size=HALF)
    return tumble.World(b.build(), dt=1 / 240, **world_options)


world = spinning_box(1)
model = world.model
a, b_, c = HALF
m = model.body_mass[0]
print(f"mass {m:.2f} kg; principal moments {np.round(model.body_inertia[0], 5)} kg m^2")
print("box formula:", np.round([m / 3 * (b_**2 + c**2), m / 3 * (a**2 + c**2),
                                m / 3 * (a**2 + b_**2)], 5))
assert np.allclose(model.body_inertia[0], [m / 3 * (b_**2 + c**2), m / 3 * (a**2 + c**2),
                                           m / 3 * (a**2 + b_**2)])

# %% [markdown]
# In a notebook a `World` shows itself as a picture of its bodies (drawn by tumble's
# software renderer, no display needed):

# %%
world

# %% [markdown]
# ## Spin about each axis
#
# We step the world in chunks (`world.step(n)` runs n steps in one compiled call) and
# read the angular velocity in the box's own frame, `world.vector_to_body`. The tilt of
# the spin axis is the angle between that vector and the axis we spun about.

# %%
SECONDS = 8.0 if QUICK else 20.0


def spin(axis, seconds=SECONDS, **world_options):
    world = spinning_box(axis, **world_options)
    L0, E0 = world.angular_momentum().copy(), sum(world.energy())
    times, omegas = [0.0], [world.vector_to_body(0, world.body_angvel[0])]
    while world.time < seconds - 1e-9:
        world.step(12)                          # 0.05 s
        times.append(world.time)
        omegas.append(world.vector_to_body(0, world.body_angvel[0]))
    omegas = np.array(omegas)
    along = omegas[:, axis] / np.linalg.norm(omegas, axis=1)
    tilt = np.degrees(np.arccos(np.clip(np.abs(along), 0, 1))).max()
    flips = int(np.sum(np.diff(np.sign(omegas[:, axis])) != 0))
    dL = abs(np.linalg.norm(world.angular_momentum()) / np.linalg.norm(L0) - 1)
    turn = np.degrees(np.arccos(np.clip(world.angular_momentum() @ L0
                                        / np.linalg.norm(L0) ** 2, -1, 1)))
    dE = abs(sum(world.energy()) - E0) / E0
    return np.array(times), omegas, dict(tilt=tilt, flips=flips, dL=dL, dE=dE, turn=turn)


results = {}
for axis, name in ((0, "largest"), (1, "middle"), (2, "smallest")):
    t, omega, r = spin(axis)
    results[name] = (t, omega, r)
    print(f"spin about the {name:8s} axis: spin axis tilts up to {r['tilt']:6.2f} deg, "
          f"{r['flips']} flips; |L| changed by {r['dL']:.1e}, E by {r['dE']:.1e} (relative), "
          f"L turned by {r['turn']:.2f} deg")

# %% [markdown]
# The spins about the largest and the smallest axis stay within a degree of where they
# started; the spin about the middle axis turns over completely, again and again, while
# the energy and the size of the angular momentum stay what they were to round-off (its
# direction in the world turns by a fraction of a degree: that is the error of the
# orientation update, which shrinks with the step):

# %%
assert results["largest"][2]["tilt"] < 2 and results["smallest"][2]["tilt"] < 2
assert results["middle"][2]["flips"] >= 2 and results["middle"][2]["tilt"] > 80
assert results["middle"][2]["dE"] < 1e-9 and results["middle"][2]["dL"] < 1e-9
assert results["middle"][2]["turn"] < 1.0

t, omega, _ = results["middle"]
fig, ax = plt.subplots(figsize=(8, 3))
for k, label in enumerate(("ω_x (largest)", "ω_y (middle)", "ω_z (smallest)")):
    ax.plot(t, omega[:, k], label=label)
ax.set_xlabel("time (s)")
ax.set_ylabel("body-frame ω (rad/s)")
ax.legend(ncol=3, fontsize=8)
ax.set_title("Spin about the middle axis: the box flips over and back")
plt.show()

# %% [markdown]
# ## Implicit or explicit gyroscopic term
#
# Euler's equations carry the gyroscopic torque −ω × Iω. The lecture adds it explicitly,
# from the velocity at the start of the step; that pumps energy into a spinning body,
# more at a larger step. tumble's default (`gyroscopic="implicit"`) solves the implicit
# midpoint rule by Newton's method, which keeps kinetic energy and |L| exactly. At a
# step of 1/60 s:

# %%
def energy_drift(gyroscopic, dt=1 / 60, seconds=10.0):
    world = spinning_box(1, gyroscopic=gyroscopic)
    world.options.dt = dt
    E0 = sum(world.energy())
    world.step(int(round(seconds / dt)))
    return sum(world.energy()) / E0 - 1


drift = {g: energy_drift(g) for g in ("implicit", "explicit")}
for g, d in drift.items():
    print(f"gyroscopic={g!r:11s}: energy changed by {100 * d:+.2e} % in 10 s at dt = 1/60 s")
assert abs(drift["implicit"]) < 1e-8 and drift["explicit"] > 0.01

# %% [markdown]
# ## Watch it
#
# A `Recorder` takes a frame of the world at a chosen rate; in a notebook its
# `Recording` plays inline as an animated GIF (`recording.animation(format="mp4")`
# gives a video instead).

# %%
world = spinning_box(1)
recorder = tumble.Recorder(world)
recorder.run(3.0 if QUICK else 8.0, fps=20)
recording = recorder.recording()
recording.animation(size=(360, 240), fps=10 if QUICK else 20)

# %% [markdown]
# **Next:** [joints, ERP and CFM](../t02_joints_erp_cfm/) — bodies held together.
