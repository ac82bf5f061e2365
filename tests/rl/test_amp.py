"""Adversarial motion priors: the steering task (tumble/rl/tasks/amp.py), its kernels, the
discriminator and style reward (tumble/rl/amp.py), training and resuming (tumble/rl/train.py)
and the command-following evaluation (tumble/rl/amp_eval.py).

Runs are tiny (4 worlds, 8 steps per iteration, 32-32 networks, one PyTorch thread): quick on
a busy 2-core machine and bit-repeatable.
"""
import csv
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import tumble
from tumble.rl.kernels import amp_features, heading_reward
from tumble.rl.tasks.amp import AMPEnv, _turn

torch = pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

from tumble.rl.amp import (AMPStyle, Discriminator, gradient_penalty,  # noqa: E402
                           lsgan_loss, style_reward)
from tumble.rl.amp_eval import evaluate_amp                            # noqa: E402
from tumble.rl.policy import Policy                                    # noqa: E402
from tumble.rl.train import TrainConfig, Trainer, train                # noqa: E402


@pytest.fixture(scope="module")
def env():
    e = AMPEnv(4, seed=0)
    e.reset()
    return e


def features(env, s):
    out = np.empty((len(s.body_pos), env.amp_feature_size), np.float32)
    amp_features(s.body_pos, s.body_quat, s.body_vel, s.body_angvel, s.joint_quat, s.joint_qd,
                 env.root, env.up, env.amp_joints, env.end_effectors, out)
    return out


def test_sizes_and_spec(env):
    nb = env.model.nbody
    assert env.observation_size == 1 + 15 * nb + 3
    assert env.action_size == 45
    # 13 root features, 9 per actuated joint but the toes (17), 3 per end effector (wrists
    # and ankles)
    assert env.amp_feature_size == 13 + 9 * 17 + 3 * 4
    assert not any("toe" in env.model.joint_names[j].lower() for j in env.amp_joints)
    spec = env.spec()
    assert spec["task"] == "amp" and spec["clips"] == ["walk", "run", "idle"]
    obs, r, term, trunc, info = env.step(np.zeros((4, env.action_size)))
    assert obs.shape == (4, env.observation_size) and obs.dtype == np.float32
    assert info["amp_obs"].shape == (4, env.amp_observation_size)
    assert np.all((0.0 <= r) & (r <= 1.0))


@settings(max_examples=20, deadline=None)
@given(yaw=st.floats(-math.pi, math.pi), t=st.floats(0.0, 0.9), clip=st.integers(0, 2))
def test_the_discriminator_features_do_not_depend_on_heading(env, yaw, t, clip):
    which = np.array([clip])
    s = env._sample_clips(which, np.array([t * env.references[clip].period]))
    before = features(env, s)
    _turn(s, np.array([yaw]), env.up, env.root)
    after = features(env, s)
    np.testing.assert_allclose(after, before, atol=2e-5)


def test_the_discriminator_sees_a_clips_hinge_by_its_angle(env):
    """A clip's knee turns a little off its axis, which a simulated hinge cannot: the
    clips' transitions hold each hinge's rotation about its axis by its angle, as the
    simulated character's do."""
    from tumble.math import quat_np as Q
    ref = env.references[0]
    off_axis = [np.abs(Q.qrotvec(ref.frames.joint_quat[:, j])[:, 1:]).max() for j in env.amp_hinges]
    assert max(off_axis) > 0.05                       # the clip's own rotations are off axis
    s = env._sample_clips(np.zeros(8, np.int64), np.linspace(0.0, 0.8, 8))
    angles = s.joint_q[:, env.amp_hinges, 0].copy()
    env._hinges_on_axis(s)
    rv = Q.qrotvec(s.joint_quat[:, env.amp_hinges])
    np.testing.assert_allclose(rv[..., 0], angles, atol=1e-12)
    np.testing.assert_allclose(rv[..., 1:], 0.0, atol=1e-12)
    # the simulated hinges: rotations about their joint frame's x axis by their angle
    env.step(np.random.default_rng(0).uniform(-0.5, 0.5, (4, env.action_size)))
    sim = Q.qrotvec(env._joint_quat[:, env.amp_hinges])
    q = np.reshape(env.world.joint_q, (4, env.model.njoint, 3))[:, env.amp_hinges, 0]
    np.testing.assert_allclose(sim[..., 0], q, atol=1e-9)
    # off the axis only by what the joints drift before projection pulls them back
    np.testing.assert_allclose(sim[..., 1:], 0.0, atol=env.world.options.projection_tolerance)


