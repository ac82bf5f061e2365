"""Gymnasium facades of the batched tasks, registered when ``tumble.rl`` is imported.

``gymnasium.make("tumble/Imitate-v0", clip="walk")`` gives :class:`ImitateEnv`, a single
``gymnasium.Env`` (one world; call ``reset`` after an episode ends), and
``gymnasium.make_vec("tumble/Imitate-v0", num_envs=N, vectorization_mode="vector_entry_point")``
gives :class:`ImitateVectorEnv`, a ``gymnasium.vector.VectorEnv`` over one
``World(nworld=N)`` in Gymnasium's same-step autoreset mode: when a world's episode ends,
the observation returned is its new episode's first, ``infos["final_obs"]`` holds the ended
episode's last observation (an (N, D) float32 array; rows where ``infos["_final_obs"]``)
and ``infos["final_info"]`` its return and length. Keyword arguments go to
:class:`~tumble.rl.tasks.imitation.ImitationEnv`.

``tumble/Steer-v0`` (:class:`SteerEnv`, :class:`SteerVectorEnv`) is the same for the AMP
steering task (:class:`~tumble.rl.tasks.amp.AMPEnv`, keyword ``clips``): its reward is the
task reward, ``info["amp_obs"]`` the discriminator's view of the step's transition.

Seeds: ``reset(seed=s)`` makes everything after it repeat bit for bit (start phases;
the physics is deterministic).
"""
import gymnasium
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from .kernels import BODY_OBS
from .tasks.amp import DEFAULT_CLIPS, AMPEnv
from .tasks.imitation import ImitationEnv

__all__ = ["ImitateEnv", "ImitateVectorEnv", "SteerEnv", "SteerVectorEnv", "register_envs",
           "observation_space"]

IMITATE_ID = "tumble/Imitate-v0"
STEER_ID = "tumble/Steer-v0"


def observation_space(task):
    """The Box of one world's observation: unbounded positions and velocities, rotation axes
    and the phase's sin and cos in [-1, 1] (for the steering task: the command's cos and
    sin in [-1, 1], its speed >= 0); float32."""
    D = task.observation_size
    low = np.full(D, -np.inf, np.float32)
    high = np.full(D, np.inf, np.float32)
    for b in range(task.model.nbody):
        k = 1 + BODY_OBS * b + 3
        low[k:k + 6], high[k:k + 6] = -1.0, 1.0
    if isinstance(task, AMPEnv):
        low[-3:-1], high[-3:-1] = -1.0, 1.0
        low[-1] = 0.0
    else:
        low[-2:], high[-2:] = -1.0, 1.0
    return spaces.Box(low, high, dtype=np.float32)


def action_space(task):
    """The Box of one world's action: [-1, 1]^A, float32."""
    return spaces.Box(-1.0, 1.0, (task.action_size,), dtype=np.float32)


