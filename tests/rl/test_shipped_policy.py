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
