"""Behaviour cloning of the shipped imitation walk into a steering actor (tumble/rl/clone.py)
and the trainer's start from it (``TrainConfig.init_from``, ``critic_warmup``).

Small: a few thousand teacher samples, 64-64 networks, one PyTorch thread.
"""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from tumble.errors import ModelError
from tumble.rl.kernels import DOF_BALL, pd_targets
from tumble.rl.tasks.amp import AMPEnv

torch = pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

from tumble.rl.clone import (_steering_actions, clone_into, load_teacher,  # noqa: E402
                             teacher_dataset)
from tumble.rl.train import TrainConfig, Trainer, make_algorithm  # noqa: E402


@pytest.fixture(scope="module")
def student():
    e = AMPEnv(2, seed=0)
    e.reset()
    return e


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), spread=st.floats(0.05, 1.2))
def test_steering_actions_reproduce_the_targets(student, seed, spread):
    """Actions from targets, then targets from those actions (the task's own kernel): the
    same ball-joint rotations (to 1e-9) and hinge angles."""
    rng = np.random.default_rng(seed)
    nj, n = student.model.njoint, 3
    # targets: random rotation vectors and angles of the actuated joints (the kernel, from
    # the identity)
    tq, tj = np.zeros((n, nj, 4)), np.zeros((n, nj, 3))
    tq[..., 3] = 1.0
    pd_targets(rng.normal(0.0, spread, (n, student.action_size)), np.ones(student.action_size),
               False, student.dof_joint, student.dof_kind, student.dof_start, tq.copy(),
               tj.copy(), tq, tj)
    a = _steering_actions(student, tq, tj)
    oq, oj = np.zeros_like(tq), np.zeros_like(tj)
    mq = np.ascontiguousarray(np.broadcast_to(student._mean_quat, (n,) + student._mean_quat.shape))
    mj = np.ascontiguousarray(np.broadcast_to(student._mean_q, (n,) + student._mean_q.shape))
    pd_targets(a, student.action_scale, True, student.dof_joint, student.dof_kind,
               student.dof_start, mq, mj, oq, oj)
    ball = student.dof_joint[student.dof_kind == DOF_BALL]
    hinge = student.dof_joint[student.dof_kind != DOF_BALL]
    dots = np.abs(np.sum(oq[:, ball] * tq[:, ball], axis=-1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-9)
    np.testing.assert_allclose(oj[:, hinge, 0], tj[:, hinge, 0], atol=1e-12)


def test_the_dataset_holds_steering_observations_and_actions(student):
    teacher = load_teacher("walk")
    obs, act = teacher_dataset(teacher, student, samples=256, num_envs=8, noise=0.0, seed=1)
    assert obs.shape == (256, student.observation_size) and act.shape == (256, 45)
    assert obs.dtype == np.float32 and np.all(np.isfinite(obs))
    assert np.all(np.abs(act) <= 1.0)
    # the commands: drawn as the task draws them, which the teacher's actions ignore
    speed = obs[:, -1]
    lo, hi = student.speed_range
    assert np.all((speed >= lo) & (speed <= hi)) and speed.std() > 0.2 * (hi - lo)
    cos_sin = obs[:, -3:-1].astype(float)
    np.testing.assert_allclose(np.hypot(cos_sin[:, 0], cos_sin[:, 1]), 1.0, atol=1e-5)
    assert (cos_sin[:, 0] < 0).any() and (cos_sin[:, 1] < 0).any()


def test_a_teacher_of_another_character_is_refused(student):
    teacher = load_teacher("walk")
    teacher.spec = dict(teacher.spec, body_names=["a"] * len(teacher.spec["body_names"]))
    with pytest.raises(ModelError, match="another character"):
        teacher_dataset(teacher, student, samples=8, num_envs=2)
    amp_policy = load_teacher("walk")
    amp_policy.spec = dict(amp_policy.spec, task="amp")
    with pytest.raises(ModelError, match="imitation policy"):
        teacher_dataset(amp_policy, student, samples=8, num_envs=2)
    with pytest.raises(ModelError, match="shipped policies"):
        load_teacher("no-such-policy")


def test_the_cloned_actor_acts_as_the_teacher_targets(student):
    """After fitting, the actor's mean action is close to the teacher's on states it was
    not fitted on."""
    torch.manual_seed(0)
    c = TrainConfig.for_task("amp", num_envs=2, hidden=(64, 64), threads=1)
    alg = make_algorithm(c, 2, student.observation_size, student.action_size)
    mse = clone_into(alg, student, "walk", samples=3000, noise=0.1, epochs=40, seed=2)
    teacher = load_teacher("walk")
    obs, act = teacher_dataset(teacher, student, samples=256, num_envs=8, noise=0.1, seed=9)
    actor = alg.get_policy()
    with torch.no_grad():
        pred = actor.mlp(actor.obs_normalizer(torch.as_tensor(obs))).numpy()
    fresh = float(np.mean((pred - act) ** 2))
    spread = float(np.mean((act - act.mean(axis=0)) ** 2))
    assert mse < 0.1 * spread and fresh < 0.2 * spread, (mse, fresh, spread)


def test_a_run_starts_from_the_teacher_and_warms_up_its_critic(tmp_path):
    c = TrainConfig.for_task(
        "amp", num_envs=4, steps_per_env=8, iterations=2, eval_every=0, save_every=1,
        hidden=(32, 32), disc_hidden=(32, 32), disc_batches=2, disc_batch_size=32,
        replay_size=256, threads=1, seed=5, episode_seconds=2.0, init_from="walk",
        clone_samples=512, clone_epochs=2, critic_warmup=1)
    t = Trainer(tmp_path, c, progress=False, log=None)
    assert np.isfinite(t.clone_error)
    before = {k: v.clone() for k, v in t.alg.actor.state_dict().items()}
    critic = {k: v.clone() for k, v in t.alg.critic.state_dict().items()}
    t.run(iterations=1)
    for k, v in t.alg.actor.state_dict().items():
        assert torch.equal(v, before[k]), k
    assert any(not torch.equal(v, critic[k]) for k, v in t.alg.critic.state_dict().items())
    t.run(iterations=2)
    after = t.alg.actor.state_dict()
    assert any(not torch.equal(v, before[k]) for k, v in after.items() if "normalizer" not in k)
    # the cloned actor's observation normaliser stays as the teacher's data set it
    norm = [k for k in after if "normalizer" in k]
    assert norm and all(torch.equal(after[k], before[k]) for k in norm)
    # a resumed run does not clone again (it has its networks) and keeps it frozen
    again = Trainer(tmp_path, c, resume=True, progress=False, log=None)
    assert not hasattr(again, "clone_error")
    assert again.config.init_from == "walk"
    kept = {k: v.clone() for k, v in again.alg.actor.state_dict().items() if k in norm}
    again.run(iterations=3)
    assert all(torch.equal(again.alg.actor.state_dict()[k], kept[k]) for k in norm)


def test_train_amp_from_the_walk_on_the_command_line(tmp_path, capsys, monkeypatch):
    from tumble.cli import main
    from tumble.rl import clone
    real = clone.clone_into
    monkeypatch.setattr(clone, "clone_into", lambda *a, **kw: real(
        *a, **{**kw, "samples": 256, "epochs": 1}))          # a small teacher data set
    out = tmp_path / "run"
    assert main(["train", "amp", "walk", "--init-from", "walk", "--out", str(out), "--envs", "4",
                 "--iterations", "1", "--eval-every", "0", "--no-progress"]) == 0
    assert "clone: 256 samples of the teacher" in capsys.readouterr().out
    config = torch.load(out / "checkpoint.pt", weights_only=False)["config"]
    assert config["init_from"] == "walk" and config["critic_warmup"] == 40
    assert config["init_std"] == 0.05
    code = main(["train", "amp", "--init-from", "no-such-walk", "--out", str(tmp_path / "x"),
                 "--envs", "4", "--iterations", "1", "--no-progress"])
    assert code != 0 and "shipped policies" in capsys.readouterr().err
