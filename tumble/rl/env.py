"""Batched environments: N worlds stepped together, observed, rewarded and reset as arrays.

:class:`BatchedEnv` is the loop every task shares (``observe -> act -> step -> reward ->
reset``) over one ``World(nworld=N)``; a task (``tumble.rl.tasks``) says what the
observation, the action's effect, the reward, a failure and a fresh start are, each for all
N worlds in one call. One policy step is ``substeps`` physics steps in one ``World.step``
call.

Episodes. An episode ends when the task says the character failed (``terminated``) or at
the time limit (``truncated``). With ``autoreset`` (the default, Gymnasium's same-step
mode) the worlds whose episodes ended are started afresh inside the same ``step`` call: the
observation returned is the new episode's first, and the last one of the ended episode is in
``info["final_obs"]`` (rows of the ended worlds; ``info["done"]`` marks them).

A world whose simulation diverges (``tumble.SimulationError``) is not allowed to stop the
others: it is started afresh, its episode reported as terminated, and the step is run again
for the batch (the failed call left every world as it was). ``info["diverged"]`` counts them.
"""
import numpy as np

from ..errors import ModelError, SimulationError, TumbleError

__all__ = ["BatchedEnv", "ActionError", "check_task_settings"]


def check_task_settings(where, num_envs, control_hz, physics_hz, episode_seconds):
    """ModelError (naming ``where`` and the setting) unless num_envs, control_hz and
    physics_hz are positive integers, physics_hz a multiple of control_hz and
    episode_seconds positive."""
    for name, v in (("num_envs", num_envs), ("control_hz", control_hz),
                    ("physics_hz", physics_hz)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ModelError(f"{where}: {name} must be a positive integer, got {v!r}")
    if physics_hz % control_hz:
        raise ModelError(f"{where}: physics_hz ({physics_hz}) must be a multiple of "
                         f"control_hz ({control_hz})")
    if not np.isfinite(episode_seconds) or episode_seconds <= 0:
        raise ModelError(f"{where}: episode_seconds must be > 0, got {episode_seconds!r}")


class ActionError(TumbleError, ValueError):
    """An action the environment refuses: wrong shape or not finite."""


class BatchedEnv:
    """The shared loop of a batched task. Subclasses define:

    ``observation_size``, ``action_size``; ``_observe(obs)`` fills (N, D) float32;
    ``_act(actions)`` sets the controls of every world from (N, A) actions in [-1, 1];
    ``_evaluate(reward, terminated)`` fills (N,) rewards and failures after a step;
    ``_restart(worlds, rng)`` puts the given worlds (indices) in a fresh start state;
    ``_advance()`` moves task time by one policy step (called before ``_act``).

    Attributes: ``world`` (the batch), ``num_envs``, ``substeps`` (physics steps per policy
    step), ``dt`` (policy step, s), ``max_episode_steps``, ``episode_steps`` (N,) int,
    ``episode_return`` (N,) float.
    """

    def __init__(self, world, *, substeps, max_episode_steps, seed=None, autoreset=True):
        if isinstance(substeps, bool) or not isinstance(substeps, (int, np.integer)) or substeps < 1:
            raise ModelError(f"env: substeps must be a positive integer, got {substeps!r}")
        if isinstance(max_episode_steps, bool) or not isinstance(max_episode_steps, (int, np.integer)) \
                or max_episode_steps < 1:
            raise ModelError(f"env: max_episode_steps must be a positive integer, got "
                             f"{max_episode_steps!r}")
        self.world = world
        self.num_envs = world.nworld
        self.substeps = int(substeps)
        self.dt = world.dt * self.substeps
        self.max_episode_steps = int(max_episode_steps)
        self.autoreset = bool(autoreset)
        self.rng = np.random.default_rng(seed)
        N = self.num_envs
        self.episode_steps = np.zeros(N, np.int64)
        self.episode_return = np.zeros(N)
        self.diverged = 0
        self._obs = np.zeros((N, self.observation_size), np.float32)
        self._reward = np.zeros(N)
        self._terminated = np.zeros(N, np.bool_)
        self._needs_reset = True

    # -- what a task provides -----------------------------------------------------------
    observation_size = 0
    action_size = 0

    def _observe(self, obs):
        raise NotImplementedError

    def _act(self, actions):
        raise NotImplementedError

    def _evaluate(self, reward, terminated):
        raise NotImplementedError

    def _restart(self, worlds, rng):
        raise NotImplementedError

    def _advance(self):
        raise NotImplementedError

    def _time_up(self):
        """(N,) mask of worlds whose task ran out of time (e.g. a clip played once reached
        its end); the time limit ``max_episode_steps`` is checked by the loop."""
        return np.zeros(self.num_envs, np.bool_)

    # -- the loop -----------------------------------------------------------------------
    def seed(self, seed):
        """Reseed the environment's random generator (start states)."""
        self.rng = np.random.default_rng(seed)

    def reset(self, seed=None):
        """Start every world afresh; returns the observations (N, D) float32 (a copy)."""
        if seed is not None:
            self.seed(seed)
        self._restart(np.arange(self.num_envs), self.rng)
        self.episode_steps[:] = 0
        self.episode_return[:] = 0.0
        self._observe(self._obs)
        self._needs_reset = False
        return self._obs.copy()

    def reset_worlds(self, worlds):
        """Start the given worlds (indices or an (N,) mask) afresh; returns the observations
        of all worlds (N, D)."""
        idx = np.asarray(worlds)
        idx = np.flatnonzero(idx) if idx.dtype == np.bool_ else idx.astype(np.int64).reshape(-1)
        if len(idx):
            self._restart(idx, self.rng)
            self.episode_steps[idx] = 0
            self.episode_return[idx] = 0.0
        self._observe(self._obs)
        return self._obs.copy()

    def check_actions(self, actions):
        """(N, A) float64 actions clipped to [-1, 1]; ActionError if the shape is wrong or a
        value is not finite (naming the worlds and components)."""
        a = np.asarray(actions, dtype=np.float64)
        N, A = self.num_envs, self.action_size
        if a.shape == (A,) and N == 1:
            a = a[None]
        if a.shape != (N, A):
            raise ActionError(f"actions must have shape ({N}, {A}), got {a.shape}")
        bad = ~np.isfinite(a)
        if bad.any():
            w, c = np.nonzero(bad)
            raise ActionError(f"actions are not finite in {len(set(w.tolist()))} world(s): "
                              f"world {int(w[0])}, component {int(c[0])} is {a[w[0], c[0]]!r}"
                              f" (a policy that outputs NaN has diverged; nothing was stepped)")
        return np.clip(a, -1.0, 1.0)

    def step(self, actions):
        """One policy step of every world.

        actions : (N, A) in [-1, 1] (clipped to it; refused with ActionError if not finite).
        Returns obs (N, D) float32, reward (N,) float64, terminated (N,) bool, truncated
        (N,) bool, info (dict of arrays; see the module docs). The arrays are fresh copies.
        """
        if self._needs_reset:
            raise ModelError("env: call reset() before step()")
        a = self.check_actions(actions)
        self._advance()
        self._act(a)
        diverged = self._step_physics()
        self.episode_steps += 1
        self._evaluate(self._reward, self._terminated)
        terminated = self._terminated.copy()
        terminated[diverged] = True
        self._reward[diverged] = 0.0
        truncated = ((self.episode_steps >= self.max_episode_steps) | self._time_up()) \
            & ~terminated
        self.episode_return += self._reward
        self._observe(self._obs)
        done = terminated | truncated
        info = {"done": done, "diverged": diverged}
        if done.any():
            info["final_obs"] = self._obs.copy()
            info["episode_return"] = self.episode_return.copy()
            info["episode_steps"] = self.episode_steps.copy()
            if self.autoreset:
                idx = np.flatnonzero(done)
                self._restart(idx, self.rng)
                self.episode_steps[idx] = 0
                self.episode_return[idx] = 0.0
                self._observe(self._obs)
            else:
                self._needs_reset = True
        return self._obs.copy(), self._reward.copy(), terminated, truncated, info

    def _view_character(self, where):
        """Live (N, ...) views of the world's body, joint and servo-target arrays, the
        world axis kept for one world too: ``_pos``, ``_quat``, ``_vel``, ``_angvel``,
        ``_joint_quat``, ``_joint_qd``, ``_target_quat``, ``_target_q`` (the kernels write
        the targets in place, so these must be views, not copies)."""
        w, N = self.world, self.num_envs
        nb, nj = self.model.nbody, self.model.njoint
        self._pos = np.reshape(w.body_pos, (N, nb, 3))
        self._quat = np.reshape(w.body_quat, (N, nb, 4))
        self._vel = np.reshape(w.body_vel, (N, nb, 3))
        self._angvel = np.reshape(w.body_angvel, (N, nb, 3))
        self._joint_quat = np.reshape(w.joint_quat, (N, nj, 4))
        self._joint_qd = np.reshape(w.joint_qd, (N, nj, 3))
        self._target_quat = np.reshape(w.pd_target_quat, (N, nj, 4))
        self._target_q = np.reshape(w.pd_target_q, (N, nj, 3))
        if not (np.shares_memory(self._target_quat, w.pd_target_quat)
                and np.shares_memory(self._target_q, w.pd_target_q)):
            raise ModelError(f"{where}: the world's servo targets are not contiguous arrays")

    def _step_physics(self):
        """``world.step(substeps)``; a world that diverges is restarted and the batch
        stepped again. Returns the (N,) mask of the worlds that diverged."""
        diverged = np.zeros(self.num_envs, np.bool_)
        for _ in range(self.num_envs + 1):
            try:
                self.world.step(self.substeps)
                return diverged
            except SimulationError as exc:
                w = 0 if exc.world is None else int(exc.world)
                diverged[w] = True
                self.diverged += 1
                self._restart(np.array([w]), self.rng)
        raise SimulationError("env: every world diverged in one step; check the task's gains "
                              "and time step")
