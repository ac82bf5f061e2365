"""The imitation task (tumble/rl/tasks/imitation.py, tumble/rl/env.py, tumble/rl/kernels.py)
and the two World methods it relies on (World.set_body_state, World.ground_contacts), on
the GAMES-105 ragdoll walking (the course is Y up).

Tolerances: a state written by set_body_state reads back to 1e-9 (it normalises the
quaternions); the reward on the reference is 1 to 1e-6 (its joint terms compare the world's
joint coordinates of the interpolated bodies with the interpolated joint coordinates, which
differ by ~1e-4 rad between frames); observations of a character turned about the vertical
are equal to 1e-6 (float32 of values up to ~10). Seeded runs are compared bit for bit.
"""
import numpy as np
import pytest

import tumble
from tumble.math import quat_np as Q
from tumble.rl import ActionError, ImitationEnv
from tumble.rl.kernels import BODY_OBS

UP = 1
N = 4


@pytest.fixture(scope="module")
def env():
    """A shared 4-world walk; every test that uses it resets it first."""
    return ImitationEnv(N, seed=5)


def zeros(env):
    return np.zeros((env.num_envs, env.action_size))


def evaluate(env):
    reward = np.zeros(env.num_envs)
    terminated = np.zeros(env.num_envs, np.bool_)
    env._evaluate(reward, terminated)
    return reward, terminated, env.reward_terms


def yaw(theta):
    return np.array([0.0, np.sin(theta / 2), 0.0, np.cos(theta / 2)])


def turn(q, v):
    """Rotate vectors v (..., 3) by the quaternion q (4,)."""
    return Q.qrot(np.broadcast_to(q, v.shape[:-1] + (4,)), v)


def set_state(world, s, worlds=None):
    world.set_body_state(s.body_pos, s.body_quat, s.body_vel, s.body_angvel, worlds=worlds)


def lowest_point(model, pos, quat):
    """Lowest height (m) over the corners of the boxes of one world's bodies (nb, 3/4)."""
    corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    low = np.inf
    for g, b in enumerate(model.geom_body):
        if b < 0:
            continue
        c = turn(model.geom_quat[g], corners * model.geom_size[g]) + model.geom_pos[g]
        c = turn(quat[b], c) + pos[b]
        low = min(low, c[:, UP].min())
    return low


def state_arrays(world):
    return {k: np.array(getattr(world, k)) for k in
            ("body_pos", "body_quat", "body_vel", "body_angvel", "joint_q", "joint_qd",
             "joint_quat")}


# -- sizes and layout -------------------------------------------------------------------
def test_sizes_and_spec(env):
    m = env.model
    assert m.nbody == 20
    assert env.observation_size == 1 + BODY_OBS * m.nbody + 2 == 303
    # 13 ball joints x 3 + 6 hinges (knees, toes, elbows) x 1; the root's free joint none
    types = list(m.joint_type_names)
    assert types.count("ball") == 13 and types.count("hinge") == 6 and types[0] == "free"
    assert env.action_size == 3 * 13 + 6 == 45
    assert env.dt == pytest.approx(1 / 30) and env.substeps == 2
    assert env.max_episode_steps == 300
    assert np.allclose(m.gravity, (0, -9.81, 0))
    spec = env.spec()
    assert spec["observation_size"] == 303 and spec["action_size"] == 45
    assert spec["body_names"] == list(m.body_names) and spec["control_hz"] == 30
    # joints projected back together past 1 mm, not the World's 0.05 mm (the docs' why)
    assert env.world.options.projection_tolerance == spec["projection_tolerance"] == 1e-3
    # the reward weights are DeepMimic's, normalised
    assert env.reward_weights.sum() == pytest.approx(1.0)


