"""Training on Ray (tumble/rl/distributed.py): rollout workers feeding one learner, on a local
cluster of 2 CPUs. Skipped only when Ray (or PyTorch and rsl-rl) is not installed.

Runs are tiny (4 worlds a worker, 8 steps, 32-32 networks, one thread) so that the cluster's
start-up (about 15 s) dominates.
"""
import csv
import os
import signal

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("rsl_rl")
ray = pytest.importorskip("ray")

from tumble.rl.distributed import RayTrainer, init_ray   # noqa: E402
from tumble.rl.policy import Policy                      # noqa: E402
from tumble.rl.train import TrainConfig, Trainer         # noqa: E402


def config(**changes):
    c = dict(num_envs=4, steps_per_env=8, iterations=2, eval_every=0, save_every=1,
             hidden=(32, 32), threads=1, seed=3)
    c.update(changes)
    return TrainConfig(**c)


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module", autouse=True)
def cluster():
    init_ray(num_cpus=2)
    yield
    ray.shutdown()


def test_one_worker_repeats_the_single_process_trainer(tmp_path):
    """Same seed, same worlds, same threads: the same run to the last bit."""
    remote = RayTrainer(tmp_path / "ray", config(), workers=1, progress=False, log=None)
    remote.run()
    remote.close()
    local = Trainer(tmp_path / "local", config(), progress=False, log=None)
    local.run()
    a, b = rows(tmp_path / "ray" / "progress.csv"), rows(tmp_path / "local" / "progress.csv")
    assert len(a) == len(b) == 2
    for ra, rb in zip(a, b):
        for key in ("samples", "reward", "r_pose", "r_root", "loss_value", "loss_surrogate",
                    "action_std", "learning_rate"):
            assert ra[key] == rb[key], key
    x = np.random.default_rng(0).normal(size=(3, 303)).astype(np.float32)
    assert np.array_equal(Policy.load(tmp_path / "ray" / "policy.npz").act(x),
                          Policy.load(tmp_path / "local" / "policy.npz").act(x))


def test_two_workers_train_replace_a_killed_one_checkpoint_and_resume(tmp_path):
    """One run through it all (each trainer starts two worker processes: seconds each)."""
    out = tmp_path / "run"
    log = []
    t = RayTrainer(out, config(), workers=2, progress=False, log=log.append)
    # the learner compiled (or loaded) the kernels first: the workers load them
    pids = {pid for pid, _, _ in t.worker_info}
    assert len(pids) == 2 and os.getpid() not in pids
    assert all(seconds < 120 for _, seconds, _ in t.worker_info), t.worker_info
    t.run()
    assert [int(r["samples"]) for r in rows(out / "progress.csv")] == [64, 128]  # 2 x 4 x 8
    assert (out / "checkpoint.pt").exists()
    os.kill(t.worker_info[1][0], signal.SIGKILL)          # a worker's process dies
    t.run(3)
    t.close()
    assert t.iteration == 3 and t.worker_restarts >= 1
    assert any("worker 1 failed" in m for m in log)
    again = RayTrainer(out, config(iterations=4), workers=2, resume=True, progress=False,
                       log=None)
    assert again.iteration == 3
    again.run()
    again.close()
    assert [int(r["iteration"]) for r in rows(out / "progress.csv")] == [1, 2, 3, 4]


def test_amp_trains_on_workers(tmp_path):
    c = TrainConfig.for_task("amp", num_envs=4, steps_per_env=8, iterations=1, eval_every=0,
                             save_every=1, hidden=(32, 32), disc_hidden=(32, 32),
                             disc_batches=2, disc_batch_size=32, replay_size=256, threads=1,
                             seed=5, episode_seconds=2.0)
    t = RayTrainer(tmp_path / "amp", c, workers=2, progress=False, log=None)
    t.run()
    t.close()
    r = rows(tmp_path / "amp" / "progress.csv")[0]
    assert int(r["samples"]) == 64
    assert 0.0 <= float(r["r_style"]) <= 1.0 and np.isfinite(float(r["loss_disc_loss"]))
    assert t.style.replay_fill == 64                     # both workers' transitions


def test_train_with_workers_from_the_command_line(tmp_path, capsys):
    from tumble.cli import main
    out = tmp_path / "run"
    assert main(["train", "imitate", "walk", "--out", str(out), "--envs", "4", "--iterations",
                 "1", "--eval-every", "0", "--no-progress", "--workers", "2"]) == 0
    assert "tumble play" in capsys.readouterr().out
    assert int(rows(out / "progress.csv")[0]["samples"]) == 2 * 4 * 32


def test_workers_run_at_the_learners_priority():
    """Ray starts its workers at niceness 15, which starves them beside any busy process;
    a local cluster of init_ray's keeps them at the learner's."""
    @ray.remote(num_cpus=1)
    def niceness():
        return os.nice(0)
    assert ray.get(niceness.remote()) == os.nice(0)


def test_bad_worker_counts_are_refused(tmp_path):
    import tumble
    with pytest.raises(tumble.ModelError, match="workers"):
        RayTrainer(tmp_path, config(), workers=0)
    with pytest.raises(tumble.ModelError, match="worker_cpus"):
        RayTrainer(tmp_path, config(), workers=1, worker_cpus=0)
