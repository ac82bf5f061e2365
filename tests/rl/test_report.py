"""Reading a run's logs and drawing its learning curve (tumble/rl/report.py), for the two
kinds of run the trainer writes: imitation and AMP. The logs are written here with the
trainer's own column names (as in runs/imitate-walk and runs/amp-walk)."""
import csv

import numpy as np
import pytest

import tumble
from tumble.rl.report import plot_learning_curve, read_run

PROGRESS = ("iteration,samples,wall_hours,reward,episode_return,episode_seconds,{terms},"
            "loss_value,loss_surrogate,loss_entropy,{disc}learning_rate,action_std,collect_s,"
            "learn_s,samples_per_s")
IMITATION_EVAL = ("iteration,samples,wall_hours,survived,mean_seconds,mean_error,mean_reward,"
                  "episodes")
AMP_EVAL = ("iteration,samples,wall_hours,survived,mean_seconds,speed_error,speed_within,"
            "heading_error,heading_within,joint_speed,episodes,style_policy,style_clips")


def write_run(d, amp, n=30):
    terms = "r_task,r_style" if amp else "r_pose,r_velocity,r_end_effector,r_root,r_com"
    disc = "loss_disc_loss,loss_disc_gp,loss_disc_clip,loss_disc_policy," if amp else ""
    rng = np.random.default_rng(0)
    d.mkdir()
    for name, header, rows in (
            ("progress.csv", PROGRESS.format(terms=terms, disc=disc), n),
            ("eval.csv", AMP_EVAL if amp else IMITATION_EVAL, n // 10)):
        cols = header.split(",")
        with open(d / name, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(cols)
            for i in range(1, rows + 1):
                it = i * (1 if name == "progress.csv" else 10)
                row = dict(zip(cols, rng.uniform(0.0, 1.0, len(cols))))
                row.update(iteration=it, samples=8192 * it, wall_hours=0.001 * it)
                w.writerow([row[c] for c in cols])


@pytest.mark.parametrize("amp", [False, True])
def test_a_runs_logs_read_back_and_plot(tmp_path, amp):
    pytest.importorskip("matplotlib")
    run = tmp_path / ("amp" if amp else "imitate")
    write_run(run, amp)
    progress, evals = read_run(run)
    assert progress["iteration"].tolist() == list(range(1, 31))
    assert progress["samples"][-1] == 8192 * 30 and len(evals["iteration"]) == 3
    assert ("r_style" in progress) == amp and ("style_clips" in evals) == amp
    png = plot_learning_curve(run, tmp_path / "curve.png")
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000


def test_a_directory_without_logs_is_not_a_run(tmp_path):
    with pytest.raises(tumble.ModelError, match="progress.csv"):
        read_run(tmp_path)