def test_observation_layout(env):
    obs = env.reset()
    assert obs.shape == (N, 303) and obs.dtype == np.float32
    w = env.world
    pos, quat = w.body_pos, w.body_quat
    assert np.allclose(obs[:, 0], pos[:, env.root, UP], atol=1e-6)
    ph = env.phase
    assert np.all((ph >= 0) & (ph < 1))
    assert np.allclose(obs[:, -2], np.sin(2 * np.pi * ph), atol=1e-6)
    assert np.allclose(obs[:, -1], np.cos(2 * np.pi * ph), atol=1e-6)
    body = obs[:, 1:-2].reshape(N, env.model.nbody, BODY_OBS)
    # the root body sits at the origin of its own heading frame; positions relative to it
    # have the bodies' distances from the root
    assert np.all(body[:, env.root, 0:3] == 0.0)
    dist = np.linalg.norm(pos - pos[:, env.root:env.root + 1], axis=-1)
    assert np.allclose(np.linalg.norm(body[..., 0:3], axis=-1), dist, atol=1e-6)
    # heights relative to the root are kept (the heading frame turns about the vertical)
    assert np.allclose(body[..., 1], pos[..., UP] - pos[:, env.root:env.root + 1, UP], atol=1e-6)
    # two orthonormal rotation axes
    t, n = body[..., 3:6], body[..., 6:9]
    assert np.allclose(np.linalg.norm(t, axis=-1), 1.0, atol=1e-6)
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-6)
    assert np.allclose(np.sum(t * n, axis=-1), 0.0, atol=1e-6)
    # speeds are the bodies'
    assert np.allclose(np.linalg.norm(body[..., 9:12], axis=-1),
                       np.linalg.norm(w.body_vel, axis=-1), atol=1e-5)
    assert np.allclose(np.linalg.norm(body[..., 12:15], axis=-1),
                       np.linalg.norm(w.body_angvel, axis=-1), atol=1e-5)
    # the root's heading frame has its x axis level: the root's own x axis seen in it has
    # no z component (its heading is measured from x projected on the ground)
    assert np.allclose(body[:, env.root, 5], 0.0, atol=1e-6)


@pytest.mark.parametrize("theta", [0.7, np.pi, -2.0])
def test_observation_is_heading_invariant(env, theta):
    obs = env.reset(seed=1)
    s = env.reference.sample(env.ref_time)
    q = yaw(theta)
    shift = np.array([3.0, 0.0, -1.5])         # a horizontal move changes nothing either
    env.world.set_body_state(turn(q, s.body_pos) + shift,
                             Q.qmul(np.broadcast_to(q, s.body_quat.shape), s.body_quat),
                             turn(q, s.body_vel), turn(q, s.body_angvel))
    turned = np.zeros_like(obs)
    env._observe(turned)
    assert turned.dtype == np.float32
    assert np.max(np.abs(turned - obs)) < 1e-6
    # while the world-frame state did change
    assert np.max(np.abs(env.world.body_pos - s.body_pos)) > 0.5


# -- reference state initialisation ----------------------------------------------------
def test_reset_puts_the_character_on_the_reference(env):
    env.reset(seed=2)
    t = env.ref_time.copy()
    assert np.all((t >= 0) & (t < env.reference.period)) and len(set(t.tolist())) == N
    s = env.reference.sample(t)
    w = env.world
    assert np.max(np.abs(w.body_pos - s.body_pos)) < 1e-9
    assert np.max(np.abs(w.body_quat - s.body_quat)) < 1e-9
    assert np.max(np.abs(w.body_vel - s.body_vel)) < 1e-9
    assert np.max(np.abs(w.body_angvel - s.body_angvel)) < 1e-9
    # joint coordinates of the interpolated bodies against the interpolated coordinates:
    # equal but for interpolation (a few 1e-5 rad between frames)
    sign = np.sign(np.sum(w.joint_quat * s.joint_quat, axis=-1, keepdims=True))
    assert np.max(np.abs(w.joint_quat - sign * s.joint_quat)) < 1e-3
    assert np.max(np.abs(w.joint_q - s.joint_q)) < 1e-3
    assert np.max(np.abs(w.joint_qd - s.joint_qd)) < 5e-2
    # servos aimed at the clip's pose
    act = env.dof_joint
    assert np.max(np.abs(w.pd_target_quat[:, act] - s.joint_quat[:, act])) < 1e-12
    assert env.episode_steps.tolist() == [0] * N and not env.episode_return.any()