def test_the_clips_move_the_way_the_character_faces(env):
    """The heading (the root's x axis turned by ``forward``) is the clips' direction of
    travel: on the walk clip, the centre of mass moves along it at about 1.2 m/s."""
    ref = env.references[0]
    s = ref.sample(np.linspace(0.0, ref.period, 40, endpoint=False))
    env.world.set_body_state(s.body_pos[:4], s.body_quat[:4], s.body_vel[:4], s.body_angvel[:4])
    d = env.direction(env.heading)
    along = np.einsum("ij,ij->i", s.com_vel[:4], d)
    assert np.all(along > 0.9), along


def test_task_reward_is_one_on_the_command_and_falls_off(env):
    N, nb = 3, env.model.nbody
    heading = np.array([0.3, -2.0, 1.0])
    speed = np.array([1.5, 0.5, 2.0])
    vel = np.zeros((N, nb, 3))
    vel[:] = (env.direction(heading) * speed[:, None])[:, None, :]
    vel[2] += [0.0, 0.0, 0.5]                 # wrong by 0.5 m/s (z is horizontal, Y up)
    reward, com = np.zeros(N), np.zeros((N, 3))
    heading_reward(vel, env.model.body_mass, env.up, heading, speed, 2.0, 0, reward, com)
    np.testing.assert_allclose(reward[:2], 1.0, atol=1e-12)
    assert reward[2] == pytest.approx(math.exp(-2.0 * 0.25))
    # AMP's form: only the shortfall of the speed along the command counts
    heading_reward(vel, env.model.body_mass, env.up, heading, speed, 2.0, 1, reward, com)
    along = np.einsum("ij,ij->i", env.direction(heading), vel[:, 0])
    np.testing.assert_allclose(reward, np.exp(-2.0 * np.maximum(0.0, speed - along) ** 2),
                               rtol=1e-12)
    assert reward[2] < 1.0 and along[2] < speed[2]       # the added 0.5 m/s points partly back
    heading_reward(1.5 * vel[:2], env.model.body_mass, env.up, heading[:2], speed[:2], 2.0,
                   1, reward[:2], com[:2])
    np.testing.assert_allclose(reward[:2], 1.0, atol=1e-12)      # faster costs nothing
    # "speed": the speed along the command matched both ways; faster costs as slower does
    heading_reward(1.5 * vel[:2], env.model.body_mass, env.up, heading[:2], speed[:2], 2.0,
                   2, reward[:2], com[:2])
    np.testing.assert_allclose(reward[:2], np.exp(-2.0 * (0.5 * speed[:2]) ** 2), rtol=1e-12)
    heading_reward(0.5 * vel[:2], env.model.body_mass, env.up, heading[:2], speed[:2], 2.0,
                   2, reward[:2], com[:2])
    np.testing.assert_allclose(reward[:2], np.exp(-2.0 * (0.5 * speed[:2]) ** 2), rtol=1e-12)
    heading_reward(vel, env.model.body_mass, env.up, heading, speed, 2.0, 2, reward, com)
    np.testing.assert_allclose(reward, np.exp(-2.0 * (speed - along) ** 2), rtol=1e-12)


