"""How well a steering policy (task 'amp') follows commands: the figures the README reports.

:func:`evaluate_amp` runs N episodes of one world each, all at once. Every ``window``
seconds the command turns by 90 degrees (left or right at random) and keeps a speed drawn
for that episode from ``speeds`` (spread evenly over the episodes). Measured per window
(only while the character is up): the mean speed along the commanded direction over the
window's second half, and whether the direction of travel (the centre of mass's mean
horizontal velocity over the 0.5 s before ``turn_seconds``) is within ``heading_tolerance``
of the command by then.
"""
import math

import numpy as np

__all__ = ["evaluate_amp"]


def evaluate_amp(policy, config=None, *, episodes=16, seconds=60.0, seed=12345, env=None,
                 speeds=(0.5, 2.0), window=6.0, turn_seconds=3.0, speed_tolerance=0.2,
                 heading_tolerance=math.radians(20.0), style=None):
    """Returns a dict: survived (fraction of episodes that lasted ``seconds``),
    mean_seconds, speed_error (mean |speed along the command - commanded|, m/s),
    speed_within (fraction of windows within ``speed_tolerance``), heading_within (fraction
    of turns reached within ``turn_seconds``), heading_error (mean angle at
    ``turn_seconds``, rad), joint_speed (RMS of the actuated joints' rates, rad/s; the
    discriminator's joints) and clip_joint_speed (the same over the clips' frames), and with
    ``style`` (an AMPStyle) style_policy and style_clips (mean style reward of the policy's
    transitions and of held-back clip transitions)."""
    from .train import _make_env
    if env is None:
        env = _make_env(config, episodes, seed=seed, episode_seconds=seconds)
    policy.check(env.spec())
    rng = np.random.default_rng(seed)
    N = env.num_envs
    env.reset(seed=seed)
    env.commands_change = False
    speed = np.linspace(speeds[0], speeds[1], N) if N > 1 else np.array([np.mean(speeds)])
    obs = env.set_command(0.0, speed, relative=True)
    spw = max(1, int(round(window / env.dt)))
    turn_step = int(round(turn_seconds / env.dt))
    look = max(1, int(round(0.5 / env.dt)))
    total = int(round(seconds / env.dt))
    active = np.ones(N, np.bool_)
    alive_steps = np.zeros(N)
    speed_err, speed_ok, head_err, head_ok = [], [], [], []
    v_along = np.zeros(N)
    v_dir = np.zeros((N, 3))
    joint_sq, joint_n = 0.0, 0
    style_sum, style_n = 0.0, 0
    window_alive = active.copy()
    for step in range(total):
        k = step % spw
        if k == 0:
            if step > 0:
                ok = window_alive & active
                e = np.abs(v_along[ok] / (spw - spw // 2) - speed[ok])
                speed_err.extend(e.tolist())
                speed_ok.extend((e <= speed_tolerance).tolist())
                sign = rng.choice([-1.0, 1.0], N)
                obs = env.set_command(env.target_heading + sign * 0.5 * math.pi, None)
            window_alive = active.copy()
            v_along[:] = 0.0
            v_dir[:] = 0.0
        obs, reward, terminated, truncated, info = env.step(policy.act(obs))
        live = active & ~terminated
        d = env.direction(env.target_heading)
        v = env.com_velocity
        if k >= spw // 2:
            v_along += np.einsum("ij,ij->i", v, d)
        if turn_step - look <= k < turn_step:
            v_dir += v
        if k == turn_step - 1 and step >= spw:          # the first window has no turn
            ok = window_alive & live
            vd = v_dir[ok]
            cosang = np.einsum("ij,ij->i", vd, d[ok]) / np.maximum(np.linalg.norm(vd, axis=1),
                                                                   1e-9)
            ang = np.arccos(np.clip(cosang, -1.0, 1.0))
            head_err.extend(ang.tolist())
            head_ok.extend((ang <= heading_tolerance).tolist())
        qd = env._joint_qd[:, env.amp_joints]
        joint_sq += float((qd[live] ** 2).sum())
        joint_n += int(live.sum()) * qd.shape[1]
        if style is not None and live.any():
            from .amp import style_reward
            s = style_reward(style.score(info["amp_obs"][live]))
            style_sum += float(s.sum())
            style_n += int(live.sum())
        alive_steps[active] += 1
        active &= ~terminated
        if not active.any():
            break
    if active.any():                                     # the last window
        ok = window_alive & active
        e = np.abs(v_along[ok] / (spw - spw // 2) - speed[ok])
        speed_err.extend(e.tolist())
        speed_ok.extend((e <= speed_tolerance).tolist())
    result = {
        "survived": float((alive_steps >= total).mean()),
        "mean_seconds": float(alive_steps.mean() * env.dt),
        "speed_error": float(np.mean(speed_err)) if speed_err else float("nan"),
        "speed_within": float(np.mean(speed_ok)) if speed_ok else 0.0,
        "heading_error": float(np.mean(head_err)) if head_err else float("nan"),
        "heading_within": float(np.mean(head_ok)) if head_ok else 0.0,
        "joint_speed": math.sqrt(joint_sq / max(joint_n, 1)),
        "clip_joint_speed": env.clip_joint_speed(),
        "episodes": N,
    }
    if style is not None:
        result["style_policy"] = style_sum / max(style_n, 1)
        result["style_clips"] = style.clip_style()
    return result