def test_reset_at_the_clip_start_reproduces_frame_0():
    env = ImitationEnv(2, random_start=False, seed=0)
    env.reset()
    f, w = env.reference.frames, env.world
    assert np.all(env.ref_time == 0.0)
    for k in range(2):
        assert np.max(np.abs(w.body_pos[k] - f.body_pos[0])) < 1e-12
        assert np.max(np.abs(w.body_vel[k] - f.body_vel[0])) < 1e-12
        assert np.max(np.abs(w.body_angvel[k] - f.body_angvel[0])) < 1e-12
        # at a frame the joint coordinates are the frame's, by the same kernel
        assert np.max(np.abs(w.joint_q[k] - f.joint_q[0])) < 1e-9
        assert np.max(np.abs(w.joint_qd[k] - f.joint_qd[0])) < 1e-9


def test_seeds_choose_the_start_phases():
    a = ImitationEnv(N, seed=3)
    b = ImitationEnv(N, seed=3)
    c = ImitationEnv(N, seed=4)
    a.reset(), b.reset(), c.reset()
    assert np.array_equal(a.ref_time, b.ref_time)
    assert not np.any(np.isclose(a.ref_time, c.ref_time))
    # reset(seed=) reseeds
    oa = a.reset(seed=9)
    oc = c.reset(seed=9)
    assert np.array_equal(a.ref_time, c.ref_time) and np.array_equal(oa, oc)


def test_seeded_runs_are_bit_identical():
    rng = np.random.default_rng(0)
    envs = [ImitationEnv(N, seed=21), ImitationEnv(N, seed=21)]
    obs = [e.reset() for e in envs]
    assert np.array_equal(obs[0], obs[1])
    for _ in range(30):
        a = rng.uniform(-1.0, 1.0, (N, envs[0].action_size))
        out = [e.step(a) for e in envs]
        for x, y in zip(out[0][:4], out[1][:4]):
            assert np.array_equal(x, y)
        assert np.array_equal(out[0][4]["done"], out[1][4]["done"])
    assert np.array_equal(envs[0].world.body_pos, envs[1].world.body_pos)
    assert np.array_equal(envs[0].ref_time, envs[1].ref_time)


# -- reward ----------------------------------------------------------------------------
def test_reward_is_one_on_the_reference(env):
    env.reset(seed=4)
    reward, terminated, terms = evaluate(env)
    assert terms.shape == (N, 5)
    assert np.max(np.abs(terms - 1.0)) < 1e-6
    assert np.max(np.abs(reward - 1.0)) < 1e-6
    assert not terminated.any()
    # also placed from the reference by hand, at other times
    t = np.array([0.0, 0.25, 0.5, 1.7])
    env.ref_time[:] = t
    env.reference.sample(t, out=env._ref)
    set_state(env.world, env.reference.sample(t))
    reward, terminated, terms = evaluate(env)
    assert np.max(np.abs(terms - 1.0)) < 1e-6 and np.max(np.abs(reward - 1.0)) < 1e-6


def bend_knee(model, s, w, angle, joint="rKnee"):
    """Turn the shin, foot and toe of world w of sample s about the knee's hinge axis."""
    j = model.joint_names.index(joint)
    child, parent = model.joint_child[j], model.joint_parent[j]
    anchor = s.body_pos[w, child] + turn(s.body_quat[w, child], model.joint_anchor_b[j])
    axis = turn(Q.qmul(s.body_quat[w, parent], model.joint_frame_a[j]), np.array([1.0, 0, 0]))
    q = np.append(np.sin(angle / 2) * axis, np.cos(angle / 2))
    sub = [b for b in range(model.nbody) if b == child or _descends(model, b, child)]
    s.body_pos[w, sub] = turn(q, s.body_pos[w, sub] - anchor) + anchor
    s.body_quat[w, sub] = Q.qmul(np.broadcast_to(q, (len(sub), 4)), s.body_quat[w, sub])
    return j


def _descends(model, b, ancestor):
    p = model.joint_parent[b]
    while p >= 0:
        if p == ancestor:
            return True
        p = model.joint_parent[p]
    return False


