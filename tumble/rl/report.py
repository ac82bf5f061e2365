"""Reading a training run's logs: its progress and evaluations as arrays, and a plot.

``read_run(run_dir)`` reads ``progress.csv`` and ``eval.csv`` (written by
``tumble.rl.train``) into dicts of NumPy arrays; ``plot_learning_curve(run_dir, path)``
draws the mean reward per step, the episode length and the reward terms against samples
(and wall hours), with the evaluations, to a PNG, for imitation and AMP runs alike.
Needs matplotlib (the ``viewer`` extra) for the plot only.
"""
import csv
from pathlib import Path

import numpy as np

from ..errors import ModelError

__all__ = ["read_run", "plot_learning_curve"]


def _read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return {}
    out = {}
    for key in rows[0]:
        try:
            out[key] = np.array([float(r[key]) for r in rows])
        except (TypeError, ValueError):
            out[key] = np.array([r[key] for r in rows])
    return out


def read_run(run_dir):
    """(progress, evaluations): dicts of (n,) arrays by column name, from a run's CSV files
    (an empty dict where a file is missing)."""
    d = Path(run_dir)
    if not (d / "progress.csv").exists():
        raise ModelError(f"read_run: {str(d)!r} has no progress.csv (not a training run)")
    progress = _read_csv(d / "progress.csv")
    evals = _read_csv(d / "eval.csv") if (d / "eval.csv").exists() else {}
    return progress, evals


def plot_learning_curve(run_dir, path, *, title=None):
    """Draw the run's learning curve to ``path`` (PNG); returns the path.

    Three panels against samples (wall hours on top): the mean reward per step; the reward
    terms (imitation: pose, velocity, end effectors, root, COM; AMP: task and style, with
    the discriminator's mean score on clip and on policy transitions, whose targets are +1
    and -1); the training episodes' length with the evaluations (imitation: survival and
    body position error; AMP: survival, speed and heading within tolerance, and the style
    reward on the policy and on held-back clip frames)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    progress, evals = read_run(run_dir)
    amp = "r_style" in progress
    x = progress["samples"] / 1e6
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    ax = axes[0]
    ax.plot(x, progress["reward"], color="tab:blue", lw=1)
    ax.set_xlabel("samples (millions)")
    ax.set_ylabel("mean reward per step")
    ax.set_ylim(0, 1)
    ax.grid(alpha=0.3)
    if len(x) > 1:
        top = ax.secondary_xaxis("top", functions=(
            lambda s: np.interp(s, x, progress["wall_hours"]),
            lambda h: np.interp(h, progress["wall_hours"], x)))
        top.set_xlabel("wall time (hours, 2 cores)")
    ax = axes[1]
    terms = ("task", "style") if amp else ("pose", "velocity", "end_effector", "root", "com")
    for name in terms:
        key = f"r_{name}"
        if key in progress:
            ax.plot(x, progress[key], lw=1, label=name)
    ax.set_xlabel("samples (millions)")
    ax.set_ylabel("reward term" if amp else "reward term, exp(-k err)")
    ax.set_ylim(0, 1)
    ax.legend(fontsize=8, loc="lower left" if amp else "lower right")
    ax.grid(alpha=0.3)
    if amp and "loss_disc_clip" in progress:
        d = ax.twinx()
        d.plot(x, progress["loss_disc_clip"], ":", color="tab:green", lw=1, label="D on clips")
        d.plot(x, progress["loss_disc_policy"], ":", color="tab:red", lw=1, label="D on policy")
        d.set_ylim(-1.5, 1.5)
        d.set_ylabel("discriminator score (targets +1, -1)")
        d.legend(fontsize=8, loc="lower right")
    ax = axes[2]
    ax.plot(x, progress["episode_seconds"], color="tab:gray", lw=1, label="training episode (s)")
    ax.set_xlabel("samples (millions)")
    ax.set_ylabel("seconds")
    ax.grid(alpha=0.3)
    if evals:
        ex = evals["samples"] / 1e6
        ax.plot(ex, evals["mean_seconds"], "o-", color="tab:green", ms=3,
                label="evaluation episode (s)")
        ax2 = ax.twinx()
        ax2.plot(ex, 100 * evals["survived"], "s--", color="tab:red", ms=3, label="survived (%)")
        if amp:
            ax2.plot(ex, 100 * evals["speed_within"], "^:", color="tab:purple", ms=3,
                     label="speed within 0.2 m/s (%)")
            ax2.plot(ex, 100 * evals["heading_within"], "v:", color="tab:orange", ms=3,
                     label="heading within 3 s (%)")
            ax2.plot(ex, 100 * evals["style_policy"], "d-", color="tab:blue", ms=3,
                     label="style on policy (%)")
            ax2.plot(ex, 100 * evals["style_clips"], "d--", color="tab:cyan", ms=3,
                     label="style on held-back clips (%)")
            ax2.set_ylabel("% of episodes / windows / max style")
            ax2.set_ylim(0, 105)
        else:
            ax2.plot(ex, 1000 * evals["mean_error"], "^:", color="tab:purple", ms=3,
                     label="body error (mm)")
            ax2.set_ylabel("% survived / error (mm)")
        ax2.legend(fontsize=7, loc="center right")
    ax.legend(fontsize=8, loc="upper left")
    kind = "AMP steering" if amp else "imitation"
    fig.suptitle(title or f"{kind} training: {Path(run_dir).name}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
