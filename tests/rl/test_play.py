"""Playing a policy where the viewer or the recorder steps the world (``tumble.rl.play``),
policies as MODEL of ``tumble view``/``record``/``export``, and ``tumble train``.

The policy here is untrained: an MLP of the right sizes with tiny weights, so its actions
are almost 0 and the residual servos track the clip on their own for about a second before
the character falls (which the fall test speeds up with a push).
"""
import importlib.util

import numpy as np
import pytest

import tumble
from tumble.cli import main
from tumble.rl import ImitationEnv
from tumble.rl import play as play_module
from tumble.rl.play import PolicyDriver, is_policy_file, load_policy, policy_world
from tumble.rl.policy import Policy
from tumble.viewer import Recorder, Recording
from tumble.viewer.sources import load_source


@pytest.fixture(scope="module")
def walk_spec():
    """The spec a policy trained on the course walk (tumble train's default) carries."""
    env = ImitationEnv(1, "walk", contact="lcp")
    spec = env.spec()
    spec["episode_seconds"] = 10.0
    return spec


def tiny_policy(spec, seed=0, scale=1e-3, hidden=16):
    """An untrained MLP policy for ``spec``: actions within about +-0.01."""
    rng = np.random.default_rng(seed)
    D, A = spec["observation_size"], spec["action_size"]
    weights = [scale * rng.standard_normal((hidden, D)), scale * rng.standard_normal((A, hidden))]
    biases = [np.zeros(hidden), np.zeros(A)]
    return Policy(weights, biases, "elu", np.zeros(D), np.ones(D), 1e-8, spec,
                  {"samples": 0, "wall_hours": 0.0})


@pytest.fixture(scope="module")
def policy_file(tmp_path_factory, walk_spec):
    path = tmp_path_factory.mktemp("policy") / "walk.npz"
    tiny_policy(walk_spec).save(path)
    return path


def horizontal(v, up):
    return np.delete(np.asarray(v), up, axis=-1)


def test_the_driver_makes_the_character_walk_with_the_clip(policy_file):
    world, driver, env = policy_world(policy_file, seed=0)
    assert isinstance(driver, PolicyDriver) and world is env.world and world.nworld == 1
    assert driver.env.substeps == 2 and world.contact == "lcp"
    assert world.options.projection_tolerance == 1e-3          # as the policy was trained
    c0 = driver.clip_time
    rec = Recorder(world)
    rec.run(1.0, fps=30, control=driver)
    r = rec.recording()
    # 60 physics steps, a policy step every second one
    assert len(r) == 31 and abs(world.time - 1.0) < 1e-9 and driver.steps == 30
    # the clip time ran with the world's: 30 policy steps of 1/30 s
    assert driver.clip_time == pytest.approx(c0 + 1.0)
    # over the first half second (before an untrained policy stumbles) the root goes the
    # way the reference's does, at a good part of its speed
    ref = env.reference.sample(np.array([c0, c0 + 0.5])).body_pos[:, env.root]
    ref_move = horizontal(ref[1] - ref[0], env.up)
    i = r.frame_index(0.5)
    moved = horizontal(r.body_pos[i, env.root] - r.body_pos[0, env.root], env.up)
    along = moved @ ref_move / np.linalg.norm(ref_move)
    assert along > 0.4 * np.linalg.norm(ref_move), (moved, ref_move)
    # and its pose is the clip's: the root-relative body error stays small meanwhile
    assert np.isfinite(driver.reward) and 0.0 < driver.reward <= 1.0


def test_the_reference_walks_where_the_clip_walks():
    # not the driver's business, but what makes "walks with the clip" above mean it: the
    # looped reference travels a cycle as the clip's own root does, horizontally
    env = ImitationEnv(1, "walk", contact="lcp")
    ref = env.reference
    raw = env.motion.root_positions
    K = ref.cycle_end
    clip_move = raw[K] - raw[0]
    ends = ref.sample(np.array([0.0, ref.period])).body_pos[:, env.root]
    ref_move = ends[1] - ends[0]
    assert abs(ref_move[env.up]) < 1e-6                 # no climbing from cycle to cycle
    np.testing.assert_allclose(horizontal(ref_move, env.up), horizontal(clip_move, env.up),
                               atol=0.05)


def test_a_fall_shows_for_a_while_then_the_character_starts_over(policy_file):
    world, driver, env = policy_world(policy_file, seed=1, fall_delay=0.5)
    root = env.root
    start_height = float(world.body_pos[root, env.up])

    falls = []

    def control(w):
        n = driver.falls
        driver(w)
        if driver.falls > n:
            falls.append(driver.last_fall)
        if w.time < 0.25:           # a hard shove sideways: down within a second
            side = np.zeros(3)
            side[0 if env.up != 0 else 2] = 900.0
            w.apply_force(root, side)

    rec = Recorder(world)
    rec.run(3.0, fps=60, control=control)
    r = rec.recording()
    assert driver.falls >= 1 and driver.restarts >= 1
    # the restart came fall_delay after the fall (both at policy-step boundaries)
    first_restart = driver._episodes[1][0]
    assert falls[0] < 1.5 and first_restart == pytest.approx(falls[0] + 0.5, abs=env.dt)
    height = r.body_pos[:, root, env.up]
    before = (r.time > first_restart - 0.5) & (r.time < first_restart + 1e-9)
    # the frame at the restart's time was taken before the driver's call that restarted
    after = r.frame_index(first_restart) + 1
    # on the ground (or nearly) before the restart, on its feet right after
    assert height[before].min() < 0.6 * start_height
    assert height[after] > 0.85 * start_height
    # it is not the same start: a new random phase of the clip
    assert driver._episodes[1][1] != driver._episodes[0][1]