def test_reward_decreases_with_a_bent_knee(env):
    env.reset(seed=6)
    s = env.reference.sample(env.ref_time)
    angles = [0.0, 0.3, 0.6, 1.0]                # world k: the right knee bent more
    for k, a in enumerate(angles):
        j = bend_knee(env.model, s, k, a)
    set_state(env.world, s)
    bent = env.world.joint_q[:, j, 0] - env.reference.sample(env.ref_time).joint_q[:, j, 0]
    assert np.allclose(np.abs(bent), angles, atol=1e-3)    # a knee bend, nothing else
    reward, terminated, terms = evaluate(env)
    assert np.all((terms >= 0.0) & (terms <= 1.0))
    assert abs(reward[0] - 1.0) < 1e-6
    assert np.all(np.diff(reward) < 0.0)                    # strictly decreasing
    assert np.all(np.diff(terms[:, 0]) < 0.0)               # the pose term
    assert np.all(np.diff(terms[:, 2]) < 0.0)               # the ankle moved: end effectors
    # the pose error of a bend alone: exp(-2 w_knee a^2)
    wk = env.joint_weight[j]
    assert np.allclose(terms[:, 0], np.exp(-2.0 * wk * np.square(angles)), rtol=1e-3)
    # root and centre of mass untouched by a knee bend (the COM velocity is the same)
    assert np.allclose(terms[:, 3], 1.0, atol=1e-6)


def test_reward_terms_in_range_under_random_actions(env):
    env.reset(seed=7)
    rng = np.random.default_rng(1)
    for _ in range(5):
        _, r, *_ = env.step(rng.uniform(-1, 1, (N, env.action_size)))
        terms = env.reward_terms
        assert np.all((terms >= 0.0) & (terms <= 1.0))
        assert np.all((r >= 0.0) & (r <= 1.0 + 1e-12))
        assert np.allclose(r, terms @ env.reward_weights, rtol=1e-12)


# -- termination -----------------------------------------------------------------------
def lying_state(env, s):
    """The reference pose turned 90 degrees about the horizontal x axis (about the root),
    face up (the walk faces +z), at rest, lowered until its lowest box corner is 5 mm above
    the ground."""
    q = np.array([-np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4)])
    for w in range(env.num_envs):
        root = s.body_pos[w, env.root].copy()
        s.body_pos[w] = turn(q, s.body_pos[w] - root) + root
        s.body_quat[w] = Q.qmul(np.broadcast_to(q, s.body_quat[w].shape), s.body_quat[w])
        low = lowest_point(env.model, s.body_pos[w], s.body_quat[w])
        s.body_pos[w, :, UP] -= low - 0.005
    s.body_vel[:] = 0.0
    s.body_angvel[:] = 0.0
    return s


def test_a_fall_ends_the_episode():
    # only contacts end it here (the root-height test off): a character lying on its back
    # (some lie on a bent leg's foot first, then topple) ends when its body touches
    env = ImitationEnv(2, seed=8, min_root_height=-10.0, autoreset=False)
    env.reset()
    set_state(env.world, lying_state(env, env.reference.sample(env.ref_time)))
    ended = np.zeros(2, np.bool_)
    for _ in range(20):
        obs, r, terminated, truncated, info = env.step(zeros(env))
        assert not truncated.any()
        touching = env.world.ground_contacts()
        body = np.any(touching & ~env.allowed_contacts[None], axis=1)
        # it ends exactly when a body other than the feet touches
        assert np.array_equal(terminated, body)
        ended |= terminated
        if ended.all():
            break
        env._needs_reset = False        # keep stepping the worlds that have not ended
    assert ended.all()
    # the root height alone ends it too: the walk's root is 0.85-0.9 m up, below 1 m
    env = ImitationEnv(2, seed=8, min_root_height=1.0, autoreset=False)
    env.reset()
    _, _, terminated, truncated, info = env.step(zeros(env))
    assert not np.any(env.world.ground_contacts() & ~env.allowed_contacts[None])
    assert terminated.all() and not truncated.any() and info["done"].all()
    with pytest.raises(tumble.ModelError, match="reset"):
        env.step(zeros(env))       # without autoreset, an ended episode must be reset


