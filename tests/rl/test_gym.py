"""The Gymnasium facades (tumble/rl/gym.py): ``tumble/Imitate-v0`` as a single
``gymnasium.Env`` and as a ``VectorEnv`` over one batch of worlds with same-step autoreset.

Observations are compared bit for bit where the docs promise repetition (seeded resets).
"""
import warnings

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")
from gymnasium.utils.env_checker import check_env       # noqa: E402
from gymnasium.vector import AutoresetMode               # noqa: E402

import tumble                                             # noqa: E402
import tumble.rl                                          # noqa: E402,F401  (registers the id)
from tumble.rl.gym import ImitateEnv, ImitateVectorEnv    # noqa: E402

ID = "tumble/Imitate-v0"
D, A = 303, 45

# The passive checker's only remarks: the observation Box is unbounded (positions and
# velocities), as MuJoCo's own environments' are.
UNBOUNDED = ("minimum value is -infinity", "maximum value is infinity")


def unexpected(records):
    return [str(r.message) for r in records
            if not any(u in str(r.message) for u in UNBOUNDED)]


@pytest.fixture(scope="module")
def vec():
    env = gymnasium.make_vec(ID, num_envs=4, vectorization_mode="vector_entry_point",
                             episode_seconds=0.2)
    yield env
    env.close()


def test_registered():
    assert ID in gymnasium.registry
    spec = gymnasium.registry[ID]
    assert spec.entry_point == "tumble.rl.gym:ImitateEnv"
    assert spec.vector_entry_point == "tumble.rl.gym:ImitateVectorEnv"


def test_env_checker_passes():
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        env = gymnasium.make(ID)
        assert isinstance(env.unwrapped, ImitateEnv)
        check_env(env.unwrapped)
    assert unexpected(rec) == []
    env.close()


def test_rgb_array_rendering():
    pytest.importorskip("matplotlib")
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        env = gymnasium.make(ID, render_mode="rgb_array", render_size=(96, 64))
        check_env(env.unwrapped, skip_render_check=False)
        env.reset(seed=3)
        first = env.render()
        for _ in range(5):
            env.step(env.action_space.sample())
        later = env.render()
    assert unexpected(rec) == []
    assert first.shape == later.shape == (64, 96, 3) and first.dtype == np.uint8
    assert first.std() > 5.0 and np.any(first != later)      # a picture, and it moves
    env.close()
    with pytest.raises(ValueError, match="render_mode must be None or one of"):
        ImitateEnv(render_mode="ansi")


def test_passive_checker_and_spaces():
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        env = gymnasium.make(ID)                  # wrapped in the PassiveEnvChecker
        obs, info = env.reset(seed=3)
        for _ in range(3):
            obs, r, terminated, truncated, info = env.step(env.action_space.sample())
    assert unexpected(rec) == []
    assert "PassiveEnvChecker" in str(env)
    assert env.observation_space.shape == (D,) and env.observation_space.dtype == np.float32
    assert env.action_space.shape == (A,) and env.action_space.dtype == np.float32
    assert np.all(env.action_space.low == -1.0) and np.all(env.action_space.high == 1.0)
    assert obs.dtype == np.float32 and env.observation_space.contains(obs)
    assert isinstance(r, float) and 0.0 <= r <= 1.0
    assert isinstance(terminated, bool) and isinstance(truncated, bool)
    assert info["reward_terms"].shape == (5,) and 0.0 <= info["phase"] < 1.0
    assert env.unwrapped.task.num_envs == 1
    env.close()


def test_single_env_reset_seed_repeats():
    env = gymnasium.make(ID).unwrapped
    a, _ = env.reset(seed=11)
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (5, A)).astype(np.float32)
    run_a = [env.step(x)[:2] for x in acts]
    b, _ = env.reset(seed=11)
    run_b = [env.step(x)[:2] for x in acts]
    assert np.array_equal(a, b)
    for (oa, ra), (ob, rb) in zip(run_a, run_b):
        assert np.array_equal(oa, ob) and ra == rb
    c, _ = env.reset(seed=12)
    assert not np.array_equal(a, c)


def test_single_env_must_reset_after_an_episode():
    env = ImitateEnv(episode_seconds=0.1)             # 3 policy steps
    env.reset(seed=0)
    for k in range(3):
        *_, terminated, truncated, _ = env.step(np.zeros(A, np.float32))
    assert truncated and not terminated
    with pytest.raises(tumble.ModelError, match="reset"):
        env.step(np.zeros(A, np.float32))
    env.reset()
    env.step(np.zeros(A, np.float32))


