"""matplotlib figures for examples and reports: energy over time, a joint's angle against
its target, contact forces over time.

Each function takes a recording (or plain arrays), draws into ``ax`` if given (else a new
figure), saves to ``path`` if given, and returns the matplotlib Figure. Figures are made
with the Agg backend objects directly, so no display is needed.
"""
import numpy as np

from ..errors import ModelError


def _axes(ax, figsize):
    if ax is not None:
        return ax.figure, ax
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, dpi=110)
    return fig, fig.add_subplot(1, 1, 1)


def _finish(fig, ax, path, title):
    if title:
        ax.set_title(title)
    ax.grid(True, color="0.9", lw=0.6)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path)
    return fig


def plot_energy(recording=None, *, time=None, kinetic=None, potential=None, ax=None,
                path=None, title="Energy"):
    """Kinetic, potential and total energy (J) against time (s).

    Give a recording made with ``Recorder(world, energy=True)``, or the arrays ``time``,
    ``kinetic`` and ``potential`` (each (F,)).
    """
    if recording is not None:
        if recording.kinetic is None:
            raise ModelError("plot_energy: the recording has no energy; record with "
                             "Recorder(world, energy=True)")
        time, kinetic, potential = recording.time, recording.kinetic, recording.potential
    if time is None or kinetic is None or potential is None:
        raise ModelError("plot_energy: give a recording or time, kinetic and potential")
    t, k, p = (np.asarray(a, float) for a in (time, kinetic, potential))
    if not (t.shape == k.shape == p.shape and t.ndim == 1):
        raise ModelError(f"plot_energy: time, kinetic and potential must be equal-length 1-D "
                         f"arrays, got {t.shape}, {k.shape}, {p.shape}")
    fig, ax = _axes(ax, (7, 3.2))
    ax.plot(t, k, label="kinetic", lw=1.4)
    ax.plot(t, p - p[0], label="potential (from start)", lw=1.4)
    ax.plot(t, k + p - p[0], label="total", lw=2.0, color="k")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("energy (J)")
    ax.legend(loc="best", fontsize=8)
    return _finish(fig, ax, path, title)


def plot_joint_tracking(time, angle, target, *, name="joint", unit="rad", ax=None, path=None,
                        title=None):
    """A joint coordinate and its target against time: ``time`` (F,) s, ``angle`` (F,),
    ``target`` (F,) or a constant (rad, or m for sliders: set ``unit``)."""
    t = np.asarray(time, float)
    a = np.asarray(angle, float)
    g = np.broadcast_to(np.asarray(target, float), t.shape)
    if a.shape != t.shape or t.ndim != 1:
        raise ModelError(f"plot_joint_tracking: time and angle must be equal-length 1-D "
                         f"arrays, got {t.shape} and {a.shape}")
    fig, ax = _axes(ax, (7, 3.2))
    ax.plot(t, g, "--", color="0.35", lw=1.4, label="target")
    ax.plot(t, a, lw=1.8, label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{name} ({unit})")
    ax.legend(loc="best", fontsize=8)
    return _finish(fig, ax, path, title or f"{name}: angle against target")


def contact_force_series(recording, bodies=None):
    """Per body, the total contact force magnitude on it in every frame.

    Returns ``(names, forces (F, k))`` in N for the ``bodies`` given (names or indices;
    default every body that touches something). The force on each contact's second body
    is recorded; the first body gets the opposite."""
    if not recording.has_contacts:
        raise ModelError("contact forces: the recording has no contacts; record with "
                         "Recorder(world, contacts=True)")
    scene = recording.scene
    nf = len(recording)
    total = np.zeros((nf, scene.nbody, 3))
    for i in range(nf):
        _, force, pair = recording.contacts(i)
        for side, sign in ((0, -1.0), (1, 1.0)):
            b = pair[:, side]
            ok = b >= 0
            np.add.at(total[i], b[ok], sign * force[ok])
    mag = np.linalg.norm(total, axis=-1)
    if bodies is None:
        idx = [b for b in range(scene.nbody) if mag[:, b].max() > 0]
    else:
        idx = [scene.body_index(b) for b in bodies]
    return [str(scene.body_names[b]) for b in idx], mag[:, idx]


def plot_contact_forces(recording, bodies=None, *, weight=True, ax=None, path=None,
                        title="Contact forces"):
    """Total contact force (N) on each of ``bodies`` (default: those in contact) against
    time, from a recording made with ``Recorder(world, contacts=True)``; with ``weight``,
    a dashed line marks the total weight of the dynamic bodies (what the ground carries
    at rest)."""
    names, forces = contact_force_series(recording, bodies)
    fig, ax = _axes(ax, (7, 3.2))
    t = recording.time
    for k, name in enumerate(names):
        ax.plot(t, forces[:, k], lw=1.3, label=name)
    if weight:
        s = recording.scene
        m = np.where(s.body_kind == 0, s.body_mass, 0.0).sum()
        w = m * np.linalg.norm(s.gravity)
        if w > 0:
            ax.axhline(w, ls="--", color="0.3", lw=1.0, label=f"total weight {w:.0f} N")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("contact force (N)")
    if names:
        ax.legend(loc="best", fontsize=7, ncol=2 if len(names) > 6 else 1)
    return _finish(fig, ax, path, title)