def test_feet_on_the_ground_do_not_end_the_episode(env):
    env.reset(seed=10)
    feet = np.zeros(N, np.bool_)
    for _ in range(3):
        _, r, terminated, truncated, _ = env.step(zeros(env))
        assert not terminated.any() and not truncated.any()
        assert np.all(r > 0.8)
        touching = env.world.ground_contacts()
        assert touching.shape == (N, env.model.nbody)
        assert not np.any(touching & ~env.allowed_contacts[None])
        feet |= np.any(touching & env.allowed_contacts[None], axis=1)
    assert feet.all()              # every walker stood on a foot meanwhile


def test_time_limit_truncates_and_autoresets():
    env = ImitationEnv(2, seed=12, episode_seconds=0.1)       # 3 policy steps
    env.reset()
    total = np.zeros(2)
    for k in range(3):
        obs, r, terminated, truncated, info = env.step(zeros(env))
        total += r
        assert info["done"].any() == (k == 2)
    assert truncated.all() and not terminated.any() and info["done"].all()
    assert info["episode_steps"].tolist() == [3, 3]
    assert np.allclose(info["episode_return"], total, rtol=1e-12)
    # same-step autoreset: the returned observation is the new episode's first
    assert env.episode_steps.tolist() == [0, 0] and not env.episode_return.any()
    assert not np.array_equal(info["final_obs"], obs)
    again = np.zeros_like(obs)
    env._observe(again)
    assert np.array_equal(again, obs)
    s = env.reference.sample(env.ref_time)
    assert np.max(np.abs(env.world.body_pos - s.body_pos)) < 1e-9


# -- actions ---------------------------------------------------------------------------
def test_nan_action_is_refused_and_steps_nothing(env):
    env.reset(seed=13)
    env.step(zeros(env))
    before = state_arrays(env.world)
    t, ref_t, steps = env.world.time, env.ref_time.copy(), env.episode_steps.copy()
    a = zeros(env)
    a[2, 7] = np.nan
    with pytest.raises(ActionError, match="world 2, component 7") as e:
        env.step(a)
    assert isinstance(e.value, tumble.TumbleError)
    a[2, 7] = np.inf
    with pytest.raises(ActionError):
        env.step(a)
    assert env.world.time == t
    assert np.array_equal(env.ref_time, ref_t) and np.array_equal(env.episode_steps, steps)
    for k, v in state_arrays(env.world).items():
        assert np.array_equal(v, before[k]), k
    env.step(zeros(env))             # and the env goes on


def test_wrong_action_shapes_are_refused(env):
    env.reset(seed=14)
    A = env.action_size
    for bad in (np.zeros((N, A + 1)), np.zeros((N + 1, A)), np.zeros(A), np.zeros((N, A, 1))):
        with pytest.raises(ActionError, match="shape"):
            env.step(bad)
    assert issubclass(ActionError, ValueError)


def test_out_of_range_actions_are_clipped():
    rng = np.random.default_rng(2)
    a = rng.uniform(-1, 1, (2, 45))
    big = np.where(a > 0, 7.0, -3.0) * np.abs(np.sign(a))
    envs = [ImitationEnv(2, seed=15), ImitationEnv(2, seed=15)]
    for e in envs:
        e.reset()
    out_big = envs[0].step(big)
    out_one = envs[1].step(np.sign(big))
    for x, y in zip(out_big[:4], out_one[:4]):
        assert np.array_equal(x, y)
    assert np.array_equal(envs[0].world.pd_target_quat, envs[1].world.pd_target_quat)
    assert np.array_equal(envs[0].world.pd_target_q, envs[1].world.pd_target_q)