@pytest.mark.parametrize("mode", [0, 1, 2])
def test_walking_the_wrong_way_against_standing(env, mode):
    """Under "vector" standing still beats walking 90 degrees off the command; under AMP's
    "along" and under "speed" both earn the same, and walking 45 degrees off earns more."""
    along = mode > 0
    nb = env.model.nbody
    heading, speed = np.zeros(3), np.full(3, 1.25)
    off = env.direction(np.array([0.0, math.pi / 2, math.pi / 4]))
    vel = np.zeros((3, nb, 3))
    vel[1:] = (1.25 * off[1:])[:, None, :]
    reward, com = np.zeros(3), np.zeros((3, 3))
    heading_reward(vel, env.model.body_mass, env.up, heading, speed, 1.0, mode, reward, com)
    stand, sideways, diagonal = reward
    assert stand == pytest.approx(math.exp(-1.25 ** 2))
    if along:
        assert sideways == pytest.approx(stand) and diagonal > stand
    else:
        assert sideways == pytest.approx(math.exp(-2 * 1.25 ** 2)) and sideways < stand


def test_a_command_is_observed_relative_to_the_heading(env):
    obs = env.set_command(0.0, 1.25, relative=True)
    np.testing.assert_allclose(obs[:, -3], 1.0, atol=1e-6)
    np.testing.assert_allclose(obs[:, -2], 0.0, atol=1e-6)
    np.testing.assert_allclose(obs[:, -1], 1.25)
    obs = env.set_command(env.heading + math.pi / 2, None)
    np.testing.assert_allclose(obs[:, -2], 1.0, atol=1e-6)        # sin(90 degrees)


def test_commands_change_only_when_asked(env):
    env.reset(seed=1)
    env.commands_change = False
    before = env.target_heading.copy(), env.target_speed.copy()
    for _ in range(5):
        env.step(np.zeros((4, env.action_size)))
    # worlds that fell were restarted with a new command; the others keep theirs
    env.commands_change = True
    env.command_timer[:] = 0.01
    env.step(np.zeros((4, env.action_size)))
    lo, hi = env.speed_range
    assert np.all((lo <= env.target_speed) & (env.target_speed <= hi))
    assert not np.array_equal(before[1], env.target_speed)


def test_reference_transitions_keep_the_held_back_frames_apart(env):
    rng = np.random.default_rng(0)
    a = env.reference_transitions(64, rng)
    b = env.reference_transitions(64, rng, held_out=True)
    assert a.shape == b.shape == (64, env.amp_observation_size)
    assert np.all(np.isfinite(a)) and np.all(np.isfinite(b))
    # s' is one policy step after s: the root height changes little
    assert np.all(np.abs(a[:, env.amp_feature_size] - a[:, 0]) < 0.1)


def test_clip_transitions_turn_only_the_roots_yaw_rate(env):
    """turn_rate: the same clip transitions, each shown turning at one yaw rate within
    +-turn_rate, in s and s' alike; no other feature moves."""
    F, k = env.amp_feature_size, 10 + env.up          # the root's vertical angular velocity
    straight, turning = AMPEnv.__new__(AMPEnv), AMPEnv.__new__(AMPEnv)
    straight.__dict__.update(env.__dict__, turn_rate=0.0)
    turning.__dict__.update(env.__dict__, turn_rate=0.8)
    a = straight.reference_transitions(256, np.random.default_rng(5))
    b = turning.reference_transitions(256, np.random.default_rng(5))
    added = b[:, k] - a[:, k]
    np.testing.assert_allclose(b[:, F + k] - a[:, F + k], added, atol=1e-5)
    assert np.all(np.abs(added) <= 0.8 + 1e-6) and added.std() > 0.3      # spread over it
    others = np.ones(2 * F, bool)
    others[[k, F + k]] = False
    np.testing.assert_array_equal(a[:, others], b[:, others])
    assert env.spec()["turn_rate"] == env.turn_rate == 0.8