def test_vector_spaces(vec):
    assert isinstance(vec, ImitateVectorEnv) and vec.num_envs == 4
    assert vec.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    so, sa = vec.single_observation_space, vec.single_action_space
    assert so.shape == (D,) and so.dtype == np.float32
    assert sa.shape == (A,) and sa.dtype == np.float32
    assert np.all(sa.low == -1.0) and np.all(sa.high == 1.0)
    assert vec.observation_space.shape == (4, D) and vec.observation_space.dtype == np.float32
    assert vec.action_space.shape == (4, A) and vec.action_space.dtype == np.float32
    # rotation axes and phase bounded, positions and velocities not
    assert so.low[-1] == -1.0 and so.high[-2] == 1.0 and so.low[0] == -np.inf
    obs, info = vec.reset(seed=0)
    assert obs.shape == (4, D) and obs.dtype == np.float32 and vec.observation_space.contains(obs)
    obs, r, terminated, truncated, info = vec.step(vec.action_space.sample())
    assert obs.dtype == np.float32 and vec.observation_space.contains(obs)
    assert r.shape == (4,) and terminated.shape == (4,) and truncated.shape == (4,)
    assert terminated.dtype == np.bool_ and truncated.dtype == np.bool_
    assert info["reward_terms"].shape == (4, 5)


def test_vector_reset_seed_repeats(vec):
    a, _ = vec.reset(seed=5)
    ta = vec.task.ref_time.copy()
    b, _ = vec.reset(seed=5)
    assert np.array_equal(a, b) and np.array_equal(ta, vec.task.ref_time)
    # the four worlds start at different phases
    assert len(set(ta.tolist())) == 4
    c, _ = vec.reset(seed=6)
    assert not np.array_equal(a, c)
    # and what follows repeats too
    rng = np.random.default_rng(1)
    acts = rng.uniform(-1, 1, (4, 4, A)).astype(np.float32)
    runs = []
    for _ in range(2):
        vec.reset(seed=5)
        runs.append([vec.step(x)[:2] for x in acts])
    for (oa, ra), (ob, rb) in zip(*runs):
        assert np.array_equal(oa, ob) and np.array_equal(ra, rb)


def test_vector_same_step_autoreset(vec):
    vec.reset(seed=7)
    zero = np.zeros((4, A), np.float32)
    steps = vec.task.max_episode_steps
    assert steps == 6                                 # 0.2 s at 30 Hz
    returns = np.zeros(4)
    for k in range(steps - 1):
        obs, r, terminated, truncated, info = vec.step(zero)
        returns += r
        assert "final_obs" not in info and "_final_obs" not in info
    # from the reference with the clip's targets none falls in 0.2 s: all are cut by time
    assert not terminated.any()
    last = obs
    obs, r, terminated, truncated, info = vec.step(zero)
    returns += r
    assert truncated.all() and not terminated.any()
    assert info["_final_obs"].tolist() == [True] * 4
    final = info["final_obs"]
    assert final.shape == (4, D) and final.dtype == np.float32
    # the ended episode's last observation follows on from the one before ...
    assert np.all(np.abs(final[:, 0] - last[:, 0]) < 0.1)         # root height, m
    # ... and the returned one is the new episode's first: on the reference at a new phase
    assert not np.array_equal(final, obs)
    t = vec.task
    s = t.reference.sample(t.ref_time)
    assert np.max(np.abs(t.world.body_pos - s.body_pos)) < 1e-9
    assert t.episode_steps.tolist() == [0] * 4
    assert info["_final_info"].tolist() == [True] * 4
    assert info["final_info"]["episode_steps"].tolist() == [steps] * 4
    assert np.allclose(info["final_info"]["episode_return"], returns, rtol=1e-12)
    # the next step is the new episode's first
    obs, r, terminated, truncated, info = vec.step(zero)
    assert "final_obs" not in info and t.episode_steps.tolist() == [1] * 4


def test_vector_refuses_bad_actions(vec):
    vec.reset(seed=8)
    a = np.zeros((4, A), np.float32)
    a[1, 3] = np.nan
    with pytest.raises(tumble.rl.ActionError):
        vec.step(a)
    with pytest.raises(tumble.rl.ActionError):
        vec.step(np.zeros((3, A), np.float32))