def test_residual_action_turns_the_target_by_scale_times_action(env):
    env.reset(seed=16)
    a = zeros(env)
    j = env.model.joint_names.index("lKnee")
    i = int(np.flatnonzero(env.dof_joint == j)[0])
    a[:, env.dof_start[i]] = 0.4
    env.step(a)
    ref = env.reference.sample(env.ref_time)
    assert np.allclose(env.world.pd_target_q[:, j, 0], ref.joint_q[:, j, 0] + 0.5 * 0.4,
                       atol=1e-12)
    # a ball joint with zero action aims at the clip's rotation
    h = env.model.joint_names.index("rHip")
    assert np.allclose(env.world.pd_target_quat[:, h], ref.joint_quat[:, h], atol=1e-12)


def test_diverged_world_is_restarted_alone(monkeypatch):
    env = ImitationEnv(3, seed=17)
    env.reset()
    real = env.world.step
    calls = []

    def failing_once(n=1):
        calls.append(n)
        if len(calls) == 1:
            raise tumble.SimulationError("diverged (test)", world=1)
        return real(n)

    monkeypatch.setattr(env.world, "step", failing_once)
    _, r, terminated, truncated, info = env.step(zeros(env))
    assert info["diverged"].tolist() == [False, True, False]
    assert terminated[1] and r[1] == 0.0 and not terminated[[0, 2]].any()
    assert env.diverged == 1 and len(calls) == 2
    assert env.episode_steps.tolist() == [1, 0, 1]


# -- World.set_body_state and World.ground_contacts ------------------------------------
def test_set_body_state_resets_only_the_selected_worlds():
    a = ImitationEnv(3, seed=18)
    a.reset()
    for _ in range(2):
        a.step(zeros(a))
    w = a.world
    assert all(len(w.contacts_of(k).depth) for k in range(3))   # contacts to forget
    before = state_arrays(w)
    time = w.time
    s = a.reference.sample(np.array([0.3]))
    s.body_vel[:] += 0.1
    set_state(w, s, worlds=[1])
    after = state_arrays(w)
    for k in before:
        assert np.array_equal(after[k][[0, 2]], before[k][[0, 2]]), k
    assert np.max(np.abs(w.body_pos[1] - s.body_pos[0])) < 1e-12
    assert np.max(np.abs(w.body_vel[1] - s.body_vel[0])) < 1e-12
    assert w.time == time
    assert len(w.contacts_of(1).depth) == 0
    assert len(w.contacts_of(0).depth) and len(w.contacts_of(2).depth)
    # a boolean mask selects as well
    set_state(w, s, worlds=np.array([False, False, True]))
    assert np.max(np.abs(w.body_pos[2] - s.body_pos[0])) < 1e-12
    assert np.array_equal(w.body_pos[0], before["body_pos"][0])
    # the worlds restarted step exactly as a world that never stepped (their solver's
    # warm start forgotten)
    b = ImitationEnv(3, seed=18)
    b.reset()
    b.world.set_body_state(*(np.repeat(getattr(s, k), 3, axis=0) for k in
                             ("body_pos", "body_quat", "body_vel", "body_angvel")))
    b.world.pd_target_quat[:] = w.pd_target_quat
    b.world.pd_target_q[:] = w.pd_target_q
    w.step(2)
    b.world.step(2)
    for k in ("body_pos", "body_quat", "body_vel", "body_angvel"):
        assert np.array_equal(getattr(w, k)[1], getattr(b.world, k)[1]), k
        assert np.array_equal(getattr(w, k)[2], getattr(b.world, k)[2]), k