@pytest.mark.parametrize("bad, match", [
    (dict(clips=[]), "clips"), (dict(clips="walk"), "clips"),
    (dict(speed_range=(2.0, 1.0)), "speed_range"), (dict(speed_range=(-1, 1)), "speed_range"),
    (dict(command_seconds=(0, 1)), "command_seconds"), (dict(max_turn=4.0), "max_turn"),
    (dict(task_scale=0.0), "task_scale"), (dict(holdout=1.0), "holdout"),
    (dict(clips=["no_such_clip.bvh"]), "no_such_clip"), (dict(turn_rate=-0.1), "turn_rate"),
    (dict(turn_rate=float("nan")), "turn_rate"), (dict(task_reward="fast"), "task_reward"),
])
def test_bad_settings_are_named(bad, match):
    with pytest.raises(tumble.TumbleError, match=match):
        AMPEnv(1, **bad)


def test_bad_commands_are_refused(env):
    with pytest.raises(tumble.ModelError, match="speed"):
        env.set_command(0.0, -1.0)
    with pytest.raises(tumble.ModelError, match="heading"):
        env.set_command(float("nan"), 1.0)


# -- the discriminator ---------------------------------------------------------------------

@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=20))
def test_style_reward_lies_in_zero_one(scores):
    r = style_reward(torch.tensor(scores, dtype=torch.float64))
    assert torch.all((r >= 0.0) & (r <= 1.0))
    assert float(style_reward(torch.tensor([1.0]))) == 1.0


def test_gradient_penalty_is_zero_on_a_constant_discriminator():
    d = Discriminator(10, (8, 8))
    with torch.no_grad():
        for p in d.parameters():
            p.zero_()
        d.head.bias.fill_(0.7)
    x = torch.randn(16, 10)
    assert gradient_penalty(d, x).item() == 0.0
    assert d(x, normalized=True)[0].item() == pytest.approx(0.7)
    # and positive on one that depends on its input: D(x) = sum(x) has |grad|^2 = 10
    lin = Discriminator(10, ())
    with torch.no_grad():
        lin.head.weight.fill_(1.0)
        lin.head.bias.zero_()
    assert gradient_penalty(lin, x).item() == pytest.approx(10.0)


def test_lsgan_loss_is_zero_at_the_targets():
    assert float(lsgan_loss(torch.ones(4), -torch.ones(4))) == 0.0
    assert float(lsgan_loss(torch.zeros(4), torch.zeros(4))) == pytest.approx(1.0)


def test_the_discriminator_separates_clips_from_random_motion(env):
    """After a short fit, clip transitions score higher than those of a character driven
    by random actions, and their style reward is higher."""
    torch.manual_seed(0)
    style = AMPStyle(env, hidden=(64, 64), learning_rate=1e-3, batches=20, batch_size=128,
                     replay_size=2000, seed=0)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    for _ in range(4):
        for _ in range(16):
            _, r, _, _, info = env.step(rng.uniform(-1, 1, (4, env.action_size)))
            style.combine(r, info["amp_obs"])
        losses = style.update()
    assert set(losses) == {"disc_loss", "disc_gp", "disc_clip", "disc_policy"}
    clips = env.reference_transitions(256, rng, held_out=True)
    rand = []
    for _ in range(16):
        _, _, _, _, info = env.step(rng.uniform(-1, 1, (4, env.action_size)))
        rand.append(info["amp_obs"])
    rand = np.concatenate(rand)
    d_clip, d_rand = style.score(clips).mean(), style.score(rand).mean()
    assert d_clip > 0.5 and d_rand < -0.5, (d_clip, d_rand)
    assert style.clip_style() > float(style_reward(style.score(rand)).mean()) + 0.3


# -- training --------------------------------------------------------------------------------

def config(**changes):
    c = dict(num_envs=4, steps_per_env=8, iterations=2, eval_every=2, eval_episodes=2,
             eval_seconds=2.0, save_every=1, hidden=(32, 32), disc_hidden=(32, 32),
             disc_batches=2, disc_batch_size=32, replay_size=256, threads=1, seed=5,
             episode_seconds=2.0)
    c.update(changes)
    return TrainConfig.for_task("amp", **c)


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("amp-run")
    log = []
    train(out, config(), progress=False, log=log.append)
    return out, rows(out / "progress.csv"), rows(out / "eval.csv"), log


