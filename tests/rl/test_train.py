"""Training (tumble/rl/train.py): a tiny PPO run of rsl-rl on the imitation task, its files,
resuming from its checkpoint and its repeatability.

The runs are tiny (4 worlds, 8 steps each per iteration, 32-32 networks) and use one
PyTorch thread (``threads=1``): quick on a busy 2-core machine, and bit-repeatable (the
same seed gives the same first iteration to the last bit, which is asserted).
"""
import csv

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

import tumble                                            # noqa: E402
from tumble.rl.policy import Policy                      # noqa: E402
from tumble.rl.train import TrainConfig, Trainer, train  # noqa: E402


def config(**changes):
    c = dict(num_envs=4, steps_per_env=8, iterations=2, eval_every=2, eval_episodes=2,
             eval_seconds=0.5, save_every=1, hidden=(32, 32), threads=1, seed=3)
    c.update(changes)
    return TrainConfig(**c)


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A 2-iteration run, then resumed to 3 (each stage's files copied aside)."""
    out = tmp_path_factory.mktemp("run")
    log = []
    trainer = train(out, config(), progress=False, log=log.append)
    stage2 = {"progress": rows(out / "progress.csv"), "eval": rows(out / "eval.csv"),
              "policy": Policy.load(out / "policy.npz"), "log": list(log),
              "spec": trainer.env.spec()}
    return out, stage2


def test_a_short_run_writes_its_files(run):
    out, s = run
    for name in ("checkpoint.pt", "policy.npz", "best.npz", "progress.csv", "eval.csv"):
        assert (out / name).is_file(), name
    progress = s["progress"]
    assert [int(r["iteration"]) for r in progress] == [1, 2]
    assert [int(r["samples"]) for r in progress] == [32, 64]            # 4 worlds x 8 steps
    for r in progress:
        assert 0.0 < float(r["reward"]) <= 1.0
        for term in ("pose", "velocity", "end_effector", "root", "com"):
            assert 0.0 <= float(r[f"r_{term}"]) <= 1.0
        assert np.isfinite(float(r["loss_value"])) and float(r["samples_per_s"]) > 0
    ev = s["eval"]
    assert len(ev) == 1 and int(ev[0]["iteration"]) == 2 and int(ev[0]["episodes"]) == 2
    assert 0.0 <= float(ev[0]["survived"]) <= 1.0
    assert 0.0 < float(ev[0]["mean_seconds"]) <= 0.5 + 1e-9
    assert float(ev[0]["mean_error"]) > 0.0
    assert any("eval at 2" in m for m in s["log"])


def test_the_policy_file_runs_in_the_environment(run):
    out, s = run
    p = s["policy"]
    assert p.info["iteration"] == 2 and p.info["samples"] == 64
    assert p.observation_size == 303 and p.action_size == 45
    assert [w.shape[0] for w in p.weights] == [32, 32, 45]
    p.check(s["spec"])
    env = tumble.rl.ImitationEnv(2, seed=0, **config().env_options())
    p.check(env.spec())
    obs = env.reset()
    a = p.act(obs)
    assert a.shape == (2, 45) and a.dtype == np.float32 and np.all(np.abs(a) <= 1.0)
    obs, r, *_ = env.step(a)
    assert np.all(np.isfinite(obs)) and np.all(np.isfinite(r))


def test_resume_continues_the_run(run):
    out, s = run
    log = []
    trainer = Trainer(out, config(iterations=3), resume=True, progress=False, log=log.append)
    assert trainer.iteration == 2 and trainer.samples == 64
    assert any("resumed" in m and "iteration 2" in m for m in log)
    # the networks are the saved ones
    x = np.random.default_rng(0).normal(size=(5, 303)).astype(np.float32)
    assert np.array_equal(trainer.policy().act(x), s["policy"].act(x))
    trainer.run()
    progress = rows(out / "progress.csv")
    assert progress[:2] == s["progress"]
    assert [int(r["iteration"]) for r in progress] == [1, 2, 3]
    assert int(progress[2]["samples"]) == 96
    assert float(progress[2]["wall_hours"]) > float(progress[1]["wall_hours"])
    assert [int(r["iteration"]) for r in rows(out / "eval.csv")] == [2, 3]
    assert Policy.load(out / "policy.npz").info["iteration"] == 3
    # nothing to do once the iterations are done
    again = Trainer(out, config(iterations=3), resume=True, progress=False, log=log.append)
    again.run()
    assert len(rows(out / "progress.csv")) == 3


def test_resume_needs_a_checkpoint(tmp_path):
    with pytest.raises(tumble.ModelError, match="checkpoint"):
        Trainer(tmp_path / "empty", config(), resume=True, progress=False, log=None)


def test_same_seed_same_first_iteration(run, tmp_path):
    out, s = run
    train(tmp_path, config(iterations=1, eval_every=0), progress=False, log=None)
    first = rows(tmp_path / "progress.csv")
    assert len(first) == 1
    a, b = first[0], s["progress"][0]
    # bit for bit (the CSV holds Python's round-tripping repr of each float)
    for key in ("reward", "r_pose", "r_root", "loss_value", "loss_surrogate", "action_std"):
        assert a[key] == b[key], key


def _quiet(*_):
    pass


def _action_std(trainer):
    return trainer.alg.actor.distribution.std_param.detach().numpy().copy()


def test_a_fixed_action_noise_stays_fixed_and_survives_resumes(tmp_path):
    """``learn_std=False`` holds the noise at init_std through updates; ``fix_std`` turns a
    run that learnt it into one that holds it, and a resume keeps holding it."""
    held = train(tmp_path / "held", config(init_std=0.2, learn_std=False), progress=False,
                 log=_quiet)
    np.testing.assert_array_equal(_action_std(held), np.full(45, 0.2, np.float32))
    learnt = train(tmp_path / "learnt", config(init_std=0.2, learning_rate=1e-3,
                                                desired_kl=1.0), progress=False, log=_quiet)
    assert not np.allclose(_action_std(learnt), 0.2)      # the default: std is learnt
    resumed = Trainer(tmp_path / "learnt", config(iterations=3), resume=True, progress=False,
                      log=_quiet)
    resumed.fix_std(0.07)
    resumed.run()
    np.testing.assert_allclose(_action_std(resumed), 0.07, rtol=1e-6)
    again = Trainer(tmp_path / "learnt", config(iterations=4), resume=True, progress=False,
                    log=_quiet)
    assert again.config.learn_std is False and again.config.init_std == 0.07
    again.run()
    np.testing.assert_allclose(_action_std(again), 0.07, rtol=1e-6)
    with pytest.raises(tumble.ModelError, match="noise"):
        again.fix_std(0.0)


def test_a_new_discount_on_resume_trains_the_critic_first_and_is_kept(tmp_path):
    """``set_gamma`` changes PPO's discount of a resumed run: for the warm-up iterations the
    actor stays bit for bit while the critic learns the new returns; the next resume keeps
    the new discount."""
    train(tmp_path, config(learning_rate=1e-3, desired_kl=1.0), progress=False, log=_quiet)
    resumed = Trainer(tmp_path, config(iterations=4), resume=True, progress=False, log=_quiet)
    actor = {k: v.clone() for k, v in resumed.alg.actor.state_dict().items()}
    critic = {k: v.clone() for k, v in resumed.alg.critic.state_dict().items()}
    resumed.set_gamma(0.99, critic_iterations=2)
    assert resumed.alg.gamma == 0.99 and resumed.config.critic_warmup == 4
    resumed.run()
    for k, v in resumed.alg.actor.state_dict().items():
        assert (v == actor[k]).all(), k
    assert any((v != critic[k]).any() for k, v in resumed.alg.critic.state_dict().items())
    again = Trainer(tmp_path, config(iterations=5), resume=True, progress=False, log=_quiet)
    assert again.alg.gamma == 0.99 and again.config.gamma == 0.99
    again.run()
    assert any((v != actor[k]).any() for k, v in again.alg.actor.state_dict().items())
    with pytest.raises(tumble.ModelError, match="gamma"):
        again.set_gamma(1.0)


def test_a_log_gaining_a_column_on_resume_stays_aligned(tmp_path):
    """A run resumed by a tumble that logs one more column rewrites its CSV with the
    column (blank in the older rows) instead of appending misaligned rows."""
    from types import SimpleNamespace

    owner = SimpleNamespace(out_dir=tmp_path, _writer=None)
    Trainer._csv(owner, "eval.csv", {"iteration": 50, "survived": 0.5})
    Trainer._csv(owner, "eval.csv", {"iteration": 100, "survived": 0.75})
    Trainer._csv(owner, "eval.csv", {"iteration": 150, "survived": 1.0, "clip_speed": 2.5})
    Trainer._csv(owner, "eval.csv", {"iteration": 200, "survived": 1.0, "clip_speed": 2.5})
    got = rows(tmp_path / "eval.csv")
    assert [r["iteration"] for r in got] == ["50", "100", "150", "200"]
    assert [r["survived"] for r in got] == ["0.5", "0.75", "1.0", "1.0"]
    assert [r["clip_speed"] for r in got] == ["", "", "2.5", "2.5"]
