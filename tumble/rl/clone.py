"""Behaviour cloning of an imitation policy into a steering (AMP) actor.

An AMP policy trained from scratch on two cores finds standing still long before it finds
walking: standing keeps the episode alive and earns an idle-like style, a local optimum the
adversarial reward gives no gradient out of. A policy that already imitates the walk clip
is a better start. Its observation has the clip's phase where the steering task has a
command, and its actions are corrections to the clip's pose where the steering task's turn
the clips' mean pose, so the walk is carried over by supervised learning, not by copying
weights:

1. the imitation policy (the *teacher*) walks N worlds of its own task, with Gaussian noise
   added to the actions it executes (DART, Laskey et al. 2017: the student then sees states
   off the teacher's path together with the teacher's correction from them);
2. every state becomes a steering observation: the same body state and a command drawn as
   the task draws them (a heading relative to the character's, a speed), which the
   teacher's actions do not depend on: the cloned actor walks whatever it is told, and
   PPO then teaches it to listen (a command held constant in the data would leave the
   actor's response to any other command arbitrary, and its observation normaliser
   dividing by a zero spread);
3. the teacher's noise-free servo targets become steering actions (the rotation from the
   clips' mean pose, in the steering task's action units);
4. the actor's mean is fitted to them by least squares, its observation normaliser set to
   the data's statistics.

:func:`clone_into` does all four on an rsl-rl PPO (the trainer calls it for a fresh run with
``TrainConfig.init_from``).
"""
import math

import numpy as np
import torch

from ..errors import ModelError
from ..math import quat_np as Q
from .kernels import DOF_BALL, DOF_HINGE, pd_targets
from .tasks.imitation import ImitationEnv

__all__ = ["teacher_dataset", "fit_actor", "clone_into", "load_teacher", "freeze_normalizer"]


def load_teacher(source):
    """A Policy from a file path or a shipped policy name ('walk')."""
    from .play import load_policy
    return load_policy(source)


def _steering_actions(student, joint_quat, joint_q):
    """Steering actions (n, A) whose servo targets are the given joint rotations (n, nj, 4)
    and coordinates (n, nj, 3): the rotation vector from the clips' mean pose, over the
    student task's action scale."""
    n = joint_quat.shape[0]
    out = np.zeros((n, student.action_size))
    for j, kind, s in zip(student.dof_joint, student.dof_kind, student.dof_start):
        if kind == DOF_BALL:
            d = Q.qmul(Q.qconj(student._mean_quat[j])[None], joint_quat[:, j])
            out[:, s:s + 3] = Q.qrotvec(d)
        else:
            k = _coords(kind)
            out[:, s:s + k] = joint_q[:, j, :k] - student._mean_q[j, :k]
    return out / student.action_scale


def teacher_dataset(teacher, student, *, samples=200_000, num_envs=64, noise=0.1, seed=0,
                    log=None):
    """Observations (n, D) and actions (n, A) of the steering task ``student`` (an AMPEnv)
    from rollouts of ``teacher`` (an imitation Policy) in its own task, with Gaussian
    action noise of standard deviation ``noise`` (the teacher's action units) executed and
    the noise-free targets recorded. Actions are clipped to [-1, 1] as the task clips
    them."""
    spec = teacher.spec
    if spec.get("task", "imitate") != "imitate":
        raise ModelError(f"clone: the teacher must be an imitation policy, got task "
                         f"{spec.get('task')!r}")
    if list(spec["body_names"]) != list(student.model.body_names):
        raise ModelError("clone: the teacher was trained on another character (its body "
                         "names differ from the steering task's)")
    env = ImitationEnv(num_envs, spec["clip"], ragdoll=student.ragdoll,
                       control_hz=spec["control_hz"], physics_hz=spec["physics_hz"],
                       contact=spec["contact"], residual=spec["residual"],
                       action_scale=np.asarray(spec["action_scale"]),
                       episode_seconds=spec.get("episode_seconds", 10.0), seed=seed)
    teacher.check(env.spec())
    if env.dt != student.dt:
        raise ModelError(f"clone: the teacher acts every {env.dt:.4g} s, the steering task "
                         f"every {student.dt:.4g} s")
    rng = np.random.default_rng(seed)
    body = 1 + 15 * student.model.nbody
    steps = max(1, int(math.ceil(samples / num_envs)))
    obs_out = np.empty((steps * num_envs, student.observation_size), np.float32)
    act_out = np.empty((steps * num_envs, student.action_size), np.float32)
    obs = env.reset(seed=seed)
    alive = []
    for k in range(steps):
        rows = slice(k * num_envs, (k + 1) * num_envs)
        o = obs_out[rows]
        o[:, :body] = obs[:, :body]
        turn = rng.uniform(-math.pi, math.pi, num_envs)
        o[:, body], o[:, body + 1] = np.cos(turn), np.sin(turn)
        o[:, body + 2] = rng.uniform(*student.speed_range, num_envs)
        clean = np.clip(teacher.act(obs), -1.0, 1.0)
        # the targets the teacher's clean action sets: the clip's pose at the end of this
        # policy step, turned by the action (the imitation task's own kernel)
        r = env.reference.sample(env.ref_time + env.dt)
        tq, tj = r.joint_quat.copy(), r.joint_q.copy()
        pd_targets(clean, env.action_scale, env.residual, env.dof_joint, env.dof_kind,
                   env.dof_start, r.joint_quat, r.joint_q, tq, tj)
        act_out[rows] = np.clip(_steering_actions(student, tq, tj), -1.0, 1.0)
        noisy = clean + noise * rng.standard_normal(clean.shape)
        obs, _, _, _, info = env.step(np.clip(noisy, -1.0, 1.0))
        if "episode_steps" in info:
            alive.extend((info["episode_steps"][info["done"]] * env.dt).tolist())
    if log:
        n_ep = len(alive)
        log(f"clone: {len(obs_out)} samples of the teacher ({spec['clip']}, noise {noise}); "
            f"{n_ep} episodes ended"
            + (f" (mean {np.mean(alive):.1f} s)" if n_ep else "")
            + "; commands drawn at random")
    return obs_out, act_out


