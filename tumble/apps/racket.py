"""The tennis-racket (Dzhanibekov) flip: a free box spun about its middle principal axis.

Spin about the axis of largest or smallest inertia is stable; about the middle one a
tiny perturbation grows until the body turns over, again and again, while its angular
momentum and energy stay fixed. The demo prints the body-frame angular velocity as
it flips and the conservation figures at the end.
"""
import numpy as np

import tumble

HALF_EXTENTS = (0.04, 0.12, 0.25)     # m: moments I_z < I_y < I_x, middle axis y


def build(spin=np.pi, perturbation=0.01, density=500.0):
    """A world holding one box spinning at ``spin`` rad/s about its middle (y) axis."""
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_body("racket", density=density, angvel=(0.0, spin, perturbation * spin))
    b.add_geom("racket", "box", size=HALF_EXTENTS)
    return tumble.World(b.build(), dt=1.0 / 240.0)


def _row(t, w_b, spin):
    """One printed line: time, body-frame angular velocity and a bar of its y part."""
    bar = "#" * int(round(10 * (w_b[1] / spin + 1)))
    return f"  {t:7.2f} {w_b[0]:8.3f} {w_b[1]:8.3f} {w_b[2]:8.3f}   {bar}"


def run(seconds=20.0, spin=np.pi, print_every=0.5, out=print):
    """Simulate; return times (T,), body-frame angular velocities (T, 3) and a summary dict."""
    world = build(spin)
    L0 = world.angular_momentum().copy()
    E0 = world.energy()[0]
    steps_per_sample = max(1, int(round(0.05 / world.dt)))
    times, omegas = [0.0], [world.vector_to_body(0, world.body_angvel[0])]
    next_print = print_every
    flips, last_sign = 0, 1.0
    if out:
        out("    t (s)    w_x      w_y      w_z   (rad/s, body frame; y is the middle axis)")
        out(_row(0.0, omegas[0], spin))
    while world.time < seconds - 1e-9:
        world.step(steps_per_sample)
        w_b = world.vector_to_body(0, world.body_angvel[0])
        times.append(world.time)
        omegas.append(w_b)
        if np.sign(w_b[1]) != last_sign and abs(w_b[1]) > 0.5 * spin:
            flips += 1
            last_sign = np.sign(w_b[1])
        if out and world.time >= next_print - 1e-9:
            out(_row(world.time, w_b, spin))
            next_print += print_every
    dL = np.linalg.norm(world.angular_momentum() - L0) / np.linalg.norm(L0)
    dE = abs(world.energy()[0] - E0) / E0
    summary = dict(flips=flips, seconds=world.time, dL=dL, dE=dE)
    if out:
        out(f"\n{flips} half-turn flips in {world.time:.1f} s; angular momentum changed by "
            f"{100 * dL:.3f}%, energy by {100 * dE:.2e}%")
    return np.array(times), np.array(omegas), summary


def plot(times, omegas, path, spin=np.pi):
    """Save the body-frame angular velocity over time as an image (needs matplotlib)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 3.2), dpi=110)
    for k, label in enumerate(("w_x (major)", "w_y (middle)", "w_z (minor)")):
        ax.plot(times, omegas[:, k], label=label, lw=1.6)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("body angular velocity (rad/s)")
    ax.set_title("tumble: tennis-racket flip of a free box (dt = 1/240 s)")
    ax.axhline(0, color="0.7", lw=0.8)
    ax.set_ylim(-1.2 * spin, 1.2 * spin)
    ax.legend(loc="upper right", fontsize=8, ncol=3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
