"""Policy files (tumble/rl/policy.py): an MLP actor with its normaliser and the spec of the
environment it was trained in, saved as .npz and run in NumPy.

Round trips are compared bit for bit; the forward pass against a hand-written one to 1e-6
(float32 output).
"""
import json

import numpy as np
import pytest

import tumble
from tumble.data.games105 import clip_path
from tumble.rl import ImitationEnv
from tumble.rl.policy import POLICY_FORMAT, Policy


@pytest.fixture(scope="module")
def spec():
    env = ImitationEnv(1, parallel=False)       # built, never stepped
    return env.spec()


def make_policy(spec, activation="elu", hidden=(32, 16), seed=0):
    rng = np.random.default_rng(seed)
    sizes = [spec["observation_size"], *hidden, spec["action_size"]]
    weights = [rng.normal(0, 1 / np.sqrt(i), (o, i)) for i, o in zip(sizes[:-1], sizes[1:])]
    biases = [rng.normal(0, 0.1, o) for o in sizes[1:]]
    mean = rng.normal(0, 1, sizes[0])
    std = rng.uniform(0.5, 2.0, sizes[0])
    return Policy(weights, biases, activation, mean, std, 1e-2, spec,
                  {"iteration": 7, "samples": 1234})


def forward(p, x, act):
    x = (np.asarray(x, float) - p.obs_mean) / (p.obs_std + p.obs_eps)
    for k, (w, b) in enumerate(zip(p.weights, p.biases)):
        x = x @ w.T + b
        if k < len(p.weights) - 1:
            x = act(x)
    return np.clip(x, -1, 1)


def obs_batch(spec, n, seed=1):
    return np.random.default_rng(seed).normal(0, 1, (n, spec["observation_size"])).astype(np.float32)


def test_spec_of_the_environment(spec):
    assert spec["task"] == "imitate" and spec["clip"] == "walk"
    assert spec["observation_size"] == 303 and spec["action_size"] == 45
    assert spec["control_hz"] == 30 and spec["physics_hz"] == 60
    assert len(spec["body_names"]) == 20 and spec["residual"] is True
    json.dumps(spec)                            # storable as it is


@pytest.mark.parametrize("activation, f", [
    ("elu", lambda x: np.where(x > 0, x, np.expm1(np.minimum(x, 0)))),
    ("relu", lambda x: np.maximum(x, 0)),
    ("tanh", np.tanh)])
def test_act_is_the_mlp(spec, activation, f):
    p = make_policy(spec, activation)
    x = obs_batch(spec, 6)
    a = p.act(x)
    assert a.shape == (6, 45) and a.dtype == np.float32
    assert np.all(np.abs(a) <= 1.0)
    assert np.max(np.abs(a - forward(p, x, f))) < 1e-6
    # one observation (D,) -> one action (A,), the same as its row of the batch
    one = p.act(x[2])
    assert one.shape == (45,) and np.array_equal(one, a[2])
    # outputs beyond [-1, 1] are clipped
    p.weights[-1] = p.weights[-1] * 100.0
    big = p.act(x)
    assert np.all(np.abs(big) <= 1.0) and np.sum(np.abs(big) == 1.0) > 10
    assert p.observation_size == 303 and p.action_size == 45
    with pytest.raises(tumble.ModelError, match="size"):
        p.act(np.zeros((2, 300)))


def test_save_load_round_trip(spec, tmp_path):
    p = make_policy(spec)
    path = tmp_path / "walk.npz"
    p.save(path)
    q = Policy.load(path)
    x = obs_batch(spec, 8)
    assert np.array_equal(p.act(x), q.act(x))
    assert np.array_equal(p.act(x[0]), q.act(x[0]))
    for a, b in zip(p.weights + p.biases, q.weights + q.biases):
        assert np.array_equal(a, b)
    assert np.array_equal(p.obs_mean, q.obs_mean) and np.array_equal(p.obs_std, q.obs_std)
    assert q.obs_eps == p.obs_eps and q.activation == "elu"
    assert q.spec == spec and q.info == {"iteration": 7, "samples": 1234}
    q.check(spec)                                # its own environment is accepted
    assert "walk" in repr(q)


def test_check_refuses_another_setting(spec):
    p = make_policy(spec)
    p.check(dict(spec))
    cases = {
        "body_names": dict(spec, body_names=spec["body_names"][:-1] + ["tail"]),
        "joint_names": dict(spec, joint_names=list(reversed(spec["joint_names"]))),
        "observation_size": dict(spec, observation_size=300),
        "action_size": dict(spec, action_size=44),
        "control_hz": dict(spec, control_hz=60),
        "residual": dict(spec, residual=False),
        "action_scale": dict(spec, action_scale=[0.25] * 45),
        "task": dict(spec, task="run"),
        "total_mass": dict(spec, total_mass=spec["total_mass"] * 1.1),
    }
    for field, other in cases.items():
        with pytest.raises(tumble.ModelError, match=field):
            p.check(other)
    # all that differ are named at once
    with pytest.raises(tumble.ModelError, match="observation_size.*control_hz"):
        p.check(dict(spec, observation_size=300, control_hz=60))
    # another character, the clip's own skeleton as a capsule ragdoll, is refused by name
    walk = tumble.load_bvh(clip_path("walk"))
    env = ImitationEnv(1, walk, ragdoll=tumble.ragdoll_from_motion(walk), parallel=False)
    with pytest.raises(tumble.ModelError, match="body_names"):
        p.check(env.spec())


def test_load_refuses_what_is_not_a_policy(tmp_path):
    text = tmp_path / "notes.npz"
    text.write_text("not a policy")
    with pytest.raises(tumble.ModelError, match="not a tumble policy"):
        Policy.load(text)
    arrays = tmp_path / "arrays.npz"
    np.savez(arrays, x=np.zeros(3))
    with pytest.raises(tumble.ModelError, match="not a tumble policy"):
        Policy.load(arrays)
    with pytest.raises(tumble.ModelError, match="no file"):
        Policy.load(tmp_path / "missing.npz")


def test_load_refuses_a_newer_format(spec, tmp_path):
    p = make_policy(spec)
    path = tmp_path / "p.npz"
    p.save(path)
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    meta["format"] = POLICY_FORMAT + 1
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(path, **arrays)
    with pytest.raises(tumble.ModelError, match="format"):
        Policy.load(path)


def test_inconsistent_networks_are_refused(spec):
    p = make_policy(spec)
    with pytest.raises(tumble.ModelError, match="activation"):
        Policy(p.weights, p.biases, "gelu", p.obs_mean, p.obs_std, 0.0, spec)
    with pytest.raises(tumble.ModelError, match="normaliser"):
        Policy(p.weights, p.biases, "elu", p.obs_mean[:-1], p.obs_std, 0.0, spec)
    with pytest.raises(tumble.ModelError, match="observations"):
        Policy(p.weights, p.biases, "elu", p.obs_mean, p.obs_std, 0.0,
               dict(spec, observation_size=300))