def test_a_short_amp_run_trains_and_logs_the_discriminator(run):
    out, progress, ev, log = run
    assert [int(r["iteration"]) for r in progress] == [1, 2]
    for r in progress:
        for k in ("r_task", "r_style"):
            assert 0.0 <= float(r[k]) <= 1.0
        for k in ("loss_disc_loss", "loss_disc_gp", "loss_disc_clip", "loss_disc_policy",
                  "loss_value"):
            assert np.isfinite(float(r[k])), k
    assert len(ev) == 1
    for k in ("survived", "speed_within", "heading_within", "style_policy", "style_clips"):
        assert 0.0 <= float(ev[0][k]) <= 1.0, k
    assert any("eval at 2" in m and "speed error" in m for m in log)
    p = Policy.load(out / "policy.npz")
    assert p.spec["task"] == "amp" and p.action_size == 45


def test_an_amp_run_resumes_with_its_discriminator(run):
    out, progress, _, log = run
    t = Trainer(out, config(iterations=3), resume=True, progress=False, log=log.append)
    saved = torch.load(out / "checkpoint.pt", weights_only=False)
    for k, v in saved["style"]["disc"].items():
        assert torch.equal(t.style.disc.state_dict()[k], v), k
    t.run()
    again = rows(out / "progress.csv")
    assert again[:2] == progress and int(again[2]["iteration"]) == 3


def test_seeded_amp_runs_repeat(run, tmp_path):
    _, progress, _, _ = run
    train(tmp_path, config(iterations=1, eval_every=0), progress=False, log=None)
    first = rows(tmp_path / "progress.csv")[0]
    for key in ("reward", "r_task", "r_style", "loss_value", "loss_disc_loss", "action_std"):
        assert first[key] == progress[0][key], key


def test_evaluate_amp_reports_command_following(run):
    out, *_ = run
    p = Policy.load(out / "policy.npz")
    r = evaluate_amp(p, config(), episodes=2, seconds=7.0, window=3.5, turn_seconds=1.5)
    assert r["episodes"] == 2 and 0.0 < r["mean_seconds"] <= 7.0 + 1e-9
    assert r["joint_speed"] > 0.0
    # the clips' joints (walk and run) move at a few rad/s RMS
    assert 0.5 < r["clip_joint_speed"] < 10.0


# -- playing and the command line -------------------------------------------------------------

def test_a_steering_policy_plays_and_takes_commands(run):
    from tumble.rl.play import policy_world
    out, *_ = run
    world, driver, env = policy_world(out / "policy.npz", seed=0)
    assert driver.clip_time is None and not env.commands_change
    driver.command(math.pi / 2, 1.5, relative=True)
    goal = env.target_heading[0]
    for _ in range(90):                       # 1.5 s: the tiny policy falls and restarts
        driver(world)
        world.step(1)
    assert driver.steps == 45
    # the command outlives restarts
    assert env.target_speed[0] == 1.5 and env.target_heading[0] == goal
    # an imitation policy takes no commands
    _, walker, _ = policy_world("walk")
    with pytest.raises(tumble.ModelError, match="steering"):
        walker.command(0.0, 1.0)


def test_the_viewer_page_steers_the_character(run):
    pytest.importorskip("viser")
    from tumble.rl.play import add_steering_gui, policy_world
    from tumble.viewer.app import Viewer
    out, *_ = run
    world, driver, env = policy_world(out / "policy.npz", seed=0)
    with Viewer(world, port=0, paused=True, control=driver) as v:
        speed, heading = add_steering_gui(v, driver)
        speed.value = 1.75
        heading.value = 90.0
        assert env.target_speed[0] == pytest.approx(1.75)
        assert env.target_heading[0] == pytest.approx(math.pi / 2)


