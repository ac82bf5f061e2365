"""The policy shipped in the package (tumble/rl/policies/imitate_walk.npz) walks."""
import numpy as np

from tumble.rl import ImitationEnv
from tumble.rl.play import load_policy


def test_the_shipped_walk_policy_rolls_out_5_s_without_falling():
    policy = load_policy("walk")
    spec = policy.spec
    env = ImitationEnv(4, spec["clip"], control_hz=spec["control_hz"],
                       physics_hz=spec["physics_hz"], contact=spec["contact"],
                       residual=spec["residual"], action_scale=spec["action_scale"],
                       episode_seconds=5.0, seed=7, autoreset=False)
    policy.check(env.spec())
    obs = env.reset()
    start = env.world.body_pos[:, env.root].copy()
    errors = []
    for _ in range(env.max_episode_steps):
        obs, reward, terminated, truncated, info = env.step(policy.act(obs))
        assert not terminated.any(), f"fell at {env.episode_steps[0] * env.dt:.2f} s"
        errors.append(env.body_position_error().mean())
    assert truncated.all()                          # the 5 s limit, not a fall
    travelled = np.linalg.norm((env.world.body_pos[:, env.root] - start)[:, [0, 2]], axis=1)
    assert np.all(travelled > 3.0)                  # the clip walks 1.2 m/s: 6 m in 5 s
    # the 100-episode evaluation of this policy: 29 mm (README); four worlds vary more
    assert np.mean(errors) < 0.05


def test_the_shipped_steering_policy_follows_a_turn_and_its_speeds():
    """Four characters at 0.8 to 1.6 m/s, turned by 90 degrees after 6 s, for 12 s: none
    falls, each walks within 0.3 m/s of its speed and faces the new heading within 3 s
    (the 50-episode evaluation of 60 s is the README's)."""
    from tumble.rl import AMPEnv
    from tumble.rl.amp_eval import evaluate_amp

    policy = load_policy("steer")
    spec = policy.spec
    env = AMPEnv(4, spec["clips"], control_hz=spec["control_hz"],
                 physics_hz=spec["physics_hz"], contact=spec["contact"],
                 action_scale=np.asarray(spec["action_scale"]),
                 projection_tolerance=spec["projection_tolerance"], episode_seconds=12.0, seed=11)
    result = evaluate_amp(policy, env=env, seconds=12.0, seed=11, speeds=(0.8, 1.6),
                          speed_tolerance=0.3)
    assert result["survived"] == 1.0
    assert result["speed_within"] == 1.0 and result["speed_error"] < 0.2
    assert result["heading_within"] == 1.0