def _coords(kind):
    """Action components of a hinge (1) or universal (2) joint."""
    return 1 if kind == DOF_HINGE else 2


def freeze_normalizer(alg):
    """Stop ``alg``'s actor observation normaliser learning (rsl-rl's ``until``): the
    cloned weights are fitted to the teacher's states' statistics, and a normaliser that
    goes on averaging the policy's own states shifts every input under them (a cloned
    walk then falls apart within a hundred PPO iterations). Not saved in a checkpoint:
    call it again after loading one."""
    norm = alg.get_policy().obs_normalizer
    if not isinstance(norm, torch.nn.Identity):
        norm.until = int(norm.count)


def fit_actor(alg, obs, actions, *, epochs=30, batch_size=1024, learning_rate=1e-3, seed=0,
              log=None):
    """Fit the mean of ``alg``'s actor (rsl-rl PPO) to ``actions`` (n, A) at ``obs``
    (n, D) by least squares, after setting its observation normaliser to the data's mean
    and standard deviation (and freezing it there: :func:`freeze_normalizer`). Returns the
    held-out mean squared error (action units^2)."""
    actor = alg.get_policy()
    x = torch.as_tensor(obs, dtype=torch.float32)
    y = torch.as_tensor(actions, dtype=torch.float32)
    norm = actor.obs_normalizer
    if not isinstance(norm, torch.nn.Identity):
        with torch.no_grad():
            var = x.var(dim=0, unbiased=False, keepdim=True)
            norm._mean.copy_(x.mean(dim=0, keepdim=True))
            norm._var.copy_(var)
            norm._std.copy_(var.sqrt())
            norm.count.fill_(x.shape[0])
    freeze_normalizer(alg)
    params = list(actor.mlp.parameters())
    opt = torch.optim.Adam(params, lr=learning_rate)
    gen = torch.Generator().manual_seed(seed)
    n = x.shape[0]
    held = max(1, n // 20)
    perm = torch.randperm(n, generator=gen)
    test, train = perm[:held], perm[held:]
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, epochs)

    def mean_of(rows):
        return actor.mlp(norm(x[rows]))

    loss = torch.tensor(0.0)
    for epoch in range(epochs):
        order = train[torch.randperm(len(train), generator=gen)]
        for start in range(0, len(order), batch_size):
            rows = order[start:start + batch_size]
            loss = torch.mean((mean_of(rows) - y[rows]) ** 2)
            opt.zero_grad()
            loss.backward()
            opt.step()
        sched.step()
        if log and (epoch % 10 == 9 or epoch == epochs - 1):
            with torch.no_grad():
                err = float(torch.mean((mean_of(test) - y[test]) ** 2))
            log(f"clone: epoch {epoch + 1}/{epochs}: train mse {float(loss.detach()):.4f}, held-out "
                f"{err:.4f}")
    with torch.no_grad():
        return float(torch.mean((mean_of(test) - y[test]) ** 2))


def clone_into(alg, student, teacher, *, samples=200_000, noise=0.1, epochs=30, seed=0,
               log=None):
    """Behaviour-clone ``teacher`` (a Policy, a path or a shipped name) into ``alg``'s actor
    for the steering task ``student`` (see the module docs). Returns the held-out mean
    squared error of the fit."""
    teacher = load_teacher(teacher)
    obs, actions = teacher_dataset(teacher, student, samples=samples, noise=noise, seed=seed,
                                   log=log)
    return fit_actor(alg, obs, actions, epochs=epochs, seed=seed, log=log)