def test_steer_gymnasium_environment():
    gym = pytest.importorskip("gymnasium")
    e = gym.make("tumble/Steer-v0", clips=("walk", "idle"))
    obs, info = e.reset(seed=0)
    assert e.observation_space.contains(obs) and "target_speed" in info
    obs, r, term, trunc, info = e.step(e.action_space.sample())
    assert info["amp_obs"].shape == (e.unwrapped.task.amp_observation_size,)
    v = gym.make_vec("tumble/Steer-v0", num_envs=3, vectorization_mode="vector_entry_point")
    obs, _ = v.reset(seed=0)
    obs, r, term, trunc, infos = v.step(v.action_space.sample())
    assert obs.shape == (3, 304) and infos["amp_obs"].shape == (3, 356)


def test_train_amp_from_the_command_line(tmp_path, capsys):
    from tumble.cli import main
    out = tmp_path / "run"
    args = ["train", "amp", "walk", "idle", "--out", str(out), "--envs", "4", "--iterations",
            "1", "--eval-every", "0", "--no-progress", "--task-reward", "along"]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "amp 'walk, idle'" in text and "tumble play" in text
    p = Policy.load(out / "policy.npz")
    assert p.spec["clips"] == ["walk", "idle"] and p.info["iteration"] == 1
    assert main(args) == 2                                 # never overwrites a run
    assert main(["train", "amp", "--out", str(out), "--resume", "--iterations", "2",
                 "--fixed-std", "0.07", "--no-progress"]) == 0
    assert Policy.load(out / "policy.npz").info["iteration"] == 2
    saved = torch.load(out / "checkpoint.pt", weights_only=False, map_location="cpu")
    assert saved["config"]["learn_std"] is False and saved["config"]["init_std"] == 0.07
    assert TrainConfig.for_task("amp").learn_std           # learnt unless asked
    assert saved["spec"]["turn_rate"] == 0.8 and saved["spec"]["task_reward"] == "along"
    # a resumed run may change its task reward; the change is saved with it
    assert main(["train", "amp", "--out", str(out), "--resume", "--iterations", "3",
                 "--task-reward", "vector", "--no-progress"]) == 0
    saved = torch.load(out / "checkpoint.pt", weights_only=False, map_location="cpu")
    assert saved["iteration"] == 3 and saved["spec"]["task_reward"] == "vector"
    assert saved["config"]["env_kwargs"]["task_reward"] == "vector"
    assert saved["config"]["learn_std"] is False           # the rest as the run had it
    # a curriculum: the random commands' settings change on resume, and reach the env
    assert main(["train", "amp", "--out", str(out), "--resume", "--iterations", "4",
                 "--task-reward", "speed", "--max-turn", "90", "--command-seconds", "4", "8",
                 "--speed-range", "0.5", "2", "--task-scale", "4", "--gamma", "0.99",
                 "--no-progress"]) == 0
    saved = torch.load(out / "checkpoint.pt", weights_only=False, map_location="cpu")
    kw = saved["config"]["env_kwargs"]
    assert kw["task_reward"] == "speed" and kw["max_turn"] == pytest.approx(math.pi / 2)
    assert kw["task_scale"] == 4.0 and saved["config"]["gamma"] == 0.99
    assert tuple(kw["command_seconds"]) == (4.0, 8.0) and tuple(kw["speed_range"]) == (0.5, 2.0)
    trainer = Trainer(out, resume=True, progress=False, log=lambda *a: None)
    assert trainer.env.max_turn == pytest.approx(math.pi / 2)
    assert trainer.env.speed_range == (0.5, 2.0) and trainer.env.task_reward == "speed"
    assert trainer.env.task_scale == 4.0 and trainer.alg.gamma == 0.99
    with pytest.raises(SystemExit):                        # a turn beyond 180 degrees
        main(["train", "amp", "--out", str(out), "--resume", "--max-turn", "200"])