def test_set_body_state_refuses_bad_states_and_changes_nothing(env):
    env.reset(seed=19)
    env.step(zeros(env))
    w = env.world
    before = state_arrays(w)
    forces = [w.contacts_of(k).normal_force for k in range(N)]
    s = env.reference.sample(np.array([0.1, 0.2]))
    lknee = env.model.body_names.index("lKnee")
    rwrist = env.model.body_names.index("rWrist")

    def refused(match, **changes):
        arrays = {k: getattr(s, k).copy() for k in ("body_pos", "body_quat", "body_vel",
                                                     "body_angvel")}
        for k, f in changes.items():
            f(arrays[k])
        with pytest.raises(tumble.StateError, match=match):
            w.set_body_state(**arrays, worlds=[2, 0])

    refused(r"body_pos of body 'lKnee' in world 0 is not finite",
            body_pos=lambda a: a.__setitem__((1, lknee, 1), np.nan))
    refused(r"body_vel of body 'rWrist' in world 2 is not finite",
            body_vel=lambda a: a.__setitem__((0, rwrist, 0), np.inf))
    refused(r"body_angvel of body 'lKnee' in world 2",
            body_angvel=lambda a: a.__setitem__((0, lknee, 2), np.nan))
    refused(r"body_quat of body 'rWrist' in world 0 is zero",
            body_quat=lambda a: a.__setitem__((1, rwrist), 0.0))
    refused(r"body_quat of body 'lKnee' in world 2 is not finite",
            body_quat=lambda a: a.__setitem__((0, lknee, 3), np.nan))
    with pytest.raises(tumble.StateError, match="shape"):
        w.set_body_state(s.body_pos[:, :-1], s.body_quat, s.body_vel, s.body_angvel,
                         worlds=[2, 0])
    with pytest.raises(tumble.StateError, match="shape"):
        w.set_body_state(s.body_pos, s.body_quat[..., :3], s.body_vel, s.body_angvel,
                         worlds=[2, 0])
    with pytest.raises(tumble.StateError, match="shape"):      # 2 states for 3 worlds
        w.set_body_state(s.body_pos, s.body_quat, s.body_vel, s.body_angvel, worlds=[0, 1, 2])
    with pytest.raises(tumble.ModelError, match="world indices"):
        w.set_body_state(s.body_pos, s.body_quat, s.body_vel, s.body_angvel, worlds=[0, N])
    with pytest.raises(tumble.ModelError, match="mask"):
        w.set_body_state(s.body_pos, s.body_quat, s.body_vel, s.body_angvel,
                         worlds=np.array([True, False]))
    for k, v in state_arrays(w).items():
        assert np.array_equal(v, before[k]), k
    for k in range(N):
        assert np.array_equal(w.contacts_of(k).normal_force, forces[k])
    # quaternions are normalised
    q = s.body_quat * 3.0
    w.set_body_state(s.body_pos, q, s.body_vel, s.body_angvel, worlds=[2, 0])
    assert np.allclose(np.linalg.norm(w.body_quat[[2, 0]], axis=-1), 1.0, atol=1e-15)
    assert np.max(np.abs(w.body_quat[[2, 0]] - s.body_quat)) < 1e-12


def test_ground_contacts_mark_the_feet():
    env = ImitationEnv(2, seed=20, random_start=False)
    env.reset()
    env.step(zeros(env))
    g = env.world.ground_contacts()
    assert g.shape == (2, env.model.nbody) and g.dtype == np.bool_
    names = env.model.body_names
    for k in range(2):
        touched = {names[b] for b in np.flatnonzero(g[k])}
        assert touched and touched <= {"lAnkle", "rAnkle", "lToeJoint", "rToeJoint"}
        # the same as the contacts of that world say
        c = env.world.contacts_of(k)
        bodies = {names[b] for pair in c.bodies for b in pair if b >= 0
                  and -1 in pair}
        assert touched <= bodies
    # lifted 1 m into the air: nothing touches after a step
    s = env.reference.sample(np.array([0.0]))
    s.body_pos[..., UP] += 1.0
    set_state(env.world, s, worlds=[1])
    env.world.step(1)
    g = env.world.ground_contacts()
    assert not g[1].any() and g[0].any()


def test_ground_contacts_of_a_single_world():
    env = ImitationEnv(1, seed=0, random_start=False, parallel=False)
    env.reset()
    # one world: the leading axis may be dropped
    s = env.reference.sample(np.array([0.0]))
    env.world.set_body_state(s.body_pos[0], s.body_quat[0], s.body_vel[0], s.body_angvel[0])
    assert np.max(np.abs(env.world.body_pos - s.body_pos[0])) < 1e-12
    env.step(np.zeros(env.action_size))
    g = env.world.ground_contacts()
    assert g.shape == (env.model.nbody,) and np.any(g & env.allowed_contacts)
