"""Policy samples per second of PyBullet's DeepMimic environment (it ships inside the
pybullet wheel: ``pybullet_envs.deep_mimic``, humanoid walk, 1/240 s physics with stable
PD, a 30 Hz policy), random actions, one core, as a user of that port would drive it.

    python bench/peers/pybullet_deepmimic.py [seconds]

Its package still imports the old ``gym`` for a base class it never uses here, so an empty
stand-in module is put in its place when ``gym`` is not installed. Prints one JSON line:
samples_per_s, updates_per_s (physics steps), resets.
"""
import json
import sys
import time
import types

import numpy as np


def _gym_stand_in():
    """Empty ``gym``, ``gym.envs``, ``gym.envs.registration`` and ``gym.utils`` modules: what
    ``pybullet_envs`` imports (a base class and a registry it fills) and never uses here."""
    if "gym" in sys.modules:
        return
    try:
        import gym  # noqa: F401
        return
    except ImportError:
        pass
    gym = types.ModuleType("gym")
    gym.Env = type("Env", (), {})
    envs = types.ModuleType("gym.envs")
    registration = types.ModuleType("gym.envs.registration")
    registration.registry = type("Registry", (dict,), {"env_specs": {}})()
    registration.register = lambda *a, **k: None

    def unavailable(*a, **k):
        raise RuntimeError("gym stand-in: no environments")

    registration.make = registration.spec = unavailable
    utils = types.ModuleType("gym.utils")
    gym.envs, gym.utils, envs.registration = envs, utils, registration
    sys.modules.update({"gym": gym, "gym.envs": envs, "gym.envs.registration": registration,
                        "gym.utils": utils})


def measure(seconds=20.0, seed=0):
    """Run the walk environment for ``seconds`` of wall time; returns the rates."""
    _gym_stand_in()
    import pybullet_data
    from pybullet_envs.deep_mimic.env.pybullet_deep_mimic_env import PyBulletDeepMimicEnv
    from pybullet_utils.arg_parser import ArgParser
    args = ArgParser()
    args.load_file(pybullet_data.getDataPath() + "/args/run_humanoid3d_walk_args.txt")
    env = PyBulletDeepMimicEnv(args, enable_draw=False)
    env.reset()
    rng = np.random.default_rng(seed)
    samples = updates = resets = 0
    start = time.perf_counter()
    while time.perf_counter() - start < seconds:
        if env.need_new_action(0):
            env.record_state(0)
            env.record_goal(0)
            env.set_action(0, rng.normal(0.0, 0.1, size=36))
            env.calc_reward(0)
            samples += 1
        env.update(1.0 / 240.0)
        updates += 1
        if env.is_episode_end():
            env.reset()
            resets += 1
    wall = time.perf_counter() - start
    return {"samples_per_s": samples / wall, "updates_per_s": updates / wall, "resets": resets}


if __name__ == "__main__":
    secs = float(sys.argv[1]) if len(sys.argv) > 1 else 20.0
    print(json.dumps(measure(secs)))