def test_resetting_or_rewinding_the_world_puts_the_clip_back(policy_file):
    world, driver, env = policy_world(policy_file, seed=2)
    pos0 = world.body_pos.copy()
    first_clip = driver.clip_time

    def run(n):
        for _ in range(n):
            driver(world)
            world.step(1)

    run(30)                                     # 0.5 s: a policy-step boundary
    state = world.get_state()
    driver(world)
    clip_then = driver.clip_time
    world.step(1)
    run(25)
    # the viewer plays on from a frame scrubbed back to: the clip time is the one it was
    world.set_state(state)
    driver(world)
    assert driver.clip_time == pytest.approx(clip_then)
    world.step(1)
    run(5)
    # the viewer's reset: the built pose at time 0; the character starts as it first did
    world.reset()
    driver(world)
    assert driver.clip_time == pytest.approx(first_clip + env.dt)
    np.testing.assert_allclose(world.body_pos, pos0, atol=1e-12)
    assert driver.restarts == 0


def test_policy_files_are_models_and_recordings_still_recordings(tmp_path, policy_file):
    assert is_policy_file(policy_file)
    world, control = load_source(policy_file)
    assert isinstance(world, tumble.World) and isinstance(control, PolicyDriver)
    rec_path = Recorder(world).recording().save(tmp_path / "rec.npz")
    assert not is_policy_file(rec_path)
    rec, control = load_source(rec_path)
    assert isinstance(rec, Recording) and control is None
    # an .npz that is neither: the recording loader says what is wrong, as before
    np.savez(tmp_path / "other.npz", meta=np.array("not json"), x=np.zeros(3))
    assert not is_policy_file(tmp_path / "other.npz")
    with pytest.raises(tumble.ModelError, match="not a tumble recording"):
        load_source(tmp_path / "other.npz")
    assert not is_policy_file(tmp_path / "missing.npz")


def test_policies_by_name_and_unknown_names(tmp_path, monkeypatch, policy_file):
    with pytest.raises(tumble.ModelError, match="shipped policies") as exc:
        load_policy("nonexistent")
    shipped = play_module.shipped_policies()
    for name in shipped:
        assert name in str(exc.value)
    if not shipped:
        assert "none yet" in str(exc.value)
    with pytest.raises(tumble.ModelError, match="no policy file"):
        load_policy(tmp_path / "missing.npz")
    # a shipped directory with one policy: found by name, listed when the name is wrong
    (tmp_path / "imitate_walk.npz").write_bytes(policy_file.read_bytes())
    monkeypatch.setattr(play_module, "POLICY_DIR", tmp_path)
    assert load_policy("walk").spec["clip"] == "walk"
    with pytest.raises(tumble.ModelError, match=r"shipped policies .*: walk\b"):
        load_policy("nonexistent")
    world, control = load_source("walk")
    assert isinstance(control, PolicyDriver)
    with pytest.raises(tumble.ModelError, match=r"neither a file nor a demo.*\['walk'\]"):
        load_source("nonexistent")


def test_a_policy_for_another_character_is_refused(walk_spec):
    spec = dict(walk_spec, joint_names=["x"] + walk_spec["joint_names"][1:])
    with pytest.raises(tumble.ModelError, match="trained for another setting; joint_names"):
        policy_world(tiny_policy(spec))
    with pytest.raises(tumble.ModelError, match="one world"):
        PolicyDriver(tiny_policy(walk_spec), ImitationEnv(2, "walk", contact="lcp"))


def test_export_a_policy_to_a_gif(tmp_path, policy_file, capsys):
    pytest.importorskip("imageio_ffmpeg")
    gif = tmp_path / "walk.gif"
    assert main(["export", str(policy_file), str(gif), "--seconds", "1", "--fps", "10",
                 "--size", "96x64"]) == 0
    from PIL import Image
    with Image.open(gif) as im:
        assert im.n_frames == 10 and im.size == (96, 64)
    assert "10 frames written" in capsys.readouterr().out


def test_train_needs_torch_says_how_to_get_it(tmp_path, monkeypatch, capsys):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "torch" else real(name, *a))
    assert main(["train", "imitate", "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert 'pip install "tumble[rl]"' in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "run").exists()


def test_train_imitate_end_to_end(tmp_path, capsys):
    if importlib.util.find_spec("torch") is None or importlib.util.find_spec("rsl_rl") is None:
        pytest.skip("training needs torch and rsl-rl")
    out = tmp_path / "run"
    args = ["train", "imitate", "walk", "--out", str(out), "--envs", "4", "--iterations", "2",
            "--eval-every", "0", "--no-progress"]
    assert main(args) == 0
    assert (out / "checkpoint.pt").exists() and (out / "policy.npz").exists()
    assert "tumble play" in capsys.readouterr().out
    policy = Policy.load(out / "policy.npz")
    assert policy.spec["clip"] == "walk" and policy.info["iteration"] == 2
    # the run is not overwritten by a second start without --resume
    assert main(args) == 2
    assert "--resume" in capsys.readouterr().err
    # what it wrote plays
    world, driver, _ = policy_world(out / "policy.npz")
    Recorder(world).run(0.2, fps=30, control=driver)
    assert driver.steps == 6