class ImitateEnv(gymnasium.Env):
    """One character imitating a clip (``tumble/Imitate-v0``); see the module docs."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(self, clip="walk", render_mode=None, render_size=(480, 270), **kwargs):
        self._setup(IMITATE_ID, lambda: ImitationEnv(1, clip, autoreset=False, **kwargs),
                    render_mode, render_size, kwargs)

    def _setup(self, name, make_task, render_mode, render_size, kwargs):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"{name}: render_mode must be None or one of "
                             f"{self.metadata['render_modes']}, got {render_mode!r}")
        kwargs.setdefault("parallel", False)
        self.task = make_task()
        self.observation_space = observation_space(self.task)
        self.action_space = action_space(self.task)
        self.metadata = dict(self.metadata, render_fps=self.task.control_hz)
        self.render_mode = render_mode
        self._render_size = tuple(int(v) for v in render_size)
        self._renderer = self._camera = None

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.task.rng = self.np_random
        obs = self.task.reset()
        return obs[0], {"phase": float(self.task.phase[0])}

    def step(self, action):
        obs, reward, terminated, truncated, info = self.task.step(np.asarray(action)[None])
        out = {"reward_terms": self.task.reward_terms[0], "phase": float(self.task.phase[0]),
               "diverged": bool(info["diverged"][0])}
        return obs[0], float(reward[0]), bool(terminated[0]), bool(truncated[0]), out

    def render(self):
        """With ``render_mode="rgb_array"``: an (H, W, 3) uint8 image of the character,
        the camera following its centre of mass (``render_size`` = (W, H) pixels; software
        rendering, needs ``tumble[viewer]``). None without a render mode."""
        if self.render_mode is None:
            return None
        from ..viewer.render import Renderer, auto_camera
        from ..viewer.scene import Scene
        world = self.task.world
        if self._renderer is None:
            scene = Scene.from_model(self.task.model)
            width, height = self._render_size
            self._renderer = Renderer(scene, width, height)
            self._camera = auto_camera(scene, world.body_pos, follow="com",
                                       aspect=width / height)
        return self._renderer.render(world.body_pos, world.body_quat, self._camera)

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        super().close()


class ImitateVectorEnv(VectorEnv):
    """N characters imitating a clip in one batch of worlds; see the module docs."""

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, num_envs=1, clip="walk", **kwargs):
        self._setup(ImitationEnv(num_envs, clip, autoreset=True, **kwargs))

    def _setup(self, task):
        self.task = task
        self.num_envs = int(task.num_envs)
        self.single_observation_space = observation_space(self.task)
        self.single_action_space = action_space(self.task)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = dict(self.metadata, render_fps=self.task.control_hz)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.task.rng = self.np_random
        obs = self.task.reset()
        return obs, {}

    def step(self, actions):
        obs, reward, terminated, truncated, info = self.task.step(actions)
        infos = {"reward_terms": self.task.reward_terms}
        done = info["done"]
        if done.any():
            infos["final_obs"] = info["final_obs"]
            infos["_final_obs"] = done
            infos["final_info"] = {"episode_return": info["episode_return"],
                                   "episode_steps": info["episode_steps"]}
            infos["_final_info"] = done
        return obs, reward, terminated, truncated, infos


class SteerEnv(ImitateEnv):
    """One character steered by heading and speed commands in the style of clips (AMP's
    task, ``tumble/Steer-v0``); ``info["amp_obs"]`` (2F,) is the step's transition."""

    def __init__(self, clips=DEFAULT_CLIPS, render_mode=None, render_size=(480, 270), **kwargs):
        self._setup(STEER_ID, lambda: AMPEnv(1, clips, autoreset=False, **kwargs),
                    render_mode, render_size, kwargs)

    def _command(self):
        return {"target_heading": float(self.task.target_heading[0]),
                "target_speed": float(self.task.target_speed[0])}

    def reset(self, *, seed=None, options=None):
        gymnasium.Env.reset(self, seed=seed)
        self.task.rng = self.np_random
        obs = self.task.reset()
        return obs[0], self._command()

    def step(self, action):
        obs, reward, terminated, truncated, info = self.task.step(np.asarray(action)[None])
        out = {"amp_obs": info["amp_obs"][0], "diverged": bool(info["diverged"][0]),
               **self._command()}
        return obs[0], float(reward[0]), bool(terminated[0]), bool(truncated[0]), out


class SteerVectorEnv(ImitateVectorEnv):
    """N steered characters in one batch of worlds (``tumble/Steer-v0``);
    ``infos["amp_obs"]`` (N, 2F) holds every world's transition before any reset."""

    def __init__(self, num_envs=1, clips=DEFAULT_CLIPS, **kwargs):
        self._setup(AMPEnv(num_envs, clips, autoreset=True, **kwargs))

    def step(self, actions):
        obs, reward, terminated, truncated, infos = super().step(actions)
        infos["amp_obs"] = self.task.step_amp_obs
        return obs, reward, terminated, truncated, infos


def register_envs():
    """Register ``tumble/Imitate-v0`` and ``tumble/Steer-v0`` (idempotent)."""
    if IMITATE_ID not in gymnasium.registry:
        gymnasium.register(IMITATE_ID, entry_point="tumble.rl.gym:ImitateEnv",
                           vector_entry_point="tumble.rl.gym:ImitateVectorEnv",
                           kwargs={"clip": "walk"})
    if STEER_ID not in gymnasium.registry:
        gymnasium.register(STEER_ID, entry_point="tumble.rl.gym:SteerEnv",
                           vector_entry_point="tumble.rl.gym:SteerVectorEnv",
                           kwargs={"clips": DEFAULT_CLIPS})
